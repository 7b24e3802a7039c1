"""The joint trajectory optimisation of all arms: one CasADi NLP solved with IPOPT (MUMPS).

Formulation (``build_nlp`` builds, ``solve_nlp`` solves; nothing here plans on its own):

* One time grid shared by every arm, knots ``t_0 = 0 < t_1 < ... < t_K``, whose interval
  lengths ``h_k`` are decision variables. The grid holds every step boundary of the warm
  start, so each pick/place/hold is pinned to a knot range while its timing stays free, and
  every jerk switch of its S-curves, so constant jerk per interval represents it exactly.
* Per arm and knot the state ``(q, qd, qdd)`` (6 numbers); per interval a constant jerk
  (2 numbers). Integration is exact (a cubic per interval), so the continuous trajectory is
  known between knots.
* Bounds: joint limits and velocity at the knots, and between knots on the Bezier control
  points of each interval's position (cubic) and velocity (quadratic), which bound the
  polynomial (exactly where its extremum falls on a knot, as every S-curve extremum does on
  this grid); acceleration (linear inside an interval, so knot bounds are exact); jerk. The
  warm start is therefore a feasible point. Picks/places: pose fixed at the IK pose, zero velocity and
  acceleration, for at least the dwell (sum of its ``h_k``). Start at home at rest; after its
  last step, an arm rests at home.
* Link separation: for chosen (knot, fraction-of-interval) points and neighbouring arm
  pairs, a separating line per link pair -- normal angle ``theta`` and offset ``c`` as extra
  variables -- with both capsules on opposite sides, ``clearance + margin`` apart. This is
  exact for segments (two convex sets are this far apart iff such a line exists) and smooth.
* Objective: the makespan ``M >= (end of each arm's last place)``, plus small terms for
  every arm finishing early, the whole plan's length and jerk smoothness.

Solving (IPOPT, the best iterate, Ctrl-C, time limits) is in :mod:`coplan.planners.optimal.nlp_solve`.
"""

from __future__ import annotations

import functools
import math
import time as _time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from ...kinematics import arm as kin
from ...problem.model import Problem
from ..coordinated.schedule import ArmSchedule, StepKind
from .nlp_data import NLP, ConstraintPoint, Grid, NLPSolution, SolverStatus, WidenGoal, build_grid, map_status

__all__ = ["SolverStatus", "Grid", "ConstraintPoint", "NLP", "NLPSolution", "build_grid", "build_nlp", "map_status"]  # data: .nlp_data


def _var_state(problem: Problem, sch: ArmSchedule, grid: Grid, free_idle: bool = False, times_held: bool = False):
    """Bounds and warm start of one arm's (6, K+1) states and (2, K) jerks.

    Knot bounds are the limits themselves (widened only to a pose the arm must hold: home,
    picks, places); between knots the ``hull`` rows of :func:`build_nlp` bound the motion.
    An arm with no work holds home throughout, or (``free_idle``) at the first and last knot only.
    The jerk is bounded a hair inside its limit, but with every knot time held (``times_held``) at the
    limit itself: a time-optimal move (full jerk) between two held poses in a held time has
    no slower way, and the program would have no feasible point."""
    arm = sch.arm
    K = grid.K
    held = np.array([arm.home] + [st.q1 for st in sch.steps if st.kind in (StepKind.PICK, StepKind.PLACE)], float)
    lim = np.column_stack([np.minimum(arm.limits[:, 0], held.min(axis=0)), np.maximum(arm.limits[:, 1], held.max(axis=0))])
    v = np.asarray(arm.max_velocity)
    a = np.asarray(arm.max_acceleration)
    j = np.asarray(arm.max_jerk) * (1.0 if times_held else 1.0 - 1e-5)  # IPOPT may relax bounds by its tolerances: stay inside
    lo = np.vstack([lim[:, 0:1], -v[:, None], -a[:, None]]) * np.ones((1, K + 1))
    hi = np.vstack([lim[:, 1:2], v[:, None], a[:, None]]) * np.ones((1, K + 1))
    ulo = -j[:, None] * np.ones((1, K))
    uhi = j[:, None] * np.ones((1, K))
    state = sch.state(grid.t)  # (3, K+1, 2)
    X0 = np.concatenate([state[0].T, state[1].T, state[2].T], axis=0)
    X0 = np.clip(X0, lo, hi)

    def fix(k0, k1, q):
        rest = np.r_[np.asarray(q, float), 0.0, 0.0, 0.0, 0.0][:, None]
        lo[:, k0 : k1 + 1] = rest
        hi[:, k0 : k1 + 1] = rest
        X0[:, k0 : k1 + 1] = rest
        ulo[:, k0:k1] = 0.0
        uhi[:, k0:k1] = 0.0

    home = np.asarray(arm.home, float)
    fix(0, 0, home)
    dwell_ranges = []
    ranges = grid.ranges[arm.name]
    for st, (k0, k1) in zip(sch.steps, ranges):
        if st.kind in (StepKind.PICK, StepKind.PLACE):
            fix(k0, k1, st.q1)
            dwell_ranges.append((k0, k1, st.duration))
    k_last = ranges[-1][1] if ranges else (K if free_idle else 0)
    fix(k_last, K, home)
    h = np.diff(grid.t)
    U0 = np.where(h > 0, np.diff(X0[4:6], axis=1) / np.where(h > 0, h, 1.0), 0.0)
    U0 = np.clip(U0, ulo, uhi)
    place_ends = [k1 for st, (k0, k1) in zip(sch.steps, ranges) if st.kind == StepKind.PLACE]
    return lo, hi, X0, ulo, uhi, U0, dwell_ranges, (max(place_ends) if place_ends else 0)


