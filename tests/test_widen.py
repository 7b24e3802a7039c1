"""The widening stage: the same makespan, more certified room between neighbours, less jerk.

Reference values (a cubic's jerk), a cross-check of the widening program against the
independent verifier on seeded random plans, and the stage inside the optimal planner on a
shipped problem (its makespan held, its margin more than doubled, its report in plan.json).
"""

from __future__ import annotations

import numpy as np
import pytest

from coplan.generate import overlap_problem, to_yaml
from coplan.plan import Plan, PlannerKind, PlanStatus, jerk_figures
from coplan.planners.coordinated import plan_coordinated
from coplan.planners.coordinated.planner import schedules_plan
from coplan.planners.optimal import OptimalOptions, OptionsError, parse_options, plan_optimal
from coplan.planners.optimal.nlp_data import build_grid
from coplan.planners.optimal.widen import WidenOptions, pinned_knots, widen
from coplan.problem import load_problem, parse_problem, shipped_problems
from coplan.verify import verify


def _shipped(stem: str):
    return load_problem(next(p for p in shipped_problems() if p.stem == stem))


def test_jerk_figures_of_a_cubic_are_its_jerk():
    """q = j t^3 / 6 has jerk j everywhere: third differences give it exactly."""
    t = np.arange(0.0, 1.0 + 1e-12, 0.01)
    j = 7.5
    q = np.column_stack([j * t**3 / 6, np.zeros_like(t)])
    plan = Plan("p", PlannerKind.HEURISTIC, PlanStatus.UNVERIFIED, t, {"a": q}, [], {}, [])
    fig = jerk_figures(plan)["a"]
    assert fig["rms_jerk"] == pytest.approx(j, rel=1e-6)
    assert fig["peak_jerk"] == pytest.approx(j, rel=1e-6)


def test_the_margin_is_the_certified_clearance_less_the_required():
    prob = _shipped("crossing_paths")
    plan = plan_coordinated(prob).plan
    ver = verify(prob, plan)
    s = ver.summary()
    assert s["margin"] == pytest.approx(ver.certified_clearance - prob.task.clearance)
    for key, pair in s["pairs"].items():
        assert pair["margin"] == pytest.approx(pair["certified"] - prob.task.clearance)
    assert plan.metrics["per_arm"]["left"]["rms_jerk"] > 0


def test_picks_places_and_home_are_pinned():
    prob = _shipped("crossing_paths")
    cand = plan_coordinated(prob).candidate
    grid = build_grid(cand.schedules)
    pin = pinned_knots(cand.schedules, grid)
    for name, sch in cand.schedules.items():
        assert pin[name][0] and pin[name][-1]
        for st, (k0, k1) in zip(sch.steps, grid.ranges[name]):
            if st.kind.value in ("pick", "place"):
                assert pin[name][k0 : k1 + 1].all()
        assert not pin[name].all()  # the moves are free


@pytest.mark.parametrize("seed", [3, 11])
def test_what_the_widening_program_calls_feasible_the_verifier_certifies(seed):
    """Seeded random two-arm cells with shared fruit: every widened plan IPOPT solves passes
    the independent verifier (limits by finite differences of the replay, picks and places,
    certified clearance) with nothing shrunk, at a makespan no longer than the start's."""
    prob = parse_problem(to_yaml(overlap_problem(n_arms=2, n_fruits=4, spacing=1.3, seed=seed)), f"overlap-{seed}")
    cand = plan_coordinated(prob).candidate
    start = schedules_plan(prob, cand.alloc, cand.schedules, PlannerKind.OPTIMAL, {})
    res = widen(prob, cand.alloc, cand.schedules, start.metrics["makespan"], WidenOptions())
    assert res.info["status"] in ("solved", "failed", "skipped")
    if res.plan is None:
        assert res.info.get("reason")  # skipped or failed: says why
        return
    ver = verify(prob, res.plan)
    assert ver.passed, [v.kind.value for v in ver.violations]
    assert res.plan.metrics["makespan"] <= start.metrics["makespan"] + 1e-9
    assert res.plan.metrics["harvested"] == start.metrics["harvested"]
    # the room the program reports between its points is what the verifier samples (1 kHz), nearly
    assert ver.min_clearance - prob.task.clearance >= res.info["dense_room"] - 2e-3


