"""What each centimetre costs: a cell's makespan against the clearance asked for.

Entry point: :func:`clearance_cost` (``coplan compare PROBLEM --clearance-sweep``). The problem
file is planned again with its ``task.clearance`` raised by each extra (default the problem's
own, +10, +25, +50 and +100 mm; the problem's own always, the reference of every ratio), each
with the same planner and options, each plan verified
against the raised clearance; ``clearance.json``, ``clearance.md`` and ``clearance_cost.png``
(makespan against clearance) go to the output folder, each plan to ``plus_<mm>mm/`` and the
problem it was planned for to ``plus_<mm>mm.yaml`` beside it (the plan names that file, so that
``coplan verify`` checks it at the clearance it was planned for).

A plan for a smaller clearance may keep the larger one too (the widening stage moves arms apart
beyond what is asked): each level's row is the fastest verified plan at that clearance among its
own and the smaller levels' plans, each verified against the raised clearance -- the cost of room
never rises where a plan that keeps it exists. ``planned_makespan`` is the planner's own answer
at the level, ``plan_from_mm`` the level whose plan the row is (its files in ``plus_<mm>mm/``).

A clearance the problem's fixed geometry cannot give (the home poses closer than it) is not a
plan: its row says so (the validation error) and the sweep goes on.
"""

from __future__ import annotations

import copy
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ProblemError
from ..kinds import PlanStatus
from ..output import atomic_text, check_folder, keep_reports
from ..plan import jsonable
from ..problem.generate import to_yaml
from ..problem.load import load_problem, parse_problem
from ..problem.yamlsafe import read_yaml
from ..progress import Tick, nested, speaker, ticker

__all__ = ["EXTRAS_MM", "COLUMNS", "ClearanceCost", "clearance_cost", "cell", "to_markdown"]

#: The extra clearance (mm) asked for by default: the problem's own, then +1, +2.5, +5 and +10 cm.
EXTRAS_MM: tuple[float, ...] = (0.0, 10.0, 25.0, 50.0, 100.0)

COLUMNS = (("extra_mm", "extra, mm"), ("clearance", "clearance, m"), ("makespan", "makespan, s"),
            ("lower_bound", "lower bound, s"), ("ratio", "x problem's"), ("margin_mm", "certified margin, mm"), ("harvested", "harvested"),
            ("verified", "verified"), ("plan_from_mm", "plan (planned for)"), ("planned_makespan", "this level's own plan, s"),
            ("planning_time", "planning, s"))


@dataclass
class ClearanceCost:
    """The sweep's rows (one per extra clearance) and the files written."""

    problem: str
    planner: str
    rows: list[dict] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict[str, Any]:
        return {"format": "coplan.clearance-cost/1", "problem": self.problem, "planner": self.planner,
                "rows": jsonable(self.rows), "notes": list(self.notes)}


