"""The coordinated planner: min-makespan allocation, time-optimal jerk-limited moves, and
conflict-free coordination by waiting -- no NLP. Fast, and verified like every plan.

Entry point: :func:`plan_coordinated`. It is also the first stage of the anytime optimal
planner (:mod:`coplan.optimal`), whose incumbent starts as this planner's verified plan.

1. **Allocations** (:func:`coplan.allocate.allocation.allocate`): the min-makespan assignment, then the
   same MILP with a territory penalty (1, 3, 10 s for reaching into a neighbour's side)
   and/or with blocked pairs avoided; the heuristic method uses the course's allocation only.
2. **Schedules** (:func:`warm_variants`): each arm's fastest decoupled schedule with elbow
   branches chosen to keep out of the neighbours' way, then with the fastest branches.
3. **Coordination** (:func:`coplan.planners.coordinated.coordinate.coordinate`) under a few priority orders.
   The search goes breadth first (the most promising variant of every allocation, then the
   others) and skips an allocation whose own decoupled estimate (which no coordination can
   beat) is no better than the best found. Every budget here is *work* (conflict checks,
   attempts), never seconds, so the same problem gives the same plan on any machine and
   under any load; only an explicit ``time_limit`` depends on the clock.
4. **Fallback**: when no candidate can be coordinated (leg-by-leg booking deadlocks), the
   same search runs with the clearance alone, without the planning buffer (``margin``), kept
   if the verifier passes it -- a buffer wider than a passage the clearance leaves open
   deadlocks every candidate. Failing that, the arms take turns (:func:`coplan.planners.coordinated.serial.serial_schedules`): a neighbour
   parks clear of the zone while an arm works. When taking turns spends its work budget too,
   the last resort (:func:`coplan.planners.coordinated.alone.one_at_a_time`): one arm works at
   a time while the others rest, moving a resting neighbour out of the way where it must, and
   leaving out (with the reason) any fruit whose cycle no rest pose of that neighbour clears
   -- so every problem gets a plan, at worst partial.
"""

from __future__ import annotations

import itertools
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ...errors import check_fields, known_fields
from ...allocate.allocation import Allocation, AllocationMethod, LowerBound, allocate, bound_allocation, bound_details
from .budget import attempt_checks
from .coordinate import coordinate
from ..heuristic import grid as uniform_grid
from ...plan import DEFAULT_RATE, Event, Plan, PlannerKind, PlanStatus, compute_metrics, finalize_plan
from ...problem.model import Problem
from ...ties import quantised
from .alone import one_at_a_time
from .candidate import BranchRule, Coordinated, Fallback, makespan_of
from .routing import choose_branches
from .schedule import ArmSchedule, ConflictError, decoupled_schedules, pair_distances

__all__ = [
    "CoordinatedOptions",
    "CoordinatedResult",
    "Coordinated",
    "plan_coordinated",
    "find_coordinated",
    "make_plan",
    "schedules_plan",
    "warm_variants",
    "priority_orders",
    "makespan_of",
    "one_at_a_time",
]


# Work budget of the fallback in which the arms take turns, in pose-pair tests (1-4 million a
# second on one core): every random_problem(0..9) and shipped problem needs at most 9 million.
# One attempt may spend a quarter of it; each further attempt leaves out one more fruit.
SERIAL_PAIRS = 160_000_000


@known_fields
@dataclass(frozen=True)
class CoordinatedOptions:
    """Options of the coordinated planner (separate from the problem).

    margin : extra clearance (m) kept between neighbours' capsules while coordinating
    attempt_checks : work cap of one coordination attempt (conflict checks), so one hard
        candidate cannot use the whole budget -- or ``checks_per_fruit`` per fruit, if more
        (:func:`~coplan.planners.coordinated.budget.attempt_checks`)
    checks_per_fruit : the cap's growth with the row (8: from 75 fruit on); when it sets the
        cap, the budget is at least five attempts' caps
    budget_checks : work budget of the whole candidate search (conflict checks)
    serial_pairs : work budget of the fallback in which the arms take turns (pose-pair
        tests over all its attempts), so that no layout holds the planner for hours; one
        attempt may spend a quarter of it
    time_limit : optional wall-clock limit (s); the plan then depends on the machine
    relax_margin : where no candidate can be coordinated with ``margin``, search again with
        the clearance alone before the arms take turns (kept if verified); False where the
        margin is a requirement (a live row's stop cell: its booking's clearance)
    """

    margin: float = 0.015
    attempt_checks: int = 600
    checks_per_fruit: int = 8
    budget_checks: int = 3000
    serial_pairs: int = SERIAL_PAIRS
    time_limit: float | None = None
    relax_margin: bool = True

    def __post_init__(self) -> None:
        check_fields(self)  # (time_limit 0: the first candidate only) built in Python: every value checked (OptionsError: what was expected, found)


