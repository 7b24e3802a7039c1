"""What a planner comparison found (:class:`Comparison`, made by
:func:`coplan.report.comparison.compare`) and its tables: one per problem (a row per figure, a
column per planner), the aggregate over several problems, as Markdown (``compare.md``,
:func:`to_markdown`) and as Rich tables for the terminal (:func:`rich_tables`)."""

from __future__ import annotations

import math
import os
from collections.abc import Callable
from pathlib import Path
from dataclasses import dataclass, field
from typing import Any

from ..errors import plural, printable

__all__ = ["Comparison", "to_markdown", "rich_tables", "problem_table", "same_source"]


@dataclass
class Comparison:
    """Everything :func:`coplan.report.comparison.compare` found: one row per (problem, planner), aggregates, files."""

    planners: list[str]
    problems: list[dict[str, Any]] = field(default_factory=list)
    rows: list[dict[str, Any]] = field(default_factory=list)
    aggregate: dict[str, Any] = field(default_factory=dict)
    files: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def __repr__(self) -> str:  # (every row's figures: 10k characters for one problem and three planners)
        return (f"Comparison(planners={self.planners}, problems={len(self.problems)}, rows={len(self.rows)}, "
                f"failed={len(self.failed_runs)}, files={sorted(self.files)})")

    @property
    def bad_inputs(self) -> list[dict[str, Any]]:
        return [p for p in self.problems if p.get("error")]

    @property
    def failed_runs(self) -> list[dict[str, Any]]:
        return [r for r in self.rows if r.get("error")]

    def to_dict(self) -> dict[str, Any]:
        return _json(
            {"format": "coplan.compare/1", "planners": self.planners, "problems": self.problems, "rows": self.rows,
             "aggregate": self.aggregate, "files": self.files, "notes": self.notes}
        )


def _json(x):
    if isinstance(x, dict):
        return {str(k): _json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_json(v) for v in x]
    if isinstance(x, float):
        return x if math.isfinite(x) else None
    return x


def _f(x, nd: int = 2, unit: str = "") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    if isinstance(x, bool):
        return "yes" if x else "no"
    if isinstance(x, int):
        return str(x)
    return f"{x:.{nd}f}{unit}"


def _peak_jerk_cell(r: dict) -> str:
    """Each arm's peak jerk, ``unbounded`` where its acceleration steps, the largest step said once
    (said per arm, a three-arm heuristic plan's cell ran to about 200 characters)."""
    steps = r.get("acceleration_steps") or {}
    parts = [f"{a} " + ("unbounded" if a in steps else _f(v, 0)) for a, v in (r.get("peak_jerk_per_arm") or {}).items()]
    if not parts:
        return "-"
    return ", ".join(parts) + (f" (acceleration steps up to {_f(max(steps.values()), 1)} rad/s^2)" if steps else "")


