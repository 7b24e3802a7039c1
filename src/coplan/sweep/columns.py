"""The columns of one sweep table row a solve fills (:func:`coplan.sweep.run.solve_item`): the
problem's own figures (:func:`problem_columns`), the result's (:func:`result_columns`) and, where
the plan is not a success, why (:func:`why_not`)."""

from __future__ import annotations

from typing import Any

from ..kinds import ExitCode, PlannerKind
from .spec import SweepItem

__all__ = ["exit_class", "problem_columns", "result_columns", "why_not"]


def exit_class(code: ExitCode) -> str:
    """``ExitCode.BAD_INPUT`` -> ``"bad input"``."""
    return code.name.lower().replace("_", " ")


def problem_columns(problem, item: SweepItem) -> dict[str, Any]:
    xs = sorted(a.base[0] for a in problem.arms)
    n = len(xs)
    spacing = (xs[-1] - xs[0]) / (n - 1) if n > 1 else None
    a0 = problem.arms[0]
    length = item.row_length
    if length is None and problem.gantry is not None:  # a row's file: its rail (it was arms x spacing: 6 m of an 8 m row)
        length = problem.gantry.length
    if length is None:
        length = n * spacing if spacing else 2.0 * a0.reach
    out = {"name": problem.name, "n_arms": n, "n_fruits": len(problem.fruits), "spacing": spacing, "row_length": length,
           "link_1": a0.links[0], "link_2": a0.links[1], "link_radius": a0.link_radius}
    if item.params.get("density") is None and length:
        out["density"] = len(problem.fruits) / length
    return out


def result_columns(res, row: dict[str, Any]) -> dict[str, Any]:
    m, ver, planner = res.plan.metrics, res.plan.verification or {}, res.plan.planner_name
    makespan, harvested = m.get("makespan"), m.get("harvested") or 0
    per_min = 60.0 * harvested / makespan if makespan else None
    out = {
        "status": res.status.value, "exit_code": int(res.exit_code), "exit_class": exit_class(res.exit_code),
        "reachable": m.get("reachable"), "harvested": m.get("harvested"), "makespan": makespan,
        "lower_bound": m.get("lower_bound"), "ratio": m.get("gap_to_lower_bound"), "optimality": m.get("optimality"),
        "coordinated_makespan": m.get("coordinated_makespan"), "heuristic_makespan": m.get("baseline_makespan"),
        "heuristic_status": m.get("baseline_status"), "cycle_worst": m.get("cycle_time"), "cycle_mean": m.get("cycle_time_mean"),
        "throughput": per_min, "throughput_per_m": per_min / row["row_length"] if per_min and row.get("row_length") else None,
        "certified_clearance": ver.get("certified_clearance"), "required_clearance": ver.get("required_clearance"),
        "verified": ver.get("passed"), "solve_time": res.timings.get("total"),
        "stopped_by": (res.plan.solver or {}).get("stopped_by"),
        "message": None if res.success else (res.plan.solver.get("message") or why_not(res)),
    }
    # (two of three arms locked by 0.6 m spacing was a success with an empty message: only coplan
    # check said why two arms did nothing and the row took longer than one arm's)
    r = m.get("row")
    locked = ((r or {}).get("locked_arms") or {}) or (((res.plan.solver or {}).get("screen") or {}).get("locked") or ())
    out["locked_arms"] = ", ".join(sorted(locked)) or None
    if r:  # a row on a gantry: what a grower judges
        # ``gantry``: the mode asked (a design's); ``gantry_mode``: the one the plan used (auto: the one kept; the
        # report lost the design that asked for auto, merged with continuous)
        out.update({"gantry": row.get("gantry") or r.get("mode"), "gantry_mode": r.get("mode"),
                    "fruit_per_hour": r.get("fruit_per_hour"), "share_harvested": r.get("share_harvested"),
                    "mean_speed": r.get("mean_speed"), "ratio": r.get("ratio_any_plan_bound"),
                    # (no other planner's row beside it: "coordinated / plan makespan" read 1.000, a
                    # coordinated row against itself, and the optimal rows had none)
                    "coordinated_makespan": None, "heuristic_makespan": None})
    if (m.get("reachable") or 0) > harvested:  # (the bound counts fruit this plan left out: 0.73 'below the bound')
        out["ratio"] = None
    if not res.problem.fruits:  # nothing to plan: no makespan, bound or ratio to show (they read 0.0)
        out.update(makespan=None, lower_bound=None, ratio=None, coordinated_makespan=None, heuristic_makespan=None)
        return out
    if planner == PlannerKind.COORDINATED.value and out["coordinated_makespan"] is None and not r:
        out["coordinated_makespan"] = makespan
    if planner == PlannerKind.HEURISTIC.value and not r:
        out["heuristic_makespan"], out["heuristic_status"] = makespan, res.status.value
    return out


def why_not(res) -> str:
    """A row's message where its plan is not a success: the status and fruit, the verifier's
    violations, and the reason for the first fruit it left out (``solver.left_out``, a row's
    ``solver.row.left_out``; else the screen's: ``solver.screen``, a row's
    ``metrics.row.screened_out``) -- or, with nothing to plan, that the problem has no fruit."""
    ver = res.plan.verification or {}
    kinds = ", ".join(ver.get("violation_kinds", []))
    m = res.plan.metrics
    if not res.problem.fruits:  # (a short row at a low density draws no fruit: 0/0 said nothing of why)
        # (a file's problem said "its generator drew none" too; a generated one's source names the generator)
        src = str(res.problem.source or "")
        made = not src.endswith((".yaml", ".yml", ".json"))
        return (f"{res.status.value}: the problem has no fruit ("
                + ("its generator drew none for these parameters" if made else "its file lists none") + ")")
    solver = res.plan.solver or {}
    left = solver.get("left_out") or (solver.get("row") or {}).get("left_out") or {}
    if not left:  # the fruit the screen rules out (a locked arm's, say), each with its reason
        screen = solver.get("screen") or {}
        left = {f: (screen.get("reasons") or {}).get(f, "screened out") for f in screen.get("unharvestable") or ()}
        left = left or dict((m.get("row") or {}).get("screened_out") or {})
    first = next(iter(left.items()), None)
    return (f"{res.status.value}: {m.get('harvested')}/{m.get('reachable')} fruit harvested" + (f"; violations: {kinds}" if kinds else "")
            + (f"; left out: {first[1] if str(first[1]).startswith(f'{first[0]}:') else f'{first[0]}: {first[1]}'}"
               + (f" (and {len(left) - 1} more)" if len(left) > 1 else "") if first else ""))
