"""``coplan sweep-report``: what a sweep's table says, in numbers and figures.

Counts by status and exit class, the success rate among problems with reachable fruit,
medians and worst cases, the three planners side by side where computed, and the figures a
designer looks at (matplotlib figures, imported lazily; no pyplot, so no backend chosen or changed):

* ``throughput.png`` -- throughput (fruit/min) against base spacing, one panel per arm count,
  one line per fruit density (median over seeds; one arm has no spacing: a level per density);
* ``ratio.png`` -- distribution of makespan / lower bound;
* ``solve_time.png`` -- distribution of solve times;
* ``pareto.png`` -- arms (cost) against throughput: every design (median over seeds) and the
  Pareto front of each fruit density (no design with as few arms is faster).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import plural
from ..kinds import PlannerKind, RowStatus
from .table import COLUMNS, read_sweep_record, read_table

__all__ = ["SweepReport", "sweep_report", "summarise", "pareto_front", "designs", "varied", "FAMILY", "fronts",
           "counts_as_with_fruit"]

_MEDIANS = ("makespan", "ratio", "throughput", "throughput_per_m", "cycle_worst", "cycle_mean", "certified_clearance", "solve_time")


@dataclass
class SweepReport:
    summary: dict[str, Any]
    text: str
    files: dict[str, Path] = field(default_factory=dict)
    notes: dict[str, Any] = field(default_factory=dict)  # what reading the table found (:func:`coplan.sweep.table.read_table`)


def _median(xs: list[float]) -> float | None:
    xs = sorted(x for x in xs if x is not None and math.isfinite(x))
    if not xs:
        return None
    n = len(xs)
    return xs[n // 2] if n % 2 else 0.5 * (xs[n // 2 - 1] + xs[n // 2])


# what tells two designs apart besides arms, spacing and density (a row's gantry mode, the
# planner and how it ran too: a re-run with another time limit is another design, not more seeds),
# and besides every other parameter the sweep set (dwells, clearance, fruit box, a file, ...)
FAMILY = ("link_1", "link_2", "link_radius", "planner", "gantry", "time_limit", "options")
_IN_COLUMNS = {"seed", "n_arms", "spacing", "density", "links", "link_radius", "gantry", "planner"}  # (table columns)


def _other_params(r: dict[str, Any]) -> dict[str, Any]:
    """The parameters of a row that set its design beyond its columns (not its seed; solver
    options are in the options column)."""
    params = json.loads(r["params"] or "{}")
    return {k: v for k, v in params.items() if k not in _IN_COLUMNS and not k.startswith("options.")}


def designs(rows: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """Successful rows grouped by design (arms, spacing, density, :data:`FAMILY` -- links, link
    radius, planner, a row's gantry mode, time limit, options -- and every other parameter but
    the seed; seeds pooled): the median throughput and makespan of each design, how many
    distinct seeds it has and how many rows. Two modes of one row are two designs, never one
    with twice the seeds; nor are two time limits, two dwells or two problem files."""
    groups: dict[tuple, list[dict]] = {}
    for r in rows:
        if r["status"] != RowStatus.SUCCESS.value or r["throughput"] is None:
            continue
        dens = json.loads(r["params"] or "{}").get("density")  # a design parameter only when the sweep set it
        sp = round(r["spacing"], 6) if r["spacing"] is not None else None
        k = (r["n_arms"], sp, dens) + tuple(r.get(f) for f in FAMILY) + (json.dumps(_other_params(r), sort_keys=True, default=str),)
        groups.setdefault(k, []).append(r)
    out = []
    for k, rs in sorted(groups.items(), key=lambda kv: tuple(str(x) for x in kv[0])):
        arms, sp, dens = k[:3]
        out.append({"n_arms": arms, "spacing": sp, "density": dens, **dict(zip(FAMILY, k[3:-1])),
                    "params": json.loads(k[-1]), "seeds": len({r["seed"] for r in rs}), "rows": len(rs),
                    "throughput": _median([r["throughput"] for r in rs]),
                    "throughput_per_m": _median([r["throughput_per_m"] for r in rs]),
                    "makespan": _median([r["makespan"] for r in rs])})
    return out


def varied(des: list[dict[str, Any]]) -> list[str]:
    """What must be shown to tell ``des`` apart beyond arms, spacing and density: the
    :data:`FAMILY` fields whose values differ, then the other parameters that do (by name)."""
    out = [f for f in FAMILY if len({json.dumps(d.get(f), default=str) for d in des}) > 1]
    names = sorted({k for d in des for k in d["params"]})
    return out + [k for k in names if len({json.dumps(d["params"].get(k), default=str) for d in des}) > 1]


def _value(d: dict[str, Any], f: str):
    return d.get(f) if f in FAMILY else d["params"].get(f)


def _family_words(d: dict[str, Any], fields: list[str]) -> str:
    words = {"link_1": lambda v: f"l1 {v:g} m", "link_2": lambda v: f"l2 {v:g} m", "link_radius": lambda v: f"r {v:g} m",
             "time_limit": lambda v: f"{v:g} s", "planner": str, "gantry": str, "options": lambda v: f"options {v}",
             "problem": lambda v: Path(str(v)).stem}  # (a file's name: its whole path ran off the figure)
    return ", ".join((words[f](_value(d, f)) if f in words else f"{f} {_value(d, f)}") if _value(d, f) is not None else f"{f} -"
                     for f in fields)


def pareto_front(points: list[tuple[float, float]]) -> list[int]:
    """Indices of the points (cost, value) no other point dominates (cost <= and value >=, one
    strictly), sorted by cost."""
    order = sorted(range(len(points)), key=lambda i: (points[i][0], -points[i][1]))
    front, best = [], -math.inf
    for i in order:
        if points[i][1] > best:
            front.append(i)
            best = points[i][1]
    return front


def counts_as_with_fruit(row: dict[str, Any]) -> bool:
    """Whether a row counts among "problems with reachable fruit" for the success rate: its
    reachable count is positive, or unknown because the solve itself failed (error, timeout,
    lost: counted against the rate, never hidden from it). A bad input has no fruit to count."""
    if row["reachable"] is not None:
        return row["reachable"] > 0
    return row["status"] in (RowStatus.ERROR.value, RowStatus.TIMEOUT.value, RowStatus.LOST.value)


def fronts(des: list[dict[str, Any]]) -> dict[float | None, list[dict[str, Any]]]:
    """The Pareto front of arms (cost) against median throughput, one per fruit density (the
    crop is given; spacing and arm count are the design), each sorted by arm count."""
    out: dict[float | None, list[dict[str, Any]]] = {}
    for dn in sorted({d["density"] for d in des}, key=lambda x: (x is None, x or 0.0)):
        group = [d for d in des if d["density"] == dn]
        out[dn] = [group[i] for i in pareto_front([(float(d["n_arms"]), float(d["throughput"])) for d in group])]
    return out


def summarise(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The report's numbers (``report.json``)."""
    counts: dict[str, int] = {}
    classes: dict[str, int] = {}
    for r in rows:
        counts[r["status"]] = counts.get(r["status"], 0) + 1
        classes[r["exit_class"]] = classes.get(r["exit_class"], 0) + 1
    ok = [r for r in rows if r["status"] == RowStatus.SUCCESS.value]
    with_fruit = [r for r in rows if counts_as_with_fruit(r)]
    ok_fruit = [r for r in with_fruit if r["status"] == RowStatus.SUCCESS.value]
    unverified_success = [r["key"] for r in ok if not r["verified"]]
    med = {k: _median([r[k] for r in ok]) for k in _MEDIANS}

    params = {r["key"]: json.loads(r["params"] or "{}") for r in ok}
    # the parameters the rows differ in besides the seed: a worst case names its own (four rows
    # "row-2arms-1.8m-5fruit-seed1" at other clearances and speeds were told apart by key alone)
    differ = sorted(k for k in {k for p in params.values() for k in p} - {"seed"}
                    if len({json.dumps(p.get(k), default=str) for p in params.values()}) > 1)

    # a varied planner is named in the worst cases and the failures (two planners' rows of one
    # problem read alike but for their keys)
    planners = len({r["planner"] for r in rows}) > 1

    def worst(col: str, high: bool, n: int = 5) -> list[dict]:
        rs = [r for r in ok if r[col] is not None]
        rs.sort(key=lambda r: r[col], reverse=high)
        return [{"key": r["key"], "name": r["name"], "seed": r["seed"], "gantry": _mode(r),
                 "planner": r["planner"] if planners else None,
                 "params": {k: params[r["key"]].get(k) for k in differ}, col: r[col]} for r in rs[:n]]

    def gain(a: str, b: str, by: str) -> float | None:
        """The median of a / b over the rows whose own plan is not the one compared (a
        coordinated row's coordinated makespan is its plan: 1.0 by construction, which pulled
        the optimal rows' median from 1.047 to 1.006)."""
        xs = [r[a] / r[b] for r in ok if r[a] and r[b] and r["planner"] != by]
        return _median(xs)

    def label(r) -> str:  # (a problem that could not be made has no name: its generator or file says which it was, not "None")
        return r["name"] or r.get("source") or "-"

    failures = [{"key": r["key"], "name": label(r) + (f" ({r['planner']})" if planners and r["planner"] else ""),
                 "seed": r["seed"], "status": r["status"],
                 "exit_class": r["exit_class"], "message": (r["message"] or "")[:300]}
                for r in rows if r["status"] != RowStatus.SUCCESS.value]
    return {
        "rows": len(rows), "counts": counts, "exit_classes": classes,
        "with_reachable_fruit": len(with_fruit), "success_with_reachable_fruit": len(ok_fruit),
        "success_rate": len(ok_fruit) / len(with_fruit) if with_fruit else None,
        "success_by_planner": {pl: [sum(r["status"] == RowStatus.SUCCESS.value for r in with_fruit if r["planner"] == pl),
                                    sum(r["planner"] == pl for r in with_fruit)]
                               for pl in sorted({r["planner"] for r in with_fruit if r["planner"]})},
        "success_but_not_verified": unverified_success,
        "with_locked_arms": [{"name": label(r), "key": r["key"], "locked_arms": r["locked_arms"]}
                             for r in rows if r.get("locked_arms")],
        "medians": med,
        "median_heuristic_over_plan": gain("heuristic_makespan", "makespan", PlannerKind.HEURISTIC.value),
        "median_coordinated_over_plan": gain("coordinated_makespan", "makespan", PlannerKind.COORDINATED.value),
        "worst": {"ratio": worst("ratio", True), "solve_time": worst("solve_time", True),
                  "certified_clearance": worst("certified_clearance", False), "throughput": worst("throughput", False)},
        "failures": failures,
    }