@functools.lru_cache(maxsize=1)
def _kernels():
    """Small SX kernels, mapped over intervals/points inside an MX problem (fast to build)."""
    xk, xk1 = ca.SX.sym("xk", 6), ca.SX.sym("xk1", 6)
    u, h, sc = ca.SX.sym("u", 2), ca.SX.sym("h"), ca.SX.sym("sc", 8)
    X, X1, U = xk * sc[0:6], xk1 * sc[0:6], u * sc[6:8]
    res = ca.vertcat(
        X1[0:2] - (X[0:2] + X[2:4] * h + X[4:6] * h**2 / 2 + U * h**3 / 6),
        (X1[2:4] - (X[2:4] + X[4:6] * h + U * h**2 / 2)) / sc[2:4],
        (X1[4:6] - (X[4:6] + U * h)) / sc[4:6],
    )
    dyn = ca.Function("dyn", [xk, xk1, u, h, sc], [res])
    # Bezier control points of the interval's velocity (quadratic: one inner point) and joint
    # position (cubic: two inner points); a polynomial stays inside the hull of its control
    # points, so bounding them bounds the motion between knots (exactly where an extremum
    # falls on a knot, as every extremum of an S-curve does on a grid with its switches)
    hull = ca.Function("hull", [xk, xk1, h, sc], [ca.vertcat(
        (X[2:4] + X[4:6] * h / 2) / sc[2:4],
        X[0:2] + X[2:4] * h / 3,
        X1[0:2] - X1[2:4] * h / 3,
    )])
    # separation: states of both arms at knot + tau*h, a line (theta, c) between link s of A and u of B
    xa, xb = ca.SX.sym("xa", 6), ca.SX.sym("xb", 6)
    ua, ub = ca.SX.sym("ua", 2), ca.SX.sym("ub", 2)
    tau, th, c = ca.SX.sym("tau"), ca.SX.sym("th"), ca.SX.sym("c")
    geo = ca.SX.sym("geo", 14)  # base_a(2) links_a(2) base_b(2) links_b(2) s u need_a need_b jscale_a(2)... see below
    sca, scb = ca.SX.sym("sca", 8), ca.SX.sym("scb", 8)

    def q_at(x, uu, scv):
        Xp, Up = x * scv[0:6], uu * scv[6:8]
        dt = tau * h
        return Xp[0:2] + Xp[2:4] * dt + Xp[4:6] * dt**2 / 2 + Up * dt**3 / 6

    def link(q, base, links, sel):
        elbow = base + links[0] * ca.vertcat(ca.cos(q[0]), ca.sin(q[0]))
        tip = elbow + links[1] * ca.vertcat(ca.cos(q[0] + q[1]), ca.sin(q[0] + q[1]))
        return (1 - sel) * base + sel * elbow, (1 - sel) * elbow + sel * tip

    qa, qb = q_at(xa, ua, sca), q_at(xb, ub, scb)
    pa0, pa1 = link(qa, geo[0:2], geo[2:4], geo[8])
    pb0, pb1 = link(qb, geo[4:6], geo[6:8], geo[9])
    n = ca.vertcat(ca.cos(th), ca.sin(th))
    out = ca.vertcat(
        ca.dot(n, pa0) + c - geo[10],
        ca.dot(n, pa1) + c - geo[10],
        -(ca.dot(n, pb0) + c) - geo[11],
        -(ca.dot(n, pb1) + c) - geo[11],
    )
    sep = ca.Function("sep", [xa, ua, xb, ub, h, tau, th, c, geo, sca, scb], [out])
    return dyn, sep, hull


