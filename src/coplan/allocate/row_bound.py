"""Lower bounds on a row's time (the last fruit placed), valid for every plan.

Entry point: :func:`row_bounds` -> :class:`RowBounds`.

* **Cycle bound per fruit and arm** (:func:`cycle_bounds`): every harvest is a move from the
  bin to the fruit, the pick dwell, a move back and the place dwell; each move takes at least
  the per-joint time-optimal S-curve time of its largest joint step. The fruit's joint pose
  depends on where the carriage stands, so the bound is taken over *every* position, not a
  sample of them: the rail is cut into cells of ``step`` m and, in each, the range of each
  joint angle is enclosed exactly -- the elbow angle is a monotone function of the distance to
  the base (whose least value, right above the base, is added when the cell holds it), the
  shoulder angle is the angle of the fruit seen from the base (monotone along the rail) less a
  function of the elbow angle, so its range lies within the difference of the two ranges. The
  joint step from the bin pose is at least the distance to that range (2 pi shifts included),
  on the better elbow branch. The least over all cells bounds every carriage position.
* **Work bound**: the busiest arm's cycles under the best assignment of fruit to arms (each
  fruit to an arm that can reach it from somewhere; an arm that cannot reach its bin -- locked,
  by the cell screen -- harvests nothing), the min-max assignment's LP relaxation
  (HiGHS, :func:`coplan.allocate.allocation.min_max_bound`: fractional assignments allowed, so
  a bound on the integer one too, and fast on thousands of fruit). No plan -- whatever the carriage does --
  can be faster: an arm's cycles never overlap.
* **Travel bound**: the carriage must get to where the last fruit can be reached from, at its
  speed limit at best, and that fruit must then still be picked and placed.
* **Stop-and-go bound**: for plans that work stop by stop -- the carriage moves, stops, the arms
  do that stop's work, the carriage moves on -- with no cell work overlapping a move. Their
  moves, each at rest at both ends, take at least one rest-to-rest move over the same distance
  (a time-optimal move is never slower than a chain of stops), and their stops' cells at least
  the busiest arm's cycles (each stop's cell lasts at least its busiest arm's cycles there, and
  those sum to at least the work bound). coplan's own row plans let the arms place and go home,
  and come out to the next stop's first fruit, while the carriage moves: they can be faster than
  this bound by that overlap, which ``metrics.row.overlap_seconds`` reports.

``any_plan`` = max(work, travel); ``stop_and_go`` = max(any_plan, moves + work).
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass

import numpy as np

from .allocation import min_max_bound
from ..kinematics.timing import Move1D, scurve_times
from ..problem.model import Problem

__all__ = ["RowBounds", "row_bounds", "cycle_bounds"]

_TWO_PI = 2.0 * math.pi


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

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in self.__dataclass_fields__}


def _phi(l1: float, l2: float, q2):
    return np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))


def _q2_of_r(l1: float, l2: float, r):
    c = np.clip((r * r - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0, 1.0)
    return np.arccos(c)  # elbow-up branch (>= 0); elbow-down is its negative


def _dist_to_range(b, lo, hi):
    return np.where(b < lo, lo - b, np.where(b > hi, b - hi, 0.0))


def cycle_bounds(problem: Problem, step: float = 0.05) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(cost (A, F), reach (A, F) bool, reach_from (F,))``: per arm and fruit, a lower bound on
    one harvest cycle (bin -> fruit -> bin and both dwells) over every carriage position (module
    docstring); whether the arm can reach the fruit from some position on the rail (annulus
    less the margin, ignoring joint limits: a superset); and the least carriage position from
    which some arm might reach the fruit. An arm the cell screen locks (it cannot reach its bin,
    which rides with the carriage: the screen of the cell at any carriage position) reaches nothing."""
    from ..problem.gantry import cell_at
    from .screen import screened

    g = problem.gantry
    locked = set(screened(cell_at(problem, 0.0, ())).locked)
    m = problem.task.reach_margin
    dw = problem.task.pick_dwell + problem.task.place_dwell
    cs = np.arange(g.start, g.end + step, step)
    cs = np.minimum(cs, g.end)
    lo_c, hi_c = cs[:-1], cs[1:]  # cells [lo, hi] covering the rail
    A, F = len(problem.arms), len(problem.fruits)
    cost = np.full((A, F), np.inf)
    reach = np.zeros((A, F), dtype=bool)
    reach_from = np.full(F, np.inf)
    xs = problem.fruit_positions[:, 0] if F else np.zeros(0)
    ys = problem.fruit_positions[:, 1] if F else np.zeros(0)
    for a, arm in enumerate(problem.arms):
        l1, l2 = arm.links
        r_in, r_out = abs(l1 - l2) + m, l1 + l2 - m
        qb, vb = arm.ik(np.asarray(arm.bin, float), 0.0)
        bins = qb[vb]
        if bins.size == 0 or F == 0 or arm.name in locked:
            continue
        # per fruit, the band of cells within reach: (F, W) cell indices (clipped; duplicates are harmless)
        first = np.searchsorted(hi_c, xs - arm.base[0] - arm.reach)
        W = int(math.ceil(2.0 * arm.reach / step)) + 2
        idx = np.minimum(first[:, None] + np.arange(W)[None, :], lo_c.size - 1)
        dy = (ys - arm.base[1])[:, None]
        p0, p1 = xs[:, None] - hi_c[idx] - arm.base[0], xs[:, None] - lo_c[idx] - arm.base[0]
        rmin = np.where((p0 <= 0) & (p1 >= 0), np.abs(dy), np.minimum(np.hypot(p0, dy), np.hypot(p1, dy)))
        rmax = np.maximum(np.hypot(p0, dy), np.hypot(p1, dy))
        inside = (rmin <= r_out) & (rmax >= r_in)
        has = inside.any(axis=1)
        reach[a] = has
        lo_at = np.where(inside, lo_c[idx], np.inf).min(axis=1)
        reach_from = np.minimum(reach_from, lo_at)
        r_lo, r_hi = np.clip(rmin, r_in, r_out), np.clip(rmax, r_in, r_out)
        q2a, q2b = _q2_of_r(l1, l2, r_hi), _q2_of_r(l1, l2, r_lo)  # q2 falls as r grows: [q2a, q2b]
        # phi(q2) over [q2a, q2b]: its ends and, if inside, its turning point (cos q2 = -l2 / l1)
        ph = [_phi(l1, l2, q2a), _phi(l1, l2, q2b)]
        if l2 < l1:
            qc = math.acos(-l2 / l1)
            ph.append(np.where((q2a <= qc) & (qc <= q2b), _phi(l1, l2, qc), ph[0]))
        ph_lo, ph_hi = np.minimum.reduce(ph), np.maximum.reduce(ph)
        th0, th1 = np.arctan2(np.broadcast_to(dy, p0.shape), p0), np.arctan2(np.broadcast_to(dy, p1.shape), p1)
        flat = np.broadcast_to(np.abs(dy) < 1e-12, p0.shape)  # a fruit at base height: the angle jumps 0 <-> pi
        th_lo = np.where(flat, -math.pi, np.minimum(th0, th1))
        th_hi = np.where(flat, math.pi, np.maximum(th0, th1))
        best = np.full(F, np.inf)
        for sgn in (1.0, -1.0):  # elbow up: q2 >= 0, q1 = theta - phi; elbow down: mirrored
            q2_lo, q2_hi = (q2a, q2b) if sgn > 0 else (-q2b, -q2a)
            q1_lo, q1_hi = (th_lo - ph_hi, th_hi - ph_lo) if sgn > 0 else (th_lo + ph_lo, th_hi + ph_hi)
            for qb0 in bins:
                d1 = np.minimum.reduce([_dist_to_range(qb0[0], q1_lo + s, q1_hi + s) for s in (-_TWO_PI, 0.0, _TWO_PI)])
                d2 = _dist_to_range(qb0[1], q2_lo, q2_hi)
                t = np.maximum(scurve_times(d1, arm.max_velocity[0], arm.max_acceleration[0], arm.max_jerk[0]),
                               scurve_times(d2, arm.max_velocity[1], arm.max_acceleration[1], arm.max_jerk[1]))
                best = np.minimum(best, np.where(inside, t, np.inf).min(axis=1))
        cost[a] = np.where(has, 2.0 * best + dw, np.inf)
    return cost, reach, reach_from


def row_bounds(problem: Problem, step: float = 0.05) -> RowBounds:
    """The row's lower bounds (module docstring)."""
    if problem.gantry is None:  # (it raised AttributeError from inside)
        raise ValueError(f"{problem.name!r} has no gantry: a cell's lower bound is coplan.allocate.lower_bound")
    t0 = _time.perf_counter()
    g = problem.gantry
    cost, reach, reach_from = cycle_bounds(problem, step)
    ok = reach.any(axis=0)
    n = int(ok.sum())
    if n == 0:
        return RowBounds(0.0, 0.0, 0.0, 0.0, 0.0, g.start, 0, _time.perf_counter() - t0)
    work = min_max_bound(np.where(reach, cost, 0.0), reach, relax=True)
    far = float(max(reach_from[ok].max(), g.start))
    dist = far - g.start
    travel = dist / g.max_velocity + problem.task.pick_dwell + problem.task.place_dwell
    moves = Move1D.between(g.start, far, g.max_velocity, g.max_acceleration, g.max_jerk).duration
    any_plan = max(work, travel)
    return RowBounds(float(any_plan), float(max(any_plan, moves + work)), float(work), float(travel), float(moves), far, n,
                     _time.perf_counter() - t0)
