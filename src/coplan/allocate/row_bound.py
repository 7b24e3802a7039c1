"""Lower bounds on a row's time (the last fruit placed), valid for every plan.

Entry point: :func:`row_bounds` -> :class:`RowBounds`.

* **Cycle bound per fruit and arm** (:func:`coplan.allocate.row_cycles.cycle_bounds`): a
  harvest cycle's least time over *every* carriage position (joint ranges enclosed exactly
  over rail cells).
* **Work bound**: the busiest arm's cycles under the best assignment of fruit to arms (each
  fruit to an arm that can reach it from somewhere; an arm that cannot reach its bin -- locked,
  by the cell screen -- harvests nothing), the min-max assignment's LP relaxation
  (HiGHS, :func:`coplan.allocate.allocation.min_max_bound`: fractional assignments allowed, so
  a bound on the integer one too, and fast on thousands of fruit), less the most any arm's
  first cycle may save by starting at home rather than over its bin
  (:func:`coplan.allocate.row_cycles.home_savings`). No plan -- whatever the carriage does --
  can be faster: an arm's cycles never overlap.
* **Travel bound**: the carriage must get to where the last fruit can be reached from, at its
  speed limit at best, and that fruit must then still be picked and placed.
* **Arrival bound** (:func:`arrival_bound`): the travel bound, sharpened and for every stretch
  of the row's end. The carriage starts at rest, so it reaches ``x`` no sooner than
  :func:`from_rest` of ``x - start`` (its top speed's ramp included), and an arm picks no fruit
  before the carriage is where it reaches that fruit from; after the pick come the way back to
  the bin and the place. And the fruit no arm can pick before some time are all picked after
  it, shared among the arms that reach them, each arm from the first of them it can pick (the
  arms farther back reach the row's last fruit later). Where travel sets the bound it adds the
  ramp and the last fruit's way back (sparse_row 92.9 -> 94.4 s; a 20 m row of 2 fruit per
  metre and 6 arms, seed 0, 26.4 -> 27.9 s), and each arm's own start on the row's tail more
  (96.13 s and 31.13 s). With it the arrival bound is above the busiest arm's cycles on every
  shipped row, by 0.03-1.6 s where the fruit are dense.
* **Stop-and-go bound**: for plans that work stop by stop -- the carriage moves, stops, the arms
  do that stop's work, the carriage moves on -- with no cell work overlapping a move. Their
  moves, each at rest at both ends, take at least one rest-to-rest move over the same distance
  (a time-optimal move is never slower than a chain of stops), and their stops' cells at least
  the busiest arm's cycles (each stop's cell lasts at least its busiest arm's cycles there, and
  those sum to at least the work bound); where the gantry settles after a move, the stop it ends
  at lasts that much longer, less what may fall within the settle: the end of the last stop's
  cycle and the way to the first fruit here (:func:`coplan.allocate.stop_bound.settle_floor`). coplan's own row plans let the arms place and go home,
  and come out to the next stop's first fruit, while the carriage moves: they can be faster than
  this bound by that overlap, which ``metrics.row.overlap_seconds`` reports.
* **Priced stops** (:mod:`coplan.allocate.stop_bound`): the same plans, with where the carriage
  stops and what each fruit costs from there priced together (a dynamic programme over rail
  cells: fewer stops cost the fruit more, more stops cost the carriage more), each stop at
  least a weighted mean of its arms' cycles, the weights per rail cell searched towards the
  busiest arm's (a bound for any weights), never below the work bound's mean over the arms plus
  its stops' moves.

``any_plan`` = max(work, travel, arrival); ``stop_and_go`` = max(any_plan, moves + work, priced).

What the cycle bound assumes (so what "every plan" covers): each move of a cycle is taken rest
to rest. That holds for every move of a stop-by-stop plan, and on the move for the moves to and
from the bin's end (the bin rides with the carriage); but a pick on the move begins and ends with
the joints tracking the fruit, so the moves into and out of it could each be shorter by at most
the time to brake from the tracking speed (for the lesson's arms at the gantry's 0.5 m/s, about
0.2 s where the elbow is well bent, more near the edge of reach). No plan coplan makes on the move
comes near that (1.09-1.99 x ``any_plan`` on the benchmark rows in c1e85ab's run, the closest 2.7 s
above it; 1.24-2.09 x when this was written). A cycle bound that allows for it
by braking -- each move extended by a stop from the tracking state (joint speeds from ``J^-1`` at
the gantry's top speed, accelerations with the centripetal terms), so at least a rest-to-rest
move over the distance less the braking distance, less the braking time -- was measured and is
too weak to use: course_row's work bound fell from 241.5 s to 50.2 s (the direction of the
arrival speed is unknown, and near the edge of reach the joint speeds reach their limits).
"""

