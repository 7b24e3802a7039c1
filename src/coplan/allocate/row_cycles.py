"""A row's harvest cycles, bounded below over carriage positions (the basis of the row's lower
bounds, :mod:`coplan.allocate.row_bound`).

Every harvest is a move from the bin to the fruit, the pick dwell, a move back and the place
dwell; each move takes at least the per-joint time-optimal S-curve time of its largest joint
step. The fruit's joint pose depends on where the carriage stands, so the bound is taken over
*every* position, not a sample of them: the rail is cut into cells of ``step`` m and, in each,
the range of each joint angle is enclosed exactly -- the elbow angle is a monotone function of
the distance to the base (whose least value, right above the base, is added when the cell
holds it), the shoulder angle is the angle of the fruit seen from the base (monotone along the
rail) less a function of the elbow angle, so its range lies within the difference of the two
ranges. The joint step from the bin pose is at least the distance to the part of that range within
the joint's limits (a joint turns within them, never round past one; 2 pi shifts
included), on the better elbow branch.

:func:`cell_cycles` -> :class:`CellCycles`: per arm, fruit and cell; :func:`cycle_bounds`: the
least over all cells, per arm and fruit.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..kinematics.timing import scurve_times
from ..problem.model import Problem

__all__ = ["CellCycles", "cell_cycles", "cycle_bounds", "home_savings"]

_TWO_PI = 2.0 * math.pi


def _phi(l1: float, l2: float, q2):
    return np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))


def _q2_of_r(l1: float, l2: float, r):
    c = np.clip((r * r - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0, 1.0)
    return np.arccos(c)  # elbow-up branch (>= 0); elbow-down is its negative


def _dist_to_range(b, lo, hi):
    return np.where(b < lo, lo - b, np.where(b > hi, b - hi, 0.0))


def _dist_within(b, lo, hi, lim_lo: float, lim_hi: float):
    """The distance from ``b`` (within the joint's limits) to the part of ``[lo, hi]`` within
    them, inf where none is: a joint moves within its limits, so it cannot reach an angle past
    one by the other way round."""
    a, c = np.maximum(lo, lim_lo), np.minimum(hi, lim_hi)
    return np.where(a <= c, _dist_to_range(b, a, c), np.inf)


@dataclass(frozen=True)
class CellCycles:
    """Per arm, a lower bound on each fruit's harvest cycle with the carriage anywhere in each
    rail cell (:func:`cell_cycles`). Cells ``[lo[c], hi[c]]`` cover the rail; for arm ``a``,
    ``cost[a]`` (F, W) holds the bound for fruit ``f`` in cells ``first[a][f] + 0 .. W - 1``
    (clipped to the last cell; inf where the arm cannot reach the fruit from that cell); an arm
    that harvests nothing (locked, or no bin pose) has ``cost[a]`` None."""

    lo: np.ndarray  # (N,) m
    hi: np.ndarray  # (N,) m
    first: tuple  # per arm: (F,) int cell index, or None
    cost: tuple  # per arm: (F, W) s, or None
    reach: np.ndarray  # (A, F) bool: the arm reaches the fruit from some cell (annulus less the margin; limits: as :func:`cell_cycles`)
    ways: tuple = ()  # per arm: (F, W) s, the least way between a bin pose and the fruit (as ``cost``), or None
    home_ways: tuple = ()  # per arm: (F, W) s, the least way from home to the fruit, or None

    def band(self, a: int) -> tuple[np.ndarray, np.ndarray]:
        """``(cells (F, W), cost (F, W))`` of arm ``a``: the cell index of each column, clipped."""
        W = self.cost[a].shape[1]
        return np.minimum(self.first[a][:, None] + np.arange(W)[None, :], self.lo.size - 1), self.cost[a]


def cell_cycles(problem: Problem, step: float = 0.05, limits: bool = True) -> CellCycles:
    """Per arm, fruit and rail cell of ``step`` m: a lower bound on one harvest cycle (bin ->
    fruit -> bin and both dwells) with the carriage anywhere in the cell (module docstring).

    ``limits``: each joint's way is to the part of the fruit's range of angles within the
    joint's limits, never round past one (a shoulder limited to [-pi, pi] turns from 3.0 rad to
    -3.0 rad the long way, 6.0 rad, not 0.28); a cell where no angle of a branch is within them
    is out of that branch's reach. False: the enclosure before the limits were taken (the way
    may wrap by 2 pi, as the row's speed search estimates its fruit's cycles; a looser bound)."""
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
    reach = np.zeros((A, F), dtype=bool)
    firsts, costs, ways, home_ways = [], [], [], []
    xs = problem.fruit_positions[:, 0] if F else np.zeros(0)
    ys = problem.fruit_positions[:, 1] if F else np.zeros(0)
    for a, arm in enumerate(problem.arms):
        l1, l2 = arm.links
        r_in, r_out = abs(l1 - l2) + m, l1 + l2 - m
        qb, vb = arm.ik(np.asarray(arm.bin, float), 0.0)
        bins = qb[vb]
        if bins.size == 0 or F == 0 or arm.name in locked:
            firsts.append(None)
            costs.append(None)
            ways.append(None)
            home_ways.append(None)
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
        best = np.full(p0.shape, np.inf)  # the way from the bin, on the better branch and bin pose
        out = np.full(p0.shape, np.inf)  # the way from home (an arm's first cycle starts there)
        home = np.asarray(arm.home, float)
        (lo1, hi1), (lo2, hi2) = arm.joint_limits
        dist = _dist_within if limits else (lambda b, lo, hi, _l, _h: _dist_to_range(b, lo, hi))
        shifts2 = [0.0] + ([_TWO_PI] if hi2 > math.pi else []) + ([-_TWO_PI] if lo2 < -math.pi else [])
        for sgn in (1.0, -1.0):  # elbow up: q2 >= 0, q1 = theta - phi; elbow down: mirrored
            q2_lo, q2_hi = (q2a, q2b) if sgn > 0 else (-q2b, -q2a)
            q1_lo, q1_hi = (th_lo - ph_hi, th_hi - ph_lo) if sgn > 0 else (th_lo + ph_lo, th_hi + ph_hi)

            def way(q):  # the least time from joint pose q to the branch's range of fruit poses
                d1 = np.minimum.reduce([dist(q[0], q1_lo + s, q1_hi + s, lo1, hi1) for s in (-_TWO_PI, 0.0, _TWO_PI)])
                # (the branch's q2 range 2 pi on where the elbow's limits reach past +-pi)
                d2 = np.minimum.reduce([dist(q[1], q2_lo + s, q2_hi + s, lo2, hi2) for s in shifts2])
                return np.maximum(scurve_times(d1, arm.max_velocity[0], arm.max_acceleration[0], arm.max_jerk[0]),
                                  scurve_times(d2, arm.max_velocity[1], arm.max_acceleration[1], arm.max_jerk[1]))

            back = np.minimum.reduce([way(qb0) for qb0 in bins])  # (moves are symmetric)
            best = np.minimum(best, back)
            out = np.minimum(out, way(home))
        inside &= np.isfinite(best)  # (with limits: some branch's angles within them)
        reach[a] = inside.any(axis=1)
        firsts.append(first)
        costs.append(np.where(inside, 2.0 * best + dw, np.inf))
        ways.append(np.where(inside, best, np.inf))
        home_ways.append(np.where(inside, out, np.inf))
    return CellCycles(lo_c, hi_c, tuple(firsts), tuple(costs), reach, tuple(ways), tuple(home_ways))


def cycle_bounds(problem: Problem, step: float = 0.05, cc: CellCycles | None = None,
                 limits: bool = True) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(cost (A, F), reach (A, F) bool, reach_from (F,))``: per arm and fruit, a lower bound on
    one harvest cycle (bin -> fruit -> bin and both dwells) over every carriage position (module
    docstring); whether the arm can reach the fruit from some position on the rail (a superset:
    the annulus less the margin, with ``limits`` where some branch's angles are within the
    joints' limits, as :func:`cell_cycles`); and the least carriage position from
    which some arm might reach the fruit. An arm the cell screen locks (it cannot reach its bin,
    which rides with the carriage: the screen of the cell at any carriage position) reaches nothing.
    ``cc``: :func:`cell_cycles` of ``problem`` on ``step`` (and ``limits``), when already computed."""
    cc = cell_cycles(problem, step, limits) if cc is None else cc
    A, F = cc.reach.shape
    cost = np.full((A, F), np.inf)
    reach_from = np.full(F, np.inf)
    for a in range(A):
        if cc.cost[a] is None:
            continue
        cells, t = cc.band(a)
        inside = np.isfinite(t)
        reach_from = np.minimum(reach_from, np.where(inside, cc.lo[cells], np.inf).min(axis=1))
        cost[a] = np.where(cc.reach[a], t.min(axis=1), np.inf)
    return cost, cc.reach.copy(), reach_from