@dataclass
class CoordinatedResult:
    plan: Plan
    verification: object
    candidate: Coordinated | None
    timings: dict[str, float]
    tried: list[dict]
    bound: LowerBound | None = None  # the lower bound's details (its own allocation too)


# ----------------------------------------------------------------------------- plans
def make_plan(problem: Problem, alloc: Allocation, sampler, t_end: float, events: list[Event], status: PlanStatus,
              solver_info: dict, planner: PlannerKind) -> Plan:
    """A plan on the uniform grid from ``sampler(times) -> {arm: (K, 2)}``."""
    times = uniform_grid(t_end, DEFAULT_RATE)
    plan = Plan(
        problem=problem.name,
        planner=planner,
        status=status,
        time=times,
        q=sampler(times),
        events=events,
        allocation={a: list(v) for a, v in alloc.assignment.items()},
        unreachable=list(alloc.unreachable),
        solver=solver_info,
    )
    plan.metrics = compute_metrics(plan, len(problem.reachable_ids()))
    plan.metrics["lower_bound"] = alloc.lower_bound
    return plan


def schedules_plan(problem: Problem, alloc: Allocation, schedules: dict[str, ArmSchedule], planner: PlannerKind,
                   solver_info: dict, status: PlanStatus = PlanStatus.UNVERIFIED) -> Plan:
    """The plan of coordinated schedules (sampled exactly from their S-curves)."""
    names = [a.name for a in problem.arms]
    t_end = max((s.end for s in schedules.values()), default=0.0)
    events = sorted((e for s in schedules.values() for e in s.events()), key=lambda e: (e.t_start, e.arm))
    return make_plan(problem, alloc, lambda t: {n: schedules[n].state(t)[0] for n in names}, t_end, events, status,
                     solver_info, planner)


# ----------------------------------------------------------------------------- search
def priority_orders(base: dict[str, ArmSchedule], limit: int = 2) -> list[list[str]]:
    """Priority orders to try: the arm that finishes last first, then the reverse, then other
    orders (up to ``limit``)."""
    names = sorted(base, key=lambda n: -float(quantised(base[n].last_place)))  # stable: ties keep arm order
    if len(names) < 2:
        return [names]
    orders = [names, names[::-1]]
    for perm in itertools.permutations(names):
        if len(orders) >= limit:
            break
        if list(perm) not in orders:
            orders.append(list(perm))
    return orders[:limit]


def warm_variants(problem: Problem, alloc: Allocation, need: float):
    """``(label, allocation, schedules)`` to coordinate for one allocation, most promising
    first: elbow branches chosen to keep out of the neighbours' way
    (:func:`coplan.planners.coordinated.routing.choose_branches`), then the allocation's own (fastest) branches,
    when they differ."""
    seen = []
    for label, al in ((BranchRule.BRANCHES, None), (BranchRule.FASTEST, alloc)):
        al = choose_branches(problem, alloc, need) if al is None else al
        base = decoupled_schedules(problem, al)
        key = [(n, [(st.kind, st.q1) for st in s.steps]) for n, s in base.items()]
        if key in seen:
            continue
        seen.append(key)
        yield label, al, base


def find_coordinated(problem: Problem, method: AllocationMethod, opts: CoordinatedOptions, say: Callable[[str], None],
                     cache: dict | None = None, deadline: float | None = None,
                     on_feasible: Callable[[Coordinated], None] | None = None) -> tuple[Coordinated | None, list[dict], LowerBound]:
    """The fastest conflict-free coordinated candidate of a few allocations (see the module
    docstring). Returns ``(candidate or None, attempts tried, the lower bound's details)``.
    ``on_feasible`` is called with each new best candidate as soon as it is found (an anytime
    caller verifies the first one and has a plan long before every candidate is tried).

    When no candidate can be coordinated with the planning buffer (``opts.margin``), the same
    search runs again with the clearance alone (:func:`_without_margin`) before the arms take
    turns: a buffer wider than a passage the clearance leaves open (a link passing a
    neighbour's base with less than the buffer to spare) deadlocks every candidate."""
    tried: list[dict] = []
    details = bound_details(problem)  # depends only on the problem: one MILP for every candidate
    best = _search(problem, method, opts, say, cache, deadline, on_feasible, tried, details)
    if best is None and opts.relax_margin and opts.margin > 0 and not (deadline is not None and _time.perf_counter() > deadline):
        best = _without_margin(problem, method, opts, say, cache, deadline, on_feasible, tried, details)
    if best is None:
        best = _fallback(problem, method, opts, details.value, say, tried, deadline)
    return best, tried, details