from __future__ import annotations

import functools
import time as _time
from dataclasses import dataclass

import numpy as np

from .allocation import min_max_bound
from .row_cycles import CellCycles, cell_cycles, cycle_bounds, home_savings
from .stop_bound import stops_bound
from ..kinematics.timing import Move1D, accel_time
from ..problem.gantry import RESOLUTION_RANGE
from ..problem.model import Problem, require_problem
from ..problem.plausible import check_as_file

__all__ = ["RowBounds", "row_bounds", "cycle_bounds", "busiest_cycles", "arrival_bound", "from_rest", "water_level"]

@dataclass(frozen=True)
class RowBounds:
    """The row's lower bounds (s) and what they are made of."""

    any_plan: float
    stop_and_go: float
    work: float
    travel: float
    moves: float
    reach_to: float  # m: the carriage must get at least this far
    fruit: int  # fruit the bounds count (reachable from some carriage position)
    seconds: float
    priced: float = 0.0  # the priced-stops bound (0: not computed)
    priced_stops: int = 0  # stops of its witness (where its cheapest stop-by-stop plan stops)
    problem: str | None = None  # the name of the row they bound (row_metrics refuses another row's)
    arrival: float = 0.0  # the arrival bound (module docstring; 0: not computed)

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__ if k != "problem"}


def row_bounds(problem: Problem, step: float = 0.05, priced: bool = True) -> RowBounds:
    """The row's lower bounds, a :class:`RowBounds`: ``any_plan`` (valid whatever the carriage
    does: the busiest arm's work, the carriage's travel, the arrival bound) and ``stop_and_go``
    (valid for plans that pick only while the carriage stands; with the priced stops), and their
    parts (the module docstring derives each). ``step``: the rail cells' size (m) of the cycle
    bounds; ``priced=False`` leaves out the priced-stops programme (1.2-5.6 s on the shipped rows,
    22 s on a 200 m row of 2,040 fruit: its weight rounds) where only the others are wanted. A row's
    bounds are remembered for the row and these settings (a second call costs nothing)."""
    require_problem(problem, "row_bounds")
    if problem.gantry is None:  # (it raised AttributeError from inside)
        raise ValueError(f"{problem.name!r} has no gantry: a cell's lower bound is coplan.allocate.lower_bound")
    lo, hi = RESOLUTION_RANGE
    if isinstance(step, bool) or not isinstance(step, (int, float)) or not lo <= step <= hi:
        raise ValueError(f"step: expected the spacing of the carriage positions from {lo:g} to {hi:g} m "
                         f"(as --resolution), found {type(step).__name__} {step!r}")  # (0: ZeroDivisionError)
    if not isinstance(priced, bool):  # ("no" was taken as true)
        raise TypeError(f"priced: expected True or False, found {type(priced).__name__} {priced!r}")
    try:  # (one row's bounds once per process: `coplan compare` solves it with every stop rule and on the move)
        return _remembered(problem, float(step), priced)
    except TypeError:  # (a problem that cannot be hashed: computed each time)
        return _bounds(problem, float(step), priced)


