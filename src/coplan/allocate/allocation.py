"""Allocate fruit to arms and sequence each arm's fruit.

Entry point: :func:`allocate`. Two methods (:class:`AllocationMethod`):

* ``heuristic`` -- the course's rule: in file order, each fruit goes to the arm with the best
  score manipulability / (distance + 0.1) among arms that can reach it; the arm harvests in
  file order.
* ``makespan`` -- an assignment problem solved exactly with HiGHS (``scipy.optimize.milp``):
  minimise the slowest arm's work, where a fruit's cost for an arm is its time-optimal
  (jerk-limited S-curve) bin -> fruit -> bin round trip plus both dwells. A tiny secondary
  term prefers less total work among equal makespans.

Sequencing (:class:`SequenceRule`): ``sweep`` (default for ``makespan``) orders every arm's
fruit by x, so all arms sweep the row in the same direction. Each arm then visits its overlap
zone with the left neighbour early and the one with the right neighbour late, while that
neighbour is at the other end of its own sweep: conflicts in shared zones become rare
without any change to travel time (every cycle starts and ends at the bin, so the order only
changes the first move from home). ``file`` keeps file order; ``shortest`` puts the fruit
closest in time to home first and sorts the rest by x.

The makespan lower bound (:attr:`Allocation.lower_bound`, :func:`lower_bound`,
:func:`bound_details`) relaxes the problem to arms that never wait for each other: each arm
goes home -> its first fruit -> bin, then bin -> fruit -> bin, with per-joint time-optimal
moves (the slowest joint alone), the best IK branches and both dwells. The min over
assignments and first fruits of the slowest arm's time is a MILP (HiGHS); its dual bound
is valid for any allocation, sequence and trajectory.
"""

from __future__ import annotations

import functools
import math
import time as _time
from dataclasses import dataclass, field

import numpy as np

from ..kinematics import arm as kin
from ..errors import CoplanError
from ..kinds import AllocationMethod, SequenceRule
from ..problem.gantry import require_cell, standing_reach
from ..problem.model import Arm, Problem, require_problem
from ..kinematics.timing import move_lower_bound, sync_duration
from ..ties import TIE, TIME_QUANTUM, first_min, quantised

__all__ = ["AllocationMethod", "SequenceRule", "Allocation", "allocate", "arm_configs", "lower_bound", "bound_details",
           "LowerBound", "bound_allocation", "screened_reach", "min_max_bound"]


class AllocationError(CoplanError):
    pass


@dataclass(frozen=True)
class Allocation:
    """Which arm harvests which fruit, in which order, with which IK branch.

    Attributes
    ----------
    assignment : arm -> fruit ids in harvesting order
    unreachable : fruit no arm can reach
    fruit_q : arm -> fruit id -> joint pose (2,) at the fruit (the chosen IK branch)
    place_q : arm -> fruit id -> joint pose (2,) over the bin when placing that fruit
    bin_q : arm -> a default joint pose (2,) over the bin
    estimate : arm -> estimated finish (last place) time with time-optimal synchronised moves
    lower_bound : makespan lower bound (s), valid for any plan
    """

    method: AllocationMethod
    sequence: SequenceRule
    assignment: dict[str, tuple[str, ...]]
    unreachable: tuple[str, ...]
    fruit_q: dict[str, dict[str, np.ndarray]]
    place_q: dict[str, dict[str, np.ndarray]]
    bin_q: dict[str, np.ndarray]
    estimate: dict[str, float]
    lower_bound: float
    seconds: float = 0.0
    info: dict = field(default_factory=dict)

    @property
    def estimated_makespan(self) -> float:
        """The busiest arm's estimated time (s): the allocation's own estimate, not a plan's."""
        return max(self.estimate.values(), default=0.0)


def _sync_time(arm: Arm, q0, q1) -> float:
    return sync_duration(q0, q1, arm.max_velocity, arm.max_acceleration, arm.max_jerk)


