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

The makespan lower bound (:attr:`Allocation.lower_bound`) is the optimum of the same
assignment problem with per-fruit costs no plan can beat: per joint time-optimal moves
(the slowest joint alone), the cheaper of coming from home or from the bin, the best IK
branches. It is valid for any allocation, sequence and trajectory.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field
from enum import Enum

import numpy as np
from scipy.optimize import Bounds, LinearConstraint, milp

from . import kinematics as kin
from .errors import CoplanError
from .problem import Arm, Problem
from .timing import SCurve, move_lower_bound

__all__ = ["AllocationMethod", "SequenceRule", "Allocation", "allocate", "arm_configs", "lower_bound"]


class AllocationMethod(str, Enum):
    HEURISTIC = "heuristic"
    MAKESPAN = "makespan"


class SequenceRule(str, Enum):
    FILE = "file"
    SWEEP = "sweep"
    SHORTEST = "shortest"


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
        return max(self.estimate.values(), default=0.0)

    def arm_of(self, fruit_id: str) -> str:
        for a, fs in self.assignment.items():
            if fruit_id in fs:
                return a
        raise KeyError(fruit_id)


def _sync_time(arm: Arm, q0, q1) -> float:
    return SCurve.between(q0, q1, arm.max_velocity, arm.max_acceleration, arm.max_jerk).duration


def _lb_time(arm: Arm, q0, q1) -> float:
    return move_lower_bound(q0, q1, arm.max_velocity, arm.max_acceleration, arm.max_jerk)


def _branches(arm: Arm, point, margin: float) -> list[np.ndarray]:
    q, valid = arm.ik(np.asarray(point, float), margin)
    return [q[b] for b in range(2) if valid[b]]


def arm_configs(problem: Problem, arm: Arm, prefer_elbow_up: bool = False):
    """IK branches an arm can use: over its bin, and at every fruit it can reach.

    Returns ``(bin_branches, {fruit_id: [branches]})`` (lists of (2,) joint poses). With
    ``prefer_elbow_up`` (the course's IK) only the elbow-up branch is kept where it is valid.
    """
    margin = problem.task.reach_margin
    bins = _branches(arm, arm.bin, 0.0)
    if not bins:
        raise AllocationError(f"arm {arm.name!r} cannot reach its bin")
    if prefer_elbow_up:
        bins = bins[:1]
    fruit_q: dict[str, list[np.ndarray]] = {}
    for f in problem.fruits:
        br = _branches(arm, f.position, margin)
        if br:
            fruit_q[f.id] = br[:1] if prefer_elbow_up else br
    return bins, fruit_q


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
                    if b not in new or tt < new[b][0]:
                        new[b] = (tt, fs + [qf], ps + [qb])
        states = new
    best = min(states.values(), key=lambda v: v[0])
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
    first = min(ids, key=lambda f: _first_trip(arm, bins, fq[f], _sync_time) - _round_trip(arm, bins, fq[f], _sync_time))
    return (first,) + tuple(f for f in by_x if f != first)


BLOCKED_COST = 1000.0  # s: effectively forbids a blocked pair unless no other arm can take the fruit


def _blocked(problem: Problem, a: int, bins, branches, samples: int = 24) -> bool:
    """Whether every branch's pick pose or bin round trip hits a neighbour resting at home."""
    from .geometry import segment_distance

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


def _solve_minmax(cost: np.ndarray, reach: np.ndarray, time_limit: float | None, offset=None):
    """min over assignments of max_a (offset[a] + sum_f cost[a, f] x[a, f]).

    Returns (assign (F,), value, dual bound). ``offset`` (A,) <= 0 applies to used arms.
    """
    A, F = cost.shape
    offset = np.zeros(A) if offset is None else np.asarray(offset, float)
    pairs = np.argwhere(reach)  # (P, 2) rows (a, f)
    P = len(pairs)
    n = P + 1
    c = np.zeros(n)
    c[-1] = 1.0
    c[:P] = 1e-4 * cost[pairs[:, 0], pairs[:, 1]] / max(F, 1)
    rows, lo, hi = [], [], []
    for f in range(F):
        r = np.zeros(n)
        r[:P][pairs[:, 1] == f] = 1.0
        rows.append(r)
        lo.append(1.0)
        hi.append(1.0)
    for a in range(A):
        r = np.zeros(n)
        m = pairs[:, 0] == a
        r[:P][m] = cost[a, pairs[m, 1]]
        r[-1] = -1.0
        rows.append(r)
        lo.append(-np.inf)
        hi.append(-offset[a])
    integrality = np.ones(n)
    integrality[-1] = 0
    opts = {"disp": False, "mip_rel_gap": 1e-6}
    if time_limit is not None:
        opts["time_limit"] = float(time_limit)
    res = milp(
        c,
        constraints=LinearConstraint(np.array(rows), lo, hi),
        integrality=integrality,
        bounds=Bounds(np.zeros(n), np.r_[np.ones(P), np.inf]),
        options=opts,
    )
    if res.x is None:
        raise AllocationError(f"assignment MILP failed: {res.message}")
    x = res.x[:P] > 0.5
    assign = np.full(F, -1)
    assign[pairs[x, 1]] = pairs[x, 0]
    value = float(max(offset[a] + cost[a, assign == a].sum() if (assign == a).any() else 0.0 for a in range(A)))
    dual = getattr(res, "mip_dual_bound", None)
    dual = float(dual) if dual is not None and np.isfinite(dual) else value
    return assign, value, min(dual, value)