def _search(problem: Problem, method: AllocationMethod, opts: CoordinatedOptions, say: Callable[[str], None],
            cache: dict | None, deadline: float | None, on_feasible: Callable[[Coordinated], None] | None,
            tried: list[dict], details: LowerBound, tag: dict | None = None) -> Coordinated | None:
    """The candidate search of :func:`find_coordinated` (each attempt appended to ``tried``, with
    ``tag``'s entries): the best conflict-free candidate, or None."""
    tag = tag or {}
    if method == AllocationMethod.MAKESPAN:  # None: the lower bound's own assignment
        variants = [(None, False)] + [(t, b) for t in (0.0, 1.0, 3.0, 10.0) for b in (False, True)]
    else:
        variants = [(0.0, False)]
    need = problem.task.clearance + opts.margin
    cache = {} if cache is None else cache
    per_attempt = attempt_checks(problem, opts.attempt_checks, opts.checks_per_fruit)
    left = opts.budget_checks if per_attempt == opts.attempt_checks else max(opts.budget_checks, 5 * per_attempt)
    best: Coordinated | None = None
    allocs: list[tuple] = []  # (territory, avoid, allocation, its remaining attempts, its first makespan)
    seen = []
    bound = details.value
    reference = None  # the plain min-makespan estimate: no candidate can beat it by waiting

    def attempts(alloc):
        for label, al, base in warm_variants(problem, alloc, need):
            for order in priority_orders(base):
                yield label, al, base, order

    def out_of_work():
        # the clock limit never stops the first candidate (time_limit 0: the first only); once one
        # is tried and the limit has passed, no more -- with none feasible, the arms take turns
        # (:func:`_fallback`): a margin that leaves no room spent 8 x a 3 s limit on candidates
        late = (best is not None or bool(tried)) and deadline is not None and _time.perf_counter() > deadline
        return left <= 0 or late

    def good_enough():
        return best is not None and best.makespan <= 1.02 * reference + 1e-6

    def decoupled(alloc):  # each arm alone at full speed: when no pair comes too close, nothing beats it
        nonlocal best
        base = decoupled_schedules(problem, alloc)
        if clear(problem, base, need):
            span = makespan_of(base)
            tried.append({"allocation": "bound" if alloc.info.get("bound_allocation") else "milp", "schedules": "decoupled",
                          "feasible": True, "makespan": span, "waits": 0} | tag)
            best = Coordinated(alloc, base, span, [], BranchRule.FASTEST, 0)
            if on_feasible is not None:
                on_feasible(best)

    def attempt(terr, avoid, label, al, base, order):
        nonlocal best, left
        entry = {"allocation": "bound" if terr is None else "milp", "territory": terr, "avoid_blocked": avoid, "schedules": label.value, "priority": order,
                 "estimate": al.estimated_makespan} | tag
        checks = min(per_attempt, left)
        try:
            sched, n, extra = coordinate(problem, base, opts.margin, priority=order, max_checks=checks, cache=cache,
                                         deadline=deadline if best is not None else None)
        except ConflictError as e:
            left -= checks
            tried.append(entry | {"feasible": False, "reason": str(e)})
            say(f"coordination candidate ({entry['allocation']}, territory {terr or 0:g} s, {label.value}): {e}")
            return np.inf
        left -= 1  # every attempt costs at least one unit, so the search always ends
        span = makespan_of(sched)
        tried.append(entry | {"feasible": True, "makespan": span, "waits": n, "yields": extra})
        if best is None or span < best.makespan - 1e-9:
            best = Coordinated(al, sched, span, list(order), label, n)
            if on_feasible is not None:
                on_feasible(best)
        return span

    for terr, avoid in variants:  # breadth first: the first attempt of every allocation
        if good_enough() or out_of_work():
            break
        if terr is None:
            alloc = bound_allocation(problem, details)
        else:
            alloc = allocate(problem, method, territory=terr, avoid_blocked=avoid, bound=bound)
        if reference is None:
            reference = alloc.estimated_makespan
            decoupled(alloc)
        if alloc.assignment in seen or (best is not None and alloc.estimated_makespan >= best.makespan - 1e-9):
            continue
        seen.append(alloc.assignment)
        it = attempts(alloc)
        first = next(it, None)
        if first is not None:
            allocs.append((terr, avoid, alloc, it, attempt(terr, avoid, *first)))
    # then the remaining attempts of allocations whose first came within 15 % of the best
    for terr, avoid, alloc, it, first_span in allocs:
        if best is not None and first_span > 1.15 * best.makespan:
            continue
        for label, al, base, order in it:
            if good_enough() or out_of_work() or (best is not None and alloc.estimated_makespan >= best.makespan - 1e-9):
                break
            attempt(terr, avoid, label, al, base, order)
    return best