def _lb_time(arm: Arm, q0, q1) -> float:
    return move_lower_bound(q0, q1, arm.max_velocity, arm.max_acceleration, arm.max_jerk)


def arm_configs(problem: Problem, arm: Arm, prefer_elbow_up: bool = False, screen: bool = True):
    """IK branches an arm can use: over its bin, and at every fruit it can reach.

    Returns ``(bin_branches, {fruit_id: [branches]})`` (lists of (2,) joint poses). Only
    branches the static feasibility screen leaves usable (:func:`coplan.allocate.screen.screened`;
    ``screen=False``: every valid IK branch): an arm that can never reach its bin gets ``([],
    {})`` and takes no fruit. With ``prefer_elbow_up`` (the course's IK) only the elbow-up branch
    is kept where it is valid; where it is not, elbow-down is used (the lesson's IK skips the
    fruit), and a shoulder angle is wrapped into (-pi, pi] (the lesson's is not, and refuses a
    pose below -pi that the arm reaches): coplan's deviations from the lesson, docs/usage.md.
    """
    from .screen import screened

    scr = screened(problem)
    margin = problem.task.reach_margin
    q, valid = arm.ik(np.asarray(arm.bin, float), 0.0)
    bins = [q[b] for b in range(2) if valid[b] and (not screen or b in scr.bin_branches.get(arm.name, []))]
    if not bins:
        return [], {}
    if prefer_elbow_up:
        bins = bins[:1]
    fruit_q: dict[str, list[np.ndarray]] = {}
    q, valid = arm.ik(problem.fruit_positions, margin)  # every fruit at once
    for f, qs, ok in zip(problem.fruits, q, valid):
        usable = scr.fruit_branches.get((arm.name, f.id), []) if screen else (0, 1)
        br = [qs[b] for b in range(2) if ok[b] and b in usable]
        if br:
            fruit_q[f.id] = br[:1] if prefer_elbow_up else br
    return bins, fruit_q


def screened_reach(problem: Problem) -> np.ndarray:
    """(A, F) bool: which arm can harvest which fruit, after the static feasibility screen."""
    from .screen import screened

    return screened(problem).reach


def _round_trip(arm: Arm, bins, branches, timer) -> float:
    """Cheapest bin -> fruit -> bin over branches (each bin side chosen freely)."""
    return min(min(timer(arm, qb, qf) for qb in bins) + min(timer(arm, qf, qb) for qb in bins) for qf in branches)


def _first_trip(arm: Arm, bins, branches, timer) -> float:
    home = np.asarray(arm.home, float)
    return min(timer(arm, home, qf) + min(timer(arm, qf, qb) for qb in bins) for qf in branches)


def choose_branches(problem: Problem, arm: Arm, seq, bins, fq):
    """Dynamic programme over the sequence: IK branch at each fruit and at each place.

    Returns ``(fruit poses, place poses, finish time)``: the fastest chain
    home -> f1 -> bin -> f2 -> bin ... with time-optimal moves and the dwells.
    """
    dw = problem.task.pick_dwell + problem.task.place_dwell
    home = np.asarray(arm.home, float)
    states: dict = {None: (0.0, [], [])}
    for fid in seq:
        new: dict = {}
        for prev, (t, fs, ps) in states.items():
            start = home if prev is None else bins[prev]
            for qf in fq[fid]:
                t_f = t + _sync_time(arm, start, qf)
                for b, qb in enumerate(bins):
                    tt = t_f + _sync_time(arm, qf, qb) + dw
                    if b not in new or tt < new[b][0] - TIE:  # ties: the first branch, on any CPU
                        new[b] = (tt, fs + [qf], ps + [qb])
        states = new
    best = first_min(states.values(), key=lambda v: v[0])
    return best[1], best[2], best[0]


