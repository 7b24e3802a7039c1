"""The anytime optimal planner: the coordinated plan, improved by search and joint optimisation.

Entry point: :func:`plan_optimal`. It keeps an **incumbent**: a verified plan. Every later
candidate replaces it only if the independent verifier passes it and it harvests more, or as
much and faster (the widening stage: as much and no slower, with no less room). So the optimal
planner never returns a plan slower than the coordinated one that harvests as much (one that
harvests more may be slower), and whenever it stops -- at its work budget, at an explicit
``time_limit``, on Ctrl-C, or because the incumbent meets the lower bound (then it is
*proven optimal*) -- it has a verified plan to return.

1. **coordinated** (:func:`coplan.planners.coordinated.planner.plan_coordinated`): allocation, time-optimal
   S-curve moves, conflict-free coordination; verified, it is the first incumbent. The course's
   heuristic baseline (always returned beside the plan) is made right after that first plan.
2. **search** (:func:`coplan.planners.optimal.search.improve`): large-neighbourhood search over allocation,
   order, elbow branches and priorities with the coordinator as evaluator; each new best is
   verified and offered to the incumbent.
   Before the search, the coordinated plan's moves are **retimed**
   (:func:`coplan.planners.optimal.retime.retime`): the same moves, picks and places, every
   start chosen together by CP-SAT instead of leg by leg; a retimed plan is verified and
   offered like any other.
3. **refine** (:func:`coplan.planners.optimal.refine.refine`): the search's neighbourhood
   again from its best (and its other local bests), each neighbour retimed and ranked by its
   retimed makespan; each new best verified and offered. Without it (``refine_retimes: 0``,
   or more than ``refine_fruit`` fruit) the search's best alone is retimed.
4. **polish** (:func:`coplan.planners.optimal.windows.solve_windows`, with ``polish: true``):
   one CasADi/IPOPT program over all arms from the incumbent's schedules, where it still waits
   (receding windows on long rows); its plan is verified and offered like any other. When no
   coordinated plan could be verified at all, this is the planner's last resort (whatever
   ``polish`` says) and its status is reported honestly (best iterate kept, baseline beside it).
5. **widen** (:func:`coplan.planners.optimal.widen.widen`, ``widen: true`` by default): when the
   incumbent keeps less than ``widen_goal`` beyond the clearance, one CasADi/IPOPT program over
   all arms at its makespan and order of events widens the least room between neighbours and
   smooths the jerk; kept when verified, as fast and with a certified margin no smaller.
6. **regroup** (:func:`coplan.planners.optimal.regroup.regrouped`, ``regroup: true`` by
   default): where the widened plan still keeps less room than the widening's goal, stages 1-5
   again at a clearance raised by the shortfall -- other allocation, order and events -- kept
   when verified at the problem's clearance, as fast, harvesting as much, with more room.

The stages are named steps (:data:`coplan.planners.optimal.stages.STAGES`) that
:func:`plan_optimal` runs in turn over one :class:`~coplan.planners.optimal.incumbent.Incumbent`;
each writes its report (plan.json ``solver.<stage>``) and its wall time (``solver.timings``),
and ``solver.stages`` says what each did.

Every default budget is work (coordinator checks, evaluations, IPOPT iterations), so the
same input gives the same plan on any machine and under any load.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ...allocate.allocation import Allocation, AllocationMethod
from ...allocate.screen import screened
from ...plan import Plan, PlannerKind, PlanStatus, finalize_plan
from ...problem.model import Problem
from ...progress import ProgressCallbackError, guarded, speaker, ticker
from ..coordinated.planner import make_plan
from .incumbent import Incumbent, stop_message, time_to_ratio
from .nlp_data import SolverStatus
from ...errors import OptionsError
from .options import OptimalOptions, ipopt_issues
from .search_setup import StopReason
from .stages import STAGES, Run, nlp_plan, retimable

__all__ = ["OptimalOptions", "OptimalResult", "plan_optimal", "nlp_plan", "retimable", "time_to_ratio"]  # (re-exported)


@dataclass
class OptimalResult:
    plan: Plan
    verification: object
    baseline: Plan
    baseline_verification: object
    allocation: Allocation
    timings: dict[str, float]
    solver_status: SolverStatus
    coordinated: Plan | None = None
    error: str | None = None  # an internal error that stopped the planner (what it had is kept)
    error_trace: str | None = None
    candidate: object = None  # the incumbent's schedules (a Coordinated), when it has them


def plan_optimal(
    problem: Problem,
    allocation: AllocationMethod | str = AllocationMethod.MAKESPAN,
    options: OptimalOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> OptimalResult:
    """Plan all arms, anytime: the stages of :data:`~coplan.planners.optimal.stages.STAGES` in
    turn (coordinated, retime, search, refine, polish, widen, regroup); every incumbent verified."""
    from ...problem.gantry import require_cell

    require_cell(problem, "plan_optimal")
    opts = options or OptimalOptions()
    if opts.ipopt and (bad := ipopt_issues(opts.ipopt)):  # (checked when made, but a dict can change since)
        raise OptionsError(bad, f"{type(opts).__name__}, as changed since it was made")
    progress = guarded(progress)  # (a callback that raised once was swallowed: a plan 'found', with an error)
    say = speaker(progress)
    t_start = _time.perf_counter()
    run = Run(problem, allocation, opts, say, ticker(progress), t_start, Incumbent(problem, t_start, say),
              deadline=None if opts.time_limit is None else t_start + opts.time_limit, again=plan_optimal)
    error = error_trace = None
    try:
        for name, step in STAGES:
            if run.interrupted:
                break
            ts = _time.perf_counter()
            try:
                did = step(run)
            except KeyboardInterrupt:  # (said in plan.json: a stage cut short left no entry, its report None)
                _cut_in(run, name, _time.perf_counter() - ts)
                raise
            run.log.append({"stage": name, "result": did, "wall_seconds": _time.perf_counter() - ts})
        if run.proven():
            run.stop = StopReason.PROVEN_OPTIMAL
        elif run.deadline is not None and _time.perf_counter() >= run.deadline:
            run.stop = StopReason.TIME_LIMIT
    except KeyboardInterrupt:
        run.interrupted = True
    except ProgressCallbackError:
        raise
    except Exception as e:  # noqa: BLE001 -- a bug in a stage: keep what was computed before it, report it
        import traceback

        error, error_trace = f"{type(e).__name__}: {e}", traceback.format_exc()
        say(f"internal error ({error}); keeping what was computed before it")
    return _finish(run, error, error_trace)


def _cut_in(run: Run, name: str, seconds: float) -> None:
    """A Ctrl-C inside stage ``name``, ``seconds`` into it: its entry in the stages' log
    (``interrupted``), its time, and -- the widening stage, whose report the summary reads -- a
    report saying it was cut short and kept nothing of its own (a Ctrl-C between its rounds left
    ``solver.widen`` null and no stage entry: "never reached" could not be told from "cut off")."""
    run.log.append({"stage": name, "result": "interrupted", "wall_seconds": seconds})
    if name == "widen":
        run.timings["widen"] = run.timings.get("widen", 0.0) + seconds
        if run.reports.get("widen") is None:
            run.reports["widen"] = {"status": "interrupted", "accepted": False, "wall_seconds": seconds,
                                    "margin_before": (run.inc.plan.verification or {}).get("margin") if run.inc.plan is not None else None,
                                    "reason": f"interrupted (Ctrl-C) {seconds:.1f} s into the widening stage: "
                                              "the incumbent as it was before it is kept"}


def _finish(run: Run, error: str | None, error_trace: str | None) -> OptimalResult:
    """The incumbent as the planner's plan: its status, metrics and every stage's report."""
    from ...verify.verifier import verify

    problem, opts, inc, coord_plan = run.problem, run.opts, run.inc, run.coord_plan
    if run.interrupted:
        run.stop = StopReason.INTERRUPTED
    if not run.base:
        run.make_baseline()
    baseline, base_ver = run.base
    if inc.plan is None:  # interrupted before anything, or nothing could be planned
        if coord_plan is not None:
            inc.plan, inc.verification = coord_plan, None
        else:
            from ...allocate.allocation import allocate

            alloc0 = allocate(problem, run.allocation)
            inc.plan = make_plan(problem, alloc0, lambda t: {a.name: np.tile(a.home, (t.size, 1)) for a in problem.arms},
                                 0.0, [], PlanStatus.FAILED if error else PlanStatus.INTERRUPTED,
                                 {"message": "stopped before the first plan"}, PlannerKind.OPTIMAL)
        inc.verification = inc.verification or verify(problem, inc.plan)
    plan = inc.plan
    plan.planner = PlannerKind.OPTIMAL
    if run.interrupted:
        plan.status = PlanStatus.INTERRUPTED
    plan = finalize_plan(plan, inc.verification, run.n_reach)
    coord_mk = coord_plan.metrics.get("makespan") if coord_plan is not None and coord_plan.status == PlanStatus.SUCCESS else None
    lb = plan.metrics.get("lower_bound")
    mk = plan.metrics.get("makespan") or 0.0
    verified = plan.verification is not None and plan.verification.get("passed")
    plan.metrics.update(
        coordinated_makespan=coord_mk,
        improvement_over_coordinated=(1.0 - mk / coord_mk) if coord_mk else None,
        optimality="proven" if (verified and lb and mk <= lb + opts.tolerance and run.everything_harvestable(plan))
        else "not proven",
        baseline_makespan=baseline.metrics.get("makespan"),
        baseline_status=baseline.status.value,
        time_to_first_verified=inc.first_at,
        time_of_last_improvement=inc.improved_at,
        time_to_ratio=time_to_ratio(inc.history, lb),
    )
    timings = run.timings
    timings["total"] = _time.perf_counter() - run.t_start - timings["baseline"]
    plan.solver = {
        "status": plan.status.value,
        "message": stop_message(inc, run.stop),
        "stopped_by": run.stop.value,
        "incumbent_from": None if inc.source is None else inc.source.value,
        "moved_by": inc.moved_by,  # (the stage whose plan, at the incumbent's makespan, is the one written)
        "incumbents": inc.history,
        "first_verified_wall_time": inc.first_wall,  # s since the epoch: when a caller outside could have had a plan
        # fruit the incumbent's coordination could not fit in, each with the reason
        "left_out": dict(inc.candidate.left_out) if inc.candidate is not None else {},
        "allocation": AllocationMethod(run.allocation).value,
        "screen": screened(problem).summary(),
        "lower_bound": coord_plan.solver.get("lower_bound") if coord_plan is not None else None,
        "coordinated": coord_plan.solver if coord_plan is not None else None,
        "stages": run.log,
        **run.reports,
        "options": {k: v for k, v in opts.__dict__.items() if k != "ipopt"} | {"ipopt": dict(opts.ipopt)},
        "timings": dict(timings),
    }
    if error:
        kept = f"the verified incumbent from the {inc.source.value} stage ({mk:.3f} s)" if verified and inc.source \
            else "no verified plan (the arms stay at home)"
        plan.solver.update(internal_error=error, stopped_by="internal_error",
                           message=f"internal error ({error}); kept {kept} and the baseline")
    alloc_out = inc.candidate.alloc if inc.candidate is not None else None
    status = SolverStatus.INTERRUPTED if run.interrupted else SolverStatus.OPTIMAL if verified else SolverStatus.NUMERICAL_ERROR
    return OptimalResult(plan, inc.verification, baseline, base_ver, alloc_out, timings, status, coord_plan, error,
                         error_trace, inc.candidate)