@dataclass
class _Segments:
    """The time scales of one window: one per union segment (the intervals between two step
    boundaries of any arm), ``h_k = h0_k * eta[seg_of[k]]``."""

    h0: np.ndarray  # (K,) the grid's interval lengths in the window
    seg_of: np.ndarray  # (K,) segment of each interval
    n: int
    elo: np.ndarray  # bounds of each segment's scale
    ehi: np.ndarray
    length: np.ndarray  # each segment's length on the grid (s)
    boundary: dict  # knot (a segment boundary) -> index into [0, T_0, T_1, ...]


def _segments(grid: Grid, lo_k: int, hi_k: int, h_bounds: tuple[float, float], h_max: float) -> _Segments:
    """Step 1 of :func:`build_nlp`: the window's time-scale segments and their bounds."""
    K = hi_k - lo_k
    h0 = np.diff(grid.t)[lo_k:hi_k]
    seg = grid.segment[lo_k:hi_k]
    _, seg_of = np.unique(seg, return_inverse=True)
    nseg = int(seg_of.max()) + 1 if K else 0
    hmax_seg = np.array([h0[seg_of == i].max() for i in range(nseg)])
    elo = np.full(nseg, h_bounds[0])
    ehi = np.maximum(np.minimum(h_bounds[1], h_max / hmax_seg), elo)
    seg_len = np.array([h0[seg_of == i].sum() for i in range(nseg)])
    boundary = {0: 0}
    for i in range(nseg):
        boundary[int(np.flatnonzero(seg_of == i).max()) + 1] = i + 1
    return _Segments(h0, seg_of, nseg, elo, ehi, seg_len, boundary)


def _arm_blocks(problem: Problem, schedules, grid: Grid, window: tuple[int, int], last: bool, start, blocks: list,
                free_idle: bool = False, held: bool = False) -> dict:
    """Step 2: each arm's state and jerk variables (scaled to O(1)) appended to ``blocks``
    as ``(key, size, lower, upper, guess)``; returns each arm's bounds and scales."""
    lo_k, hi_k = window
    K = hi_k - lo_k
    per_arm = {}
    for name in [a.name for a in problem.arms]:
        sch = schedules[name]
        arm = problem.arm(name)
        # knot bounds are the limits themselves: between knots, velocity and position are
        # bounded by their Bezier control points (the ``hull`` rows below)
        lo, hi, X0, ulo, uhi, U0, dwells, k_end = _var_state(problem, sch, grid, free_idle, held)
        lo, hi, X0 = lo[:, lo_k : hi_k + 1], hi[:, lo_k : hi_k + 1], X0[:, lo_k : hi_k + 1]
        ulo, uhi, U0 = ulo[:, lo_k:hi_k], uhi[:, lo_k:hi_k], U0[:, lo_k:hi_k]
        if start is not None:
            lo[:, 0] = hi[:, 0] = X0[:, 0] = start[name]
        if not last:
            # reach the warm start's pose at the window's end; velocity and acceleration stay
            # free (pinning a mid-move state exactly over-constrains the discretised problem)
            lo[0:2, -1] = hi[0:2, -1] = X0[0:2, -1]
        sx = np.r_[1.0, 1.0, arm.max_velocity, arm.max_acceleration][:, None]
        su = np.asarray(arm.max_jerk, float)[:, None]
        per_arm[name] = (lo, hi, ulo, uhi, dwells, k_end, sx, su)
        blocks.append((f"X_{name}", 6 * (K + 1), (lo / sx).ravel("F"), (hi / sx).ravel("F"), (X0 / sx).ravel("F")))
        blocks.append((f"U_{name}", 2 * K, (ulo / su).ravel("F"), (uhi / su).ravel("F"), (U0 / su).ravel("F")))
    return per_arm


