"""Receding windows of the optimal planner: separation points, cuts, commits, and fallbacks.

:func:`solve_windows` solves the NLP of :mod:`coplan.planners.optimal.nlp` window by window: separation points
are screened from the warm start (:func:`screen_points`) and refined from a dense check of
each solution (:func:`refine_points`); cuts avoid dwells and the knots just before a rest
(:func:`_cut_allowed`); each window commits where no arm is saturated (:func:`_choose_commit`)
and hands its state, solution and points to the next; a window that cannot be solved with
free timing is solved again near the warm start's timing (``LADDER``).
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, replace

import numpy as np

from ...kinematics import arm as kin
from ...kinematics.geometry import segment_distance
from .nlp import build_nlp
from .nlp_data import ConstraintPoint, Grid, NLPSolution, SolverStatus
from .nlp_solve import solve_nlp
from .options import OptimalOptions
from ...problem.model import Problem
from ..coordinated.schedule import ArmSchedule, StepKind


__all__ = ["screen_points", "refine_points", "solve_windows", "window_count", "link_pair_distances", "min_clearance"]


# ----------------------------------------------------------------------------- screening
def _states_at(schedules: dict[str, ArmSchedule], names, t: np.ndarray) -> dict[str, np.ndarray]:
    return {n: schedules[n].state(t)[0] for n in names}


def link_pair_distances(problem: Problem, qa, qb, ia, ib) -> np.ndarray:
    """(4, N) distances for link pairs (s, u) in order (0,0), (0,1), (1,0), (1,1)."""
    A, B = problem.arms[ia], problem.arms[ib]
    pa = kin.fk_points(qa, A.links, A.base)
    pb = kin.fk_points(qb, B.links, B.base)
    r = A.link_radius + B.link_radius
    return np.stack([segment_distance(pa[:, s], pa[:, s + 1], pb[:, u], pb[:, u + 1]) - r for s in range(2) for u in range(2)])


def _candidate_points(grid: Grid, lo: int, hi: int, taus=(0.0, 0.5)):
    ks, ts = [], []
    for k in range(lo, hi + 1):
        for tau in taus if k < hi else (0.0,):
            ks.append(k)
            ts.append(tau)
    ks = np.asarray(ks)
    ts = np.asarray(ts)
    k1 = np.minimum(ks + 1, grid.K)
    return ks, ts, grid.t[ks] + ts * (grid.t[k1] - grid.t[ks])


def screen_points(problem: Problem, schedules, grid: Grid, lo: int, hi: int, screen: float,
                  shift: float = 0.0) -> list[ConstraintPoint]:
    """Constraint points where the warm start's links come within ``clearance + screen``, also
    when one arm of the pair runs up to ``shift`` s earlier or later than the other (the
    optimiser retimes the arms, so a near miss in the warm start can become a contact
    elsewhere in time)."""
    names = [a.name for a in problem.arms]
    ks, ts, times = _candidate_points(grid, lo, hi)
    q = _states_at(schedules, names, times)
    shifts = np.linspace(-shift, shift, 2 * int(np.ceil(shift / 0.05)) + 1) if shift > 0 else np.zeros(1)
    t_end = grid.t[-1]
    pts = []
    for ia, ib in problem.neighbour_pairs():
        d = np.full((4, times.size), np.inf)
        for sh in shifts:
            qb = schedules[names[ib]].state(np.clip(times + sh, 0.0, t_end))[0] if sh else q[names[ib]]
            d = np.minimum(d, link_pair_distances(problem, q[names[ia]], qb, ia, ib))
        for li, (s, u) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
            for i in np.flatnonzero(d[li] < problem.task.clearance + screen):
                pts.append(ConstraintPoint(int(ks[i]), float(ts[i]), ia, ib, s, u))
    return pts


def refine_points(problem: Problem, sol: NLPSolution, lo: int, hi: int, rate: float, need: float, have,
                  band: float = 0.0) -> list[ConstraintPoint]:
    """Dense check of the continuous solution; new points where it comes closer than ``need``.

    When it does anywhere, points are also added wherever a link pair comes within
    ``need + band`` (where the next solve would most likely push the dip to), so the
    refinement does not chase one dip at a time."""
    names = [a.name for a in problem.arms]
    t0, t1 = sol.t[lo], sol.t[hi]
    times = np.arange(t0, t1 + 0.5 / rate, 1.0 / rate)
    q = sol.sample(times)
    new: set = set()
    pairs = problem.neighbour_pairs()
    dists = [link_pair_distances(problem, q[names[ia]], q[names[ib]], ia, ib) for ia, ib in pairs]
    if not any((d < need).any() for d in dists):
        return []
    for (ia, ib), d in zip(pairs, dists):
        for li, (s, u) in enumerate(((0, 0), (0, 1), (1, 0), (1, 1))):
            for i in np.flatnonzero(d[li] < need + band):
                k = int(np.clip(np.searchsorted(sol.t, times[i], side="right") - 1, lo, hi - 1))
                h = sol.t[k + 1] - sol.t[k]
                eighth = int(np.floor((times[i] - sol.t[k]) / h * 8)) if h > 0 else 0
                # the two sub-interval points around the dip (eighths of the interval)
                for e in (eighth, eighth + 1):
                    kk, ee = (k + 1, 0) if e >= 8 else (k, max(e, 0))
                    if kk > hi:
                        continue
                    p = ConstraintPoint(kk, ee / 8.0, ia, ib, s, u)
                    if p not in have:
                        new.add(p)
    return sorted(new, key=lambda p: (p.k, p.tau, p.ia, p.s, p.u))


def min_clearance(problem: Problem, q: dict[str, np.ndarray]) -> float:
    """Least link-to-link clearance (m) over poses ``q`` (arm -> (N, 2)), the optimiser's own measure."""
    names = [a.name for a in problem.arms]
    out = np.inf
    for ia, ib in problem.neighbour_pairs():
        out = min(out, float(link_pair_distances(problem, q[names[ia]], q[names[ib]], ia, ib).min()))
    return out