def _sequence(problem: Problem, arm: Arm, fruit_ids, rule: SequenceRule, bins, fq) -> tuple[str, ...]:
    order = {f.id: i for i, f in enumerate(problem.fruits)}
    ids = sorted(fruit_ids, key=order.__getitem__)
    if rule == SequenceRule.FILE or not ids:
        return tuple(ids)
    pos = {f.id: f.position for f in problem.fruits}
    by_x = sorted(ids, key=lambda f: (pos[f][0], pos[f][1]))
    if rule == SequenceRule.SWEEP:
        return tuple(by_x)
    first = first_min(ids, key=lambda f: _first_trip(arm, bins, fq[f], _sync_time) - _round_trip(arm, bins, fq[f], _sync_time))
    return (first,) + tuple(f for f in by_x if f != first)


BLOCKED_COST = 1000.0  # s: effectively forbids a blocked pair unless no other arm can take the fruit


@functools.lru_cache(maxsize=64)
def _blocked_memo(problem: Problem, a: int) -> dict[str, bool]:
    """Arm a's :func:`_blocked` results by fruit id, kept per problem: the coordinated planner
    allocates several times with ``avoid_blocked`` and the same screened branches."""
    return {}


def _blocked_fruit(problem: Problem, a: int, fid: str, bins, branches) -> bool:
    memo = _blocked_memo(problem, a)
    if fid not in memo:
        memo[fid] = _blocked(problem, a, bins, branches)
    return memo[fid]


def _blocked(problem: Problem, a: int, bins, branches, samples: int = 24) -> bool:
    """Whether every branch's pick pose or bin round trip hits a neighbour resting at home."""
    from ..kinematics.geometry import segment_distance

    arm = problem.arms[a]
    need = problem.task.clearance
    neighbours = [j if i == a else i for i, j in problem.neighbour_pairs() if a in (i, j)]
    if not neighbours:
        return False
    s = np.linspace(0.0, 1.0, samples)[:, None]
    for qf in branches:
        ok = True
        for qb in bins:
            path = np.vstack([qb + s * (qf - qb)])
            pa = kin.fk_points(path, arm.links, arm.base)
            for j in neighbours:
                other = problem.arms[j]
                pb = kin.fk_points(np.asarray(other.home, float), other.links, other.base)
                d = min(
                    float(np.min(segment_distance(pa[:, u], pa[:, u + 1], pb[v], pb[v + 1])))
                    for u in range(2)
                    for v in range(2)
                ) - arm.link_radius - other.link_radius
                if d < need:
                    ok = False
        if ok:
            return False
    return True


def _first_candidates(pairs: np.ndarray, saving: np.ndarray, only: np.ndarray):
    """(pairs given a first-fruit binary y, pairs g forcing sum y >= x[g], arms always used), exact:
    an arm that alone reaches some fruit always harvests it, so y is needed only below its least
    saving m among those (and on that fruit), with sum y = 1. Otherwise y is needed where the
    saving (P,) is < 0 or, if some is > 0, everywhere: positive g force a first fruit."""
    ys, force, always = [], [], set()
    for a in np.unique(pairs[:, 0]):
        idx = np.flatnonzero(pairs[:, 0] == a)
        s, own = saving[idx], only[pairs[idx, 1]]
        if own.any():
            k = int(np.argmin(np.where(own, s, np.inf)))
            ys += [*idx[s < s[k]], idx[k]]
            always.add(a)
        else:
            ys += list(idx if (s > 0).any() else idx[s < 0])
            force += list(idx[s > 0])
    return np.array(ys, int), np.array(force, int), always


# MILP time coefficients are :func:`coplan.ties.quantised` (whole microseconds, rounded down):
# fed the last bits of move times, which differ between CPUs, HiGHS returned another of a
# min-max MILP's many optima on another machine.

#: Branch-and-bound nodes a MILP may spend: a deterministic limit (the clock limit, seconds, is
#: only a safety net). 300 random layouts of the benchmark need at most 822.
MILP_NODES = 5_000
#: The MILPs' clock limit (s): a safety net behind :data:`MILP_NODES`, which binds first.
MILP_SECONDS = 60.0