_FIGURES: list[tuple[str, str, Callable[[dict], str]]] = [
    ("status", "status", lambda r: r.get("status") or "error"),
    ("verified safe", "passed", lambda r: _f(r.get("passed"))),
    ("fruit harvested / reachable / unreachable", "harvested",
     lambda r: f"{_f(r.get('harvested'))} / {_f(r.get('reachable'))} / {_f(r.get('unreachable'))}"),
    ("makespan (s)", "makespan", lambda r: _f(r.get("makespan"))),
    ("cycle time per fruit, worst arm (s)", "cycle_time_worst", lambda r: _f(r.get("cycle_time_worst"))),
    ("cycle time per fruit, mean (s)", "cycle_time_mean", lambda r: _f(r.get("cycle_time_mean"))),
    ("throughput (fruit/s)", "throughput", lambda r: _f(r.get("throughput"), 3)),
    ("fruit per arm", "per_arm", lambda r: ", ".join(f"{a} {_f(v['fruit'])}" for a, v in (r.get("per_arm") or {}).items())),
    ("idle fraction per arm", "per_arm", lambda r: ", ".join(f"{a} {_f(v['idle_fraction'])}" for a, v in (r.get("per_arm") or {}).items())),
    ("least clearance (m)", "min_clearance", lambda r: _f(r.get("min_clearance"), 4)),
    ("certified clearance (m)", "certified_clearance", lambda r: _f(r.get("certified_clearance"), 4)),
    ("certified margin (mm)", "margin", lambda r: _f(None if r.get("margin") is None else 1000 * r["margin"], 1)),
    ("margin per pair (mm)", "margin_per_pair",
     lambda r: ", ".join(f"{k} {_f(None if v is None else 1000 * v, 1)}" for k, v in (r.get("margin_per_pair") or {}).items()) or "-"),
    ("RMS jerk per arm (rad/s^3)", "rms_jerk",
     lambda r: ", ".join(f"{a} " + ("unbounded" if a in (r.get("acceleration_steps") or {}) else _f(v, 0))
                         for a, v in (r.get("rms_jerk") or {}).items()) or "-"),
    ("peak jerk per arm (rad/s^3)", "peak_jerk_per_arm", _peak_jerk_cell),
    ("collision intervals", "collision_count", lambda r: _f(r.get("collision_count"))),
    ("peak velocity / limit", "peak_velocity", lambda r: _f(r.get("peak_velocity"))),
    ("peak acceleration / limit", "peak_acceleration", lambda r: _f(r.get("peak_acceleration"))),
    ("peak jerk / limit", "peak_jerk", lambda r: "unbounded" if r.get("acceleration_steps") else _f(r.get("peak_jerk"))),
    ("violations", "violation_kinds", lambda r: f"{_f(r.get('violation_count'))} ({', '.join(r.get('violation_kinds') or []) or 'none'})"),
    ("planning time (s)", "planning_time", lambda r: _f(r.get("planning_time"), 3)),
    ("makespan lower bound (s)", "lower_bound", lambda r: _f(r.get("lower_bound"))),
    ("makespan / lower bound", "makespan_ratio", lambda r: _f(r.get("makespan_ratio"), 3)),
    ("optimality", "optimality", lambda r: r.get("optimality") or "-"),
]


def same_source(a: dict[str, Any], b: dict[str, Any]) -> bool:
    """Whether two rows (or a row and a ``problems`` entry) come from the same problem file
    (by name where a row records no file)."""
    if a.get("file") and b.get("file"):
        return a["file"] == b["file"]
    return a.get("problem", a.get("name")) == b.get("problem", b.get("name"))


def problem_table(cmp: Comparison, problem: str | dict[str, Any]) -> tuple[list[str], list[list[str]]]:
    """Header and rows (figure x planner) for one problem: its ``problems`` entry (its file), or its name."""
    entry = problem if isinstance(problem, dict) else {"name": problem}
    rows = {r["planner"]: r for r in cmp.rows if same_source(r, entry)}
    header = ["figure"] + [p for p in cmp.planners if p in rows]
    body = []
    for title, _, fmt in _FIGURES:
        body.append([title] + [(rows[p]["error"] if rows[p].get("error") and title == "status" else fmt(rows[p])) for p in header[1:]])
    return header, body


def _aggregate_table(cmp: Comparison) -> tuple[list[str], list[list[str]]]:
    header = ["figure"] + cmp.planners
    agg = cmp.aggregate

    def w(label, key, nd=2):
        x = agg[label]["worst"][key]
        return "-" if x is None else f"unbounded ({x['problem']})" if x.get("unbounded") else f"{_f(x['value'], nd)} ({x['problem']})"

    spec = [
        ("runs (errors)", lambda a, l: f"{a['runs']} ({a['errors']})"),
        ("verified safe", lambda a, l: str(a["passed"])),
        ("safe and complete", lambda a, l: str(a["complete"])),
        ("collision-free", lambda a, l: str(a["collision_free"])),
        ("fruit harvested / reachable", lambda a, l: f"{a['fruit_harvested']} / {a['fruit_reachable']}"),
        ("median makespan (s)", lambda a, l: _f(a["median"]["makespan"])),
        ("median makespan / lower bound", lambda a, l: _f(a["median"]["makespan_ratio"], 3)),
        ("median throughput (fruit/s)", lambda a, l: _f(a["median"]["throughput"], 3)),
        ("median least clearance (m)", lambda a, l: _f(a["median"]["min_clearance"], 4)),
        ("median planning time (s)", lambda a, l: _f(a["median"]["planning_time"], 3)),
        ("worst makespan / lower bound", lambda a, l: w(l, "makespan_ratio", 3)),
        ("worst least clearance (m)", lambda a, l: w(l, "min_clearance", 4)),
        ("most collision intervals", lambda a, l: w(l, "collision_count", 0)),
        ("worst peak jerk / limit", lambda a, l: w(l, "peak_jerk")),
        ("slowest planning (s)", lambda a, l: w(l, "planning_time", 3)),
    ]
    return header, [[title] + [fn(agg[p], p) for p in cmp.planners] for title, fn in spec]