# ----------------------------------------------------------------------------- windows
_PIN_GAP = 3  # intervals kept between a window's cut and the next knot where an arm is pinned at rest


def _cut_allowed(grid: Grid, schedules: dict[str, ArmSchedule] | None) -> np.ndarray:
    """(K+1,) bool: knots where a window may be cut.

    Not inside any arm's pick or place (every dwell is solved whole within one window) and
    not one of the ``_PIN_GAP`` knots just before an arm comes to rest (a dwell, or home at
    the end): the next window pins every arm's full state at its cut, and a moving arm
    pinned again at rest one or two intervals later leaves more equations than unknowns
    there -- a rank-deficient constraint Jacobian on which IPOPT's factorisations stall.
    """
    ok = np.ones(grid.K + 1, bool)
    ok[[0, grid.K]] = False
    if schedules is not None:
        for name, sch in schedules.items():
            ranges = grid.ranges[name]
            rests = [(k0, k1) for st, (k0, k1) in zip(sch.steps, ranges) if st.kind in (StepKind.PICK, StepKind.PLACE)]
            if ranges:
                rests.append((ranges[-1][1], grid.K))  # home at rest after the last step
            for k0, k1 in rests:
                ok[max(k0 - _PIN_GAP, 0) : k0] = False
                ok[k0 + 1 : k1] = False
    return ok