def _minmax_milp(cost, reach, time_limit, offset=None, saving=None, tie_break=True, least_work=False, relax=False):
    """min t: each fruit to one arm that reaches it, t >= offset[a] + sum_f cost[a, f] x[a, f]
    (+ saving[a, f] y[a, f], y: the arm's first fruit, see :func:`_first_candidates`).

    Every time is :func:`quantised` first. ``tie_break`` adds a tiny total-work term
    (allocation); ``least_work`` instead solves a second MILP: the least total work among the
    optima of the first (the bound: its dual bound stays the first's). Returns (scipy result, arm per fruit (F,) or -1, HiGHS's dual bound or nan).
    """
    from scipy.optimize import Bounds, LinearConstraint, milp  # imported here: `coplan --help` stays quick
    from scipy.sparse import coo_array

    A, F = cost.shape
    cost = quantised(cost)
    saving = None if saving is None else quantised(saving)
    offset = np.zeros(A) if offset is None else quantised(offset)
    pairs = np.argwhere(reach)  # (P, 2) rows (a, f)
    P = len(pairs)
    ys, force, always = np.zeros(0, int), np.zeros(0, int), set()
    if saving is not None:
        ys, force, always = _first_candidates(pairs, saving[reach], reach.sum(axis=0) == 1)
    n = P + len(ys) + 1
    c = np.zeros(n)
    c[-1] = 1.0
    if tie_break:
        c[:P] = 1e-4 * cost[pairs[:, 0], pairs[:, 1]] / max(F, 1)
    ents, lo, hi = [], [], []  # (row, column, value), row bounds

    def row(cols, vals, lb, ub):
        ents.extend((len(lo), j, v) for j, v in zip(cols, np.broadcast_to(vals, len(cols))))
        lo.append(lb)
        hi.append(ub)

    for f in range(F):
        row(np.flatnonzero(pairs[:, 1] == f), 1.0, 1.0, 1.0)
    for a in range(A):
        m, my = np.flatnonzero(pairs[:, 0] == a), P + np.flatnonzero(pairs[ys, 0] == a)
        sv = saving[a, pairs[ys[my - P], 1]] if my.size else []
        row(np.r_[m, my, n - 1], np.r_[cost[a, pairs[m, 1]], sv, -1.0], -np.inf, -offset[a])
        if my.size:  # at most one first fruit (exactly one if the arm is always used)
            row(my, 1.0, 1.0 if a in always else -np.inf, 1.0)
            for g in force[pairs[force, 0] == a]:
                row(np.r_[my, g], np.r_[np.ones(my.size), -1.0], 0.0, np.inf)
    for q, p in enumerate(ys):  # y[a, f] <= x[a, f]
        row([P + q, p], [1.0, -1.0], -np.inf, 0.0)
    r, j, v = np.array(ents, float).reshape(-1, 3).T
    mat = coo_array((v, (r.astype(int), j.astype(int))), shape=(len(lo), n)).tocsr()
    opts = {"disp": False, "mip_rel_gap": 1e-6, "node_limit": MILP_NODES} | (
        {} if time_limit is None else {"time_limit": float(time_limit)})
    res = milp(
        c,
        constraints=LinearConstraint(mat, lo, hi),
        integrality=np.zeros(n) if relax else np.r_[np.ones(n - 1), 0.0],
        bounds=Bounds(np.zeros(n), np.r_[np.ones(n - 1), np.inf]),
        options=opts,
    )
    x_best = res.x
    if least_work and res.x is not None and res.status == 0:
        # among the optima, the least total work: a canonical choice, and the most efficient one
        work = np.zeros(n)
        work[:P] = cost[pairs[:, 0], pairs[:, 1]]
        work[P:n - 1] = saving[pairs[ys, 0], pairs[ys, 1]] if len(ys) else []
        second = milp(work, constraints=LinearConstraint(mat, lo, hi), integrality=np.r_[np.ones(n - 1), 0.0],
                      bounds=Bounds(np.zeros(n), np.r_[np.ones(n - 1), res.x[-1] + 0.5 * TIME_QUANTUM]), options=opts)
        if second.x is not None:  # else (its node limit) the first optimum stands
            x_best = second.x
    assign = np.full(F, -1)
    if x_best is not None:
        x = x_best[:P] > 0.5
        assign[pairs[x, 1]] = pairs[x, 0]
    dual = res.fun if relax and res.status == 0 else getattr(res, "mip_dual_bound", None)
    return res, assign, float(dual) if dual is not None and np.isfinite(dual) else np.nan