def _guess_from_carry(blocks: list, per_arm: dict, carry: "NLPSolution", window: tuple[int, int], sg: _Segments) -> None:
    """Step 3: where the previous window's solution overlaps this window, it is the guess of
    the states, jerks and time scales (it meets every constraint there)."""
    lo_k, hi_k = window
    K = hi_k - lo_k
    lo_p, hi_p = carry.window
    n_ov = max(0, min(hi_k, hi_p) - lo_k + 1) if lo_p <= lo_k else 0  # knots (from lo) it covers
    if n_ov < 2:
        return
    off_p = lo_k - carry.window[0]
    for b in blocks:
        if b[0].startswith("X_"):
            name = b[0][2:]
            sx, su = per_arm[name][6], per_arm[name][7]
            X0s = b[4].reshape((6, K + 1), order="F")
            X0s[:, :n_ov] = carry.X[name][:, off_p : off_p + n_ov] / sx
            b4u = next(bb for bb in blocks if bb[0] == f"U_{name}")[4].reshape((2, K), order="F")
            b4u[:, : n_ov - 1] = carry.U[name][:, off_p : off_p + n_ov - 1] / su
    # time scales of the segments the two windows share
    ratio = np.diff(carry.t)[off_p : off_p + n_ov - 1] / sg.h0[: n_ov - 1]
    eta0 = blocks[0][4]
    for i in range(sg.n):
        ks = np.flatnonzero(sg.seg_of[: n_ov - 1] == i)
        if ks.size:
            eta0[i] = float(np.clip(np.median(ratio[ks]), sg.elo[i], sg.ehi[i]))
    blocks[1] = ("T", sg.n, blocks[1][2], blocks[1][3], np.cumsum(eta0 * sg.length))


class _Vars:
    """The decision vector ``x`` and its named slices (``layout``), with the knot times."""

    def __init__(self, blocks: list, sg: _Segments):
        self.layout: dict = {}
        off = 0
        for key, n, *_ in blocks:
            self.layout[key] = (off, off + n)
            off += n
        self.size = off
        self.x = ca.MX.sym("x", off)
        self.sg = sg
        self.eta = self.var("eta")
        self.H = _take(self.eta, sg.seg_of) * ca.DM(sg.h0)
        self.Tb = ca.vertcat(0, self.var("T"))  # time at each segment boundary (sparse chain)

    def var(self, key):
        a_, b_ = self.layout[key]
        return self.x[a_:b_]

    def time_at(self, k: int):
        return self.Tb[self.sg.boundary[k]]


