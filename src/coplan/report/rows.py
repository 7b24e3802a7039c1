"""A row's stop rules side by side (``coplan compare ROW.yaml``).

Entry point: :func:`compare_rows` -> :class:`RowComparison`: the row planned with each stop
rule (fixed stride, fewest stops, optimised; the same cell planner at every stop), each plan
verified in the row frame and written to ``<out>/<rule>/``; ``compare.json`` and
``compare.md`` with, per rule, the stops, the row time, fruit per hour, the share of the
harvestable fruit harvested, the ratios to the row's lower bounds and the planning time.
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path

from ..kinds import PlannerKind, PlanStatus, StopRule
from ..output import atomic_text, check_folder
from ..plan import jsonable
from ..problem.generate import problem_from_mapping
from ..problem.load import load_problem
from ..problem.model import Problem
from ..progress import Tick, nested, speaker, ticker

__all__ = ["RowComparison", "compare_rows", "ROW_COLUMNS", "cell_text", "to_markdown"]

#: (key, heading) of the comparison's table.
ROW_COLUMNS = (("rule", "stop rule"), ("stops", "stops"), ("row_time", "row time, s"), ("fruit_per_hour", "fruit / h"),
               ("share_harvested", "harvested"), ("ratio_any_plan_bound", "/ bound (any plan)"),
               ("ratio_stop_and_go_bound", "/ bound (stop by stop, no overlap)"), ("planning_time", "planning, s"), ("verified", "verified"))


@dataclass
class RowComparison:
    problem: str
    cell_planner: str = PlannerKind.COORDINATED.value  # the cell planner at every stop (it was recorded nowhere)
    rows: list[dict] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)
    notes: list[str] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"format": "coplan.compare-rows/1", "problem": self.problem, "cell_planner": self.cell_planner,
                "rows": self.rows, "notes": self.notes}


def compare_rows(problem: Problem, out_dir: str | Path, rules=tuple(StopRule), planner: PlannerKind | str | None = None,
                 progress=None, workers: int | None = None) -> RowComparison:
    """Plan ``problem`` (a row) with each of ``rules``; write each run and the comparison
    (``workers``: each rule's stops' cells in that many processes, :class:`coplan.row.plan.RowOptions`)."""
    from ..pipeline import solve
    from ..row.metrics import fruit_bounds_count

    if isinstance(problem, (str, os.PathLike)):  # (a name or a path, as coplan.solve takes: it raised from inside)
        problem = load_problem(problem)
    elif isinstance(problem, Mapping):
        problem = problem_from_mapping(problem)
    elif not isinstance(problem, Problem):
        raise TypeError(f"compare_rows: expected a Problem, a problem file's path or a shipped name, found "
                        f"{type(problem).__name__} {str(problem)[:60]!r}")
    if isinstance(rules, str):  # one rule, not its letters ("found 'f'")
        rules = (rules,)
    say, tick = speaker(progress), ticker(progress)
    check_folder(out_dir, "out_dir")  # (before any work)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    cmp = RowComparison(problem.name, PlannerKind(planner).value if planner is not None else PlannerKind.COORDINATED.value)
    rules = [StopRule(r) for r in rules]
    options = None
    if workers is not None:
        from ..row.plan import RowOptions

        options = RowOptions(workers=workers)
    for i, rule in enumerate(rules):
        tick(Tick("compare", i, len(rules), "stop rules", note=rule.value))
        say(f"{problem.name}: stops {rule.value}")
        res = solve(problem, planner=planner, out_dir=out / rule.value, progress=nested(progress), stops=rule, options=options)
        m = res.plan.metrics.get("row") or {}
        cut = res.plan.status == PlanStatus.INTERRUPTED
        whole = (m.get("harvested") or 0) >= fruit_bounds_count(m)  # (no ratio to bounds that count fruit it left)
        cmp.rows.append({"rule": rule.value + (" (interrupted)" if cut else ""), "stops": m.get("stops"), "row_time": m.get("row_time"),
                         "fruit_per_hour": m.get("fruit_per_hour"), "share_harvested": m.get("share_harvested"),
                         "ratio_any_plan_bound": m.get("ratio_any_plan_bound") if whole else None,
                         "ratio_stop_and_go_bound": m.get("ratio_stop_and_go_bound") if whole else None,
                         "planning_time": m.get("planning_time"), "first_motion_seconds": m.get("first_motion_seconds"),
                         "kept_ahead": m.get("kept_ahead"), "verified": bool(res.verification.passed),
                         "status": res.plan.status.value, "plan": str(res.files.get("json", ""))})
        if res.plan.status not in (PlanStatus.SUCCESS, PlanStatus.INTERRUPTED):  # (an empty row read "0.0 s, verified")
            cmp.notes.append(_status_note(rule, res.plan, problem))
        if cut:  # Ctrl-C / SIGTERM: what finished is written, said, and the run stops
            cmp.notes.append(f"interrupted while planning stop rule {rule.value}: its row is cut short (status interrupted); "
                             f"this report covers {i} of {len(rules)} rules whole")
            _write(cmp, out)
            raise KeyboardInterrupt
    _write(cmp, out)
    return cmp


def _status_note(rule: StopRule, plan, problem: Problem) -> str:
    """Why a rule's row is not a success, in one line (its status is in compare.json too)."""
    m = plan.metrics
    why = {PlanStatus.INFEASIBLE: "no fruit can be harvested from any carriage position"
                                  + (" (the problem lists no fruit)" if not problem.fruits else ""),
           PlanStatus.PARTIAL: f"{m.get('harvested', 0)} of {m.get('reachable', 0)} harvestable fruit harvested",
           PlanStatus.UNSAFE: "the verifier failed its plan (verification.json says where)"}.get(plan.status, "")
    return f"stop rule {rule.value}: status {plan.status.value}" + (f": {why}" if why else "")


def _write(cmp: RowComparison, out: Path) -> None:
    """compare.json and compare.md (each rule's share of the best fruit per hour among those written)."""
    best = max((r["fruit_per_hour"] or 0.0 for r in cmp.rows), default=0.0)
    for r in cmp.rows:
        r["fruit_per_hour_vs_best"] = (r["fruit_per_hour"] or 0.0) / best if best else None
    cmp.files = {"json": str(out / "compare.json"), "markdown": str(out / "compare.md")}
    atomic_text(out / "compare.json", json.dumps(jsonable(cmp.to_dict()), indent=1, allow_nan=False))
    atomic_text(out / "compare.md", to_markdown(cmp))


def cell_text(key: str, v) -> str:
    if v is None:
        return "-"
    if key == "share_harvested":
        return f"{100 * v:.1f} %"
    if key == "verified":
        return "yes" if v else "NO"
    if isinstance(v, float):
        return f"{v:.3f}" if key.startswith("ratio") else f"{v:.1f}" if key != "planning_time" else f"{v:.2f}"
    return str(v)


def to_markdown(cmp: RowComparison) -> str:
    lines = [f"# {cmp.problem}: stop rules side by side ({cmp.cell_planner} cell planner at each stop)", "",
             "| " + " | ".join(h for _, h in ROW_COLUMNS) + " |", "|" + "---|" * len(ROW_COLUMNS)]
    lines += ["| " + " | ".join(cell_text(k, r.get(k)) for k, _ in ROW_COLUMNS) + " |" for r in cmp.rows]
    lines += [""] + [f"Note: {n}" for n in cmp.notes] if cmp.notes else []
    return "\n".join(lines) + "\n"