@pytest.mark.parametrize("stem", ["crossing_paths", "dense_overlap", "locked_arms"])
def test_with_every_knot_time_held_the_plan_itself_is_a_feasible_point_of_the_program(stem):
    """The program with every knot time held (``h_bounds`` (1, 1)) starts from the plan, which
    must meet its every row to IPOPT's tolerance (1e-7): a time-optimal move at full jerk
    between held poses in held time has no gentler way (the jerk bound a hair inside the limit
    left it 6e-6 off), nor a held dwell any longer (a dwell row asking 1e-6 s more)."""
    import casadi as ca

    from coplan.planners.optimal.nlp import build_nlp
    from coplan.planners.optimal.nlp_data import WidenGoal
    from coplan.planners.optimal.windows import screen_points

    prob = _shipped(stem)
    cand = plan_coordinated(prob).candidate
    grid = build_grid(cand.schedules, 0.06)
    mk = max(s.last_place for s in cand.schedules.values())
    pts = screen_points(prob, cand.schedules, grid, 0, grid.K, 0.15)
    assert pts  # (neighbours come close: the separation rows are part of what is checked)
    goal = WidenGoal(makespan=mk + 1e-9, end=float(grid.t[-1]) + 1e-9, floor=0.0, cap=0.1, guess=0.0, weight=1e5)
    nlp = build_nlp(prob, cand.schedules, grid, pts, 0.0, h_bounds=(1.0, 1.0), h_max=np.inf, widen=goal, track=10.0)
    g = ca.Function("g", [nlp.problem["x"]], [nlp.problem["g"]])(nlp.x0).full().ravel()
    assert np.maximum(nlp.lbg - g, g - nlp.ubg).max() <= 1e-7
    assert np.all(nlp.lbx <= nlp.x0) and np.all(nlp.x0 <= nlp.ubx)
    # the time scales are the plan's own, and the jerk reaches the limit somewhere (the case under test)
    lo, hi = nlp.layout["eta"]
    assert np.all(nlp.x0[lo:hi] == 1.0)
    name = prob.arms[0].name
    lo, hi = nlp.layout[f"U_{name}"]
    assert np.abs(nlp.x0[lo:hi]).max() == pytest.approx(1.0)


def test_the_option_widen_false_skips_the_stage_and_says_so():
    off = plan_optimal(_shipped("locked_arms"), options=OptimalOptions(widen=False, search_work=500, refine_retimes=5))
    assert off.plan.solver["widen"] == {"status": "skipped", "accepted": False, "reason": "the option widen is false"}
    assert off.plan.solver["moved_by"] is None and off.verification.passed


def test_widening_is_repeatable():
    # (a two-arm cell the stage widens in about 3 s: crossing_paths took 5 s a call)
    prob = parse_problem(to_yaml(overlap_problem(n_arms=2, n_fruits=4, spacing=1.5, seed=9)), "overlap-2x4-s9")
    cand = plan_coordinated(prob).candidate
    mk = max(s.last_place for s in cand.schedules.values())
    a = widen(prob, cand.alloc, cand.schedules, mk)
    b = widen(prob, cand.alloc, cand.schedules, mk)
    assert a.plan is not None and b.plan is not None
    for n in a.plan.q:
        assert np.array_equal(a.plan.q[n], b.plan.q[n])


def test_widening_options_are_validated():
    assert parse_options("widen: false").widen is False
    assert parse_options("widen_cap: 0.05").widen_cap == 0.05
    with pytest.raises(OptionsError, match="widen_cap"):
        parse_options("widen_cap: -1")
    with pytest.raises(OptionsError, match="widen"):
        parse_options("widen: 3")