def _without_margin(problem: Problem, method: AllocationMethod, opts: CoordinatedOptions, say: Callable[[str], None],
                    cache: dict | None, deadline: float | None, on_feasible: Callable[[Coordinated], None] | None,
                    tried: list[dict], details: LowerBound) -> Coordinated | None:
    """The candidate search again with the clearance alone (no planning buffer), kept only if
    the verifier passes its best: the buffer covers the motion between the coordinator's
    samples, which the verifier certifies. None: the arms take turns, with the buffer."""
    from ...verify.verifier import verify

    say(f"no candidate keeps the planning buffer ({opts.margin * 1000:g} mm beyond the clearance): "
        "coordinating with the clearance alone")
    best = _search(problem, method, replace(opts, margin=0.0), say, cache, deadline, on_feasible, tried, details,
                   {"margin": 0.0})
    if best is None:
        return None
    verdict = verify(problem, schedules_plan(problem, best.alloc, best.schedules, PlannerKind.COORDINATED, {}))
    tried.append({"margin": 0.0, "verified": bool(verdict.passed), "makespan": best.makespan})
    if not verdict.passed:
        say(f"coordinated with the clearance alone ({best.makespan:.2f} s), but the verifier does not pass it: "
            "the arms take turns")
        return None
    return replace(best, margin=0.0)


def clear(problem: Problem, schedules: dict[str, ArmSchedule], need: float, rate: float = 200.0) -> bool:
    """Whether every neighbouring pair keeps ``need`` (m) apart, sampled at ``rate`` (Hz)."""
    end = max((s.end for s in schedules.values()), default=0.0)
    t = np.append(np.arange(0.0, end, 1.0 / rate), end)
    q = {a.name: schedules[a.name].state(t)[0] for a in problem.arms}
    for i, j in problem.neighbour_pairs():
        qa, qb = q[problem.arms[i].name], q[problem.arms[j].name]
        if float(np.min(pair_distances(problem, qa, qb, i, j))) < need:
            return False
    return True