def _seed(r: dict) -> str:
    """A row's seed as the report names it (a problem file's row has none)."""
    return "from its file" if r.get("seed") is None else f"seed {r['seed']}"


def _fmt(x, nd=3) -> str:
    return "-" if x is None else f"{x:.{nd}f}" if isinstance(x, float) else str(x)


def _unfinished(folder: Path, rows: list[dict]) -> dict | None:
    """``{"problems", "done"}`` when the folder's ``sweep.json`` says its last run had more
    problems than the table has rows solved for that sweep (stopped part-way: the report of 6
    rows of 48 said "6/6 (100.0 %)" and nothing else); None when it had no more, or says nothing."""
    doc = read_sweep_record(folder)[0] if folder.is_dir() else None
    if doc is None or not isinstance(doc.get("problems"), int) or isinstance(doc.get("problems"), bool):
        return None
    done = sum(1 for r in rows if r["sweep"] == doc.get("name") and r["status"] != RowStatus.LOST.value)
    return {"problems": doc["problems"], "done": done} if done < doc["problems"] else None


def _text(s: dict[str, Any], title: str) -> str:
    lines = [f"# Sweep report: {title}", ""]
    if s.get("unfinished"):
        u = s["unfinished"]
        lines += [f"**Unfinished:** {u['done']} of the {u['problems']} problems of the sweep's last run (sweep.json) have "
                  "a result; the figures below are of those only. Run the same sweep into this folder to finish it.", ""]
    lines += [f"{s['rows']} rows; by status: " + ", ".join(f"{k} {v}" for k, v in sorted(s["counts"].items())),
              "exit classes: " + ", ".join(f"{k} {v}" for k, v in sorted(s["exit_classes"].items()))]
    if s["success_rate"] is not None:
        lines.append(f"success among problems with reachable fruit: {s['success_with_reachable_fruit']}/{s['with_reachable_fruit']}"
                     f" ({100 * s['success_rate']:.1f} %)"
                     + (f" (not counted: {plural(s['counts'][RowStatus.BAD_INPUT.value], 'bad input')}, no problem to solve)"
                        if s["counts"].get(RowStatus.BAD_INPUT.value) else "")
                     + ("; by planner: " + ", ".join(f"{pl} {a}/{b}" for pl, (a, b) in s["success_by_planner"].items())
                        if len(s.get("success_by_planner") or {}) > 1 else ""))
    lines.append(f"rows called success whose plan was not verified: {len(s['success_but_not_verified'])}")
    locked = s.get("with_locked_arms") or []
    if locked:  # (a design whose arms cannot all work: a success, but not the machine it was meant to be)
        lines.append(f"rows whose screen locks arms (they can never reach their bins: they harvest nothing): {len(locked)} -- "
                     + "; ".join(f"{r['name']} (key {r['key']}): {r['locked_arms']}" for r in locked[:5])
                     + (f"; ... ({len(locked) - 5} more: the locked_arms column)" if len(locked) > 5 else ""))
    lines += ["", "## Medians (successful rows)", "", "| figure | median | what, unit |", "|---|---|---|"]
    lines += [f"| {k} | {_fmt(v)} | {COLUMNS.get(k, ('', ''))[1]} |" for k, v in s["medians"].items()]
    if s["median_coordinated_over_plan"] is not None or s["median_heuristic_over_plan"] is not None:
        lines += ["", f"planners side by side: median coordinated / plan makespan {_fmt(s['median_coordinated_over_plan'])},"
                      f" heuristic / plan {_fmt(s['median_heuristic_over_plan'])}"]
    worst = {col: rs for col, rs in s["worst"].items() if rs}
    lines += ["", "## Worst cases", ""] if worst else []  # (none among no successful rows: no empty heading)
    for col, rs in worst.items():
        lines.append(f"- {col}: " + "; ".join(f"{r['name']} ({_seed(r)}{', ' + r['gantry'] if r.get('gantry') else ''}"
                                              + (f", planner {r['planner']}" if r.get("planner") else "")
                                              + "".join(f", {k} {json.dumps(v, default=str)}" for k, v in (r.get("params") or {}).items()
                                                        if not (k == "gantry" and r.get("gantry")))  # (the mode said twice)
                                              + f", key {r['key']}) {_fmt(r[col])}" for r in rs))
    if s["failures"]:
        lines += ["", f"## Rows that are not a success ({len(s['failures'])})", "", "| key | problem | seed | status | exit class | message |",
                  "|---|---|---|---|---|---|"]
        for f in s["failures"][:200]:
            msg = " ".join((f["message"] or "").split()).replace("|", "/")
            lines.append(f"| {f['key']} | {f['name']} | {'' if f['seed'] is None else f['seed']} | {f['status']} | {f['exit_class']} | {msg} |")
        if len(s["failures"]) > 200:
            lines.append(f"| ... | {len(s['failures']) - 200} more in report.json | | | | |")
    return "\n".join(lines) + "\n"