def lower_bound(problem: Problem, reach: np.ndarray | None = None, time_limit: float | None = 5.0) -> float:
    """Makespan lower bound valid for every plan.

    Each fruit costs at least its cheapest bin -> fruit -> bin round trip with per-joint
    time-optimal moves (best IK branches) plus both dwells; one fruit per arm may instead be
    approached from home, which an arm-wide offset min(0, min_f first(f) - round(f)) covers.
    The min-max assignment of these costs (solved exactly, its dual bound taken) bounds the
    makespan of any allocation, sequence and trajectory from below.
    """
    reach = problem.reach_matrix() if reach is None else reach
    cols = np.flatnonzero(reach.any(axis=0))
    if cols.size == 0:
        return 0.0
    dw = problem.task.pick_dwell + problem.task.place_dwell
    A = len(problem.arms)
    cost = np.zeros((A, cols.size))
    offset = np.zeros(A)
    for a, arm in enumerate(problem.arms):
        bins, fq = arm_configs(problem, arm)
        for k, j in enumerate(cols):
            fid = problem.fruits[j].id
            if reach[a, j]:
                rt = _round_trip(arm, bins, fq[fid], _lb_time)
                cost[a, k] = rt + dw
                offset[a] = min(offset[a], _first_trip(arm, bins, fq[fid], _lb_time) - rt)
    _, _, dual = _solve_minmax(cost, reach[:, cols], time_limit, offset)
    return dual


def allocate(
    problem: Problem,
    method: AllocationMethod | str = AllocationMethod.MAKESPAN,
    sequence: SequenceRule | str | None = None,
    time_limit: float | None = 10.0,
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
    t0 = _time.perf_counter()
    method = AllocationMethod(method)
    if sequence is None:
        sequence = SequenceRule.FILE if method == AllocationMethod.HEURISTIC else SequenceRule.SWEEP
    sequence = SequenceRule(sequence)
    reach = problem.reach_matrix()
    elbow_up = method == AllocationMethod.HEURISTIC
    cfg = [arm_configs(problem, arm, prefer_elbow_up=elbow_up) for arm in problem.arms]
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
                    if avoid_blocked and _blocked(problem, a, bins, fq[problem.fruits[j].id]):
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
    assignment: dict[str, tuple[str, ...]] = {}
    estimate: dict[str, float] = {}
    fruit_q: dict[str, dict[str, np.ndarray]] = {}
    place_q: dict[str, dict[str, np.ndarray]] = {}
    for a, arm in enumerate(problem.arms):
        bins, fq = cfg[a]
        ids = [problem.fruits[j].id for j in np.flatnonzero(assign == a)]
        seq = _sequence(problem, arm, ids, sequence, bins, fq)
        fs, ps, t_end = choose_branches(problem, arm, seq, bins, fq)
        assignment[arm.name] = seq
        estimate[arm.name] = t_end
        fruit_q[arm.name] = dict(zip(seq, fs))
        place_q[arm.name] = dict(zip(seq, ps))
    lb = lower_bound(problem, reach) if bound is None else bound
    return Allocation(
        method=method,
        sequence=sequence,
        assignment=assignment,
        unreachable=tuple(f.id for j, f in enumerate(problem.fruits) if not reach[:, j].any()),
        fruit_q=fruit_q,
        place_q=place_q,
        bin_q={arm.name: cfg[a][0][0] for a, arm in enumerate(problem.arms)},
        estimate=estimate,
        lower_bound=lb,
        seconds=_time.perf_counter() - t0,
        info=info,
    )