def clearance_cost(path: str | Path, out_dir: str | Path, extras_mm=EXTRAS_MM, planner=None, options=None,
                   figures: bool = True, progress=None) -> ClearanceCost:
    """Plan the problem file ``path`` at its clearance plus each of ``extras_mm``; see the module docstring."""
    from ..pipeline import solve
    from ..verify.verifier import verify

    say, tick = speaker(progress), ticker(progress)
    extras = sorted({0.0, *(float(e) for e in extras_mm)})  # (the problem's own: every ratio's reference)
    if extras[0] < 0.0:  # (the command line's --extra is 0-1000 mm; less clearance than the problem's asks is not room)
        raise ValueError(f"extras_mm: expected extra clearances >= 0 mm, found {extras[0]:g}")
    check_folder(out_dir, "out_dir")  # (before any work)
    path = Path(path)
    base = load_problem(path)  # a bad file fails here, with its own error
    data, _ = read_yaml(path.read_text(encoding="utf-8"), str(path))
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)

    res0_makespan = res0_harvested = None
    locked0: set = set()
    earlier: list[tuple[float, Any]] = []  # (extra, its verified plan): smaller clearances' plans, to try at larger ones
    cost = ClearanceCost(base.name, str(getattr(planner, "value", planner) or "optimal"))
    cost.notes += keep_reports(out, ("clearance.json", "clearance.md"))  # (an earlier sweep's report, moved aside)
    for i, extra in enumerate(extras):
        clearance = round(base.task.clearance + extra / 1000.0, 6)
        tick(Tick("clearance", i, len(extras), "clearances", note=f"+{extra:g} mm"))
        say(f"{base.name}: clearance {clearance:.3f} m (+{extra:g} mm)")
        d = copy.deepcopy(data)
        d.setdefault("task", {})["clearance"] = clearance
        row: dict[str, Any] = {"extra_mm": extra, "clearance": clearance}
        text = to_yaml(d)
        try:
            parse_problem(text, f"{path} with task.clearance {clearance:g}")
        except ProblemError as e:
            row.update(error=str(e).splitlines()[-1].strip() or str(e), verified=False)
            cost.rows.append(row)
            continue
        # the raised problem as a file beside its plan, which names it (plan.json problem_file):
        # `coplan verify`, `plot` and `view` then check and draw the plan at its own clearance
        source = out / f"plus_{extra:g}mm.yaml"
        atomic_text(source, text)
        prob = load_problem(source)
        row["problem_file"] = source.name  # (beside clearance.json: it was the path as the command was given, 'cmp2/plus_0mm.yaml')
        try:
            res = solve(prob, planner=planner, options=options, out_dir=out / f"plus_{extra:g}mm", progress=nested(progress))
            if res.plan.status == PlanStatus.INTERRUPTED:  # (the planner stopped at Ctrl-C and kept its incumbent)
                raise KeyboardInterrupt
        except KeyboardInterrupt:
            # the levels that finished are written (the one cut short is not: its makespan is not
            # the planner's answer), then the interruption goes on to the caller
            _cut_short(cost, out, extra, len(extras))
            raise
        m, ver = res.plan.metrics, res.verification
        if res.error:  # (an internal error in a stage: its plan from before it is this level's, and said so)
            cost.notes.append(f"+{extra:g} mm: the planner stopped on an internal error ({res.error}); its plan from "
                              "before the error is this row's")
        mk = m.get("makespan")
        locked = ((res.plan.solver or {}).get("screen") or {}).get("locked") or []
        if extra == 0.0:
            res0_makespan, res0_harvested, locked0 = mk, m.get("harvested"), set(locked)
        elif set(locked) - locked0:  # (a jump in makespan that the table alone left unexplained)
            why = ((res.plan.solver or {}).get("screen") or {}).get("reasons") or {}
            cost.notes.append(f"+{extra:g} mm: the screen locks {', '.join(sorted(set(locked) - locked0))} ("
                              + "; ".join(f"{a}: {why.get(a, 'locked')}" for a in sorted(set(locked) - locked0))
                              + ("" if m.get("lower_bound") is None else f"); the lower bound is {m['lower_bound']:.3f} s")
                              + (")" if m.get("lower_bound") is None else ""))
        own = mk
        verified = bool(ver is not None and ver.passed)
        if verified:
            earlier.append((extra, res.plan))
        best = (extra, ver)
        try:
            for e, pl in earlier[:-1] if verified else earlier:  # a smaller clearance's plan that keeps this one, faster
                mk_e = pl.metrics.get("makespan")
                if mk_e is None or (verified and mk_e >= mk - 1e-9) or pl.metrics.get("harvested") != m.get("harvested"):
                    continue
                v = verify(prob, pl)
                if v.passed:
                    best, mk, verified = (e, v), mk_e, True
        except KeyboardInterrupt:  # (while the smaller clearances' plans were verified here: as above)
            _cut_short(cost, out, extra, len(extras))
            raise
        if best[0] != extra:
            say(f"{base.name}: the +{best[0]:g} mm plan keeps {clearance:.3f} m too, at {mk:.3f} s "
                f"(this level's own plan {own:.3f} s)")
        ver = best[1]
        same_fruit = m.get("harvested") == res0_harvested  # (a ratio over fewer fruit would flatter)
        row.update(makespan=mk, lower_bound=m.get("lower_bound"), ratio=(mk / res0_makespan) if (mk and res0_makespan and same_fruit) else None,
                   margin_mm=None if ver is None or not ver.pairs else 1000 * ver.margin,
                   harvested=m.get("harvested"), reachable=m.get("reachable"), status=res.plan.status.value,
                   verified=verified, plan_from_mm=best[0], planned_makespan=own,
                   planning_time=(res.plan.solver.get("timings") or {}).get("total") or res.timings.get("total"))
        cost.rows.append(row)
    tick(Tick("clearance", len(extras), len(extras), "clearances"))
    _write(cost, out)
    if figures and any(r.get("makespan") for r in cost.rows):
        from ..viz.plots import plot_clearance_cost

        fig = plot_clearance_cost(cost.rows, title=f"{base.name}: makespan against the clearance asked for")
        fig.savefig(out / "clearance_cost.png", dpi=110)
        cost.files["figure"] = str(out / "clearance_cost.png")
    return cost


