"""The optimal planner: min-makespan allocation + joint trajectory optimisation of all arms.

Entry point: :func:`plan_optimal`. Stages (each timed):

1. **allocate** -- min-makespan assignment (HiGHS MILP) and sweep sequencing
   (:mod:`coplan.allocation`), or the course's heuristic allocation when asked.
2. **warm start** -- decoupled time-optimal S-curve schedules, conflicts removed by waiting
   (:mod:`coplan.schedule`).
3. **NLP** -- one CasADi/IPOPT program over all arms (:mod:`coplan.nlp`). Separation
   constraints start at the knots where the warm start brings neighbouring links within
   ``screen`` m of each other; after each solve the continuous trajectory is checked
   densely and the points where it comes closer than ``clearance + margin / 2`` are added,
   up to ``max_rounds`` solves. Long schedules are cut into receding windows of about
   ``window`` seconds, solved in order, each starting from the state the previous one
   committed and ending at the warm start's pose, so the cost grows linearly with the row
   (see :func:`_cut_allowed`, :func:`_choose_commit`). A window that fails is solved again
   with its timing held near the warm start's (``_LADDER``).
4. **verify** -- the independent verifier (:mod:`coplan.verify`) certifies the plan. Only a
   converged *and* verified plan is a success; otherwise the best iterate is returned
   with an honest status, and the heuristic baseline is returned beside it.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from .allocation import Allocation, AllocationMethod, allocate, lower_bound
from .heuristic import grid as uniform_grid
from .heuristic import plan_heuristic
from .nlp import Grid, SolverStatus, build_grid
from .plan import DEFAULT_RATE, Event, EventKind, Plan, PlannerKind, PlanStatus, compute_metrics
from .problem import Problem
from .coordinate import coordinate
from .routing import choose_branches
from .schedule import ArmSchedule, ConflictError, StepKind, decoupled_schedules
from .windows import _LADDER, solve_windows

__all__ = ["OptimalOptions", "OptimalResult", "plan_optimal"]


@dataclass(frozen=True)
class OptimalOptions:
    """Solver options (separate from the problem).

    margin : extra clearance the optimiser keeps at its constraint points (m), so that the
        dense, certified check between them passes
    screen : initial constraint points where the warm start's links are within this (m)
    screen_shift : ... also when one arm of a pair runs up to this much (s) earlier or later
    h_target : target knot spacing (s)
    max_rounds : solves per window while adding constraint points
    band : when the dense check finds a dip, points are also added wherever links come within
        ``band`` (m) of the refinement threshold
    window : receding-window length (s of schedule); schedules shorter than 1.5 windows are
        solved as one NLP
    overlap : each window is solved this much (s) past its cut and kept only up to it
    window_time_limit : wall-clock cap of each IPOPT solve (s), so a struggling solve ends
    warm_start_budget : wall-clock budget of the search for a conflict-free warm start (s)
    time_limit : wall-clock limit for the whole optimisation (s); None for none
    check_rate : rate of the planner's own dense clearance check (Hz)
    """

    margin: float = 0.015
    screen: float = 0.25
    h_target: float = 0.06
    max_rounds: int = 6
    band: float = 0.03
    screen_shift: float = 0.0
    window: float = 12.0
    overlap: float = 2.5
    time_limit: float | None = None
    window_time_limit: float = 15.0
    warm_start_budget: float = 4.0
    check_rate: float = 1000.0
    ipopt: dict = field(default_factory=dict)


@dataclass
class OptimalResult:
    plan: Plan
    verification: object
    baseline: Plan
    baseline_verification: object
    allocation: Allocation
    timings: dict[str, float]
    solver_status: SolverStatus


# ----------------------------------------------------------------------------- plans
def _events(problem, schedules, grid: Grid, t_knots: np.ndarray, upto: int) -> list[Event]:
    kinds = {StepKind.PICK: EventKind.PICK, StepKind.PLACE: EventKind.PLACE}
    out = []
    for n, sch in schedules.items():
        for st, (k0, k1) in zip(sch.steps, grid.ranges[n]):
            if st.kind in kinds and k1 <= upto:
                out.append(Event(n, st.fruit, kinds[st.kind], float(t_knots[k0]), float(t_knots[k1])))
    return sorted(out, key=lambda e: (e.t_start, e.arm))


def _to_plan(problem, alloc, sampler, t_end, events, status, solver_info) -> Plan:
    times = uniform_grid(t_end, DEFAULT_RATE)
    q = sampler(times)
    plan = Plan(
        problem=problem.name,
        planner=PlannerKind.OPTIMAL,
        status=status,
        time=times,
        q=q,
        events=events,
        allocation={a: list(v) for a, v in alloc.assignment.items()},
        unreachable=list(alloc.unreachable),
        solver=solver_info,
    )
    plan.metrics = compute_metrics(plan, len(problem.reachable_ids()))
    plan.metrics["lower_bound"] = alloc.lower_bound
    return plan


def _priority_orders(base: dict[str, ArmSchedule], limit: int = 2) -> list[list[str]]:
    """Priority orders to try (ties and yields in :func:`coplan.coordinate.coordinate`): the arm
    that finishes last first, then the reverse, then other orders (up to ``limit``)."""
    import itertools

    names = sorted(base, key=lambda n: -base[n].last_place)
    if len(names) < 2:
        return [names]
    orders = [names, names[::-1]]
    for perm in itertools.permutations(names):
        if len(orders) >= limit:
            break
        if list(perm) not in orders:
            orders.append(list(perm))
    return orders[:limit]


def _warm_variants(problem: Problem, alloc: Allocation, need: float):
    """Schedules to coordinate for one allocation, most promising first: elbow branches chosen
    to keep out of the neighbours' way (:func:`coplan.routing.choose_branches`), then the
    allocation's own (fastest) branches, when they differ. (Moves that would box a neighbour
    in are rerouted by the coordinator itself.)"""
    seen = []
    for label, al in (("branches", None), ("fastest", alloc)):
        al = choose_branches(problem, alloc, need) if al is None else al
        base = decoupled_schedules(problem, al)
        key = [(n, [(st.kind, st.q1) for st in s.steps]) for n, s in base.items()]
        if key in seen:
            continue
        seen.append(key)
        yield label, base


def _choose_warm_start(problem: Problem, method: AllocationMethod, opts: OptimalOptions, say):
    """Allocation + conflict-free coordinated schedule: the fastest of a few candidates.

    Allocations: the min-makespan assignment, then the same MILP with a territory penalty
    (1, 3, 10 s for reaching into a neighbour's side) and/or with blocked pairs avoided (see
    :func:`coplan.allocation.allocate`); the heuristic method uses the course's allocation only.
    For each, schedules from :func:`_warm_variants`, each coordinated
    (:func:`coplan.coordinate.coordinate`: legs booked in time, deadlocks broken by yields)
    under the orders of :func:`_priority_orders`. The search goes breadth first -- the most
    promising variant of every allocation, then the others -- and skips an allocation whose
    own estimate (its arms' fastest decoupled finish, which no warm start from it can beat)
    is no better than the best warm start found, and goes deeper only into allocations whose
    first attempt came within 15 % of the best. Each attempt gets at most a third of
    ``warm_start_budget``, so one hard candidate cannot use it all. The search stops at a
    warm start within 2 % of the plain min-makespan estimate, or when the budget is spent;
    the warm start that places its last fruit first is kept.
    """
    if method == AllocationMethod.MAKESPAN:
        variants = [(t, b) for t in (0.0, 1.0, 3.0, 10.0) for b in (False, True)]
    else:
        variants = [(0.0, False)]
    need = problem.task.clearance + opts.margin
    t_stop = _time.perf_counter() + opts.warm_start_budget  # bounded: the NLP does the rest
    per_try = opts.warm_start_budget / 3.0
    best = None
    tried: list[dict] = []
    allocs: list[tuple] = []  # (territory, avoid, allocation, its remaining attempts, its first warm makespan)
    seen = []

    def attempts(alloc):
        for kind, base in _warm_variants(problem, alloc, need):
            for order in _priority_orders(base):
                yield kind, base, order

    def good_enough():
        return best is not None and best[3] <= 1.02 * reference + 1e-6

    def attempt(terr, avoid, alloc, kind, base, order):
        nonlocal best
        now = _time.perf_counter()
        entry = {"territory": terr, "avoid_blocked": avoid, "schedules": kind, "priority": order,
                 "estimate": alloc.estimated_makespan}
        try:
            sched, n, extra = coordinate(problem, base, opts.margin, priority=order, deadline=min(t_stop, now + per_try))
        except ConflictError as e:
            tried.append(entry | {"feasible": False, "reason": str(e), "seconds": _time.perf_counter() - now})
            say(f"warm start candidate (territory {terr:g} s, {kind}): {e}")
            return np.inf
        span = max((s.last_place for s in sched.values()), default=0.0)
        tried.append(entry | {"feasible": True, "warm_makespan": span, "waits": n, "yields": extra,
                              "seconds": _time.perf_counter() - now})
        if best is None or span < best[3] - 1e-9:
            best = (alloc, sched, n, span)
        return span

    bound = lower_bound(problem)  # depends only on the problem: one MILP for every candidate
    reference = None  # the plain min-makespan estimate: no candidate can beat it by waiting
    # breadth first: the first attempt of every allocation
    for terr, avoid in variants:
        if good_enough() or _time.perf_counter() > t_stop:
            break
        alloc = allocate(problem, method, territory=terr, avoid_blocked=avoid, bound=bound)
        reference = alloc.estimated_makespan if reference is None else reference
        if alloc.assignment in seen:
            continue
        seen.append(alloc.assignment)
        if best is not None and alloc.estimated_makespan >= best[3] - 1e-9:
            continue
        it = attempts(alloc)
        first = next(it, None)
        if first is not None:
            allocs.append((terr, avoid, alloc, it, attempt(terr, avoid, alloc, *first)))
    # then the remaining attempts, allocation by allocation, for allocations whose first
    # attempt came within 15 % of the best (the other variants rarely gain more than that)
    for terr, avoid, alloc, it, first_span in allocs:
        if best is not None and first_span > 1.15 * best[3]:
            continue
        for kind, base, order in it:
            if good_enough() or _time.perf_counter() > t_stop:
                break
            if best is not None and alloc.estimated_makespan >= best[3] - 1e-9:
                break
            attempt(terr, avoid, alloc, kind, base, order)
    if best is None:
        # no candidate could be coordinated: keep the first and let the NLP deform paths
        alloc = allocate(problem, method, bound=bound)
        sched = decoupled_schedules(problem, alloc)
        best = (alloc, sched, 0, max((s.last_place for s in sched.values()), default=0.0))
        say("no conflict-free warm start found; the optimiser starts from the colliding decoupled plan")
    alloc, sched, n, span = best
    say(f"allocation ({alloc.method.value}, territory {alloc.info.get('territory', 0):g} s): "
        + ", ".join(f"{a} {len(f)}" for a, f in alloc.assignment.items())
        + f"; warm start {span:.2f} s ({n} waits), lower bound {alloc.lower_bound:.2f} s")
    return alloc, sched, n, tried


_FAIL_STATUS = {
    SolverStatus.INTERRUPTED: PlanStatus.INTERRUPTED,
    SolverStatus.INFEASIBLE: PlanStatus.FAILED,
    SolverStatus.LIMIT_REACHED: PlanStatus.FAILED,
    SolverStatus.NUMERICAL_ERROR: PlanStatus.FAILED,
}


def plan_optimal(
    problem: Problem,
    allocation: AllocationMethod | str = AllocationMethod.MAKESPAN,
    options: OptimalOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> OptimalResult:
    """Plan all arms jointly and verify. See the module docstring for the stages."""
    from .pipeline import finalize
    from .verify import verify

    opts = options or OptimalOptions()
    say = progress or (lambda m: None)
    t_start = _time.perf_counter()
    deadline = None if opts.time_limit is None else t_start + opts.time_limit
    timings: dict[str, float] = {}

    # baseline, always available
    tb = _time.perf_counter()
    baseline = plan_heuristic(problem)
    base_ver = verify(problem, baseline)
    baseline = finalize(problem, baseline, base_ver)
    timings["baseline"] = _time.perf_counter() - tb

    t0 = _time.perf_counter()
    alloc, sched, n_delays, tried = _choose_warm_start(problem, AllocationMethod(allocation), opts, say)
    grid = build_grid(sched, opts.h_target)
    timings["allocation"] = _time.perf_counter() - t0

    names = [a.name for a in problem.arms]
    solver_info: dict = {"allocation": alloc.method.value, "sequence": alloc.sequence.value, "warm_start_delays": n_delays,
                         "territory": alloc.info.get("territory"), "candidates": tried}
    if not any(alloc.assignment.values()):
        plan = _to_plan(problem, alloc, lambda t: {a.name: np.tile(a.home, (t.size, 1)) for a in problem.arms},
                        0.0, [], PlanStatus.INFEASIBLE, solver_info | {"status": "infeasible", "message": "no reachable fruit"})
        ver = verify(problem, plan)
        return OptimalResult(finalize(problem, plan, ver), ver, baseline, base_ver, alloc, timings, SolverStatus.INFEASIBLE)

    try:
        # a window solved near the warm start after free-timing windows before it starts from a
        # state those left; when any window could not be solved cleanly, the whole schedule is
        # solved again with every window near the warm start from the first
        for level in range(len(_LADDER) - 1):
            stitched, info = solve_windows(problem, sched, grid, opts, deadline, say, level)
            info["level"] = level
            if info.get("clean") or info["status"] == SolverStatus.INTERRUPTED or (
                    deadline is not None and _time.perf_counter() > deadline):
                break
            if level + 2 < len(_LADDER):
                say(f"a window could not be solved cleanly: solving every window again with {_LADDER[level + 1][0]}")
                timings["discarded_solve"] = timings.get("discarded_solve", 0.0) + info["build"] + info["solve"]
    except KeyboardInterrupt:  # Ctrl-C outside IPOPT's iterations: keep the warm start
        stitched, info = None, {"status": SolverStatus.INTERRUPTED, "ipopt_status": "KeyboardInterrupt", "iterations": 0}
    timings["build"] = info.get("build", 0.0)
    timings["solve"] = info.get("solve", 0.0) + timings.pop("discarded_solve", 0.0)  # every solve counts
    status: SolverStatus = info["status"]
    solver_info.update(
        status=status.value,
        ipopt_status=info.get("ipopt_status"),
        iterations=info.get("iterations"),
        windows=info.get("windows"),
        rounds=info.get("rounds"),
        window_timing=info.get("window_stages"),
        restarted=bool(info.get("level", 0)),
        separation_points=info.get("points"),
        n_vars=info.get("n_vars"),
        n_cons=info.get("n_cons"),
        max_constraint_violation=info.get("max_violation"),
    )
    if stitched is None:
        # nothing optimised: the best we have is the conflict-free warm start
        t_end = max(s.end for s in sched.values())
        plan = _to_plan(problem, alloc, lambda t: {n: sched[n].state(t)[0] for n in names}, t_end,
                        [e for s in sched.values() for e in s.events()], PlanStatus.INTERRUPTED,
                        solver_info | {"message": "interrupted before the first iterate; the warm start is kept"})
    else:
        upto = stitched.t.size - 1
        events = _events(problem, sched, grid, stitched.t, upto)
        plan_status = PlanStatus.UNVERIFIED if status.converged else _FAIL_STATUS[status]
        msg = (f"IPOPT {info.get('ipopt_status')}" if status.converged else
               f"IPOPT stopped ({info.get('ipopt_status')}); the best iterate of window {info.get('complete_windows', 0) + 1} is kept")
        plan = _to_plan(problem, alloc, stitched.sample, float(stitched.t[-1]), events, plan_status, solver_info | {"message": msg})
    tv = _time.perf_counter()
    ver = verify(problem, plan)
    timings["verify"] = _time.perf_counter() - tv
    plan = finalize(problem, plan, ver)
    timings["total"] = _time.perf_counter() - t_start - timings["baseline"]
    plan.solver["timings"] = dict(timings)
    plan.metrics["baseline_makespan"] = baseline.metrics.get("makespan")
    return OptimalResult(plan, ver, baseline, base_ver, alloc, timings, status)