def _windows(grid: Grid, window: float, schedules: dict[str, ArmSchedule] | None = None) -> list[tuple[int, int]]:
    """Planned windows of about ``window`` s: each cut is the allowed knot
    (:func:`_cut_allowed`) nearest its target time, within a quarter window of it."""
    T = grid.t[-1]
    if T <= 1.5 * window:
        return [(0, grid.K)]
    n = int(np.ceil(T / window))
    allowed = _cut_allowed(grid, schedules)
    cuts = [0]
    for i in range(1, n):
        target = T * i / n
        cand = np.flatnonzero((np.abs(grid.t - target) <= 0.25 * window) & allowed)
        cand = cand[(cand > cuts[-1]) & (cand < grid.K)]
        if cand.size == 0:
            continue
        cuts.append(int(cand[np.argmin(np.abs(grid.t[cand] - target))]))
    cuts.append(grid.K)
    return [(a, b) for a, b in zip(cuts[:-1], cuts[1:]) if b > a]


def window_count(grid: Grid, window: float, schedules: dict[str, ArmSchedule] | None = None) -> int:
    """How many receding windows :func:`solve_windows` cuts this grid into."""
    return len(_windows(grid, window, schedules))


def _choose_commit(problem: Problem, sol: NLPSolution, grid: Grid, lo: int, hi: int, planned: int,
                   allowed: np.ndarray, slack: float) -> int:
    """The knot at which to commit a window's solution and start the next window.

    Among the allowed knots within ``slack`` s of the planned cut (and at least one interval
    inside the solved window), the one nearest the plan where every arm's velocity and
    acceleration are at most 85 % of their limits; else the least saturated one (nearest on ties). A cut
    where a time-optimal move sits on its acceleration limit pins a state from which only a
    bang-bang continuation is feasible: many bounds active at once, unbounded multipliers,
    and IPOPT stalls on the next window."""
    t_pl = grid.t[planned]
    cand = np.flatnonzero(allowed & (np.abs(grid.t - t_pl) <= slack))
    cand = cand[(cand > lo) & (cand < hi - _PIN_GAP)]
    if cand.size == 0:
        return planned
    score = np.zeros(cand.size)
    for arm in problem.arms:
        X = sol.X[arm.name][:, cand - lo]
        v = np.abs(X[2:4]) / np.asarray(arm.max_velocity)[:, None]
        a = np.abs(X[4:6]) / np.asarray(arm.max_acceleration)[:, None]
        score = np.maximum(score, np.max(np.vstack([v, a]), axis=0))
    calm = score <= 0.85
    if calm.any():
        c = cand[calm]
        return int(c[np.argmin(np.abs(grid.t[c] - t_pl))])
    return int(cand[np.lexsort((np.abs(grid.t[cand] - t_pl), score))[0]])  # least saturated, then nearest


@dataclass
class _Stitched:
    """Knot times and states of all windows, joined."""

    t: np.ndarray
    X: dict[str, np.ndarray]
    U: dict[str, np.ndarray]

    def sample(self, times):
        return NLPSolution.sample(self, times)  # same exact cubic evaluation


# Time-scale bounds of the successive attempts at a window. The first lets the optimiser
# retime freely (each knot interval 0.3-2x its warm-start length); when that fails -- IPOPT
# does not converge, or the dense check still finds the links too close after
# ``max_rounds`` -- the window is solved again with the timing held near the warm start's:
# first within -15 %/+10 %, then only slower (1-1.1x). The warm start is conflict-free with a
# margin, so near its timing the screened separation points cover every contact that can
# arise; the last attempt gives up most of the speed-up for a plan that holds.
# Later attempts also start again from the screened points (not the failed attempt's) and
# keep a smaller margin (the third element scales ``margin``): the warm start keeps exactly
# ``clearance + margin``, which its S-curves, not quite representable on the knot grid, can
# only just meet. The verifier still certifies the full clearance.
# The fourth element is the weight that keeps every arm near the warm start's pose at each
# knot (``build_nlp(track=...)``): the arms then keep the warm start's relative progress.
LADDER = (
    ("free timing", (0.3, 2.0), 1.0, 0.0),
    ("timing held within -15/+10 % of the warm start", (0.85, 1.1), 0.6, 10.0),
    ("the warm start's timing (only slower, up to +10 %)", (1.0, 1.1), 0.4, 100.0),
)