def _arm_rows(problem: Problem, name: str, arm_vars: tuple, v: _Vars, window: tuple[int, int], kernels, q_warm, track: float, rows: list):
    """Step 5: one arm's dynamics, hull and dwell rows appended to ``rows`` (``(g, lbg, ubg)``);
    returns the arm's state and jerk matrices, scales, last-place knot (or None) and its
    smoothness and tracking terms."""
    dyn, hull = kernels
    lo_k, hi_k = window
    K = hi_k - lo_k
    g, lbg, ubg = rows
    lo, hi, ulo, uhi, dwells, k_end, sx, su = arm_vars
    Xn = ca.reshape(v.var(f"X_{name}"), 6, K + 1)
    Un = ca.reshape(v.var(f"U_{name}"), 2, K)
    SC = np.r_[sx.ravel(), su.ravel()]
    end = k_end - lo_k if lo_k < k_end <= hi_k else None
    # intervals where the arm is pinned (both knots fixed, no jerk) need no dynamics rows:
    # they would be identically zero and make the constraint Jacobian rank-deficient
    pinned = np.all(lo == hi, axis=0)
    frozen = pinned[:-1] & pinned[1:] & np.all((ulo == 0) & (uhi == 0), axis=0)
    cols = np.flatnonzero(~frozen)
    if cols.size:
        # one mapped call over contiguous slices (cheap to differentiate and evaluate),
        # then keep the rows of the intervals that are not frozen
        res = ca.vec(dyn.map(K)(Xn[:, :K], Xn[:, 1:], Un, v.H.T, ca.DM(np.tile(SC[:, None], (1, K)))))
        rws = (6 * cols[:, None] + np.arange(6)[None, :]).ravel()
        g.append(res if rws.size == 6 * K else res[[int(r) for r in rws]])
        lbg.append(np.zeros(rws.size))
        ubg.append(np.zeros(rws.size))
        arm = problem.arm(name)
        plo = np.minimum(arm.limits[:, 0], lo[0:2].min(axis=1))
        phi = np.maximum(arm.limits[:, 1], hi[0:2].max(axis=1))
        hres = ca.vec(hull.map(K)(Xn[:, :K], Xn[:, 1:], v.H.T, ca.DM(np.tile(SC[:, None], (1, K)))))
        g.append(hres if rws.size == 6 * K else hres[[int(r) for r in rws]])
        lbg.append(np.tile(np.r_[-1.0, -1.0, plo, plo], cols.size))
        ubg.append(np.tile(np.r_[1.0, 1.0, phi, phi], cols.size))
    for k0, k1, dwell in dwells:
        a_, b_ = max(k0, lo_k), min(k1, hi_k)
        segs = v.sg.seg_of[a_ - lo_k : b_ - lo_k]
        if b_ > a_ and np.all(v.sg.elo[segs] >= v.sg.ehi[segs]):
            continue  # its time scales fixed: the dwell is the plan's own (a constant row, never met 1e-6 beyond)
        if b_ > a_:  # a dwell cut by a window boundary: each part keeps its share
            g.append(v.time_at(b_ - lo_k) - v.time_at(a_ - lo_k))
            lbg.append([dwell * (b_ - a_) / (k1 - k0) + 1e-6])
            ubg.append([np.inf])
    smooth = ca.sumsqr(Un) * float(np.mean(v.sg.h0))
    tracking = 0
    if track > 0:
        dq = Xn[0:2, :] - ca.DM(q_warm)
        tracking = ca.sum2(ca.sum1(dq * dq) * ca.DM(np.r_[v.sg.h0, 0.0][None, :]))
    return Xn, Un, SC, end, smooth, tracking


def _separation_rows(problem: Problem, points: list[ConstraintPoint], margin: float, lo_k: int, K: int, names, Xn, Un, SC,
                     v: _Vars, sep, rows: list, slack=None) -> None:
    """Step 6: at every constraint point, both links on opposite sides of their separating
    line, ``clearance + margin`` apart (``+ slack``, a variable, when widening; rows appended
    to ``rows``)."""
    g, lbg, ubg = rows
    nlines = len(points)
    half = (problem.task.clearance + margin) / 2.0
    kk = [p.k - lo_k for p in points]
    kh = [min(k, K - 1) for k in kk]
    geo = np.array([
        [*problem.arms[p.ia].base, *problem.arms[p.ia].links, *problem.arms[p.ib].base, *problem.arms[p.ib].links,
         p.s, p.u, problem.arms[p.ia].link_radius + half, problem.arms[p.ib].link_radius + half, 0.0, 0.0]
        for p in points]).T

    def gather(attr, which):
        return ca.horzcat(*[(Xn[names[which(p)]][:, k] if attr == "X" else Un[names[which(p)]][:, khh])
                            for p, k, khh in zip(points, kk, kh)])

    xa = gather("X", lambda p: p.ia)
    ua = gather("U", lambda p: p.ia)
    xb = gather("X", lambda p: p.ib)
    ub = gather("U", lambda p: p.ib)
    taus = ca.DM([[p.tau for p in points]])
    hs = _take(v.H, kh).T
    sca = ca.DM(np.stack([SC[names[p.ia]] for p in points], axis=1))
    scb = ca.DM(np.stack([SC[names[p.ib]] for p in points], axis=1))
    out = ca.vec(sep.map(nlines)(xa, ua, xb, ub, hs, taus, v.var("theta").T, v.var("c").T, ca.DM(geo), sca, scb))
    g.append(out if slack is None else out - slack / 2)  # each link keeps half the extra room from the line
    lbg.append(np.zeros(4 * nlines))
    ubg.append(np.full(4 * nlines, np.inf))