def test_a_widening_goal_past_the_cap_is_refused_at_its_line_and_from_python():
    # the program asks for at most widen_cap of extra room, so a goal above it could never be met
    with pytest.raises(OptionsError) as ei:
        parse_options("# options\nwiden_goal: 0.2\nwiden_cap: 0.1\n", "opts.yaml")
    (it,) = ei.value.issues
    assert it.path == "widen_goal" and it.line == 2
    assert it.message == ("expected at most widen_cap (0.1 m): the widening asks for at most widen_cap of extra room, "
                          "so a larger goal is never met; found 0.2")
    with pytest.raises(OptionsError) as ei:  # the cap alone lowered under the default goal (0.05): the cap, at its line
        parse_options("widen_cap: 0.01\n")  # (it was said of widen_goal, which the file never wrote)
    (it,) = ei.value.issues
    assert it.path == "widen_cap" and it.line == 1 and it.message == (
        "expected at least widen_goal (0.05 m, its default): the widening asks for at most widen_cap of extra room, "
        "so a goal above it is never met; found 0.01")
    with pytest.raises(OptionsError, match="widen_cap: expected at least widen_goal"):
        OptimalOptions(widen_cap=0.0)
    with pytest.raises(OptionsError, match="widen_goal: expected at most widen_cap"):
        OptimalOptions(widen_goal=0.3)
    assert parse_options("widen_goal: 0.1\nwiden_cap: 0.1\n").widen_goal == 0.1  # equal is fine


def test_exact_dynamics_closes_the_integration_with_the_least_change():
    """IPOPT meets the dynamics to its tolerance; the projection makes them exact (a replay
    without jumps at the knots), keeps every held pose, and moves the rest by about the residual."""
    from coplan.planners.optimal.nlp_data import NLPSolution, SolverStatus
    from coplan.planners.optimal.widen import exact_dynamics

    prob = _shipped("crossing_paths")
    cand = plan_coordinated(prob).candidate
    grid = build_grid(cand.schedules)
    rng = np.random.default_rng(4)
    pin = pinned_knots(cand.schedules, grid)
    X, U = {}, {}
    for n, sch in cand.schedules.items():
        st = sch.state(grid.t)  # (3, K+1, 2)
        noise = rng.normal(0, 1e-6, (6, grid.K + 1)) * ~pin[n]  # (the NLP's held knots are bounds: exact)
        X[n] = np.concatenate([st[0].T, st[1].T, st[2].T]) + noise
        U[n] = np.diff(st[2].T, axis=1) / np.diff(grid.t)
    sol = NLPSolution(SolverStatus.ACCEPTABLE, "", 0, grid.t.copy(), X, U, 0.0, 0.0, 0.0)
    out = exact_dynamics(sol, pin)
    h = np.diff(grid.t)
    for n in X:
        Xn, Un = out.X[n], out.U[n]
        q1 = Xn[0:2, :-1] + Xn[2:4, :-1] * h + Xn[4:6, :-1] * h**2 / 2 + Un * h**3 / 6
        assert np.max(np.abs(q1 - Xn[0:2, 1:])) < 1e-10
        assert np.max(np.abs(Xn[2:4, :-1] + Xn[4:6, :-1] * h + Un * h**2 / 2 - Xn[2:4, 1:])) < 1e-9
        assert np.max(np.abs(Xn[2:6, pin[n]])) < 1e-12  # at rest where held
        assert np.array_equal(Xn[0:2, pin[n]], X[n][0:2, pin[n]])  # at the held pose, exactly
        assert np.max(np.abs(Xn - X[n])) < 1e-3


def test_a_time_limit_that_leaves_no_time_for_the_widening_stage_is_said():
    """When the clock limit comes before the widening stage, plan.json says so (the summary
    prints it as "not widened"), instead of an empty report."""
    prob = load_problem(next(p for p in shipped_problems() if p.stem == "dense_overlap"))
    res = plan_optimal(prob, options=OptimalOptions(time_limit=1.0))
    assert res.plan.solver["stopped_by"] == "time_limit"
    wid = res.plan.solver["widen"]
    assert wid["accepted"] is False and wid["reason"] == "the time limit came before the widening stage"
    assert verify(prob, res.plan).passed