def home_savings(cc: CellCycles, per_cell: bool = False) -> np.ndarray:
    """``(A,)`` s: per arm, how much shorter than its cycle bound its *first* cycle may be. Every
    arm starts at home, not over its bin: its first cycle's way out is home -> fruit, which may
    be quicker than bin -> fruit (the lesson's home pose points up, towards the fruit; the bin is
    below), so an arm's cycles last at least the sum of their cycle bounds less this: the most,
    over the fruit it reaches, by which the fruit's least way from a bin exceeds its least way
    from home (each the least over every carriage position and elbow branch). 0 for an arm that
    harvests nothing. Without it a verified plan beat the row's bound for any plan (14.09 s
    against 14.48 s: one arm's five cycles, the first from home, on a 5 cm rail).

    ``per_cell``: for a bound that charges each fruit its cycle *at the cell it is picked from*
    (:mod:`coplan.allocate.stop_bound`), the most by which the way from a bin exceeds the way from
    home in one cell -- which may exceed the difference of the two least ways (a single-fruit row
    whose cheapest stop is far from where home is quickest: 0.697 s against 0.285 s; the priced
    bound then stood above a plan, 3.186 s against 2.798 s, found by a reviewer)."""
    out = np.zeros(len(cc.cost))
    for a, (b, h) in enumerate(zip(cc.ways, cc.home_ways)):
        if b is None:
            continue
        from_bin, from_home = (b, h) if per_cell else (b.min(axis=1), h.min(axis=1))
        ok = np.isfinite(from_bin) & np.isfinite(from_home)
        gap = from_bin[ok] - from_home[ok]
        if gap.size:
            out[a] = float(max(0.0, gap.max()))
    return out
