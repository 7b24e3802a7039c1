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
   arms take turns (:func:`coplan.planners.coordinated.serial.serial_schedules`): a neighbour
   parks clear of the zone while an arm works. When taking turns spends its work budget too,
   the last resort (:func:`one_at_a_time`): one arm works at a time while the others rest,
   leaving out (with the reason) any fruit whose cycle comes too close to a resting neighbour
   -- so every problem gets a plan, at worst partial.
"""

from __future__ import annotations

import itertools
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ...allocate.allocation import (Allocation, AllocationMethod, LowerBound, allocate, arm_configs, bound_allocation,
                                   bound_details, choose_branches as fastest_branches)
from .coordinate import coordinate
from ..heuristic import grid as uniform_grid
from ...plan import DEFAULT_RATE, Event, Plan, PlannerKind, PlanStatus, compute_metrics, finalize_plan
from ...problem.model import Problem
from .routing import choose_branches
from .schedule import ArmSchedule, ConflictError, Step, StepKind, decoupled_schedules, pair_distances

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


@dataclass(frozen=True)
class CoordinatedOptions:
    """Options of the coordinated planner (separate from the problem).

    margin : extra clearance (m) kept between neighbours' capsules while coordinating
    attempt_checks : work cap of one coordination attempt (conflict checks), so one hard
        candidate cannot use the whole budget
    budget_checks : work budget of the whole candidate search (conflict checks)
    serial_pairs : work budget of the fallback in which the arms take turns (pose-pair
        tests over all its attempts), so that no layout holds the planner for hours; one
        attempt may spend a quarter of it
    time_limit : optional wall-clock limit (s); the plan then depends on the machine
    """

    margin: float = 0.015
    attempt_checks: int = 600
    budget_checks: int = 3000
    serial_pairs: int = SERIAL_PAIRS
    time_limit: float | None = None


@dataclass
class Coordinated:
    """One coordinated candidate: allocation, conflict-free schedules, priority order used."""

    alloc: Allocation
    schedules: dict[str, ArmSchedule]
    makespan: float
    order: list[str] = field(default_factory=list)
    variant: str = "branches"
    waits: int = 0
    fallback: bool = False
    left_out: dict = field(default_factory=dict)  # fruit -> why it could not be scheduled

    @property
    def total(self) -> float:
        """Sum of the arms' last places (the search's tie-breaker)."""
        return float(sum(s.last_place for s in self.schedules.values()))


@dataclass
class CoordinatedResult:
    plan: Plan
    verification: object
    candidate: Coordinated | None
    timings: dict[str, float]
    tried: list[dict]


def makespan_of(schedules: dict[str, ArmSchedule]) -> float:
    return max((s.last_place for s in schedules.values()), default=0.0)


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


def warm_variants(problem: Problem, alloc: Allocation, need: float):
    """``(label, allocation, schedules)`` to coordinate for one allocation, most promising
    first: elbow branches chosen to keep out of the neighbours' way
    (:func:`coplan.planners.coordinated.routing.choose_branches`), then the allocation's own (fastest) branches,
    when they differ."""
    seen = []
    for label, al in (("branches", None), ("fastest", alloc)):
        al = choose_branches(problem, alloc, need) if al is None else al
        base = decoupled_schedules(problem, al)
        key = [(n, [(st.kind, st.q1) for st in s.steps]) for n, s in base.items()]
        if key in seen:
            continue
        seen.append(key)
        yield label, al, base


def find_coordinated(problem: Problem, method: AllocationMethod, opts: CoordinatedOptions, say: Callable[[str], None],
                     cache: dict | None = None, deadline: float | None = None) -> tuple[Coordinated | None, list[dict], LowerBound]:
    """The fastest conflict-free coordinated candidate of a few allocations (see the module
    docstring). Returns ``(candidate or None, attempts tried, the lower bound's details)``."""
    if method == AllocationMethod.MAKESPAN:  # None: the lower bound's own assignment
        variants = [(None, False)] + [(t, b) for t in (0.0, 1.0, 3.0, 10.0) for b in (False, True)]
    else:
        variants = [(0.0, False)]
    need = problem.task.clearance + opts.margin
    cache = {} if cache is None else cache
    left = opts.budget_checks
    best: Coordinated | None = None
    tried: list[dict] = []
    allocs: list[tuple] = []  # (territory, avoid, allocation, its remaining attempts, its first makespan)
    seen = []
    details = bound_details(problem)  # depends only on the problem: one MILP for every candidate
    bound = details.value
    reference = None  # the plain min-makespan estimate: no candidate can beat it by waiting

    def attempts(alloc):
        for label, al, base in warm_variants(problem, alloc, need):
            for order in priority_orders(base):
                yield label, al, base, order

    def out_of_work():  # the clock limit never stops the first candidate: there must be a plan
        late = best is not None and deadline is not None and _time.perf_counter() > deadline
        return left <= 0 or late

    def good_enough():
        return best is not None and best.makespan <= 1.02 * reference + 1e-6

    def decoupled(alloc):  # each arm alone at full speed: when no pair comes too close, nothing beats it
        nonlocal best
        base = decoupled_schedules(problem, alloc)
        if clear(problem, base, need):
            span = makespan_of(base)
            tried.append({"allocation": "bound" if alloc.info.get("bound_allocation") else "milp", "schedules": "decoupled",
                          "feasible": True, "makespan": span, "waits": 0})
            best = Coordinated(alloc, base, span, [], "fastest", 0)

    def attempt(terr, avoid, label, al, base, order):
        nonlocal best, left
        entry = {"allocation": "bound" if terr is None else "milp", "territory": terr, "avoid_blocked": avoid, "schedules": label, "priority": order,
                 "estimate": al.estimated_makespan}
        checks = min(opts.attempt_checks, left)
        try:
            sched, n, extra = coordinate(problem, base, opts.margin, priority=order, max_checks=checks, cache=cache,
                                         deadline=deadline if best is not None else None)
        except ConflictError as e:
            left -= checks
            tried.append(entry | {"feasible": False, "reason": str(e)})
            say(f"coordination candidate ({entry['allocation']}, territory {terr or 0:g} s, {label}): {e}")
            return np.inf
        left -= 1  # every attempt costs at least one unit, so the search always ends
        span = makespan_of(sched)
        tried.append(entry | {"feasible": True, "makespan": span, "waits": n, "yields": extra})
        if best is None or span < best.makespan - 1e-9:
            best = Coordinated(al, sched, span, list(order), label, n)
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
    if best is None:
        best = _fallback(problem, method, opts, bound, say, tried)
    return best, tried, details


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


def _fallback(problem, method, opts, bound, say, tried) -> Coordinated | None:
    """The arms take turns (:func:`coplan.planners.coordinated.serial.serial_schedules`) when coordination deadlocks.

    When even that cannot schedule some fruit (its pick leaves a neighbour nowhere to go, or no
    turn for it is found within one attempt's work budget), that fruit is left out, with the
    reason, and the rest is planned again: a partial plan, never a failure, while any fruit can
    be harvested and the fallback's whole work budget (``opts.serial_pairs``) lasts."""
    from dataclasses import replace

    from .serial import serial_schedules

    full = alloc = allocate(problem, method, bound=bound)
    left_out: dict[str, str] = {}
    work: dict = {}
    while True:
        try:
            sched = serial_schedules(problem, decoupled_schedules(problem, alloc), opts.margin,
                                     max_pairs=min(opts.serial_pairs // 4, opts.serial_pairs - work.get("pairs", 0)), work=work)
            break
        except ConflictError as e:
            tried.append({"fallback": "serial", "feasible": False, "reason": str(e), "fruit": e.fruit,
                          "pairs": work.get("pairs", 0)})
            if e.fruit is None or e.fruit in left_out or work.get("pairs", 0) >= opts.serial_pairs:
                say(f"no conflict-free coordination found, and taking turns failed: {e}")
                return one_at_a_time(problem, full, opts.margin, say, tried)
            left_out[e.fruit] = str(e)
            say(f"taking turns: {e.fruit} is left out ({e})")
            alloc = replace(alloc, assignment={a: tuple(f for f in fs if f != e.fruit) for a, fs in alloc.assignment.items()})
    span = makespan_of(sched)
    tried.append({"fallback": "serial", "feasible": True, "makespan": span, "left_out": left_out,
                  "pairs": work.get("pairs", 0)})
    say(f"leg-by-leg coordination deadlocked on every candidate: the arms take turns ({span:.2f} s)")
    turns = Coordinated(alloc, sched, span, [], "serial", 0, fallback=True, left_out=left_out)
    if left_out:  # the last resort may harvest what taking turns left out
        alone = one_at_a_time(problem, full, opts.margin, say, tried)
        if len(alone.left_out) < len(left_out):
            return alone
    return turns


def one_at_a_time(problem: Problem, alloc: Allocation, margin: float, say: Callable[[str], None] | None = None,
                  tried: list | None = None, rate: float = 1000.0) -> Coordinated:
    """The last resort, which always gives a conflict-free plan: one arm works at a time while
    every other arm rests (at home, or where it finished), in the arms' order.

    Each arm does its allocated work, fastest decoupled schedule, without going home at the
    end. A fruit whose cycle (the move to it, the pick, the move to the bin, the place) comes
    within ``clearance + margin`` of a neighbour resting is left out with that reason, and the
    arm's schedule is made again; so is the last fruit when only the arm's start is in the way.
    Checked densely: each arm is sampled at least at ``rate`` and often enough that no point of
    it moves more than ``margin / 2`` between samples (at its joint velocity limits).
    """
    from dataclasses import replace

    need = problem.task.clearance + margin
    pairs = problem.neighbour_pairs()
    nbrs = {i: [j for p in pairs if i in p for j in p if j != i] for i in range(len(problem.arms))}
    rest = {a.name: tuple(float(x) for x in a.home) for a in problem.arms}
    left_out: dict[str, str] = {}
    out: dict[str, ArmSchedule] = {}
    assignment: dict[str, tuple[str, ...]] = {}
    t_start = 0.0
    fruit_q = {a: dict(v) for a, v in alloc.fruit_q.items()}
    place_q = {a: dict(v) for a, v in alloc.place_q.items()}
    x_of = {f.id: f.position[0] for f in problem.fruits}
    for i, arm in enumerate(problem.arms):
        seq = list(alloc.assignment.get(arm.name, ()))
        bins, fq = arm_configs(problem, arm)
        extra = [f for f in left_out if f in fq and bins]  # fruit an earlier arm had to leave: this one may take them
        if extra:
            seq = sorted(seq + extra, key=lambda f: x_of[f])
            fs, ps, _ = fastest_branches(problem, arm, seq, bins, fq)
            fruit_q[arm.name] = dict(zip(seq, fs))
            place_q[arm.name] = dict(zip(seq, ps))
            for f in extra:
                del left_out[f]

        l1, l2 = arm.links
        speed = (l1 + l2) * arm.max_velocity[0] + l2 * arm.max_velocity[1]  # fastest any point of the arm moves
        arm_rate = max(rate, 2.0 * speed / margin) if margin > 0 else rate

        def first_hit(sch: ArmSchedule) -> tuple[float, str] | None:
            t = np.append(np.arange(0.0, sch.end, 1.0 / arm_rate), sch.end)
            q = sch.state(t)[0]
            hit = None
            for j in nbrs[i]:
                other = problem.arms[j]
                d = pair_distances(problem, q, np.asarray(rest[other.name], float)[None, :], i, j)
                bad = np.flatnonzero(d < need)
                if bad.size and (hit is None or t[bad[0]] < hit[0]):
                    hit = (float(t[bad[0]]), other.name)
            return hit

        while True:
            solo = replace(alloc, assignment={a.name: tuple(seq) if a.name == arm.name else () for a in problem.arms},
                           fruit_q=fruit_q, place_q=place_q)
            sch = decoupled_schedules(problem, solo, return_home=False)[arm.name]
            hit = first_hit(sch)
            if hit is not None and seq and hit[0] > sch.last_place:  # only resting over the bin is in the way
                home_sch = decoupled_schedules(problem, solo, return_home=True)[arm.name]
                if first_hit(home_sch) is None:
                    sch, hit = home_sch, None
            if hit is None or not seq:
                break
            # the fruit whose cycle is under way then: the next pick or place at or after it
            nxt = next((s.fruit for s in sch.steps if s.fruit is not None and s.t1 >= hit[0]), seq[-1])
            seq.remove(nxt)
            left_out[nxt] = (f"with one arm working at a time, arm {arm.name!r} comes within {need:g} m of arm "
                             f"{hit[1]!r} resting while it harvests this fruit")
        assignment[arm.name] = tuple(seq)
        if not seq:
            out[arm.name] = ArmSchedule(arm, [])
            continue
        home = tuple(float(x) for x in arm.home)
        steps = [Step(StepKind.WAIT, 0.0, t_start, home, home)] if t_start > 0 else []
        steps += [replace(s, t0=s.t0 + t_start) for s in sch.steps]
        out[arm.name] = ArmSchedule(arm, steps)
        t_start += sch.end
        rest[arm.name] = tuple(float(x) for x in sch.steps[-1].q1)
    al = replace(alloc, assignment=assignment, fruit_q=fruit_q, place_q=place_q)
    span = makespan_of(out)
    if tried is not None:
        tried.append({"fallback": "one_at_a_time", "feasible": True, "makespan": span, "left_out": left_out})
    if say is not None:
        say(f"one arm at a time, the others resting: {span:.2f} s, {len(left_out)} fruit left out")
    return Coordinated(al, out, span, [], "one_at_a_time", 0, fallback=True, left_out=left_out)


def describe(c: Coordinated) -> str:
    return (", ".join(f"{a} {len(f)}" for a, f in c.alloc.assignment.items())
            + f"; coordinated {c.makespan:.3f} s ({c.waits} waits), lower bound {c.alloc.lower_bound:.3f} s")


def plan_coordinated(
    problem: Problem,
    allocation: AllocationMethod | str = AllocationMethod.MAKESPAN,
    options: CoordinatedOptions | None = None,
    progress: Callable[[str], None] | None = None,
    cache: dict | None = None,
) -> CoordinatedResult:
    """Allocate, schedule time-optimal S-curve moves, coordinate conflict-free; verify."""
    from ...verify.verifier import verify

    opts = options or CoordinatedOptions()
    say = progress or (lambda m: None)
    t0 = _time.perf_counter()
    deadline = None if opts.time_limit is None else t0 + opts.time_limit
    best, tried, bound = find_coordinated(problem, AllocationMethod(allocation), opts, say, cache, deadline)  # bound: LowerBound
    timings = {"allocation": _time.perf_counter() - t0}
    n_reach = len(problem.reachable_ids())
    from ...allocate.screen import screened

    info = {"allocation": AllocationMethod(allocation).value, "candidates": tried, "screen": screened(problem).summary(),
            "lower_bound": {"value": bound.value, "proven": bound.proven, "dual_bound": bound.dual_bound,
                            "milp_seconds": bound.seconds}}
    if best is None:
        alloc = allocate(problem, allocation, bound=bound.value)
        status = PlanStatus.INFEASIBLE if n_reach == 0 else PlanStatus.FAILED
        msg = "no reachable fruit" if n_reach == 0 else "no conflict-free coordination found; the arms stay home"
        plan = make_plan(problem, alloc, lambda t: {a.name: np.tile(a.home, (t.size, 1)) for a in problem.arms}, 0.0,
                         [], status, info | {"status": status.value, "message": msg}, PlannerKind.COORDINATED)
    else:
        say("coordinated: " + describe(best))
        info |= {"status": "ok", "priority": best.order, "schedules": best.variant, "waits": best.waits,
                 "fallback": best.variant if best.fallback else None, "left_out": best.left_out,
                 "territory": best.alloc.info.get("territory"), "sequence": best.alloc.sequence.value}
        plan = schedules_plan(problem, best.alloc, best.schedules, PlannerKind.COORDINATED, info)
    tv = _time.perf_counter()
    ver = verify(problem, plan)
    timings["verify"] = _time.perf_counter() - tv
    plan = finalize_plan(plan, ver, n_reach)
    timings["total"] = _time.perf_counter() - t0
    plan.solver["timings"] = dict(timings)
    return CoordinatedResult(plan, ver, best, timings, tried)