def _ipopt_options(warm, ipopt_options: dict | None) -> dict:
    """Step 8: IPOPT's settings (MUMPS, never an ``ipopt.opt``; a warm start pushes less)."""
    opts = {
        "ipopt.print_level": 0,
        "print_time": False,
        "ipopt.sb": "yes",
        "ipopt.linear_solver": "mumps",
        "ipopt.option_file_name": "",  # never read an ipopt.opt from the working directory
        "ipopt.tol": 1e-6,
        "ipopt.constr_viol_tol": 1e-7,
        "ipopt.acceptable_tol": 1e-4,
        "ipopt.acceptable_constr_viol_tol": 1e-6,
        "ipopt.acceptable_iter": 5,
        "ipopt.max_iter": 500,
        "ipopt.mu_strategy": "adaptive",
        # MUMPS's working space: 100 % beyond its estimate (IPOPT's default, 1000 %, allocates
        # and zeroes eleven times the estimate at every factorisation: on dense_overlap's
        # widening, 97 iterations, 1.0-1.4 s of 9.2-10.8 s; the same iterates, bit for bit).
        # Where MUMPS needs more, IPOPT doubles it and factorises again.
        "ipopt.mumps_mem_percent": 100,
        # MUMPS's fill-reducing ordering: approximate minimum fill (AMF) rather than IPOPT's
        # default (AMD): on dense_overlap's widening 97 iterations instead of 112, each about
        # 15 % quicker; on the widening benchmark's 33 problems the same margins (deterministic)
        "ipopt.mumps_pivot_order": 2,
    }
    if warm is not None:
        opts["ipopt.mu_init"] = 1e-3
        opts["ipopt.bound_push"] = 1e-5
        opts["ipopt.bound_frac"] = 1e-5
    opts.update(ipopt_options or {})
    return opts