def _solve_minmax(cost: np.ndarray, reach: np.ndarray, time_limit: float | None, offset=None, tie_break: bool = True):
    """min over assignments of max_a (offset[a] + sum_f cost[a, f] x[a, f]).

    Returns (assign (F,), value, dual bound). ``offset`` (A,) <= 0 applies to used arms.
    Without ``tie_break`` the objective is the makespan alone, so the dual bound bounds it.
    """
    A = cost.shape[0]
    offset = np.zeros(A) if offset is None else np.asarray(offset, float)
    res, assign, dual = _minmax_milp(cost, reach, time_limit, offset, tie_break=tie_break)
    if res.x is None:
        raise AllocationError(f"assignment MILP failed: {res.message}")
    value = float(max(offset[a] + cost[a, assign == a].sum() if (assign == a).any() else 0.0 for a in range(A)))
    return assign, value, min(value, dual) if np.isfinite(dual) else value


def min_max_bound(cost: np.ndarray, reach: np.ndarray, time_limit: float | None = MILP_SECONDS, relax: bool = False) -> float:
    """A lower bound on min over assignments (each fruit f to one arm a with ``reach[a, f]``) of
    the busiest arm's total ``cost`` (A, F): the MILP's dual bound (times :func:`quantised`, so
    rounded down), valid even when the MILP stops at its node limit; with ``relax`` the optimum
    of its LP relaxation (fractional assignments: fast on thousands of fruit, a little lower).
    0 with no fruit."""
    if cost.size == 0 or not reach.any():
        return 0.0
    cols = np.flatnonzero(reach.any(axis=0))
    res, assign, dual = _minmax_milp(np.asarray(cost, float)[:, cols], reach[:, cols], time_limit, tie_break=False,
                                     relax=relax)
    if np.isfinite(dual):
        return float(dual) - (1e-6 if relax else 0.0)  # (an LP optimum is exact to HiGHS's tolerance)
    sub = np.where(reach[:, cols], quantised(cost[:, cols]), np.inf)  # stopped before any dual bound
    return float(max(sub.min(axis=0).max(), sub.min(axis=0).sum() / cost.shape[0]))


@dataclass(frozen=True)
class LowerBound:
    """:func:`bound_details`: ``value`` the bound (s), HiGHS's dual bound (the MILP's optimum once
    ``proven``: status 0, no gap left); ``primal`` its incumbent's makespan (nan if none);
    ``first_fruit`` arm -> the fruit the incumbent approaches from home (None: an idle arm);
    ``assignment`` arm -> the incumbent's fruit, its first fruit first and the rest by x (a
    plan that runs it without waiting meets the bound: see :func:`bound_allocation`)."""

    value: float
    proven: bool
    dual_bound: float
    primal: float
    first_fruit: dict[str, str | None]
    seconds: float
    assignment: dict[str, tuple[str, ...]] = field(default_factory=dict)


