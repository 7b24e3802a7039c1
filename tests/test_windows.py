"""Receding windows of the optimal planner: where windows are cut, where a solution is
committed, and the fallback attempts when a window cannot be solved with free timing."""

from __future__ import annotations

import numpy as np
import pytest

from coplan.planners.optimal import windows as windows_mod
from coplan.allocate import allocate
from coplan.planners.optimal.nlp import Grid, NLPSolution, SolverStatus, build_grid
from coplan.allocate.allocation import AllocationMethod
from coplan.planners.coordinated import CoordinatedOptions, find_coordinated
from coplan.planners.optimal.planner import OptimalOptions, nlp_plan
from coplan.planners.optimal.windows import _choose_commit, _cut_allowed, _windows
from coplan.plan import PlanStatus
from coplan.problem import default_problem_path, load_problem
from coplan.planners.coordinated.schedule import StepKind, decoupled_schedules
from coplan.verify import verify


@pytest.fixture(scope="module")
def greenhouse():
    return load_problem(default_problem_path())


@pytest.fixture(scope="module")
def coordinated(greenhouse):
    best, _, _ = find_coordinated(greenhouse, AllocationMethod.MAKESPAN, CoordinatedOptions(), lambda m: None)
    return best


@pytest.fixture(scope="module")
def sched_grid(greenhouse):
    sched = decoupled_schedules(greenhouse, allocate(greenhouse))
    return sched, build_grid(sched, 0.06)


def test_cuts_avoid_dwells_and_the_knots_just_before_a_rest(sched_grid):
    sched, grid = sched_grid
    ok = _cut_allowed(grid, sched)
    assert not ok[0] and not ok[grid.K]
    n_rests = 0
    for name, s in sched.items():
        ranges = grid.ranges[name]
        rests = [r for st, r in zip(s.steps, ranges) if st.kind in (StepKind.PICK, StepKind.PLACE)]
        rests.append((ranges[-1][1], grid.K))
        for k0, k1 in rests:
            n_rests += 1
            assert not ok[max(k0 - windows_mod._PIN_GAP, 0) : k0].any(), (name, k0)
            assert not ok[k0 + 1 : k1].any(), (name, k0, k1)
    assert n_rests > 20
    assert ok.sum() > grid.K // 4  # plenty of places left to cut


def test_planned_windows_cover_the_grid_at_allowed_cuts(sched_grid):
    sched, grid = sched_grid
    ok = _cut_allowed(grid, sched)
    wins = _windows(grid, 4.0, sched)
    assert len(wins) >= 3
    assert wins[0][0] == 0 and wins[-1][1] == grid.K
    for (a, b), (c, _) in zip(wins[:-1], wins[1:]):
        assert b == c and ok[b] and b > a
    assert _windows(grid, 100.0, sched) == [(0, grid.K)]


def _fake_solution(problem, t, qd_scale):
    """A solution on knots ``t`` whose velocities are ``qd_scale`` (K+1,) of each arm's limit."""
    X = {}
    for arm in problem.arms:
        x = np.zeros((6, t.size))
        x[2:4] = np.asarray(arm.max_velocity)[:, None] * qd_scale[None, :]
        X[arm.name] = x
    U = {a.name: np.zeros((2, t.size - 1)) for a in problem.arms}
    return NLPSolution(SolverStatus.OPTIMAL, "Solve_Succeeded", 1, t, X, U, 0.0, 0.0, 0.0)


def test_commit_prefers_the_nearest_knot_where_no_arm_is_near_its_limits(greenhouse):
    t = np.linspace(0.0, 10.0, 201)
    grid = Grid(t, {}, np.zeros(200, int))
    allowed = np.ones(201, bool)
    scale = np.full(201, 0.99)  # saturated everywhere ...
    scale[[90, 130]] = 0.5  # ... but at two knots
    sol = _fake_solution(greenhouse, t, scale)
    # the planned cut (knot 100, 5.0 s) is saturated: the calm knot within the slack wins
    assert _choose_commit(greenhouse, sol, grid, 0, 200, 100, allowed, slack=1.0) == 90
    allowed[90] = False
    assert _choose_commit(greenhouse, sol, grid, 0, 200, 100, allowed, slack=1.0) == 100  # 130 is out of reach: all equally saturated, the nearest
    scale[:] = 0.2  # calm everywhere: the planned cut itself
    sol = _fake_solution(greenhouse, t, scale)
    assert _choose_commit(greenhouse, sol, grid, 0, 200, 100, allowed, slack=1.0) == 100