def test_an_arm_with_no_work_moves_aside_when_the_least_room_is_held_beside_it():
    """locked_arms: r1 and r3 can never place (locked out by their neighbours' bases), so the
    optimal planner's incumbent gives them no work; r2 picking p002 beside r1 resting at home
    held the room at 31 mm in every plan on these events, and the stage did not widen. An arm
    with no work is then pinned only at the first and last knot: it moves aside (home again by
    the end), with every knot time held, and the room grows -- at the same makespan, verified
    by the independent verifier (97.7 mm on the benchmark machine)."""
    prob = _shipped("locked_arms")
    cand = plan_coordinated(prob).candidate  # (r3 has no work here either)
    grid = build_grid(cand.schedules)
    pin, free = pinned_knots(cand.schedules, grid), pinned_knots(cand.schedules, grid, free_idle=True)
    assert not grid.ranges["r3"] and pin["r3"].all()
    assert free["r3"][0] and free["r3"][-1] and not free["r3"][1:-1].any()
    assert all(np.array_equal(pin[n], free[n]) for n in cand.schedules if grid.ranges[n])  # (the others as before)
    res = plan_optimal(prob, options=OptimalOptions(search_work=2000))
    w = res.plan.solver["widen"]
    assert w["idle_freed"] == ["r1", "r3"] and w["accepted"] and w["verified"] and res.verification.passed
    assert abs(res.plan.metrics["makespan"] - w["makespan_before"]) < 1e-3
    assert w["margin"] >= max(2 * w["margin_before"], 0.05), (w["margin_before"], w["margin"])
    assert res.plan.metrics["margin"] == pytest.approx(w["margin"])
    for n in w["idle_freed"]:  # home at both ends
        q, home = res.plan.q[n], np.asarray(prob.arm(n).home)
        assert np.allclose(q[0], home) and np.allclose(q[-1], home)
    assert np.abs(res.plan.q["r1"] - np.asarray(prob.arm("r1").home)).max() > 0.05  # r1 aside between


def test_an_iterate_at_ipopts_cap_within_the_feasibility_tolerance_is_a_candidate_the_verifier_judges():
    """The program with every knot time held on crossing_paths, stopped two iterations before
    it settles: IPOPT's iterate at its cap (``limit_reached``) meets the constraints within
    ``WidenOptions.feasible`` and keeps the room the start had, so it is a candidate -- exact
    dynamics restored, passed by the independent verifier, no slower, no less margin."""
    prob = _shipped("crossing_paths")
    cand = plan_coordinated(prob).candidate
    start = schedules_plan(prob, cand.alloc, cand.schedules, PlannerKind.OPTIMAL, {})
    mk, margin0 = start.metrics["makespan"], verify(prob, start).margin
    held = WidenOptions(h_bounds=(1.0, 1.0))
    settled = widen(prob, cand.alloc, cand.schedules, mk, held).info["rounds"]
    assert [r["status"] for r in settled] == ["optimal"] and settled[0]["iterations"] > 4
    res = widen(prob, cand.alloc, cand.schedules, mk, WidenOptions(h_bounds=(1.0, 1.0), iterations=settled[0]["iterations"] - 2))
    assert [r["status"] for r in res.info["rounds"]] == ["limit_reached"]
    assert res.plan is not None and res.info["status"] == "solved"
    ver = verify(prob, res.plan)
    assert ver.passed, [v.kind.value for v in ver.violations]
    assert res.plan.metrics["makespan"] <= mk + 1e-9 and res.plan.metrics["harvested"] == start.metrics["harvested"]
    assert ver.margin >= margin0 - 1e-6


def test_where_free_timing_does_not_settle_the_held_timing_program_gives_the_plan_and_runs_once():
    """A three-arm layout of the widening benchmark (overlap-3x9-s29, proven optimal), widened
    from the plan's own schedules: the free-timing program does not settle within its half of
    the iterations, and the same call solves the program with every knot time held, which
    settles. That plan is verified and kept -- the makespan and its proof held, the margin at
    least doubled or at least 50 mm (36.8 -> 67.5 mm on the benchmark machine) -- and the
    stage does not solve the held program a second time (``retry``): it would start from the
    same point and take the same steps."""
    prob = parse_problem(to_yaml(overlap_problem(n_arms=3, n_fruits=9, spacing=1.4, seed=129)), "overlap-3x9-s29")
    res = plan_optimal(prob, options=OptimalOptions(widen_ease=False))  # (from the eased start the first program settles)
    w = res.plan.solver["widen"]
    assert [r["timing"] for r in w["rounds"]][:2] == ["free", "held"] and w["rounds"][0]["status"] == "limit_reached"
    assert "retry" not in w and w["status"] == "solved" and w["iterations"] <= OptimalOptions().widen_iterations
    assert w["accepted"] and w["verified"] and res.verification.passed
    assert res.plan.metrics["makespan"] <= w["makespan_before"] + 1e-9 and res.plan.metrics["optimality"] == "proven"
    assert w["margin"] >= min(2 * w["margin_before"], 0.05), (w["margin_before"], w["margin"])