@functools.lru_cache(maxsize=8)
def _remembered(problem: Problem, step: float, priced: bool) -> RowBounds:
    return _bounds(problem, step, priced)


def _bounds(problem: Problem, step: float, priced: bool) -> RowBounds:
    # (a row changed in Python is held to what its file would be, as coplan.solve holds it: a rail
    # cut short under its fruit gave bounds over 9 of its 12 fruit, where solve names the other 3)
    check_as_file(problem)
    t0 = _time.perf_counter()
    g = problem.gantry
    cc = cell_cycles(problem, step)
    cost, reach, reach_from = cycle_bounds(problem, step, cc)
    ok = reach.any(axis=0)
    n = int(ok.sum())
    if n == 0:
        return RowBounds(0.0, 0.0, 0.0, 0.0, 0.0, g.start, 0, _time.perf_counter() - t0, problem=problem.name)
    # each arm's first cycle starts at home: the busiest arm's cycles last at least their bounds
    # less its saving (home_savings), so the min-max less the largest saving
    work = max(0.0, _min_max(cost, reach) - float(home_savings(cc).max()))
    far = float(max(reach_from[ok].max(), g.start))
    dist = far - g.start
    travel = dist / g.max_velocity + problem.task.pick_dwell + problem.task.place_dwell
    moves = Move1D.between(g.start, far, g.max_velocity, g.max_acceleration, g.max_jerk).duration
    if dist > 0 and g.settle > 0:  # the stop the move ends at settles before its first pick (stop_bound.settle_floor)
        from .stop_bound import settle_floor

        moves += settle_floor(problem, cc)
    arrival = arrival_bound(problem, cc)
    any_plan = max(work, travel, arrival)
    pv, ps = 0.0, 0
    if priced:
        sb = stops_bound(problem)
        pv, ps = sb.value, len(sb.stops)
    return RowBounds(float(any_plan), float(max(any_plan, moves + work, pv)), float(work), float(travel), float(moves), far, n,
                     _time.perf_counter() - t0, float(pv), ps, problem.name, float(arrival))


def busiest_cycles(problem: Problem, step: float = 0.05) -> float:
    """The busiest arm's rest-to-rest cycle bounds under the min-max assignment's LP (s): the
    pace the on-the-move speed search starts its constant speed from (the carriage's way over it)
    -- an estimate, not a bound (``row_bounds`` takes off what an arm's first cycle may save by
    starting at home). Kept as it was when that correction came, so the search's plans stay the same."""
    return _min_max(*cycle_bounds(problem, step)[:2])


def _min_max(cost: np.ndarray, reach: np.ndarray) -> float:
    """The busiest arm's cycles (``cost`` (A, F) s, each fruit to an arm that ``reach`` es it) under
    the min-max assignment's LP relaxation (s)."""
    return float(min_max_bound(np.where(reach, cost, 0.0), reach, relax=True))


def from_rest(d, v: float, a: float, j: float) -> np.ndarray:
    """The least time (s) to cover ``d`` (m, >= 0; array) from rest, the end speed free, under
    the speed, acceleration and jerk limits ``v``, ``a``, ``j``: at full effort the speed reaches
    ``v`` after ``t1`` (:func:`coplan.kinematics.timing.accel_time`), having covered ``v t1 / 2``;
    beyond that ``d / v + t1 / 2``. Short of it ``d / v`` (less than the time, so still a lower
    bound)."""
    d = np.asarray(d, float)
    t1 = accel_time(v, a, j)
    return np.where(d >= 0.5 * v * t1, d / v + 0.5 * t1, d / v)