def test_windowed_solve_agrees_with_one_nlp_and_is_verified(greenhouse, coordinated):
    """The same problem cut into ~5 s receding windows: verified, all fruit, and a makespan
    close to the single-NLP one (the windows only lose some look-ahead)."""
    c = coordinated
    one, one_info, _ = nlp_plan(greenhouse, c.alloc, c.schedules)
    win, info, _ = nlp_plan(greenhouse, c.alloc, c.schedules, OptimalOptions(window=5.0, overlap=2.0))
    assert one_info["windows"] == 1 and info["windows"] >= 2
    assert win.status == PlanStatus.UNVERIFIED and verify(greenhouse, win).passed
    assert win.metrics["harvested"] == 11
    assert win.metrics["makespan"] <= 1.05 * one.metrics["makespan"]
    # the stitched trajectory is continuous: no jump in any joint between 100 Hz samples
    # larger than the joint-speed limit allows
    for arm in greenhouse.arms:
        dq = np.abs(np.diff(win.q[arm.name], axis=0))
        assert (dq <= np.asarray(arm.max_velocity) * 0.01 + 1e-6).all()


def test_a_window_that_fails_with_free_timing_is_solved_again_near_the_warm_start(greenhouse, coordinated, monkeypatch):
    """First attempt made impossible (every interval at most 0.31x its warm-start length is
    faster than the joint limits allow): IPOPT fails, the window is solved again with the
    timing held near the warm start, and that plan is verified."""
    ladder = (("impossible timing", (0.3, 0.31), 1.0, 0.0),) + windows_mod.LADDER[1:]
    monkeypatch.setattr(windows_mod, "LADDER", ladder)
    plan, info, _ = nlp_plan(greenhouse, coordinated.alloc, coordinated.schedules)
    rounds = info["rounds"]
    assert rounds[0]["attempt"] == 0 and rounds[0]["status"] not in ("optimal", "acceptable")
    assert any(r["attempt"] == 1 for r in rounds)
    assert info["window_timing"] == [windows_mod.LADDER[1][0]]
    assert plan.status == PlanStatus.UNVERIFIED and verify(greenhouse, plan).passed
    assert plan.metrics["harvested"] == 11


def test_time_shifted_screening_finds_a_superset_of_points(greenhouse, sched_grid):
    """Screening with one arm of each pair shifted in time can only add points."""
    sched, grid = sched_grid
    plain = set(windows_mod.screen_points(greenhouse, sched, grid, 0, grid.K, 0.25))
    shifted = set(windows_mod.screen_points(greenhouse, sched, grid, 0, grid.K, 0.25, shift=0.4))
    assert plain and plain <= shifted and len(shifted) > len(plain)


def test_an_unclean_schedule_is_solved_again_near_the_warm_start_from_the_first_window(greenhouse, coordinated, monkeypatch):
    from coplan.planners.optimal import stages as optimal_mod  # (where nlp_plan solves its windows)

    levels = []
    original = optimal_mod.solve_windows

    def first_unclean(*args, **kwargs):
        st, info = original(*args, **kwargs)
        levels.append(args[6] if len(args) > 6 else kwargs.get("level", 0))
        if levels[-1] == 0:
            info["clean"] = False  # as if a window had ended too close after every attempt
        return st, info

    monkeypatch.setattr(optimal_mod, "solve_windows", first_unclean)
    plan, info, _ = nlp_plan(greenhouse, coordinated.alloc, coordinated.schedules)
    assert levels == [0, 1]
    assert info["restarted"] is True
    assert info["window_timing"] == [windows_mod.LADDER[1][0]]
    assert plan.status == PlanStatus.UNVERIFIED and verify(greenhouse, plan).passed