def test_a_plan_with_room_already_is_smoothed_unless_proven_optimal():
    """A plan that keeps ``widen_goal`` of margin already is only smoothed: its certified margin
    no smaller, its makespan held, its jerk lower -- verified. The search's proven-optimal plans
    are left as they are (their solve is short; a program would be most of it), and say why."""
    import time

    from coplan.planners.optimal.incumbent import Incumbent
    from coplan.planners.optimal.judged import widened

    # (a two-arm cell with 107 mm of margin: the stage widened greenhouse_row the same way in 30 s,
    # this one in 3 s)
    prob = parse_problem(to_yaml(overlap_problem(n_arms=2, n_fruits=4, spacing=1.5, seed=9)), "overlap-2x4-s9")
    c = plan_coordinated(prob)
    inc = Incumbent(prob, time.perf_counter(), lambda m: None)
    assert inc.offer(c.plan, verify(prob, c.plan), "coordinated", c.candidate)
    before = inc.plan
    opts = OptimalOptions()
    margin0 = before.verification["margin"]
    assert margin0 >= opts.widen_goal  # (the case under test: room already)
    rep = widened(prob, inc, opts, None, lambda m: None, proven=True)
    assert rep["status"] == "skipped" and not rep["accepted"] and "proven optimal" in rep["reason"]
    assert inc.plan is before
    rep = widened(prob, inc, opts, None, lambda m: None)
    assert rep["accepted"], rep.get("reason")
    assert rep["rms_jerk_before"] == pytest.approx({n: v["rms_jerk"] for n, v in before.metrics["per_arm"].items()})
    ver = verify(prob, inc.plan)
    assert ver.passed and ver.margin >= margin0 - 1e-6
    assert inc.plan.metrics["makespan"] <= before.metrics["makespan"] + 1e-9
    jerk = lambda p: np.mean([v["rms_jerk"] for v in p.metrics["per_arm"].values()])  # noqa: E731
    assert jerk(inc.plan) < 0.98 * jerk(before)
    # every knot time held is the program free timing falls back on within the first call:
    # the stage does not solve it again (``retry``)
    assert "held" in [r["timing"] for r in rep["rounds"]] and "retry" not in rep


def test_a_program_left_short_of_the_goal_is_solved_again_held_more_loosely():
    """overlap-2x6-s22 (the benchmark's layout 22): the programs held close to the start's poses
    (free_track 3, track 10) settle short of the room that doubles its certified 18.7 mm (free
    timing 35.97 mm, the held-timing retry 35.59 mm certified); once more with every knot time held
    and a lighter hold (``loose``): more room than the retry's, kept -- at the same makespan,
    verified by the independent verifier."""
    seed = 22
    d = overlap_problem(n_arms=2, n_fruits=6, spacing=round(1.3 + 0.3 * ((seed * 7) % 10) / 9, 3), seed=100 + seed,
                        name="overlap-2x6-s22")
    prob = parse_problem(to_yaml(d), d["name"])
    res = plan_optimal(prob, options=OptimalOptions(regroup=False))  # (the widening alone: regroup's is test_regroup)
    wid = res.plan.solver["widen"]
    assert wid["accepted"] and wid["retry"]["verified"] and wid["loose"]["verified"]
    assert wid["retry"]["margin"] < 2 * wid["margin_before"]  # (the case under test: short of the goal)
    assert wid["loose"]["margin"] > wid["retry"]["margin"]
    ver = verify(prob, res.plan)
    assert ver.passed and ver.margin == pytest.approx(wid["loose"]["margin"], abs=1e-6)
    assert ver.margin > 1.9 * wid["margin_before"]
    assert res.plan.metrics["makespan"] <= wid["makespan_before"] + 1e-9