def _check_cell(problem, what: str, **args) -> None:
    """TypeError where ``problem`` is not a :class:`Problem` (a name raised "cannot create weak
    reference to 'str' object"), ValueError where it is a row (:func:`require_cell`); then the
    stage's arguments ``args`` (time_limit, bound, territory, reach), every bad one in one
    ValueError, "expected X, found Y" (a negative or NaN time limit was ignored by HiGHS with a
    warning, a NaN bound became the allocation's, a reach matrix of another shape a KeyError)."""
    require_problem(problem, what)
    require_cell(problem, what)
    bad = []

    def number(v) -> bool:
        return isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, bool) and math.isfinite(v)

    # (name, may be None, least allowed, whether the least is allowed, what is expected)
    for k, optional, least, closed, words in (("time_limit", True, 0.0, False, "a positive number of seconds or None"),
                                              ("bound", True, 0.0, True, "a number of 0 s or more or None"),
                                              ("territory", False, 0.0, True, "a number of 0 s or more")):
        if k not in args or (optional and args[k] is None):
            continue
        v = args[k]
        if not (number(v) and (v >= least if closed else v > least)):
            bad.append(f"{k}: expected {words}, found {v!r}")
    reach = args.get("reach")
    if reach is not None:
        shape = (len(problem.arms), len(problem.fruits))
        r = np.asarray(reach)
        if r.shape != shape or r.dtype != bool:
            bad.append(f"reach: expected a boolean array of shape {shape} (arms x fruit), found {r.dtype} {r.shape}")
        elif (out := np.argwhere(r & ~problem.reach_matrix())).size:
            a, j = map(int, out[0])
            bad.append(f"reach: expected True only where the arm reaches the fruit (problem.reach_matrix()), found "
                       f"{problem.arms[a].name} marked to reach {problem.fruits[j].id}, out of its reach")
    if bad:
        raise ValueError(f"{what}: " + "; ".join(bad))


def bound_details(problem: Problem, reach: np.ndarray | None = None, time_limit: float | None = MILP_SECONDS) -> LowerBound:
    """Makespan lower bound valid for every plan, with the MILP's details.

    A one-arm-at-a-time relaxation: each arm goes home -> first fruit -> bin, then bin ->
    fruit -> bin for the rest, every move per-joint time-optimal (the slowest joint alone,
    best IK branches and bin poses), plus both dwells per fruit; arms never wait for each
    other. The min over assignments and first fruits of the slowest arm's time is solved as
    a MILP (HiGHS) on :func:`quantised` times; its dual bound is taken, so a solve stopped at
    :data:`MILP_NODES` stays a valid bound. Among its optima, the one with the least total work
    gives :attr:`LowerBound.assignment`.
    """
    _check_cell(problem, "lower_bound", reach=reach, time_limit=time_limit)  # (a row's was the cell's with the carriage at 0)
    t0 = _time.perf_counter()
    reach = screened_reach(problem) if reach is None else reach
    names = [arm.name for arm in problem.arms]
    cols = np.flatnonzero(reach.any(axis=0))
    if cols.size == 0:
        return LowerBound(0.0, True, 0.0, 0.0, dict.fromkeys(names), _time.perf_counter() - t0, {n: () for n in names})
    dw = problem.task.pick_dwell + problem.task.place_dwell
    A = len(problem.arms)
    cost, saving = np.zeros((A, cols.size)), np.zeros((A, cols.size))
    for a, arm in enumerate(problem.arms):
        bins, fq = arm_configs(problem, arm)
        home = np.asarray(arm.home, float)
        for k, j in enumerate(cols):
            if reach[a, j]:  # _round_trip and _first_trip at once (lower-bound moves are symmetric)
                br = fq[problem.fruits[j].id]
                leg = [min(_lb_time(arm, qb, qf) for qb in bins) for qf in br]
                cost[a, k] = 2.0 * min(leg) + dw
                saving[a, k] = min(_lb_time(arm, home, qf) + t for qf, t in zip(br, leg)) - 2.0 * min(leg)
    sub = reach[:, cols]
    cost, saving = quantised(cost), quantised(saving)  # what the MILP sees (a bound still)
    res, assign, dual = _minmax_milp(cost, sub, time_limit, saving=saving, tie_break=False, least_work=True)
    first, primal = dict.fromkeys(names), np.nan if res.x is None else 0.0
    for a in range(A):  # the incumbent's makespan; an arm's first fruit has its least saving
        mine = np.flatnonzero(assign == a)
        if mine.size:
            k = mine[np.argmin(saving[a, mine])]
            first[names[a]] = problem.fruits[cols[k]].id
            primal = max(primal, cost[a, mine].sum() + saving[a, k])
    if not np.isfinite(dual):  # stopped before any dual bound: the costliest fruit, or the mean arm
        most = np.where(sub, cost + np.minimum(saving, 0.0), np.inf).min(axis=0).max()
        mean = (np.where(sub, cost, np.inf).min(axis=0).sum() + np.minimum(saving, 0.0).min(axis=1).sum()) / A
        dual = float(max(most, mean))
    proven = res.status == 0 and primal - dual <= 1e-6 * max(1.0, primal)  # False if primal is nan
    value = min(dual, primal) if np.isfinite(primal) else dual
    pos = {f.id: f.position for f in problem.fruits}
    assignment = {}
    for a, n in enumerate(names):
        ids = sorted((problem.fruits[cols[k]].id for k in np.flatnonzero(assign == a)), key=lambda f: (pos[f][0], pos[f][1]))
        assignment[n] = tuple(([first[n]] if first[n] else []) + [f for f in ids if f != first[n]])
    return LowerBound(float(value), bool(proven), float(dual), float(primal), first, _time.perf_counter() - t0, assignment)