def arrival_bound(problem: Problem, cc: CellCycles) -> float:
    """The arrival bound (module docstring) of ``problem``'s row from its cells' cycle bounds
    ``cc`` (:func:`coplan.allocate.row_cycles.cell_cycles`), s; 0 with no fruit in reach.

    Arm ``a`` picks fruit ``f`` no sooner than ``r_a(f) = from_rest(d_a(f))``, ``d_a(f)`` the
    distance from the rail's start to the first cell it reaches ``f`` from (0 from the start's);
    ``r(f)`` is the least over the arms. Of that cycle, the pick, the way back (at least ``w_a(f)``,
    the least way between a bin and the fruit) and the place come after, at least its cycle
    bound ``p_a(f)`` less ``w_a(f)``: so ``T >= min_a (r_a(f) + p_a(f) - w_a(f))`` for every
    fruit. And for every time ``r``, the fruit ``S`` with ``r(f) >= r`` are all picked after
    ``r``, one cycle after another on each arm that picks some of them, each at least
    ``p(f) = min_a p_a(f)``: arm ``a``'s first of them, ``g``, is picked no sooner than
    ``r_a(g)``, and only its way out (at least ``w_a(g)``) comes before, so the arm ends at least
    ``s_a = min_{g in S} (r_a(g) - w_a(g))`` plus its share of ``S``'s work. Shared as evenly as
    those starts allow among the arms that reach some of ``S``, the busiest ends no sooner than
    :func:`water_level` of ``sum_{f in S} p(f)`` over the ``s_a``."""
    g = problem.gantry
    A, F = cc.reach.shape
    lim = (g.max_velocity, g.max_acceleration, g.max_jerk)
    R, P, W = (np.full((A, F), np.inf) for _ in range(3))
    for a in range(A):
        if cc.cost[a] is None:
            continue
        cells, t = cc.band(a)
        inside = np.isfinite(t) & cc.reach[a][:, None]
        has = inside.any(axis=1)
        d = np.maximum(0.0, np.where(inside, cc.lo[cells], np.inf).min(axis=1) - g.start)
        R[a] = np.where(has, from_rest(np.where(has, d, 0.0), *lim), np.inf)
        P[a] = np.where(inside, t, np.inf).min(axis=1)
        W[a] = np.where(inside, cc.ways[a], np.inf).min(axis=1)
    ok = np.isfinite(P).any(axis=0)
    if not ok.any():
        return 0.0
    R, P, W = R[:, ok], P[:, ok], W[:, ok]
    can = np.isfinite(P)
    single = float(np.where(can, R + np.where(can, P, 0.0) - np.where(can, W, 0.0), np.inf).min(axis=0).max())
    r = np.where(can, R, np.inf).min(axis=0)  # each fruit's earliest pick
    o = np.argsort(-r, kind="stable")  # latest first: the fruit with r(f) >= r[o[k]] are o[:k + 1] (and ties)
    work = np.cumsum(P.min(axis=0)[o])
    # (A, F): s_a over o[:k + 1], each arm's least earliest pick less way out there (inf: it reaches none)
    start = np.minimum.accumulate(np.where(can, R - np.where(can, W, 0.0), np.inf)[:, o], axis=1)
    return max(single, float(water_level(work, start).max()))


def water_level(work, start) -> np.ndarray:
    """The least ``T`` with ``sum_a max(0, T - start[a]) >= work``: ``work`` (s, > 0) shared among
    arms free from ``start`` (s, ``(A,)`` or ``(A, K)`` for ``K`` cases, at least one arm; finite,
    or ``inf`` for an arm that takes no part; ``work`` a scalar or ``(K,)``) so that the last ends
    as early as it can.

    With the starts sorted, the level using the first ``m`` arms is ``(work + sum_{i<=m}
    start_i) / m``; each is at least the least ``T`` (an arm left out only adds), and the one
    with the arms that start before ``T`` equals it: the least over ``m``. ``inf`` where no arm
    takes part."""
    s = np.sort(np.asarray(start, float), axis=0)
    fin = np.isfinite(s)
    m = np.arange(1, s.shape[0] + 1).reshape((-1,) + (1,) * (s.ndim - 1))
    level = np.where(fin, (np.asarray(work, float) + np.cumsum(np.where(fin, s, 0.0), axis=0)) / m, np.inf)
    return level.min(axis=0)