def build_nlp(
    problem: Problem,
    schedules: dict[str, ArmSchedule],
    grid: Grid,
    points: list[ConstraintPoint],
    margin: float,
    window: tuple[int, int] | None = None,
    start: dict[str, np.ndarray] | None = None,
    h_bounds: tuple[float, float] = (0.3, 2.0),
    h_max: float = 0.09,
    ipopt_options: dict | None = None,
    warm: "NLPSolution | None" = None,
    smooth_weight: float = 1e-2,
    carry: "NLPSolution | None" = None,
    track: float = 0.0,
    widen: WidenGoal | None = None,
) -> NLP:
    """Build the NLP over knots ``window = (lo, hi)`` of ``grid`` (default: all).

    ``start`` fixes each arm's state (6,) at knot ``lo`` (the previous window's end); when
    ``hi < K`` the arms must reach the warm start's pose at knot ``hi`` (any velocity and
    acceleration within bounds), so the next window can follow. The objective is the makespan
    in the last window and the window's duration in the others.

    Initial guess: ``warm`` (a solution of this same window, fewer points) is reused whole;
    otherwise ``carry`` (the previous window's solution, which runs past this window's start)
    supplies the states, jerks and time scales where the two windows overlap -- it satisfies
    every constraint there, so IPOPT starts feasible on the overlap -- and the warm-start
    schedules the rest. Separating lines are always guessed from the warm-start schedules.

    ``track`` > 0 adds ``track * sum_k h0_k |q_k - q_warm(t_k)|^2`` to the objective: every arm
    stays near the warm start's pose *at each knot*. All arms share the knots, so the arms
    keep the warm start's (conflict-free) relative progress while the time scales still
    shorten or stretch the intervals.

    ``widen`` (:class:`WidenGoal`, one window over the whole grid) replaces the makespan
    objective: the plan's makespan and end are held, and the least room between neighbours
    beyond ``clearance + margin`` (a variable) is maximised, then the jerk integral minimised.

    Steps: time-scale segments (:func:`_segments`), the arms' variables (:func:`_arm_blocks`),
    the guess from the previous window (:func:`_guess_from_carry`), separating lines, the
    decision vector (:class:`_Vars`), each arm's rows (:func:`_arm_rows`), the separation rows
    (:func:`_separation_rows`), the makespan and objective, IPOPT's settings.
    """
    t0 = _time.perf_counter()
    dyn, sep, hull = _kernels()
    names = [a.name for a in problem.arms]
    lo_k, hi_k = window if window is not None else (0, grid.K)
    K = hi_k - lo_k
    last = hi_k == grid.K
    sg = _segments(grid, lo_k, hi_k, h_bounds, h_max)
    blocks = [
        ("eta", sg.n, sg.elo, sg.ehi, np.clip(np.ones(sg.n), sg.elo, sg.ehi)),
        ("T", sg.n, np.zeros(sg.n), np.full(sg.n, np.inf), np.cumsum(sg.length)),
    ]
    held = bool(np.all(sg.elo >= sg.ehi))  # every knot time held (h_bounds (1, 1))
    per_arm = _arm_blocks(problem, schedules, grid, (lo_k, hi_k), last, start, blocks, widen is not None and widen.free_idle,
                          held)
    q_warm = {b[0][2:]: b[4].reshape((6, K + 1), order="F")[0:2].copy() for b in blocks if b[0].startswith("X_")}
    if carry is not None and warm is None:
        _guess_from_carry(blocks, per_arm, carry, (lo_k, hi_k), sg)
    # step 4: separating lines, guessed from the conflict-free warm-start schedules even when a
    # solution is at hand: where a solution dips below the clearance its links may cross, and a
    # line guessed from crossing links can put them on the wrong sides (IPOPT then reports
    # infeasibility)
    nlines = len(points)
    th0, c0 = np.zeros(nlines), np.zeros(nlines)
    poses = _schedule_poses(schedules, names, grid, points)
    for i, p in enumerate(points):
        th0[i], c0[i] = _line_guess(problem, (poses[names[p.ia]][i], poses[names[p.ib]][i]), p)
    blocks.append(("theta", nlines, np.full(nlines, -np.inf), np.full(nlines, np.inf), th0))
    blocks.append(("c", nlines, np.full(nlines, -np.inf), np.full(nlines, np.inf), c0))
    blocks.append(("M", 1, np.zeros(1), np.full(1, np.inf), np.zeros(1)))
    if widen is not None:
        blocks.append(("S", 1, np.array([widen.floor]), np.array([widen.cap]),
                       np.array([min(max(widen.guess, widen.floor), widen.cap)])))
    v = _Vars(blocks, sg)

    rows: list = [[], [], []]  # g, lbg, ubg
    rows[0].append(v.var("T") - v.Tb[: sg.n] - v.eta * ca.DM(sg.length))  # (not T[:-1]: 1x0 when nseg is 1)
    rows[1].append(np.zeros(sg.n))
    rows[2].append(np.zeros(sg.n))
    Xn, Un, SC, ends = {}, {}, {}, {}
    smooth, tracking = 0, 0
    for name in names:
        Xn[name], Un[name], SC[name], end, s_, t_ = _arm_rows(problem, name, per_arm[name], v, (lo_k, hi_k), (dyn, hull),
                                                              q_warm[name], track, rows)
        if end is not None:
            ends[name] = end
        smooth += s_
        if track > 0:
            tracking += t_
    if nlines:
        _separation_rows(problem, points, margin, lo_k, K, names, Xn, Un, SC, v, sep, rows,
                         None if widen is None else v.var("S"))
    # step 7: makespan epigraph over the arms whose last place lies in this window; objective
    g, lbg, ubg = rows
    M = v.var("M")
    for name, ke in ends.items():
        g.append(M - v.time_at(ke))
        lbg.append([0.0])
        ubg.append([np.inf])
    m0 = max((float(grid.t[ke + lo_k] - grid.t[lo_k]) for ke in ends.values()), default=0.0)
    if widen is not None:  # the makespan and the end held; room first, then gentleness
        g.append(M)
        lbg.append([0.0])
        ubg.append([widen.makespan])
        g.append(v.time_at(K))
        lbg.append([0.0])
        ubg.append([widen.end])
        jerk = sum(ca.sum2(ca.sum1(Un[n] * Un[n]) * v.H.T) for n in names)
        obj = -widen.weight * v.var("S") + jerk + track * tracking
    elif last:
        finish = sum(v.time_at(ke) for ke in ends.values()) / max(len(ends), 1)
        obj = M + 0.05 * finish + 0.02 * v.time_at(K) + smooth_weight * smooth + track * tracking
    else:
        obj = v.time_at(K) + 0.01 * M + smooth_weight * smooth + track * tracking
    gg = ca.vertcat(*g)
    x0v = np.concatenate([np.asarray(b[4], float).ravel() for b in blocks])
    x0v[v.layout["M"][0]] = m0
    if warm is not None and warm.x is not None:
        x0v = _transfer_warm(warm, v.layout, x0v)
    if widen is not None:  # a start whose last bits do not depend on the CPU (IPOPT then takes the same steps)
        x0v = np.round(x0v, 9)
    lbx = np.concatenate([np.asarray(b[2], float).ravel() for b in blocks])
    ubx = np.concatenate([np.asarray(b[3], float).ravel() for b in blocks])
    nlp = NLP(
        problem={"x": v.x, "f": obj, "g": gg},
        options=_ipopt_options(warm, ipopt_options),
        x0=np.clip(x0v, lbx, ubx),
        lbx=lbx,
        ubx=ubx,
        lbg=np.concatenate([np.asarray(val, float).ravel() for val in lbg]),
        ubg=np.concatenate([np.asarray(val, float).ravel() for val in ubg]),
        layout=v.layout,
        scales={n: (per_arm[n][6], per_arm[n][7]) for n in names},
        grid=grid,
        points=list(points),
        build_seconds=_time.perf_counter() - t0,
        n_vars=int(v.size),
        n_cons=int(gg.numel()),
    )
    nlp.window = (lo_k, hi_k)  # type: ignore[attr-defined]
    return nlp