def lower_bound(problem: Problem, reach: np.ndarray | None = None, time_limit: float | None = MILP_SECONDS) -> float:
    """Makespan lower bound valid for every plan: :attr:`LowerBound.value` of :func:`bound_details`."""
    return bound_details(problem, reach, time_limit).value


def allocate(
    problem: Problem,
    method: AllocationMethod | str = AllocationMethod.MAKESPAN,
    sequence: SequenceRule | str | None = None,
    time_limit: float | None = MILP_SECONDS,
    territory: float = 0.0,
    avoid_blocked: bool = False,
    bound: float | None = None,
) -> Allocation:
    """Allocate and sequence every reachable fruit. Unreachable fruit are listed, not errors.

    ``territory`` (s, ``makespan`` only) is added to the cost of giving a fruit to an arm
    when another arm that can reach it has its base closer: a penalty on reaching into a
    neighbour's side, which the optimal planner uses to trade a little estimated makespan
    for fewer conflicts between neighbours.

    ``avoid_blocked`` (``makespan`` only): a fruit whose pick pose, or straight joint path
    from/to the bin, would hit a neighbour resting at home is given to another arm whenever
    one can take it (a large cost otherwise): no timing can separate such a pair while the
    neighbour is parked, so it would force the neighbour to stay away from home.

    ``bound``: the makespan lower bound, when the caller has already computed it
    (:func:`lower_bound` depends only on the problem); computed here otherwise.
    """
    _check_cell(problem, "allocate", time_limit=time_limit, territory=territory, bound=bound)
    t0 = _time.perf_counter()
    method = AllocationMethod(method)
    if sequence is None:
        sequence = SequenceRule.FILE if method == AllocationMethod.HEURISTIC else SequenceRule.SWEEP
    sequence = SequenceRule(sequence)
    course = method == AllocationMethod.HEURISTIC  # the course's rule knows nothing of the screen
    reach = standing_reach(problem) if course else screened_reach(problem)  # (the course's rule: the arms where they stand)
    cfg = [arm_configs(problem, arm, prefer_elbow_up=course, screen=not course) for arm in problem.arms]
    F = len(problem.fruits)
    assign = np.full(F, -1)
    info: dict = {}
    if method == AllocationMethod.HEURISTIC:
        for j, f in enumerate(problem.fruits):
            best, best_score = -1, -1.0
            for a, arm in enumerate(problem.arms):
                if not reach[a, j]:
                    continue
                q = cfg[a][1][f.id][0]
                score = float(kin.manipulability(q, arm.links)) / (float(np.hypot(*np.subtract(f.position, arm.base))) + 0.1)
                if score > best_score:
                    best, best_score = a, score
            assign[j] = best
    else:
        cols = np.flatnonzero(reach.any(axis=0))
        cost = np.zeros((len(problem.arms), cols.size))
        dw = problem.task.pick_dwell + problem.task.place_dwell
        for a, arm in enumerate(problem.arms):
            bins, fq = cfg[a]
            for k, j in enumerate(cols):
                if reach[a, j]:
                    cost[a, k] = _round_trip(arm, bins, fq[problem.fruits[j].id], _sync_time) + dw
                    if avoid_blocked and _blocked_fruit(problem, a, problem.fruits[j].id, bins, fq[problem.fruits[j].id]):
                        cost[a, k] += BLOCKED_COST
                    if territory > 0:
                        pos = problem.fruits[j].position
                        mine = math.dist(pos, arm.base)
                        if any(reach[b, j] and math.dist(pos, problem.arms[b].base) < mine for b in range(len(problem.arms)) if b != a):
                            cost[a, k] += territory
        if cols.size:
            sub, value, dual = _solve_minmax(cost, reach[:, cols], time_limit)
            assign[cols] = sub
            info.update(milp_makespan=value, milp_dual_bound=dual, territory=territory, avoid_blocked=avoid_blocked)
    seqs = {}
    for a, arm in enumerate(problem.arms):
        ids = [problem.fruits[j].id for j in np.flatnonzero(assign == a)]
        seqs[arm.name] = _sequence(problem, arm, ids, sequence, *cfg[a])
    unreachable = tuple(f.id for j, f in enumerate(problem.fruits) if not reach[:, j].any())
    lb = float(lower_bound(problem) if bound is None else bound)
    return _build(problem, method, sequence, seqs, cfg, unreachable, lb, t0, info)