def _title(cmp: Comparison, entry: dict[str, Any]) -> str:
    """A problem's heading: its name, and its file where another file has the same name."""
    same = sum(1 for p in cmp.problems if p.get("name") == entry["name"])
    return entry["name"] if same < 2 else f"{entry['name']} ({Path(entry['file']).name})"


def _md_table(header: list[str], body: list[list[str]]) -> str:
    esc = [[c.replace("|", "\\|") for c in row] for row in [header] + body]
    lines = ["| " + " | ".join(esc[0]) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(r) + " |" for r in esc[1:]]
    return "\n".join(lines)


def to_markdown(cmp: Comparison, out_dir: Path | None = None) -> str:
    """The report as Markdown: one table per problem, collision intervals, figures, aggregates."""
    parts = [f"# coplan comparison: {' vs '.join(cmp.planners)}", ""]
    names = [p["name"] for p in cmp.problems if p.get("name")]
    if len(names) > 1:
        parts += [f"## Aggregate over {len(names)} problems", "", _md_table(*_aggregate_table(cmp)), ""]
    for p in cmp.problems:
        if p.get("error"):
            parts += [f"## {p['file']}", "", "Invalid problem file:", "", "```", p["error"], "```", ""]
            continue
        parts += [f"## {_title(cmp, p)}", "", f"{plural(p['arms'], 'arm')}, {p['fruit']} fruit ({p['reachable']} reachable). Source: `{p['file']}`", ""]
        parts += [_md_table(*problem_table(cmp, p)), ""]
        for r in cmp.rows:
            if same_source(r, p) and r.get("collision_intervals"):
                parts.append(f"Collision intervals of **{r['planner']}**:")
                parts.append("")
                parts += [f"- {'/'.join(c['arms'])}: {c['t_start']:.3f}-{c['t_end']:.3f} s, penetration {c['penetration'] * 1000:.1f} mm"
                          for c in r["collision_intervals"]]
                parts.append("")
        figs = [v for k, v in cmp.files.items() if k.endswith(".png") and Path(v).parent.name == Path(p["file"]).stem]
        for f in figs:
            rel = os.path.relpath(f, out_dir) if out_dir is not None else f
            parts.append(f"![{Path(f).stem}]({rel})")
        if figs:
            parts.append("")
    if cmp.notes:
        parts += ["## Notes", ""] + [f"- {n}" for n in cmp.notes] + [""]
    return "\n".join(parts)


def rich_tables(cmp: Comparison) -> list:
    """Rich tables for the terminal: one per problem, and the aggregate for several problems."""
    from rich.table import Table
    from rich.text import Text

    def plain(x) -> Text:  # names from problem files: never markup, control characters as codes
        return Text(printable(x))

    tables = []
    for p in cmp.problems:
        if p.get("error"):
            continue
        header, body = problem_table(cmp, p)
        t = Table(title=plain(_title(cmp, p)), title_justify="left")
        for h in header:
            t.add_column(h, overflow="fold")
        for row in body:
            t.add_row(*(plain(c) for c in row))
        tables.append(t)
    if sum(1 for p in cmp.problems if p.get("name")) > 1:
        header, body = _aggregate_table(cmp)
        t = Table(title="aggregate", title_justify="left")
        for h in header:
            t.add_column(h, overflow="fold")
        for row in body:
            t.add_row(*(plain(c) for c in row))
        tables.append(t)
    return tables