def _figures(rows: list[dict[str, Any]], out: Path) -> dict[str, Path]:
    from matplotlib.figure import Figure  # (no pyplot: a notebook's backend and figures are left as they are)

    files: dict[str, Path] = {}
    ok = [r for r in rows if r["status"] == RowStatus.SUCCESS.value]
    des = designs(rows)
    fam = varied(des)
    # (a single arm has no base spacing: its panel draws each density's throughput as a level)
    arms = sorted({d["n_arms"] for d in des if d["spacing"] is not None or d["n_arms"] == 1})
    if arms:
        fig = Figure(figsize=(3.6 * len(arms), 3.4))
        axes = fig.subplots(1, len(arms), sharey=True, squeeze=False)
        for ax, a in zip(axes[0], arms):
            lines: dict[tuple, list] = {}  # one line per density and design family (links, planner, gantry mode, ...)
            for d in des:
                if d["n_arms"] == a:
                    lines.setdefault((d["density"],) + tuple(json.dumps(_value(d, f), default=str) for f in fam), []).append(d)
            for key in sorted(lines, key=lambda k: ((k[0] is None, k[0] or 0),) + k[1:]):
                ds = lines[key]
                dn = key[0]
                # (a density the sweep did not set -- a cell's generator draws its fruit -- is no part of the
                # label: it read '?', beside a density column the rows do have)
                label = ", ".join(([f"{dn:g}/m"] if dn is not None else []) + ([_family_words(ds[0], fam)] if fam else [])) \
                    or "median over seeds"
                if a == 1:
                    ax.axhline(_median([d["throughput"] for d in ds]), ls="--", color=f"C{len(ax.lines)}", label=label)
                else:
                    pts = sorted((d["spacing"], d["throughput"]) for d in ds if d["spacing"] is not None)
                    ax.plot([p[0] for p in pts], [p[1] for p in pts], "o-", ms=3, label=label)
            ax.set_title(f"{a} arm{'' if a == 1 else 's'}")
            ax.set_xlabel("(one arm: no base spacing)" if a == 1 else "base spacing, m")
            ax.grid(alpha=0.3)
        axes[0][0].set_ylabel("throughput, fruit/min (median over seeds)")
        dense = any(d["density"] is not None for d in des)
        title = ", ".join((["fruit density"] if dense else []) + (["design"] if fam else [])) or None
        most = max(len(ax.get_legend_handles_labels()[0]) for ax in axes[0])
        below = most > 4  # (many lines: each legend under its panel, the figure taller -- they covered the lines and the axis)
        if below:
            fig.set_size_inches(3.6 * len(arms), 3.4 + 0.17 * most)
        for ax in axes[0]:  # (each panel its own: the last panel's legend named the others' lines with its labels)
            if ax.get_legend_handles_labels()[0]:
                ax.legend(title=title, fontsize=7, **({"loc": "upper center", "bbox_to_anchor": (0.5, -0.18)} if below else {}))
        fig.tight_layout()
        files["throughput"] = out / "throughput.png"
        fig.savefig(files["throughput"], dpi=110, bbox_inches="tight")  # (legends under the panels: the y label was cut)
    for col, name, label in (("ratio", "ratio", "makespan / lower bound"), ("solve_time", "solve_time", "solve time, s")):
        xs = [r[col] for r in (ok if col == "ratio" else rows) if r[col] is not None]
        if not xs:
            continue
        fig = Figure(figsize=(5, 3.4))
        ax = fig.subplots()
        ax.hist(xs, bins=min(40, max(5, len(xs) // 3)), color="tab:blue", alpha=0.8)
        ax.set_xlabel(label)
        ax.set_ylabel("problems")
        ax.set_title(f"{label} ({len(xs)} problems, median {_median(xs):.3g})")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        files[name] = out / f"{name}.png"
        fig.savefig(files[name], dpi=110)
    if des:
        pts = [(float(d["n_arms"]), float(d["throughput"])) for d in des]
        fig = Figure(figsize=(5.5, 3.8))
        ax = fig.subplots()
        ax.scatter([p[0] for p in pts], [p[1] for p in pts], s=10, alpha=0.35, color="grey", label="designs (median over seeds)")
        by_density = fronts(des)
        for dn, front in by_density.items():
            fp = [(float(d["n_arms"]), float(d["throughput"])) for d in front]
            line = ax.step([p[0] for p in fp], [p[1] for p in fp], "-", where="post",
                           label=f"Pareto front, {dn:g} fruit/m" if dn is not None else "Pareto front")[0]
            ax.scatter([p[0] for p in fp], [p[1] for p in fp], s=18, color=line.get_color())
            for d, p in zip(front, fp):
                if d["spacing"] is not None and len(by_density) == 1:  # several fronts: spacings in report.md
                    ax.annotate(f"{d['spacing']:g} m", p, fontsize=7, xytext=(3, 3), textcoords="offset points")
        ax.set_xticks(sorted({int(p[0]) for p in pts}))
        ax.set_xlabel("arms (cost)")
        ax.set_ylabel("throughput, fruit/min")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        fig.tight_layout()
        files["pareto"] = out / "pareto.png"
        fig.savefig(files["pareto"], dpi=110)
    return files


def sweep_report(folder: str | Path, out: str | Path | None = None, figures: bool = True) -> SweepReport:
    """Read a sweep's table and write ``report.md``, ``report.json`` (and the figures) to ``out``
    (default ``<folder>/report``)."""
    folder = Path(folder)
    notes: dict[str, Any] = {}
    rows = read_table(folder, notes).to_pylist()
    base = folder if folder.is_dir() else folder.parent
    out = Path(out) if out is not None else base / "report"
    out.mkdir(parents=True, exist_ok=True)
    s = summarise(rows)
    s["unfinished"] = _unfinished(folder, rows)
    s["designs"] = designs(rows)
    s["pareto_front"] = [d for front in fronts(s["designs"]).values() for d in front]
    title = ", ".join(sorted({r["sweep"] for r in rows if r["sweep"]})) or str(folder)
    text = _text(s, title)
    if s["pareto_front"]:
        fam = varied(s["designs"])  # (the columns that tell the designs apart: links, gantry mode, planner, ...)
        heads = {"link_1": "link 1, m", "link_2": "link 2, m", "link_radius": "link radius, m", "planner": "planner",
                 "gantry": "gantry", "time_limit": "time limit, s", "options": "options"}
        text += ("\n## Pareto front: arms against throughput\n\n| arms | spacing, m | density, /m |"
                 + "".join(f" {heads.get(f, f)} |" for f in fam) + " fruit/min | seeds | rows |\n|---|---|---|"
                 + "---|" * len(fam) + "---|---|---|\n")
        text += "".join(f"| {d['n_arms']} | {_fmt(d['spacing'])} | {_fmt(d['density'])} |"
                        + "".join(f" {_fmt(_value(d, f)) if _value(d, f) is not None else '-'} |" for f in fam)
                        + f" {_fmt(d['throughput'], 2)} | {d['seeds']} | {d['rows']} |\n" for d in s["pareto_front"])
    files = {"markdown": out / "report.md", "json": out / "report.json"}
    files["markdown"].write_text(text, encoding="utf-8")  # (the locale's on Windows: a sweep named in Chinese was an internal error)
    files["json"].write_text(json.dumps(s, indent=1, default=str, allow_nan=False), encoding="utf-8")
    if figures and rows:
        files.update(_figures(rows, out))
    return SweepReport(s, text, files, notes)


def _mode(r: dict) -> str | None:
    """A row's gantry mode as asked, and the one kept where it asked for both (``auto: continuous``)."""
    asked, used = r.get("gantry"), r.get("gantry_mode")
    return f"{asked}: {used}" if asked and used and asked != used else asked