def _build(problem: Problem, method, sequence, seqs: dict[str, tuple[str, ...]], cfg, unreachable, lb: float, t0: float,
           info: dict) -> Allocation:
    """An :class:`Allocation` of given sequences: IK branches by :func:`choose_branches`."""
    assignment: dict[str, tuple[str, ...]] = {}
    estimate: dict[str, float] = {}
    fruit_q: dict[str, dict[str, np.ndarray]] = {}
    place_q: dict[str, dict[str, np.ndarray]] = {}
    for a, arm in enumerate(problem.arms):
        seq = tuple(seqs.get(arm.name, ()))
        fs, ps, t_end = choose_branches(problem, arm, seq, *cfg[a]) if seq else ([], [], 0.0)
        assignment[arm.name] = seq
        estimate[arm.name] = t_end
        fruit_q[arm.name] = dict(zip(seq, fs))
        place_q[arm.name] = dict(zip(seq, ps))
    return Allocation(
        method=method,
        sequence=sequence,
        assignment=assignment,
        unreachable=unreachable,
        fruit_q=fruit_q,
        place_q=place_q,
        bin_q={arm.name: cfg[a][0][0] if cfg[a][0] else np.asarray(arm.home, float) for a, arm in enumerate(problem.arms)},
        estimate=estimate,
        lower_bound=lb,
        seconds=_time.perf_counter() - t0,
        info=info,
    )


def bound_allocation(problem: Problem, details: LowerBound | None = None) -> Allocation:
    """The lower bound's own assignment as an allocation: each arm's first fruit as the bound
    chose it, the rest swept by x, fastest IK branches. Run without waiting, it meets the bound."""
    t0 = _time.perf_counter()
    details = details or bound_details(problem)
    reach = screened_reach(problem)
    cfg = [arm_configs(problem, arm) for arm in problem.arms]
    unreachable = tuple(f.id for j, f in enumerate(problem.fruits) if not reach[:, j].any())
    return _build(problem, AllocationMethod.MAKESPAN, SequenceRule.SHORTEST, details.assignment, cfg, unreachable,
                  details.value, t0, {"bound_allocation": True})