def _take(col, idx):
    """``col[idx]`` as a column of ``len(idx)`` entries, always.

    CasADi returns a *row* when a 1x1 expression is indexed with a list (it is a row and a
    column at once), so a window with a single time-scale segment (``eta`` is 1x1) or a single
    interval (``H`` is 1x1) would otherwise build mismatched shapes."""
    idx = [int(i) for i in idx]
    return ca.reshape(col[idx], len(idx), 1)


def _transfer_warm(warm: NLPSolution, layout: dict, x0: np.ndarray) -> np.ndarray:
    """Reuse a previous solution on the same grid (the new constraint points keep their guesses)."""
    prev = warm.x
    for key in ("eta",) + tuple(k for k in layout if k.startswith(("X_", "U_"))):
        a, b = layout[key]
        pa, pb = warm.layout[key]
        if b - a == pb - pa:
            x0[a:b] = prev[pa:pb]
    for key in ("theta", "c"):
        a, _ = layout[key]
        pa, pb = warm.layout[key]
        x0[a : a + (pb - pa)] = prev[pa:pb]  # old points come first, in the same order
    a, b = layout["M"]
    x0[a:b] = prev[warm.layout["M"][0] : warm.layout["M"][1]]
    return x0


def _schedule_poses(schedules, names, grid: Grid, points: list[ConstraintPoint]) -> dict[str, np.ndarray]:
    """Every arm's poses (P, 2) at the times of ``points`` in the warm-start schedules (one
    vectorised evaluation per arm)."""
    if not points:
        return {n: np.zeros((0, 2)) for n in names}
    k = np.array([p.k for p in points])
    tau = np.array([p.tau for p in points])
    k1 = np.minimum(k + 1, grid.K)
    t = grid.t[k] + tau * (grid.t[k1] - grid.t[k])
    used = {names[p.ia] for p in points} | {names[p.ib] for p in points}
    return {n: schedules[n].state(t)[0] for n in names if n in used}


def _line_guess(problem, poses, p: ConstraintPoint):
    """Separating line between the two links at ``poses`` (qa, qb): normal from B towards A."""
    from ...kinematics.geometry import segment_distance

    qa, qb = poses
    A, B = problem.arms[p.ia], problem.arms[p.ib]
    pa = kin.fk_points(qa, A.links, A.base)
    pb = kin.fk_points(qb, B.links, B.base)
    _, ca_, cb_ = segment_distance(pa[p.s], pa[p.s + 1], pb[p.u], pb[p.u + 1], return_points=True)
    d = np.asarray(ca_) - np.asarray(cb_)
    nrm = float(np.hypot(*d))
    n = d / nrm if nrm > 1e-9 else (np.asarray(A.base) - np.asarray(B.base)) / max(1e-9, float(np.hypot(*np.subtract(A.base, B.base))))
    mid = (np.asarray(ca_) + np.asarray(cb_)) / 2
    return math.atan2(n[1], n[0]), -float(n @ mid)