def test_the_free_timing_program_holds_the_start_more_lightly_than_the_held_timing_one(monkeypatch):
    """``WidenOptions.free_track`` weighs the hold on the start's poses when the knot times are
    free (a pose held at a knot also holds that knot's time), ``track`` when they are held."""
    import coplan.planners.optimal.widen as W

    seen = []
    real = W.build_nlp

    def spy(*args, **kw):
        seen.append((kw["h_bounds"], kw["track"]))
        return real(*args, **kw)

    monkeypatch.setattr(W, "build_nlp", spy)
    prob = _shipped("crossing_paths")
    cand = plan_coordinated(prob).candidate
    mk = max(s.last_place for s in cand.schedules.values())
    opts = WidenOptions(track=10.0, free_track=3.0, iterations=40)
    W.widen(prob, cand.alloc, cand.schedules, mk, opts)
    W.widen(prob, cand.alloc, cand.schedules, mk, WidenOptions(track=10.0, free_track=3.0, iterations=40, h_bounds=(1.0, 1.0)))
    free = {tr for hb, tr in seen if hb[0] < hb[1]}
    held = {tr for hb, tr in seen if hb[0] >= hb[1]}
    assert free == {3.0} and held == {10.0}, seen


def test_ctrl_c_inside_the_widening_program_stops_the_planner(monkeypatch):
    """(IPOPT's own Ctrl-C handler stopped the widening program only: a row of optimal cells went
    on planning to a 'success'.) A widening round stopped by Ctrl-C marks the run interrupted."""
    from coplan.planners.optimal.nlp_data import any_interrupted

    assert any_interrupted({"rounds": [{"status": "optimal"}], "retry": {"rounds": [{"status": "interrupted"}]}})
    assert not any_interrupted({"rounds": [{"status": "optimal"}], "status": "solved"})


def test_ctrl_c_inside_the_first_widening_program_starts_no_second_one(monkeypatch):
    """(A trial: Ctrl-C stopped the free-timing program, and the stage then solved the held-timing
    one to the end before the planner stopped.) An interrupted round ends the stage's programs."""
    import coplan.planners.optimal.widen as W
    from coplan.planners.optimal.nlp_data import SolverStatus

    real, calls = W.solve_nlp, []

    def stopped(nlp, names, time_limit=None):
        sol = real(nlp, names, time_limit=time_limit)
        calls.append(sol.status)
        sol.status = SolverStatus.INTERRUPTED
        return sol

    monkeypatch.setattr(W, "solve_nlp", stopped)
    prob = _shipped("crossing_paths")
    cand = plan_coordinated(prob).candidate
    mk = max(s.last_place for s in cand.schedules.values())
    res = W.widen(prob, cand.alloc, cand.schedules, mk, WidenOptions(iterations=40))
    assert len(calls) == 1 and res.plan is None
    from coplan.planners.optimal.nlp_data import any_interrupted

    assert res.info["reason"] == "interrupted (Ctrl-C)" and any_interrupted(res.info)


def test_a_plan_past_the_knot_limit_is_left_at_once_with_no_retry():
    """(A 60-fruit cell's 2027-knot plan was eased first, then refused for its knots, then eased and
    refused again by the 'uneased' and 'loose' retries: 8 s of its solve, reported as 0 s.)"""
    import coplan
    from coplan.generate import row_problem
    from coplan.optimal import OptimalOptions

    res = coplan.solve(row_problem(5, 60, seed=11, reachable_only=True), options=OptimalOptions(search_work=2000))
    w = res.plan.solver["widen"]
    assert w["accepted"] is False and w["reason"].startswith("the plan needs") and "widen_knots is 600" in w["reason"]
    assert "uneased" not in w and "loose" not in w and "retry" not in w and "ease" not in w
    assert 0.0 < w["wall_seconds"] == pytest.approx(res.plan.solver["timings"]["widen"], abs=0.05)


def test_an_eased_plan_past_the_knot_limit_is_tried_from_the_plan_s_own_schedules():
    """(The stage returned at once when the eased schedules' grid passed widen_knots, though the
    plan's own may fit: easing moves event starts -- crossing_paths' plan 220 knots, eased 222.)"""
    prob = _shipped("crossing_paths")  # (its coordinated plan: the incumbent with no search, retime or refinement)
    res = plan_optimal(prob, options=OptimalOptions(widen_knots=221, search_work=0, retime=False, refine_retimes=0))
    w = res.plan.solver["widen"]
    assert w.get("too_long") and w["knots_uneased"] <= 221 < w["knots"]
    assert "uneased" in w and "retry" not in w and "loose" not in w  # (only the retry that can fit)
    assert w["uneased"]["status"] == "solved" and w["accepted"] and res.verification.passed


