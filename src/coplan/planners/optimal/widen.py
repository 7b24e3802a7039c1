"""The widening stage: the same makespan with more room between neighbours and gentler motion.

Entry point: :func:`widen`. From a verified plan's schedules (each arm's moves, picks and
places, all on one knot grid that keeps every event's order across arms), one CasADi/IPOPT
program over all arms (:func:`coplan.planners.optimal.nlp.build_nlp` with a
:class:`~coplan.planners.optimal.nlp_data.WidenGoal`):

maximise ``S``, the least distance between neighbouring links beyond the required clearance
at every separation point (a max-min slack, capped at ``cap``), with the plan's makespan and
end held (no arm places later, the plan ends no later); with what is left free, minimise the
jerk integral ``sum_k h_k |u_k / jmax|^2`` over every arm (one objective: the room weighted
far above the jerk). Where both arms of a pair hold poses every plan must hold (picks, places,
home), the distance is a constant: it caps ``S`` and, when it leaves no room to win, the
program only smooths. An arm with no work (one locked out of its bin, say) rests at home; where
the least room is held beside it, it is pinned only at the first and last knot instead -- it
may move aside and be home again by the end -- and the program holds every knot time (no event
moves; free timing with the extra arm did not settle within the iterations on locked_arms).

Separation points are added where a dense check of the solution comes closer than the room it
claims, and the program solved again (``rounds``). The motion is piecewise-constant jerk
integrated exactly; position and velocity between knots are bounded through their Bezier
control points and acceleration is linear per interval, so the limits hold for the continuous
trajectory, not only at the knots: the starting plan is a feasible point (up to its tucked
transits, which the knot grid represents only approximately). With every knot time held the
jerk is bounded at its limit itself and a dwell keeps the plan's own length (a time-optimal
move between held poses in held time has no gentler way), so there too.

The result is only a candidate: :func:`coplan.planners.optimal.planner.plan_optimal` keeps it
when the independent verifier passes it, it harvests as much, is no slower, and its certified
margin is no smaller. IPOPT's work is capped in iterations (the same plan on any machine).
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from ...allocate.allocation import Allocation
from ...plan import EventKind, Plan, PlannerKind, PlanStatus
from ...problem.model import Problem
from ...ties import quantised
from ..coordinated.planner import make_plan
from ..coordinated.schedule import ArmSchedule, StepKind
from .ease import ease
from .nlp import build_nlp
from .nlp_data import ConstraintPoint, NLPSolution, SolverStatus, WidenGoal, any_interrupted, build_grid, knot_events
from .nlp_solve import solve_nlp
from .windows import link_pair_distances, min_clearance, refine_points, screen_points

__all__ = ["WidenOptions", "WidenResult", "widen", "held_room", "pinned_knots"]


@dataclass(frozen=True)
class WidenOptions:
    """The widening stage's settings (from :class:`~coplan.planners.optimal.options.OptimalOptions`).

    cap : the most extra room (m) asked for beyond the required clearance
    iterations : IPOPT iterations over every solve of both phases (checked before each solve)
    rounds : solves per phase while separation points are added
    max_knots : plans whose knot grid is longer are left as they are (one program over the
        whole plan; a long row's would take minutes)
    h_bounds : each knot interval may shrink or stretch within these factors of the plan's
    h_target : knot spacing (s)
    screen, shift : separation points where the start's links come within ``cap + screen`` (m),
        also with one arm ``shift`` s earlier or later
    track : weight keeping every arm near the start's pose at each knot (so that the motion far
        from any separation point stays where the start had it), when every knot time is held
    free_track : the same weight when the knot times are free. Lighter: a pose held to the
        start's at the same knot also holds that knot to the start's time, which free timing is
        there to change. Chosen on the 30 layouts of ``benchmarks/bench_widen.py`` (median RMS
        jerk ratio with 10: 0.805, 5: 0.822, 3: 0.777, the same margins doubled but for 5's
        25 of 30): the figure moves with the local optimum IPOPT settles in on a few layouts
    give : a solution whose dense check (1 kHz) finds at least ``1 - give`` of the room it
        claims at its points is kept; else points are added where it dips and it is solved again
    least : less extra room than this (m) to win: the program only smooths (the room held)
    feasible : an iterate at IPOPT's iteration cap is kept when no constraint is violated by
        more than this and it has all the room the start had (the verifier then judges it; at
        IPOPT's own 1e-7, four of the benchmark's 30 layouts were left at 31-40 mm whose
        iterates at the cap, 3.9e-7 and 5e-7 off where printed, had 65-98 mm and were verified)
    ease : start from :func:`ease`'s schedules (each arm's rest spread over its moves)
    """

    cap: float = 0.10
    iterations: int = 300
    rounds: int = 3
    max_knots: int = 600
    h_bounds: tuple[float, float] = (0.7, 1.5)
    h_target: float = 0.06
    screen: float = 0.05
    shift: float = 0.0
    track: float = 10.0
    free_track: float = 3.0
    give: float = 0.15
    least: float = 0.002
    feasible: float = 1e-6
    weight: float | None = None
    ease: bool = True
    ipopt: dict = field(default_factory=dict)


@dataclass
class WidenResult:
    """What the widening produced: ``plan`` (unverified; None when it was skipped or IPOPT
    failed) and a JSON-able ``info`` (status, room, jerk, iterations, seconds, the reason)."""

    plan: Plan | None
    info: dict


def _weight(cap: float) -> float:
    """The weight of the room (m) against the jerk integral: at the default cap, 1 mm of room
    is worth 100 s of one joint at full jerk, so the room comes first and the jerk is
    smoothed with what is left free."""
    return 1e4 / max(cap, 1e-3)


def _rounds(problem: Problem, schedules, grid, points: list[ConstraintPoint], goal: WidenGoal, opts: WidenOptions,
            budget: list[int], deadline: float | None, say, h_bounds: tuple[float, float], makespan: float,
            spent: Callable[[int], None] | None = None):
    """Solve the program, adding points where a dense check of its solution comes closer than
    the room it claims (less ``give``), up to ``rounds`` times; ``(solution or None, points, rounds)``."""
    names = [a.name for a in problem.arms]
    sol = None
    rounds = []
    for rnd in range(opts.rounds):
        if budget[0] <= 0 or (deadline is not None and _time.perf_counter() > deadline):
            break
        ipopt = {"ipopt.max_iter": int(budget[0])} | dict(opts.ipopt)
        nlp = build_nlp(problem, schedules, grid, points, 0.0, h_bounds=h_bounds, h_max=np.inf,
                        ipopt_options=ipopt, warm=sol, widen=goal,
                        track=opts.free_track if h_bounds[0] < h_bounds[1] else opts.track)
        left = None if deadline is None else max(deadline - _time.perf_counter(), 1e-3)
        new = solve_nlp(nlp, names, time_limit=left)
        budget[0] -= new.iterations
        if spent is not None:
            spent(new.iterations)
        s_val = float(new.x[nlp.layout["S"][0]])
        rounds.append({"timing": "free" if h_bounds[0] < h_bounds[1] else "held", "round": rnd, "points": len(points), "status": new.status.value,
                       "iterations": new.iterations, "room": s_val,
                       "wall_seconds": nlp.build_seconds + new.solve_seconds})
        say(f"widen round {rnd + 1}: {len(points)} separation points, IPOPT {new.ipopt_status} after "
            f"{new.iterations} iterations, room {1000 * s_val:.1f} mm")
        # IPOPT at its iteration cap may hold a feasible point that is not yet optimal: it is
        # kept (the verifier judges it); an infeasible or failed one is not
        if not (new.status.converged or (new.status == SolverStatus.LIMIT_REACHED and new.max_violation <= opts.feasible
                                         and _in_time(schedules, grid, new, makespan))):
            break
        dense = new.sample(np.arange(0.0, new.t[-1], 1e-3))
        new.room, new.dense_room = s_val, min_clearance(problem, dense) - problem.task.clearance  # type: ignore[attr-defined]
        rounds[-1]["dense_room"] = new.dense_room
        if not new.status.converged:  # at the cap: kept only with all the room the start had
            if new.dense_room >= goal.guess - 1e-4:
                sol = new
            break
        sol = new
        # kept: its dense check finds nearly the room it claims, and no less than the start had
        if sol.dense_room >= max((1.0 - opts.give) * s_val, goal.guess):
            break
        need = problem.task.clearance + max(s_val - 5e-4, 0.0)
        added = refine_points(problem, sol, 0, sol.t.size - 1, 1000.0, need, set(points), band=0.01)
        if not added:
            break
        points = points + added
    return sol, points, rounds


def _in_time(schedules, grid, sol: NLPSolution, makespan: float) -> bool:
    """Whether an iterate's last place ends no later than the incumbent's ``makespan`` (the
    stage's own rule): the program holds it a microsecond inside, but an iterate at the cap
    meets its constraints only to ``feasible``, in scaled units (overlap-2x6-s26's free-timing
    iterate was 18 microseconds later, and the stage then refused it)."""
    places = [e.t_end for e in knot_events(schedules, grid, sol.t) if e.kind == EventKind.PLACE]
    return max(places, default=0.0) <= makespan + 1e-9


def pinned_knots(schedules: dict[str, ArmSchedule], grid, free_idle: bool = False) -> dict[str, np.ndarray]:
    """Per arm, (K+1,) bool: knots at which every plan on this grid holds the arm still at a
    pose it cannot change (home at the start and after its last step, every pick and place;
    an arm with no work: throughout, or with ``free_idle`` at the first and last knot only)."""
    out = {}
    for n, sch in schedules.items():
        m = np.zeros(grid.K + 1, bool)
        m[0] = True
        ranges = grid.ranges[n]
        for st, (k0, k1) in zip(sch.steps, ranges):
            if st.kind in (StepKind.PICK, StepKind.PLACE):
                m[k0 : k1 + 1] = True
        m[(ranges[-1][1] if ranges else (grid.K if free_idle else 0)):] = True
        out[n] = m
    return out


def held_room(problem: Problem, schedules: dict[str, ArmSchedule], grid, points: list[ConstraintPoint],
              free_idle: bool = False):
    """Split ``points`` into those the NLP can move and those where both arms are held at fixed
    poses (the distance there is a constant); returns ``(free points, least room at the held
    ones (m, inf if none), the held point with it)``. No plan on this grid has more room than
    the held points allow (``free_idle``: arms with no work free between the first and last knot)."""
    names = [a.name for a in problem.arms]
    pin = pinned_knots(schedules, grid, free_idle)

    def held(n, p):
        m = pin[n]
        return bool(m[p.k] and (p.tau == 0.0 or m[min(p.k + 1, grid.K)]))

    free, fixed = [], []
    for p in points:
        (fixed if held(names[p.ia], p) and held(names[p.ib], p) else free).append(p)
    if not fixed:
        return free, np.inf, None
    k = np.array([p.k for p in fixed])
    t = grid.t[k] + np.array([p.tau for p in fixed]) * (grid.t[np.minimum(k + 1, grid.K)] - grid.t[k])
    d = np.empty(len(fixed))
    for i, (p, ti) in enumerate(zip(fixed, t)):
        qa, qb = (schedules[names[x]].state(np.array([ti]))[0] for x in (p.ia, p.ib))
        d[i] = link_pair_distances(problem, qa, qb, p.ia, p.ib)[2 * p.s + p.u, 0]  # (rows: link pairs s, u)
    d -= problem.task.clearance
    i = int(np.argmin(d))
    return free, float(d[i]), fixed[i]


def _least_change(A):
    """A function ``r -> dz``: the least-norm ``dz`` with ``A dz = r`` (in the least-squares
    sense where the rows are dependent, as at consecutive held knots), from one sparse LU of
    the quasi-definite system ``[[I, A^T], [A, -d I]]`` (``d`` = 1e-13: nonsingular whatever
    A's rank) with two steps of iterative refinement -- milliseconds where SciPy's LSQR took
    seconds on a 565-knot plan, to the same 1e-15."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import splu

    m, nz = A.shape
    d = 1e-13
    kkt = sp.bmat([[sp.identity(nz), A.T], [A, -d * sp.identity(m)]], format="csc")
    lu = splu(kkt)

    def solve(r):
        rhs = np.concatenate([np.zeros(nz), r])
        sol = lu.solve(rhs)
        for _ in range(2):
            sol += lu.solve(rhs - kkt @ sol)
        return sol[:nz]

    return solve


def exact_dynamics(sol: NLPSolution, pinned: dict[str, np.ndarray]) -> NLPSolution:
    """``sol`` with its states and jerks moved (least change) so that the knot-to-knot
    integration holds exactly and every pinned knot keeps its pose at rest.

    IPOPT meets the dynamics to its tolerance (1e-7 and, stopped at "acceptable", more); the
    replayed plan then jumps by that much at every knot, which a second difference over 10 ms
    turns into 1e-3-1e-2 rad/s^2 the verifier rightly refuses. With the knot times fixed the
    dynamics are linear in the states and jerks, so the nearest exact trajectory is one sparse
    least-change solve per arm and joint (:func:`_least_change`)."""
    import scipy.sparse as sp

    h = np.diff(sol.t)
    K = h.size
    X = {n: x.copy() for n, x in sol.X.items()}
    U = {n: u.copy() for n, u in sol.U.items()}
    nz = 3 * (K + 1) + K  # unknowns: q_k, v_k, a_k (k = 0..K) at 3k + {0,1,2}, u_k (k < K) at 3(K+1) + k
    for n in X:
        pin = pinned[n]
        held = np.flatnonzero(pin)
        rows, cols, vals = [], [], []
        r = 0
        for k in range(K):  # the knot-to-knot integration (the same rows for both joints)
            hk = h[k]
            q0, v0, a0, q1, v1, a1, uk = 3 * k, 3 * k + 1, 3 * k + 2, 3 * k + 3, 3 * k + 4, 3 * k + 5, 3 * (K + 1) + k
            for c, v in ((q1, 1.0), (q0, -1.0), (v0, -hk), (a0, -hk**2 / 2), (uk, -hk**3 / 6)):
                rows.append(r), cols.append(c), vals.append(v)
            for c, v in ((v1, 1.0), (v0, -1.0), (a0, -hk), (uk, -hk**2 / 2)):
                rows.append(r + 1), cols.append(c), vals.append(v)
            for c, v in ((a1, 1.0), (a0, -1.0), (uk, -hk)):
                rows.append(r + 2), cols.append(c), vals.append(v)
            r += 3
        for k in held:  # held poses stay exactly where they are, at rest
            for c in (3 * k, 3 * k + 1, 3 * k + 2):
                rows.append(r), cols.append(c), vals.append(1.0)
                r += 1
        A = sp.csr_matrix((vals, (rows, cols)), shape=(r, nz))
        least = _least_change(A)
        for j in range(2):
            z0 = np.concatenate([np.stack([X[n][j], X[n][2 + j], X[n][4 + j]], axis=1).ravel(), U[n][j]])
            rhs = np.zeros(r)
            rhs[3 * K::3] = z0[3 * held]  # the held poses' rows: (q, v, a) = (pose, 0, 0)
            dz = least(rhs - A @ z0)
            z = z0 + dz
            z[3 * held], z[3 * held + 1], z[3 * held + 2] = z0[3 * held], 0.0, 0.0  # exactly (the solve: to 1e-15)
            st = z[: 3 * (K + 1)].reshape(K + 1, 3)
            X[n][j], X[n][2 + j], X[n][4 + j] = st[:, 0], st[:, 1], st[:, 2]
            U[n][j] = z[3 * (K + 1):]
    out = replace(sol, X=X, U=U)
    for attr in ("layout", "window", "room", "dense_room"):
        if hasattr(sol, attr):
            setattr(out, attr, getattr(sol, attr))
    return out


def widen(problem: Problem, alloc: Allocation, schedules: dict[str, ArmSchedule], makespan: float,
          options: WidenOptions | None = None, deadline: float | None = None,
          say: Callable[[str], None] | None = None, spent: Callable[[int], None] | None = None) -> WidenResult:
    """More room and gentler motion for ``schedules`` at their makespan; see the module docstring.
    ``spent(n)``: told the IPOPT iterations of each solve as it ends (a progress bar's share)."""
    opts = options or WidenOptions()
    say = say or (lambda m: None)
    t0 = _time.perf_counter()
    info: dict = {"status": "skipped", "rounds": [], "iterations": 0}
    if not problem.neighbour_pairs():
        info["reason"] = "no neighbouring arms: nothing to widen"
        return WidenResult(None, info)
    if not makespan > 0:  # (a plan that places nothing has no makespan to hold: its clearance over no samples raised)
        info["reason"] = "the plan harvests nothing: nothing to widen"
        return WidenResult(None, info)
    # a plan far past the knot limit is left at once (easing it first took 8 s of a 60-fruit
    # cell's solve, three times over with the retries, for a grid of 2027 knots refused after it;
    # easing keeps the plan's length, so the knots: within the limit's half more, the eased grid decides)
    pre = build_grid(schedules, opts.h_target)
    if pre.K + 1 > 1.5 * opts.max_knots:
        info.update(knots=pre.K + 1, too_long=True, wall_seconds=_time.perf_counter() - t0,
                    reason=f"the plan needs {pre.K + 1} knots (widen_knots is {opts.max_knots})")
        return WidenResult(None, info)
    # (not with an arm that has no work: it moves aside on held knot times, and from eased
    # schedules that program was infeasible on locked_arms)
    if opts.ease and all(s.steps for s in schedules.values()):
        schedules, info["ease"] = ease(problem, schedules, makespan, opts.cap)
    grid = build_grid(schedules, opts.h_target)
    info["knots"] = grid.K + 1
    if grid.K + 1 > opts.max_knots:  # (the plan's own schedules may fit where the eased ones do not: knots_uneased)
        info.update(too_long=True, knots_uneased=pre.K + 1, wall_seconds=_time.perf_counter() - t0,
                    reason=f"the plan needs {grid.K + 1} knots (widen_knots is {opts.max_knots})")
        return WidenResult(None, info)
    end = float(grid.t[-1])
    q0 = {n: s.state(np.arange(0.0, end, 1e-3))[0] for n, s in schedules.items()}
    room0 = min_clearance(problem, q0) - problem.task.clearance
    # (a plan with more room than the cap is only smoothed: its points reach as far as its room)
    points = screen_points(problem, schedules, grid, 0, grid.K, max(opts.cap, room0) + opts.screen, opts.shift)
    everywhere = points
    points, held, where = held_room(problem, schedules, grid, points)
    names = [a.name for a in problem.arms]
    idle = {n for n in names if not grid.ranges[n]}
    # the least room held by an arm with no work, at home: it may move aside (every event keeps
    # its time, so with every knot time held), home again by the end
    free_idle = where is not None and held < opts.cap and bool({names[where.ia], names[where.ib]} & idle)
    if free_idle:
        points, held, where = held_room(problem, schedules, grid, everywhere, free_idle=True)
        info["idle_freed"] = sorted(idle)
        say(f"widen: the least room is held by an arm with no work ({', '.join(sorted(idle))}): it may move aside")
    cap = round(min(opts.cap, held), 6)  # (a distance from sin/cos: whole micrometres, the same on any CPU)
    info["room_held"] = None if where is None else held
    budget = [opts.iterations]
    # held a microsecond inside the incumbent's (IPOPT meets constraints to its tolerance, ~1e-7)
    goal = WidenGoal(makespan=float(quantised(makespan)) - 1e-6, end=float(quantised(end)), floor=0.0, cap=cap,
                     guess=round(max(room0, 0.0), 6),
                     weight=opts.weight if opts.weight is not None else _weight(opts.cap), free_idle=free_idle)
    if cap <= room0 + opts.least:  # no room to win: the jerk alone, the room held
        info["room_note"] = (f"the least room ({1000 * room0:.1f} mm) is at widen_cap ({1000 * opts.cap:.0f} mm) already"
                             if where is None or held >= opts.cap else
                             f"the least room ({1000 * room0:.1f} mm) is set by poses every plan on these events holds "
                             f"({names[where.ia]} and {names[where.ib]} at t = {grid.t[where.k]:.2f} s: {1000 * held:.1f} mm)")
        say(f"widen: {info['room_note']}; smoothing only")
        budget[0] = min(budget[0], 2 * (opts.iterations // 3))  # the lesser goal gets less work
        goal = replace(goal, floor=round(max(room0, 0.0), 6), cap=round(max(cap, room0) + 1e-3, 6), weight=0.0)
    # free timing first (each knot interval within h_bounds of its length, the makespan held);
    # if IPOPT cannot settle that, the same program with every knot time held: the events then
    # keep their times exactly (half the iterations each)
    total = budget[0]
    sol = None
    attempts = ((1.0, 1.0),) if free_idle or opts.h_bounds[0] >= opts.h_bounds[1] else (opts.h_bounds, (1.0, 1.0))
    for attempt, h_bounds in enumerate(attempts):
        budget[0] = total // 2 if attempt == 0 and len(attempts) > 1 else total - sum(r["iterations"] for r in info["rounds"])
        # (every knot time held: the places end when the incumbent's do, and the program is
        # held to that, not a microsecond inside, which no point with these times meets)
        this_goal = (goal if h_bounds[0] < h_bounds[1] else
                     replace(goal, makespan=float(makespan) + 1e-9, end=max(goal.end, end + 1e-9)))
        sol, used, rounds = _rounds(problem, schedules, grid, points, this_goal, opts, budget, deadline, say, h_bounds, makespan,
                                    spent)
        info["rounds"] += rounds
        if sol is not None:
            break
        if any_interrupted(rounds):  # Ctrl-C: no second program
            break
        if deadline is not None and _time.perf_counter() >= deadline:  # (it was announced, then stopped for the limit)
            break
        if attempt == 0:
            say("widen: IPOPT did not settle with free timing; solving again with every knot time held")
    if sol is None:
        its = sum(r["iterations"] for r in info["rounds"])
        if any_interrupted(info["rounds"]):
            status, why = "failed", "interrupted (Ctrl-C)"
        elif deadline is not None and _time.perf_counter() >= deadline:  # (the clock, not IPOPT: say so)
            status, why = "time_limit", f"the time limit came during the widening stage (IPOPT stopped after {its} iterations)"
        else:
            status, why = "failed", "IPOPT did not converge"
        info.update(status=status, reason=why, iterations=its, wall_seconds=_time.perf_counter() - t0)
        return WidenResult(None, info)
    room = sol.room  # type: ignore[attr-defined]
    sol = exact_dynamics(sol, pinned_knots(schedules, grid, free_idle))
    events = knot_events(schedules, grid, sol.t)
    plan = make_plan(problem, alloc, sol.sample, float(sol.t[-1]), events, PlanStatus.UNVERIFIED,
                     {"message": "widened"}, PlannerKind.OPTIMAL)
    info.update(status="solved", room_before=room0, room=room, dense_room=sol.dense_room,  # type: ignore[attr-defined]
                points=len(used), iterations=sum(r["iterations"] for r in info["rounds"]), wall_seconds=_time.perf_counter() - t0)
    return WidenResult(plan, info)