def _cut_short(cost: ClearanceCost, out: Path, extra: float, n: int) -> None:
    """An interruption at level ``extra``: the levels that finished written, with a note."""
    cost.notes.append(f"interrupted at +{extra:g} mm: this table covers the {len(cost.rows)} of {n} clearances that finished")
    _write(cost, out)


def _write(cost: ClearanceCost, out: Path) -> None:
    """clearance.json and clearance.md, each written whole."""
    atomic_text(out / "clearance.json", json.dumps(cost.to_dict(), indent=1, allow_nan=False))
    atomic_text(out / "clearance.md", to_markdown(cost))
    cost.files.update(json=str(out / "clearance.json"), markdown=str(out / "clearance.md"))


def cell(row: dict, key: str) -> str:
    """One table cell."""
    v = row.get(key)
    if key == "makespan" and row.get("error"):
        return f"impossible: {row['error']}"
    if v is None:
        return "-"
    if isinstance(v, bool):
        return "yes" if v else "no"
    if key == "harvested":  # (a partial plan's row showed '2 / 4' beside a makespan below the bound, and no status)
        return f"{v} / {row.get('reachable')}" + (f" ({row['status']})" if row.get("status") not in (None, "success") else "")
    if key == "extra_mm":
        return f"+{v:g}"
    if key == "plan_from_mm":
        return "its own" if v == row.get("extra_mm") else f"+{v:g} mm's"
    digits = {"ratio": 3, "clearance": 3, "margin_mm": 1, "lower_bound": 3}.get(key, 2)
    return f"{v:.{digits}f}" if isinstance(v, float) else str(v)


def to_markdown(cost: ClearanceCost) -> str:
    head = [h for _, h in COLUMNS]
    lines = [f"# {cost.problem}: makespan against the clearance asked for ({cost.planner} planner)", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in cost.rows:
        lines.append("| " + " | ".join(cell(r, k) for k, _ in COLUMNS) + " |")
    borrowed = sorted({f"+{r['extra_mm']:g} mm" for r in cost.rows
                       if r.get("plan_from_mm") is not None and r.get("plan_from_mm") != r.get("extra_mm")})
    if borrowed:  # (a row's figures read as those of the plan in its own folder, which can be slower)
        lines += ["", f"The rows at {', '.join(borrowed)} give a smaller clearance's plan, which keeps that room too "
                      "(verified at the row's clearance; its files are in that level's plus_<mm>mm/ folder); each "
                      "level's own plan, in its own plus_<mm>mm/ folder, is the column \"this level's own plan\"."]
    lines += [""] + [f"- {n}" for n in cost.notes] if cost.notes else []
    return "\n".join(lines) + "\n"