def test_a_clock_limit_that_stops_the_program_is_reported_as_the_time_limit_not_as_ipopt_failing():
    """``coplan solve crossing_paths --time-limit 24`` said "not widened: IPOPT did not converge"
    where the clock had stopped the program before its first iteration (a new user's trial):
    the report says the time limit, with the iterations IPOPT made; the summary prints it."""
    import io
    import time

    from rich.console import Console

    from coplan.cli.summary import print_summary
    from coplan.pipeline import SolveResult

    prob = _shipped("crossing_paths")
    c = plan_coordinated(prob)
    cand = c.candidate
    mk = max(s.last_place for s in cand.schedules.values())
    said: list[str] = []
    res = widen(prob, cand.alloc, cand.schedules, mk, WidenOptions(), deadline=time.perf_counter(), say=said.append)
    assert res.plan is None and res.info["status"] == "time_limit" and res.info["iterations"] == 0
    assert not any("solving again" in m for m in said), said  # (a retry was announced, then stopped for the limit)
    assert res.info["reason"] == "the time limit came during the widening stage (IPOPT stopped after 0 iterations)"
    plan = c.plan
    plan.solver["widen"] = dict(res.info, accepted=False)
    buf = io.StringIO()
    print_summary(Console(file=buf, width=200), SolveResult(problem=prob, plan=plan, verification=c.verification))
    assert "not widened       the time limit came during the widening stage" in buf.getvalue()


def test_a_ctrl_c_inside_the_widening_stage_is_recorded_in_the_plan():
    """(A Ctrl-C between its rounds left ``solver.widen`` null, no stage entry and no time: "never
    reached" could not be told from "cut off"; the summary said nothing of it.)"""
    import os
    import signal

    import coplan
    from coplan.optimal import OptimalOptions

    def progress(msg):
        if str(msg).startswith("widen round 1"):
            os.kill(os.getpid(), signal.SIGINT)

    res = coplan.solve("crossing_paths", options=OptimalOptions(search_work=0, refine_fruit=0, regroup=False),
                       progress=progress)
    s = res.plan.solver
    assert res.status.value == "interrupted" and res.verification.passed
    assert s["stages"][-1]["stage"] == "widen" and s["stages"][-1]["result"] == "interrupted"
    w = s["widen"]
    assert w["status"] == "interrupted" and not w["accepted"] and w["reason"].startswith("interrupted (Ctrl-C)")
    assert w["margin_before"] == pytest.approx(res.plan.metrics["margin"]) and s["timings"]["widen"] > 0


def test_a_widening_cap_past_a_metre_or_no_iterations_is_refused():
    """(A cap of 1e6 m was taken: 1,756 separation points, a 55 s solve and less room than the
    default cap gave; widen_iterations 0 was taken and reported as "IPOPT did not converge".)"""
    with pytest.raises(OptionsError) as ei:
        parse_options("# room\nwiden_cap: 1.0e6\n", "o.yaml")
    (it,) = ei.value.issues
    assert it.path == "widen_cap" and it.line == 2 and it.message.startswith("expected at most 1 m") and it.message.endswith("found 1e+06")
    assert parse_options("widen_cap: 1.0\n").widen_cap == 1.0
    with pytest.raises(OptionsError, match="widen_iterations: expected a positive integer"):
        parse_options("widen_iterations: 0\n")


def test_a_plan_that_harvests_nothing_is_not_widened_and_raises_nothing():
    """(From a user's trial: the optimal planner on a cell whose fruit no arm can place stopped
    with "internal error (ValueError: zero-size array to reduction operation minimum ...)" -- the
    widening measured the clearance of a plan with no samples -- instead of its reasons.)"""
    from dataclasses import replace

    from coplan.allocate import allocate
    from coplan.planners.coordinated.schedule import decoupled_schedules

    p = load_problem("crossing_paths")
    alloc = allocate(p)
    idle = replace(alloc, assignment={a: () for a in alloc.assignment})
    res = widen(p, idle, decoupled_schedules(p, idle), 0.0)
    assert res.plan is None and res.info["reason"] == "the plan harvests nothing: nothing to widen"