def _fallback(problem, method, opts, bound, say, tried, deadline: float | None = None) -> Coordinated | None:
    """The arms take turns (:func:`coplan.planners.coordinated.serial.serial_schedules`) when coordination deadlocks.

    When even that cannot schedule some fruit (its pick leaves a neighbour nowhere to go, or no
    turn for it is found within one attempt's work budget), that fruit is left out, with the
    reason, and the rest is planned again: a partial plan, never a failure, while any fruit can
    be harvested and the fallback's whole work budget (``opts.serial_pairs``) lasts."""
    from .serial import serial_schedules

    full = alloc = allocate(problem, method, bound=bound)
    left_out: dict[str, str] = {}
    work: dict = {}
    while True:
        try:
            sched = serial_schedules(problem, decoupled_schedules(problem, alloc), opts.margin,
                                     max_pairs=min(opts.serial_pairs // 4, opts.serial_pairs - work.get("pairs", 0)), work=work,
                                     deadline=deadline)
            break
        except ConflictError as e:
            tried.append({"fallback": Fallback.SERIAL.value, "feasible": False, "reason": str(e), "fruit": e.fruit,
                          "pairs": work.get("pairs", 0)})
            late = deadline is not None and _time.perf_counter() > deadline  # (a clock limit: no more tries)
            if e.fruit is None or e.fruit in left_out or work.get("pairs", 0) >= opts.serial_pairs or late:
                say(f"no conflict-free coordination found, and taking turns failed: {e}"
                    + (" (the time limit has passed)" if late else ""))
                return one_at_a_time(problem, full, opts.margin, say, tried)
            left_out[e.fruit] = str(e)
            say(f"taking turns: {e.fruit} is left out ({e})")
            alloc = replace(alloc, assignment={a: tuple(f for f in fs if f != e.fruit) for a, fs in alloc.assignment.items()})
    span = makespan_of(sched)
    tried.append({"fallback": Fallback.SERIAL.value, "feasible": True, "makespan": span, "left_out": left_out,
                  "pairs": work.get("pairs", 0)})
    say(f"leg-by-leg coordination deadlocked on every candidate: the arms take turns ({span:.2f} s)")
    turns = Coordinated(alloc, sched, span, [], Fallback.SERIAL, 0, fallback=True, left_out=left_out)
    if left_out and (deadline is None or _time.perf_counter() <= deadline):  # the last resort may harvest what taking turns left out
        alone = one_at_a_time(problem, full, opts.margin, say, tried)
        if len(alone.left_out) < len(left_out):
            return alone
    return turns


def describe(c: Coordinated) -> str:
    return (", ".join(f"{a} {len(f)}" for a, f in c.alloc.assignment.items())
            + f"; coordinated {c.makespan:.3f} s ({c.waits} waits), lower bound {c.alloc.lower_bound:.3f} s")


def plan_coordinated(
    problem: Problem,
    allocation: AllocationMethod | str = AllocationMethod.MAKESPAN,
    options: CoordinatedOptions | None = None,
    progress: Callable[[str], None] | None = None,
    cache: dict | None = None,
    on_feasible: Callable[[Coordinated], None] | None = None,
) -> CoordinatedResult:
    """Allocate, schedule time-optimal S-curve moves, coordinate conflict-free; verify.
    ``on_feasible``: see :func:`find_coordinated`."""
    from ...problem.gantry import require_cell
    from ...verify.verifier import verify

    require_cell(problem, "plan_coordinated")

    if isinstance(allocation, Allocation):
        raise TypeError("allocation: the coordinated planner allocates itself; it takes the method ('makespan' or "
                        "'heuristic'), found an Allocation (plan_heuristic takes one)")
    opts = options or CoordinatedOptions()
    say = progress or (lambda m: None)
    t0 = _time.perf_counter()
    deadline = None if opts.time_limit is None else t0 + opts.time_limit
    best, tried, bound = find_coordinated(problem, AllocationMethod(allocation), opts, say, cache, deadline,
                                          on_feasible)  # bound: LowerBound
    # (one search: allocation candidates, each scheduled and coordinated -- it was called "allocation")
    timings = {"plan": _time.perf_counter() - t0}
    n_reach = len(problem.reachable_ids())
    from ...allocate.screen import screened

    info = {"allocation": AllocationMethod(allocation).value, "candidates": tried, "screen": screened(problem).summary(),
            "lower_bound": {"value": bound.value, "proven": bound.proven, "dual_bound": bound.dual_bound,
                            "milp_seconds": bound.seconds}}
    if deadline is not None and timings["plan"] > opts.time_limit:  # the clock cut the candidates short (a sweep's
        info["stopped_by"] = "time_limit"  # rows said nothing, as the optimal planner's say time_limit)
    if best is None:
        alloc = allocate(problem, allocation, bound=bound.value)
        status = PlanStatus.INFEASIBLE if n_reach == 0 else PlanStatus.FAILED
        msg = "no reachable fruit" if n_reach == 0 else "no conflict-free coordination found; the arms stay home"
        plan = make_plan(problem, alloc, lambda t: {a.name: np.tile(a.home, (t.size, 1)) for a in problem.arms}, 0.0,
                         [], status, info | {"status": status.value, "message": msg}, PlannerKind.COORDINATED)
    else:
        say("coordinated: " + describe(best))
        info |= {"status": "ok", "priority": best.order, "schedules": best.variant.value, "waits": best.waits,
                 "fallback": best.variant.value if best.fallback else None, "left_out": best.left_out,
                 "planning_margin": opts.margin if best.margin is None else best.margin,
                 "planning_margin_dropped": None if best.margin is None else opts.margin,
                 "territory": best.alloc.info.get("territory"), "sequence": best.alloc.sequence.value}
        plan = schedules_plan(problem, best.alloc, best.schedules, PlannerKind.COORDINATED, info)
    tv = _time.perf_counter()
    ver = verify(problem, plan)
    timings["verify"] = _time.perf_counter() - tv
    plan = finalize_plan(plan, ver, n_reach)
    timings["total"] = _time.perf_counter() - t0
    plan.solver["timings"] = dict(timings)
    return CoordinatedResult(plan, ver, best, timings, tried, bound)