def _solve_rounds(problem, schedules, grid, opts: OptimalOptions, window, points, start_state, prev_sol, timing,
                  deadline, info, tag, wi, attempt, say, iterations=None):
    """Solve one window, adding separation points from the dense check, up to ``max_rounds``.

    Returns ``(solution, points, clean)``; ``clean`` is True when IPOPT converged and the
    dense check of the last solution found nothing closer than the refinement threshold.
    ``iterations``: IPOPT iterations the whole :func:`solve_windows` may spend (``info``
    counts them; checked before each solve, so a solve started is finished); when they are
    spent, ``info["budget_spent"]`` is set and the last solution is returned as it is."""
    names = [a.name for a in problem.arms]
    lo, hi = window
    (h_bounds, track) = timing
    need = problem.task.clearance + opts.margin / 2
    sol = None
    for rnd in range(opts.max_rounds):
        remaining = opts.window_time_limit  # None by default: IPOPT's iteration cap bounds the work
        if deadline is not None:
            left = max(deadline - _time.perf_counter(), 1e-3)
            remaining = left if remaining is None else min(remaining, left)
        if iterations is not None and info["iterations"] >= iterations:  # the budget is checked between solves
            info["budget_spent"] = True
            return sol, points, False
        nlp = build_nlp(problem, schedules, grid, points, opts.margin, window=(lo, hi), start=start_state,
                        ipopt_options=opts.ipopt, warm=sol, carry=prev_sol, h_bounds=h_bounds, track=track)
        sol = solve_nlp(nlp, names, time_limit=remaining)
        info["build"] += nlp.build_seconds
        info["solve"] += sol.solve_seconds
        info["iterations"] += sol.iterations
        info["n_vars"] = max(info["n_vars"], nlp.n_vars)
        info["n_cons"] = max(info["n_cons"], nlp.n_cons)
        info["rounds"].append({"window": wi, "attempt": attempt, "round": rnd, "points": len(points), "status": sol.status.value,
                               "iterations": sol.iterations, "seconds": sol.solve_seconds + nlp.build_seconds})
        say(f"{tag} round {rnd + 1}: {len(points)} separation points, IPOPT {sol.ipopt_status} "
            f"after {sol.iterations} iterations ({sol.solve_seconds:.2f} s)")
        if not sol.status.converged:
            return sol, points, False
        # the solution's knots are local to the window: compare and return in global indices
        local = {replace(p, k=p.k - lo) for p in points}
        new = [replace(p, k=p.k + lo) for p in refine_points(problem, sol, 0, sol.t.size - 1, opts.check_rate, need, local, opts.band)]
        if not new:
            return sol, points, True
        points = points + new
    return sol, points, False