def test_knot_bounds_are_the_limits_and_the_hull_rows_bound_between_knots(greenhouse, sched_grid):
    """Knot bounds are the joint and velocity limits themselves (no shrinking); between knots the
    Bezier control points are bounded, so a solution's dense samples keep the limits too."""
    import casadi as ca

    from coplan.planners.optimal.nlp import build_nlp

    sched, grid = sched_grid
    nlp = build_nlp(greenhouse, sched, grid, [], 0.015)
    for arm in greenhouse.arms:
        a, b = nlp.layout[f"X_{arm.name}"]
        sx = np.r_[1.0, 1.0, arm.max_velocity, arm.max_acceleration][:, None]
        lo = nlp.lbx[a:b].reshape((6, -1), order="F") * sx
        hi = nlp.ubx[a:b].reshape((6, -1), order="F") * sx
        free = lo[0] < hi[0]
        np.testing.assert_allclose(lo[0:2, free], np.repeat(arm.limits[:, 0:1], free.sum(), axis=1))
        np.testing.assert_allclose(hi[0:2, free], np.repeat(arm.limits[:, 1:2], free.sum(), axis=1))
        np.testing.assert_allclose(hi[2:4, free], np.repeat(np.asarray(arm.max_velocity)[:, None], free.sum(), axis=1))
    # the schedules are a feasible point: dynamics exact, hull rows inside their bounds
    g = ca.Function("g", [nlp.problem["x"]], [nlp.problem["g"]])(nlp.x0).full().ravel()
    # (the jerk bound sits 1e-5 inside the limit, so the S-curves' bang-bang jerk is clipped
    # by that much: residuals of a few 1e-6 in the scaled rows)
    assert (g >= nlp.lbg - 2e-5).all() and (g <= nlp.ubg + 2e-5).all()


def test_the_coordinated_schedules_are_a_feasible_point_of_the_nlp(greenhouse, coordinated):
    """Knots at every S-curve switch: constant jerk per interval represents each move exactly,
    so the warm start satisfies the dynamics, every limit and every dwell exactly (the NLP
    starts feasible, and polishing cannot have to slow down to become feasible)."""
    import casadi as ca

    from coplan.planners.optimal.nlp import build_nlp

    sched = coordinated.schedules
    grid = build_grid(sched, 0.06)
    nlp = build_nlp(greenhouse, sched, grid, [], 0.015)
    for arm in greenhouse.arms:  # nothing was clipped: the guess is the schedules' exact state
        a, b = nlp.layout[f"X_{arm.name}"]
        sx = np.r_[1.0, 1.0, arm.max_velocity, arm.max_acceleration][:, None]
        X = nlp.x0[a:b].reshape((6, -1), order="F") * sx
        st = sched[arm.name].state(grid.t)
        np.testing.assert_allclose(X, np.concatenate([st[0].T, st[1].T, st[2].T]), atol=1e-6)
    g = ca.Function("g", [nlp.problem["x"]], [nlp.problem["g"]])(nlp.x0).full().ravel()
    # (the jerk bound sits 1e-5 inside the limit, so the S-curves' bang-bang jerk is clipped
    # by that much: residuals of a few 1e-6 in the scaled rows)
    assert (g >= nlp.lbg - 2e-5).all() and (g <= nlp.ubg + 2e-5).all()
    # without the switch knots the same schedules break the dynamics rows
    coarse = build_grid(sched, 0.06, merge_tol=0.004, switches=False)
    nlp2 = build_nlp(greenhouse, sched, coarse, [], 0.015)
    g2 = ca.Function("g", [nlp2.problem["x"]], [nlp2.problem["g"]])(nlp2.x0).full().ravel()
    assert ((g2 < nlp2.lbg - 1e-4) | (g2 > nlp2.ubg + 1e-4)).any()