def solve_windows(problem, schedules, grid, opts: OptimalOptions, deadline, say, level: int = 0,
                  iterations: int | None = None) -> tuple[_Stitched, dict]:
    """Solve the receding windows in order; each window tries ``LADDER[level:]`` in turn.

    ``iterations``: a budget of IPOPT iterations over every solve; when it is spent, the
    windows solved so far and the last solution are returned (``info["budget_spent"]``).

    ``info["clean"]`` says whether every window ended converged with its dense check clean."""
    names = [a.name for a in problem.arms]
    wins = _windows(grid, opts.window, schedules)
    allowed = _cut_allowed(grid, schedules)
    info = {"windows": len(wins), "rounds": [], "iterations": 0, "build": 0.0, "solve": 0.0, "points": 0,
            "n_vars": 0, "n_cons": 0, "status": SolverStatus.OPTIMAL, "ipopt_status": "", "max_violation": 0.0}
    t_parts: list[np.ndarray] = []
    X_parts = {n: [] for n in names}
    U_parts = {n: [] for n in names}
    start_state = None
    prev_sol = None  # the previous window's solution (it runs past this window's start)
    carried: list[ConstraintPoint] = []
    t_offset = 0.0
    worst = SolverStatus.OPTIMAL
    order = list(SolverStatus)
    lo = 0
    for wi, (_, planned) in enumerate(wins):
        # receding horizon: solve past the planned cut by ``overlap`` s, keep only up to the
        # commit knot chosen near it, so the state handed to the next window has a feasible
        # continuation (the part discarded)
        hi = planned if planned == grid.K else int(np.searchsorted(grid.t, grid.t[planned] + opts.overlap))
        hi = min(max(hi, planned), grid.K)
        points = screen_points(problem, schedules, grid, lo, hi, opts.screen, opts.screen_shift)
        # the points the previous window needed where the two overlap are needed here too
        have = set(points)
        points += [p for p in carried if lo <= p.k <= hi and p not in have]
        sol, first, clean, label = None, points, False, ""
        for attempt, (label, h_bounds, mscale, track) in enumerate(LADDER[level:], start=level):
            if attempt > level and deadline is not None and _time.perf_counter() > deadline:
                break
            if attempt > level:
                say(f"window {wi + 1}/{len(wins)}: {'IPOPT ' + sol.ipopt_status if not sol.status.converged else 'clearance not met after ' + str(opts.max_rounds) + ' rounds'}"
                    f"; solving again with {label}")
            sol, points, clean = _solve_rounds(problem, schedules, grid, replace(opts, margin=opts.margin * mscale), (lo, hi),
                                               first, start_state, prev_sol, (h_bounds, track), deadline, info,
                                               f"window {wi + 1}/{len(wins)}", wi, attempt, say, iterations)
            if sol is None or clean or sol.status == SolverStatus.INTERRUPTED or info.get("budget_spent"):
                break
        if sol is None:  # the budget was spent before this window's first solve
            worst = SolverStatus.LIMIT_REACHED
            info["ipopt_status"] = "iteration budget spent"
            break
        info.setdefault("window_stages", []).append(label)
        info["clean"] = info.get("clean", True) and clean
        info["points"] += len(points)
        info["max_violation"] = max(info["max_violation"], sol.max_violation)
        if order.index(sol.status) > order.index(worst):
            worst = sol.status
            info["ipopt_status"] = sol.ipopt_status
        elif not info["ipopt_status"]:
            info["ipopt_status"] = sol.ipopt_status
        hi_commit = grid.K if planned == grid.K else _choose_commit(
            problem, sol, grid, lo, hi, planned, allowed, slack=max(0.0, min(1.0, opts.overlap - 1.0)))
        # stitch the committed part (knots lo..hi_commit); local knot times start at 0
        c = hi_commit - lo
        if not sol.status.converged:
            c = hi - lo  # keep everything the failed solve has, for the record
        tloc = sol.t[: c + 1] + t_offset
        t_parts.append(tloc if wi == 0 else tloc[1:])
        for n in names:
            X_parts[n].append(sol.X[n][:, : c + 1] if wi == 0 else sol.X[n][:, 1 : c + 1])
            U_parts[n].append(sol.U[n][:, :c])
        t_offset = float(tloc[-1])
        start_state = {n: sol.X[n][:, c].copy() for n in names}
        prev_sol, carried = sol, points
        lo = hi_commit
        if not sol.status.converged:
            break
        if info.get("budget_spent") and wi < len(wins) - 1:  # the rest of the schedule is not solved
            worst = SolverStatus.LIMIT_REACHED
            info["ipopt_status"] = "iteration budget spent"
            break
    info["status"] = worst
    st = _Stitched(np.concatenate(t_parts), {n: np.hstack(X_parts[n]) for n in names}, {n: np.hstack(U_parts[n]) for n in names})
    info["complete_windows"] = wi + 1 if sol is not None and sol.status.converged else wi
    return st, info
