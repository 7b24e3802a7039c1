"""Pick on the move (issue 29): the carriage's cruise, pick windows, tracking, booking, the
speed search, the verifier's row-frame pick check and the CLI.

Reference values are analytic (the constant cruise is the time-optimal rest-to-rest move;
tracking derivatives against finite differences); every plan is cross-checked by the
independent verifier and by direct geometry (the tip over the fruit in row coordinates while
the carriage moves)."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.errors import OptionsError
from coplan.generate import gantry_row, to_yaml
from coplan.kinematics import arm as kin
from coplan.kinematics.timing import Move1D
from coplan.kinds import AssignRule, GantryMode, SpeedProfile
from coplan.pipeline import solve
from coplan.plan import DEFAULT_RATE, EventKind, load_plan
from coplan.problem import parse_problem
from coplan.row.assign import build_order_model, cpsat_order
from coplan.row.booking import Booker
from coplan.row.policy import run_policy
from coplan.row.branches import branch_table, screen_branches
from coplan.row.continuous import MovingOptions, make_cruise, plan_continuous, reorder_continuous
from coplan.row.moving import speed_search
from coplan.row.cruise import Cruise, EndRest, cruise_end, demand_stretches, last_place_bound, pick_windows
from coplan.row.reach import row_reach
from coplan.row.track import track, track_state
from coplan.verify import verify
from coplan.problem.gantry import REACH_STEP
from coplan.verify.row import row_reachable_ids
from coplan.verify.verdict import ViolationKind


def _row(length=10.0, density=3.0, seed=7, **kw):
    return parse_problem(to_yaml(gantry_row(length=length, density=density, seed=seed, **kw)))


@pytest.fixture(scope="module")
def row():
    return _row()


@pytest.fixture(scope="module")
def reach(row):
    return row_reach(row)


@pytest.fixture(scope="module")
def moving(row, reach):
    """One plan on the move at a constant 0.1 m/s (slow enough to harvest everything)."""
    return plan_continuous(row, 0.1, MovingOptions(profile=SpeedProfile.CONSTANT, assign=AssignRule.GREEDY), reach)


# ---------------------------------------------------------------------------- the carriage
def test_a_constant_cruise_is_the_time_optimal_rest_to_rest_move(row):
    g = row.gantry
    c = Cruise.of(row, 0.3, 8.0)
    ref = Move1D.between(g.start, 8.0, 0.3, g.max_acceleration, g.max_jerk)
    t = np.linspace(-1.0, ref.duration + 1.0, 4001)
    for a, b in zip(c.state(t), ref.state(t)):
        assert np.allclose(a, b, atol=1e-9)
    assert c.duration == pytest.approx(ref.duration, abs=1e-9)


def test_a_shaped_cruise_keeps_the_gantry_limits_and_ends_at_rest():
    p = _row(length=20.0)
    g = p.gantry
    rng = np.random.default_rng(3)
    edges = np.cumsum(rng.uniform(0.5, 3.0, 8))
    stretches = [(float(x), float(v)) for x, v in zip(edges, rng.uniform(0.02, g.max_velocity, 8))]
    c = Cruise.shaped(p, stretches, 18.0)
    dt = 1e-3
    t = np.arange(0.0, c.duration + 0.5, dt)
    x, v, a = c.state(t)
    assert x[0] == g.start and x[-1] == pytest.approx(18.0, abs=1e-9) and v[-1] == 0.0
    assert np.all(np.diff(x) >= -1e-12)  # never backwards
    assert v.max() <= g.max_velocity + 1e-9
    assert np.abs(a).max() <= g.max_acceleration + 1e-9
    assert np.abs(np.diff(a) / dt).max() <= g.max_jerk * (1 + 1e-6)
    # velocity is the derivative of position, acceleration of velocity
    assert np.abs(np.diff(x) / dt - 0.5 * (v[1:] + v[:-1])).max() < 1e-5
    xs = rng.uniform(g.start, 18.0, 50)
    assert np.abs(c.x(c.time_at(xs)) - xs).max() < 1e-4


def test_the_density_profile_runs_each_metre_at_its_fruit_s_pace(row, reach):
    from coplan.row.continuous import MIN_SPEED

    x1 = cruise_end(row, reach)
    demand = demand_stretches(row, reach, x1)
    level, n = 0.5, len(row.arms)
    c = make_cruise(row, reach, SpeedProfile.DENSITY, level, demand)
    vmax = row.gantry.max_velocity
    checked = 0
    for x_end, d in demand[1:-2]:  # away from the start and the stop
        want = vmax if d <= 0 else min(vmax, max(MIN_SPEED, level * n / d))
        v = float(c.state(c.time_at(x_end - 0.5))[1][0])  # mid-stretch: any ramp into it is over
        assert v == pytest.approx(want, rel=1e-6, abs=1e-9)
        checked += 1
    assert checked >= 3
    assert len({round(v, 6) for v in (min(vmax, level * n / d) for _, d in demand if d > 0)}) > 1  # it does vary


# ---------------------------------------------------------------------------- windows and tracking
def test_every_pick_window_keeps_the_carriage_in_a_serving_run(row, reach):
    c = Cruise.of(row, 0.2, cruise_end(row, reach))
    dwell = row.task.pick_dwell
    wins = pick_windows(row, reach, c, dwell)
    rng = np.random.default_rng(0)
    n = 0
    for fid, ws in wins.items():
        for w in ws:
            hi = w.hi if math.isfinite(w.hi) else w.lo + 5.0
            for t in rng.uniform(w.lo, hi, 3):
                x0, x1 = c.x(np.array([t, t + dwell]))
                assert w.c_lo - 1e-6 <= x0 <= x1 <= w.c_hi + 1e-6
                assert reach.cover[fid][w.arm][np.searchsorted(reach.grid, w.c_lo)]
                n += 1
    assert n > 0


def test_tracking_holds_the_tip_over_the_fruit_in_row_coordinates(row, reach):
    c = Cruise.of(row, 0.25, cruise_end(row, reach))
    arm = row.arms[1]
    fid, ws = next((f, ws) for f, ws in pick_windows(row, reach, c, row.task.pick_dwell).items()
                   if any(w.arm == 1 and math.isfinite(w.hi) for w in ws))
    w = next(w for w in ws if w.arm == 1)
    xy = next(f.position for f in row.fruits if f.id == fid)
    t = np.linspace(w.lo, w.lo + row.task.pick_dwell, 31)
    for b in (0, 1):
        q = track(arm, xy, c, t, b)
        if not np.all(np.isfinite(q)):
            continue
        _, tip = kin.fk(q, arm.links, arm.base)
        row_tip = tip + np.c_[c.x(t), np.zeros(t.size)]
        assert np.abs(row_tip - np.asarray(xy)).max() < 1e-9
        # the state's velocity and acceleration are the track's derivatives (central differences)
        tm, h = float(t[10]), 1e-4
        s = track_state(arm, xy, c, tm, b)
        qm, q0, qp = track(arm, xy, c, np.array([tm - h, tm, tm + h]), b)
        assert np.allclose(s[0], q0, atol=1e-12)
        assert np.allclose(s[1], (qp - qm) / (2 * h), atol=1e-6)
        assert np.allclose(s[2], (qp - 2 * q0 + qm) / h ** 2, atol=1e-3)


# ---------------------------------------------------------------------------- plans
def test_a_plan_on_the_move_is_verified_and_picks_while_the_carriage_moves(row, moving):
    res = moving
    assert res.verification.passed, [v.message for v in res.verification.violations[:5]]
    assert not res.verification.unharvested
    plan = res.plan
    assert plan.status.value == "success"
    # an independent run of the verifier on the same plan agrees
    assert verify(row, plan).passed
    x = np.asarray(plan.gantry_x)
    dt = plan.dt
    fruit = {f.id: np.asarray(f.position) for f in row.fruits}
    arms = {a.name: a for a in row.arms}
    moving_picks = 0
    picks = [e for e in plan.events if e.kind == EventKind.PICK]
    for e in picks:
        k = np.arange(int(round(e.t_start / dt)), int(round(e.t_end / dt)) + 1)
        a = arms[e.arm]
        _, tip = kin.fk(plan.q[e.arm][k], a.links, a.base)
        assert np.abs(tip + np.c_[x[k], np.zeros(k.size)] - fruit[e.fruit]).max() < 1e-6
        if abs(x[k[-1]] - x[k[0]]) > 0.5 * 0.1 * (e.t_end - e.t_start):
            moving_picks += 1
    assert picks and moving_picks >= 0.8 * len(picks)  # the carriage never stopped for them
    assert res.info["mode"] == "continuous" and res.stops == []


def test_a_pick_the_arm_does_not_carry_along_is_refused(row, moving):
    plan = moving.plan
    e = next(e for e in plan.events if e.kind == EventKind.PICK and e.t_start > 2.0)
    k0, k1 = int(round(e.t_start / plan.dt)), int(round(e.t_end / plan.dt))
    q = {n: v.copy() for n, v in plan.q.items()}
    q[e.arm][k0:k1 + 1] = q[e.arm][k0]  # the joints freeze: the carriage carries the tip off the fruit
    bad = type(plan)(**{**plan.__dict__, "q": q})
    ver = verify(row, bad)
    assert any(v.kind in (ViolationKind.PICK_DWELL, ViolationKind.PICK_MISSED) and v.fruit == e.fruit for v in ver.violations)


def test_too_fast_a_carriage_leaves_fruit_out_with_the_reason(row, reach):
    res = plan_continuous(row, row.gantry.max_velocity, MovingOptions(profile=SpeedProfile.CONSTANT,
                                                                       assign=AssignRule.GREEDY), reach)
    assert res.verification.passed  # what it does harvest is still safe
    missed = [f for f in reach.harvestable() if f in res.info["left_out"]]
    assert missed, "at the gantry's top speed every fruit was harvested: the test row is too sparse"
    assert all("reach" in res.info["left_out"][f] for f in missed)
    assert any("passed" in res.info["left_out"][f] and " at t = " in res.info["left_out"][f] for f in missed)


def test_the_same_input_gives_the_same_plan(row, reach, moving):
    again = plan_continuous(row, 0.1, MovingOptions(profile=SpeedProfile.CONSTANT, assign=AssignRule.GREEDY), reach)
    assert [(e.arm, e.fruit, e.t_start) for e in again.plan.events] == [(e.arm, e.fruit, e.t_start) for e in moving.plan.events]
    for n in again.plan.q:
        assert np.array_equal(again.plan.q[n], moving.plan.q[n])


@pytest.mark.parametrize("profile, level", [(SpeedProfile.CONSTANT, 0.05), (SpeedProfile.CONSTANT, 0.2), (SpeedProfile.DENSITY, 0.4),
                                            (SpeedProfile.DENSITY, 0.9)])
def test_no_plan_places_its_last_fruit_before_the_cruise_bound(row, reach, profile, level):
    """The bound the speed search's refinement stops on: every pick starts after the carriage
    passed the grid position before the fruit's first serving one, so the last place ends no
    sooner than ``last_place_bound`` on a complete plan (and each pick no sooner than its own;
    at 0.05 m/s the bound is within 2 % of the plan)."""
    x1 = cruise_end(row, reach)
    demand = demand_stretches(row, reach, x1) if profile == SpeedProfile.DENSITY else None
    res = plan_continuous(row, level, MovingOptions(profile=profile, assign=AssignRule.GREEDY), reach, demand=demand)
    cruise = make_cruise(row, reach, profile, level, demand)
    bound = last_place_bound(row, reach, cruise)
    assert bound > row.task.pick_dwell + row.task.place_dwell
    for e in res.plan.events:
        if e.kind == EventKind.PICK:
            k = max(reach.span(e.fruit)[0] - 1, 0)
            assert e.t_start >= float(cruise.time_at(float(reach.grid[k]))[0]) - 1e-6
    complete = res.plan.metrics["harvested"] == len(reach.cover)
    if profile == SpeedProfile.CONSTANT and level <= 0.05:
        assert complete  # (so slow a cruise leaves no fruit: the bound below is always exercised)
    if complete:  # (the bound speaks of plans that place every fruit)
        assert res.plan.metrics["makespan"] >= bound - 1e-6


def test_the_speed_search_keeps_the_best_complete_verified_plan(row, reach):
    best, curve = speed_search(row, MovingOptions(search_rounds=5, refine_rounds=2), reach)
    assert curve and all(p.verified for p in curve)
    complete = [p for p in curve if p.complete]
    assert complete, "no speed harvested every fruit"
    m = best.plan.metrics
    assert m["harvested"] == len(reach.cover) and best.verification.passed
    fph = m["harvested"] * 3600.0 / m["makespan"]
    assert fph >= max(p.fruit_per_hour for p in complete) - 1e-6
    # a faster carriage never came back with every fruit and more per hour
    assert all(not (p.complete and p.fruit_per_hour > fph + 1e-6) for p in curve)
    # the refinement (asked for: off by default) slows only where the slowest incomplete level
    # missed fruit: each round's plan is no faster than that level's on average
    refined = [p for p in curve if p.refined]
    slowest_bad = min(p.level for p in curve if not p.complete and not p.refined)
    assert refined and all(p.mean_speed <= next(q.mean_speed for q in curve if q.level == slowest_bad and not q.refined) + 1e-9
                           for p in refined[:1])
    plain = speed_search(row, MovingOptions(search_rounds=5), reach)[1]
    assert not any(p.refined for p in plain) and len(plain) == len(curve) - len(refined)
    # every candidate's verdict came from a screening verification (margins coarse); the plan
    # kept is verified in full: its report is the one a fresh verification gives
    again = verify(row, best.plan)
    assert best.verification.options.margin_rel == 0.0
    assert best.plan.verification["certified_clearance"] == again.certified_clearance
    assert [p.certified for p in best.verification.pairs] == [p.certified for p in again.pairs]


def test_a_screened_verification_gives_the_full_verdict_at_a_fraction_of_the_samples():
    """(A 6 m row of two fruit spent 17 s planning on the move, 16 of them certifying, to half a
    micrometre, the 1.65 m between two arms whose nearest points were a base and an elbow while
    the base's arm swept at 4 m/s: some 1.7 million samples a candidate.) The screening
    verification of every candidate gives the same verdict; its certified distances are bounds
    (below the least the full one sampled), within half each pair's margin of its own least."""
    prob = _row(length=6, n_arms=3, density=0.5, seed=0)
    plan = plan_continuous(prob, 0.3, MovingOptions()).plan
    full, quick = verify(prob, plan), verify(prob, plan, margin_rel=1.0)
    assert full.passed and quick.passed and len(full.pairs) == len(quick.pairs) == 2
    c = prob.task.clearance
    for f, q in zip(full.pairs, quick.pairs):
        assert f.min_clearance <= q.min_clearance + 1e-12  # (the full one sampled more)
        assert q.min_clearance - (q.min_clearance - c) / 2 - 1e-12 <= q.certified <= f.min_clearance
    assert sum(q.samples for q in quick.pairs) * 20 < sum(f.samples for f in full.pairs)
    # the same verdict where the clearance asked is just below the least distance (certified only
    # by refining) and just above it (a violation)
    least = min(p.min_clearance for p in full.pairs)
    for clear in (least - 1e-4, least + 1e-4):
        data = gantry_row(length=6, n_arms=3, density=0.5, seed=0)
        data["task"]["clearance"] = round(clear, 6)
        other = parse_problem(to_yaml(data))
        a, b = verify(other, plan), verify(other, plan, margin_rel=1.0)
        assert a.passed == b.passed == (clear < least)
        assert [v.kind for v in a.violations] == [v.kind for v in b.violations]
    with pytest.raises(OptionsError, match="margin_rel"):
        verify(prob, plan, margin_rel=1.5)


def test_cpsat_order_is_kept_only_when_it_does_better(row, reach):
    greedy = plan_continuous(row, 0.45, MovingOptions(profile=SpeedProfile.CONSTANT, assign=AssignRule.GREEDY), reach)
    both = plan_continuous(row, 0.45, MovingOptions(profile=SpeedProfile.CONSTANT, assign=AssignRule.CPSAT), reach)
    assert both.verification.passed
    g, b = greedy.plan.metrics, both.plan.metrics
    assert (b["harvested"], -b["makespan"]) >= (g["harvested"], -g["makespan"])
    assert greedy.info["left_out"].keys() - set(reach.reasons), "the greedy harvested everything: CP-SAT never ran"
    assert both.info["cpsat"]["status"] in ("OPTIMAL", "FEASIBLE") and both.info["cpsat"]["intervals"] > 0
    assert both.info["assign"] in (AssignRule.GREEDY.value, AssignRule.CPSAT.value)


def test_the_search_s_cpsat_step_from_the_greedy_s_booking_is_cpsat_s_plan(row, reach):
    """The speed search's CP-SAT step starts from the booking its greedy candidate already made
    (:func:`reorder_continuous`): the same model, hint and order as planning the level again with
    ``assign=cpsat``, so the same plan when CP-SAT's is kept, and none when the greedy's stands."""
    opts = MovingOptions(profile=SpeedProfile.CONSTANT)
    greedy = plan_continuous(row, 0.45, replace(opts, assign=AssignRule.GREEDY), reach)
    both = plan_continuous(row, 0.45, replace(opts, assign=AssignRule.CPSAT), reach)
    res, report = reorder_continuous(row, 0.45, opts, reach, None, greedy.plan.events)
    assert report["status"] in ("OPTIMAL", "FEASIBLE") and report["intervals"] == both.info["cpsat"]["intervals"]
    assert report["kept"] == (both.info["assign"] == AssignRule.CPSAT.value) == (res is not None)
    if res is not None:
        assert res.verification.passed
        assert [(e.arm, e.fruit, e.t_start) for e in res.plan.events] == [(e.arm, e.fruit, e.t_start) for e in both.plan.events]


@pytest.mark.parametrize("dwells", [None, (0.1, 0.2)])
def test_cpsat_starts_from_a_feasible_hint_so_it_never_orders_fewer_fruit_than_the_greedy(row, dwells):
    """Each cycle the greedy booked is priced no longer than it took (moves and dwells as the
    booker holds them, in the window it was picked in), so the greedy's bookings are a feasible
    start: CP-SAT with every variable fixed to the hint finds it feasible, and CP-SAT's order
    (before the geometry books it) holds at least as many fruit -- on three speeds, also with
    dwells whose sum is not a whole number of model units in floating point (0.1 + 0.2)."""
    from ortools.sat.python import cp_model

    if dwells is not None:
        row = replace(row, task=replace(row.task, pick_dwell=dwells[0], place_dwell=dwells[1]))
    reach = row_reach(row)
    for level in (0.3, 0.4, 0.5):
        cruise = make_cruise(row, reach, SpeedProfile.CONSTANT, level)
        booker = Booker(row, cruise, pick_windows(row, reach, cruise, row.task.pick_dwell), DEFAULT_RATE, 0.02, reach.resolution)
        run_policy(booker)
        booked = sum(1 for e in booker.events if e.kind == EventKind.PICK)
        model, items, _ = build_order_model(row, booker, cruise)
        assert sum(t is not None for *_, t in items) == booked  # every booking hinted, once
        solver = cp_model.CpSolver()
        solver.parameters.fix_variables_to_their_hinted_value = True
        solver.parameters.num_workers = 1
        assert solver.Solve(model) in (cp_model.OPTIMAL, cp_model.FEASIBLE), (level, "the hint is infeasible")
        order, report = cpsat_order(row, booker, reach, cruise)
        assert order is not None and report["fruit"] >= booked, (level, report, booked)


def test_plain_float_carriage_states_and_shared_branch_screens_change_nothing(row, reach):
    """The booking's fast paths give the slow paths' bits: :meth:`Cruise.state_one` against
    :meth:`Cruise.state` (2,000 seeded times, before the start and past the end included), and
    the elbow branches screened for every fruit at once against one fruit at a time."""
    cruise = make_cruise(row, reach, SpeedProfile.DENSITY, 0.8)
    ts = np.r_[np.random.default_rng(3).uniform(-1.0, cruise.duration + 1.0, 2000), 0.0, cruise.duration]
    x, v, a = cruise.state(ts)
    assert all((x[k], v[k], a[k]) == cruise.state_one(t) for k, t in enumerate(ts))
    pairs = [(i, f) for f in reach.harvestable() for i in np.flatnonzero(reach.cover[f].any(axis=1)).tolist()]
    batched = screen_branches(row, reach.resolution, pairs, {})
    alone: dict = {}
    for p in pairs:
        screen_branches(row, reach.resolution, [p], alone)
    assert set(batched) == set(alone) == set(pairs)
    assert all(batched[p][0] == alone[p][0] and np.array_equal(batched[p][1], alone[p][1]) for p in pairs)
    # and a booking given the shared table answers as one with its own
    shared = Booker(row, cruise, {}, DEFAULT_RATE, 0.02, reach.resolution, branch_table(row, reach.resolution))
    own = Booker(row, cruise, {}, DEFAULT_RATE, 0.02, reach.resolution)
    for i, f in pairs[::7]:
        lo, hi = (float(reach.grid[k]) for k in reach.span(f))
        for c0 in np.linspace(lo, hi, 5):
            assert shared.branches(i, f, c0, min(hi, c0 + 0.1)) == own.branches(i, f, c0, min(hi, c0 + 0.1))


class _WholeCycles(Booker):
    """The booking as it was first written, for reference: every try's cycle built whole and
    checked whole, and a move home tried one start at a time."""

    refused = 0
    waited = 0

    def plan_cycle(self, i, fid, w, t_from, tuck=False):
        k0 = self.arms[i].k_free
        q0 = self.arms[i].q[k0].copy()
        for side in ((1, -1) if tuck else (0,)):
            for k_p, b, leg in self._tries(i, fid, w, k0, q0, max(k0, self.up(t_from)), side):
                cyc = self._assemble(i, fid, k0, q0, k_p, b, leg, self.bin_q[i], None, side)
                if cyc is not None and self._clear(i, k0, cyc.q):
                    return cyc
                self.refused += 1
        return None

    def _go(self, i, target, not_before):
        from coplan.row.booking import RETRY, Cycle
        from coplan.row.track import Leg

        st = self.arms[i]
        q0, k0 = st.q[st.k_free].copy(), st.k_free
        leg = Leg(self.problem.arms[i], np.array([q0, np.zeros(2), np.zeros(2)]), np.array([target, np.zeros(2), np.zeros(2)]),
                  self.leg_share)
        k_s, n = max(k0, self.up(not_before)), self.up(leg.duration)
        reach = max([k0 + 1] + [self.arms[j].k_free + 1 for j in self.neighbours[i]])
        resting = {}
        for _ in range(int(60.0 / RETRY)):
            move = leg.sample(np.arange(k_s, k_s + n + 1) * self.dt - k_s * self.dt)
            q = np.concatenate([np.repeat(q0[None, :], k_s - k0, axis=0), move])
            q[-1] = target
            if self.moves_after_halt(i, k0, q):
                return False
            if self._rest_hit(i, q0, k0, reach, resting, k0, k_s):
                return False
            if (not self._hits(i, k_s, q[k_s - k0:], first=True).any()
                    and not self._rest_hit(i, target, k0, reach, resting, k_s + n + 1, reach)):
                self.commit(Cycle(i, "", k0, q, []))
                return True
            self.waited += 1
            k_s += self.up(RETRY)
        return False


def test_checking_each_try_s_approach_first_and_tries_together_books_what_whole_cycles_book():
    """Arms 1.2 m apart (a neighbour in the way of most tries): the booking, which checks each
    try's approach against the neighbours before it builds the rest of the cycle and checks
    the next tries' approaches (and a move's next starts) together, books the same cycles, bit
    for bit, as the reference that builds and checks every try whole, one at a time -- on a
    row where that reference refuses hundreds of tries (544) and its moves home wait for a
    neighbour (1,200 starts refused)."""
    row = _row(length=6.0, density=3.6, seed=5, spacing=1.2)
    reach = row_reach(row)
    cruise = make_cruise(row, reach, SpeedProfile.CONSTANT, 0.15)
    windows = pick_windows(row, reach, cruise, row.task.pick_dwell)
    fast, slow = (cls(row, cruise, windows, DEFAULT_RATE, 0.02, reach.resolution) for cls in (Booker, _WholeCycles))
    assert run_policy(fast) == run_policy(slow)
    assert slow.refused > 300 and slow.waited > 300, (slow.refused, slow.waited)
    assert [e.to_dict() for e in fast.events] == [e.to_dict() for e in slow.events]
    for a, b in zip(fast.arms, slow.arms):
        assert a.k_free == b.k_free and np.array_equal(a.q[:a.k_free + 1], b.q[:b.k_free + 1])


def test_a_booking_screens_a_fruit_where_its_booker_was_told_it_is(row, reach):
    """Regression (review): a live row's close-range measurement moves a fruit in its booker
    (``fruit_xy``); the elbow branches must be screened there, as for a problem whose fruit is
    at that place, not where the camera first reported it."""
    cruise = make_cruise(row, reach, SpeedProfile.CONSTANT, 0.3)
    f = reach.harvestable()[len(reach.harvestable()) // 2]
    fruit = next(x for x in row.fruits if x.id == f)
    moved = (fruit.position[0] + 0.3, fruit.position[1] - 0.05)
    told = Booker(row, cruise, {}, DEFAULT_RATE, 0.02, reach.resolution)
    told.fruit_xy[f] = moved
    there = replace(row, fruits=tuple(replace(x, position=moved) if x.id == f else x for x in row.fruits))
    truth = Booker(there, cruise, {}, DEFAULT_RATE, 0.02, reach.resolution)
    arms = np.flatnonzero(reach.cover[f].any(axis=1)).tolist()
    cs = np.arange(row.gantry.start, row.gantry.end, 0.05)
    answers = [(told.branches(i, f, c, c), truth.branches(i, f, c, c)) for i in arms for c in cs]
    assert all(a == b for a, b in answers)
    assert any(a for a, _ in answers)  # (somewhere the arm reaches the moved fruit)


def test_the_verifier_s_row_reach_is_the_per_fruit_search(row):
    """:func:`row_reachable_ids` (vectorised, once per problem) against the plain search it
    stands for: some arm, some carriage position on a 1 cm grid, IK inside the limits."""
    g = row.gantry
    cs = np.arange(g.start, g.end + REACH_STEP / 2, REACH_STEP)
    want = [f.id for f in row.fruits
            if any(a.ik(np.c_[f.position[0] - cs, np.full(cs.size, f.position[1])][np.abs(f.position[0] - cs - a.base[0]) <= a.reach],
                        row.task.reach_margin)[1].any() for a in row.arms)]
    assert row_reachable_ids(row) == want and 0 < len(want) <= len(row.fruits)


# ---------------------------------------------------------------------------- the pipeline and the CLI
def test_solve_on_the_move_writes_a_plan_that_verify_accepts(tmp_path, row):
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=10.0, density=3.0, seed=7)))
    res = CliRunner().invoke(app, ["solve", str(path), "--gantry", "continuous", "--speed", "0.1", "-o", str(tmp_path / "out"),
                                   "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["status"] == "success"
    plan = load_plan(tmp_path / "out" / "plan.json")
    assert plan.solver["row"]["mode"] == "continuous" and plan.metrics["row"]["mode"] == "continuous"
    # no stop on the move: no stop's time or planning either (they read 0 s, as if a stop took none)
    r = plan.metrics["row"]
    assert r["stops"] == 0 and r["stop_positions"] == []
    assert r["mean_time_per_stop"] is None and r["slowest_stop_seconds"] is None
    assert verify(row, plan).passed
    res = CliRunner().invoke(app, ["verify", str(path), str(tmp_path / "out" / "plan.json")])
    assert res.exit_code == 0, res.output


@pytest.mark.parametrize("args, words", [
    (["--gantry", "continuous", "--speed", "3"], "--speed: expected a cruising speed in [0.00"),
    (["--gantry", "continuous", "--speed", "3"], ", 0.5] m/s (gantry.max_velocity at most;"),
    (["--gantry", "continuous", "--stops", "fixed"], "--stops: on the move"),
    (["--gantry", "continuous", "--planner", "optimal"], "--planner: on the move"),
    # (it said "--speed: a cruising speed applies on the move (--gantry continuous or auto)", --gantry never given)
    (["--stops", "fixed", "--speed", "0.2"], "--speed and --stops: --speed plans the row on the move"),
    (["--stop-price", "2", "--profile", "constant"], "--profile and --stop-price: --profile plans the row on the move"),
    (["--gantry", "stop-and-go", "--speed", "0.2"], "--speed: a cruising speed applies on the move"),
])
def test_solve_on_the_move_refuses_options_that_do_not_apply(tmp_path, args, words):
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=10.0, density=3.0, seed=7)))
    res = CliRunner().invoke(app, ["solve", str(path), *args, "-o", str(tmp_path / "out")])
    assert res.exit_code == 2, res.output
    assert words in res.output.replace("\n", " ")
    assert "Traceback" not in res.output


def test_a_cell_refuses_the_gantry_mode():
    from coplan.problem import load_problem, shipped_problems

    cell = load_problem(next(p for p in shipped_problems() if "crossing" in str(p)))
    with pytest.raises(ValueError, match="stationary cell"):
        solve(cell, gantry=GantryMode.CONTINUOUS)


# ---------------------------------------------------------------------------- sweeps of rows
GANTRY_SWEEP = """
name: arms
base: gantry
fixed: {length: 8.0, density: 4.0, seed: 3, gantry: continuous}
vary:
  n_arms: [1, 2]
planner: coordinated
"""


def test_a_gantry_sweep_makes_rows_and_solves_them_on_the_move():
    from coplan.sweep.run import solve_item
    from coplan.sweep.spec import parse_sweep

    items = parse_sweep(GANTRY_SWEEP, "arms.yaml").items()
    assert [it.params["n_arms"] for it in items] == [1, 2]
    assert all(it.row_length == 8.0 and "gantry:" in it.problem_text for it in items)
    rows = [solve_item(it)[0] for it in items]
    for r, it in zip(rows, items):
        assert r["status"] == "success" and r["verified"], r["message"]
        assert r["gantry"] == "continuous" and r["share_harvested"] == 1.0
        assert r["fruit_per_hour"] == pytest.approx(3600.0 * r["harvested"] / r["makespan"])
        assert r["mean_speed"] > 0 and r["ratio"] >= 1.0
    # the same row, planned the same way directly
    direct = solve(parse_problem(items[1].problem_text), gantry=GantryMode.CONTINUOUS).plan.metrics
    assert rows[1]["makespan"] == pytest.approx(direct["makespan"])


@pytest.mark.parametrize("text, words", [
    (GANTRY_SWEEP.replace("gantry: continuous", "gantry: rolling"), "fixed.gantry: expected one of stop-and-go, continuous"),
    # (a mis-spelt value got no 'did you mean', where a mis-spelt key did)
    (GANTRY_SWEEP.replace("gantry: continuous", "gantry: continous"), "found string 'continous'; did you mean 'continuous'?"),
    (GANTRY_SWEEP.replace("base: gantry", "base: row"), "fixed.length: expected a parameter of base 'row'"),
    # (stored and not used: two 'designs' alike but in name)
    (GANTRY_SWEEP + "options: {search_work: 500}\n", "options: expected no 'options' with base gantry"),
])
def test_gantry_sweep_file_errors_name_the_key(text, words):
    from coplan.sweep.spec import SweepError, parse_sweep

    with pytest.raises(SweepError) as e:
        parse_sweep(text, "arms.yaml")
    assert words in str(e.value)


# ---------------------------------------------------------------------------- a live row
def test_the_row_camera_reports_fruit_as_they_come_into_view(row):
    from coplan.row.live import LiveRowOptions, row_detections

    opts = LiveRowOptions(speed=0.2, look_ahead=1.5, sigma=0.01, false_rate=0.1, duplicate_rate=0.2, seed=4)
    c = Cruise.of(row, 0.2, row.gantry.end)
    dets = row_detections(row, c, opts)
    truth = {f.id: f.position for f in row.fruits}
    real = [d for d in dets if d.truth is not None]
    assert {d.truth for d in real} == set(truth)  # every fruit reported, some twice
    assert len(real) > len(truth) and sum(d.truth is None for d in dets) == round(0.1 * len(truth))
    err = np.array([np.subtract(d.position, truth[d.truth]) for d in real])
    assert 0.005 < err.std() < 0.015  # the noise asked for
    front = max(a.base[0] for a in row.arms)
    for d in real:  # reported when the fruit comes within the look-ahead of the front arm, not before
        x = truth[d.truth][0]
        assert float(c.x(np.array([d.t]))[0]) + front + 1.5 >= x - 1e-3 or d.t == 0.0
    assert dets == row_detections(row, c, opts)  # seeded


def test_a_live_row_harvests_what_the_offline_plan_harvests_verified_against_the_truth(row):
    from coplan.row.live import LiveRowOptions, run_live_row

    res = run_live_row(row, LiveRowOptions(speed=0.15, seed=2))
    m = res.metrics
    assert res.verification.passed and m["verified"]
    # nothing the offline plan (full knowledge) harvests is left
    ref = {e.fruit for e in res.offline.plan.events if e.kind == EventKind.PLACE}
    got = {e.fruit for e in res.plan.events if e.kind == EventKind.PLACE}
    assert ref <= got and m["of_offline"] == 1.0
    # every event names a true fruit; false reports cost probes, not picks
    assert {e.fruit for e in res.plan.events} <= {f.id for f in row.fruits}
    assert m["probes"] >= m["false_reports"] > 0
    assert m["kept_ahead"] and m["decision_max_seconds"] < m["shortest_cycle_seconds"]
    assert all(v == "harvested" for k, v in res.outcome.items() if k in got)


def test_a_partial_row_on_the_move_says_which_fruit_it_left_and_why(tmp_path, row, reach):
    """A carriage too fast for every fruit: exit 5 (partial), and the summary names each fruit
    left out with its reason, as plan.json does (found by a new-user trial: only the count was
    printed)."""
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=10.0, density=3.0, seed=7)))
    res = CliRunner().invoke(app, ["solve", str(path), "--gantry", "continuous", "--speed", "0.5", "-o", str(tmp_path / "out")])
    assert res.exit_code == 5, res.output
    left = load_plan(tmp_path / "out" / "plan.json").solver["row"]["left_out"]
    missed = [f for f in left if f not in reach.reasons]
    said = " ".join(res.output.split())  # (as printed, whatever the console's width)
    assert missed and "harvestable fruit:" in said
    assert all(" ".join(left[f].split()) in said for f in missed[:5])


def test_coplan_run_on_a_row_writes_a_verified_run(tmp_path):
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=10.0, density=3.0, seed=7)))
    res = CliRunner().invoke(app, ["run", str(path), "--speed", "0.15", "--seed", "1", "-o", str(tmp_path / "live")])
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "live" / "run.json").read_text())
    assert doc["metrics"]["verified"] and doc["metrics"]["of_offline"] == 1.0 and doc["detections"]
    assert verify(parse_problem(path.read_text()), load_plan(tmp_path / "live" / "plan.json")).passed
    # the plan names its row, so the viewer finds it without --problem (found by a new-user trial)
    assert load_plan(tmp_path / "live" / "plan.json").problem_file["path"] == str(path.resolve())
    view = CliRunner().invoke(app, ["view", str(tmp_path / "live" / "plan.json"), "-o", str(tmp_path / "v.html")])
    assert view.exit_code == 0 and (tmp_path / "v.html").stat().st_size > 0, view.output
    bad = CliRunner().invoke(app, ["run", str(path), "-o", str(tmp_path / "x")])
    assert bad.exit_code == 2 and "--speed: a live row on the move needs its cruising speed" in bad.output and "Traceback" not in bad.output


def test_faults_on_a_live_row_degrade_it_safely_and_are_replayable(row):
    from coplan.row.live import LiveRowOptions, RowFaults, run_live_row

    opts = LiveRowOptions(speed=0.15, seed=5, faults=RowFaults(arm_stop=True, camera_dark=3.0, false_burst=20, late_replan=2.0))
    res = run_live_row(row, opts)
    m = res.metrics
    assert res.verification.passed  # no collision, no limit broken, every pick on its true fruit
    f = m["faults"]
    stopped = f["arm_stop"]["arm"]
    # the stopped arm books nothing after the fault: no event of it starts after its stop
    assert all(e.t_start <= f["arm_stop"]["t"] + 10.0 for e in res.plan.events if e.arm == stopped)
    late = [e for e in res.plan.events if e.arm == stopped and e.t_start > f["arm_stop"]["t"]]
    assert len(late) <= 2  # at most the pick and place of the cycle under way
    assert m["false_reports"] >= 20 and m["probes"] >= 20
    assert f["late_replan"]["decided_at"] >= f["late_replan"]["t"]
    again = run_live_row(row, opts)  # replayable from the seed
    assert again.metrics["faults"] == f and [(e.arm, e.fruit, e.t_start) for e in again.plan.events] == \
        [(e.arm, e.fruit, e.t_start) for e in res.plan.events]


def test_gantry_auto_keeps_the_better_verified_mode(row):
    res = solve(row, gantry=GantryMode.AUTO)
    auto = res.plan.solver["row"]["auto"]
    chosen, other = auto["chosen"], ({"stop-and-go", "continuous"} - {auto["chosen"]}).pop()
    assert res.verification.passed and auto[chosen]["verified"]
    assert (auto[chosen]["harvested"], auto[chosen]["fruit_per_hour"]) >= (auto[other]["harvested"], auto[other]["fruit_per_hour"]) \
        or not auto[other]["verified"]
    assert res.plan.metrics["row"]["mode"] == chosen
    m = res.plan.metrics
    assert auto[chosen]["fruit_per_hour"] == pytest.approx(3600.0 * m["harvested"] / m["makespan"])
    # each with how it moved, the stop rule too (the summary named only "stop-and-go" beside a fewest-stops plan)
    assert auto["stop-and-go"]["label"] == "coordinated (stop and go, optimised stops)"
    assert auto["continuous"]["label"] == "coordinated (on the move)"
    from rich.console import Console

    from coplan.cli.summary import print_row_summary

    con = Console(record=True, width=400)
    print_row_summary(con, res)
    said = " ".join(con.export_text().split())
    assert f"{auto[other]['fruit_per_hour']:.0f} {auto[other]['label']} (" in said, said


def test_the_speed_search_gives_the_same_plan_on_one_worker_or_two(row, reach):
    """(With one worker the search tried other levels than with two, one at a time: on course_row
    the default command settled on another speed than the README's ``--workers 2``, and stop and
    go won there instead.) The levels are SEARCH_WIDTH a round whatever the workers."""
    lines: list[str] = []
    one, curve = speed_search(row, MovingOptions(search_rounds=4, refine_rounds=1, workers=2), reach, progress=lines.append)
    two, curve_two = speed_search(row, MovingOptions(search_rounds=4, refine_rounds=1, workers=1), reach)
    assert sorted(p.level for p in curve) == sorted(p.level for p in curve_two)
    # every plan the workers made is reported, as in one process (the workers cannot reach the callback)
    # (CP-SAT's kept plan was counted among the plans tried but never said: one line a plan)
    assert sum(ln.startswith("row on the move") for ln in lines) == len(curve) > 0
    assert sum("CP-SAT's order" in ln for ln in lines) == len([p for p in curve if p.assign == "cpsat"])
    assert all(", row time " in ln for ln in lines if ln.startswith("row on the move"))
    assert one.verification.passed and two.verification.passed
    assert [(e.arm, e.fruit, e.t_start) for e in one.plan.events] == [(e.arm, e.fruit, e.t_start) for e in two.plan.events]
    assert one.info["level"] == two.info["level"]


def test_a_new_resting_pose_is_checked_against_what_the_neighbours_booked_beyond_it():
    """Regression (found by the verifier in the benchmark): arm2 went home while arm3's booked
    return from a pick still swept past arm2's home pose; the move home was checked only over its
    own span. Every sampled pose pair now keeps the booking's clearance."""
    from coplan.planners.coordinated.schedule import arm_points, points_clearance
    from coplan.problem import load_problem, shipped_rows
    from coplan.row.live import LiveRowOptions, run_live_row

    p = load_problem(next(x for x in shipped_rows() if x.stem == "sparse_row"))
    res = run_live_row(p, LiveRowOptions(speed=0.379, seed=1))
    assert res.verification.passed
    need = p.task.clearance + LiveRowOptions().margin
    for i, j in p.neighbour_pairs():
        a, b = p.arms[i], p.arms[j]
        d = points_clearance(arm_points(a, res.plan.q[a.name]), arm_points(b, res.plan.q[b.name]), a.link_radius + b.link_radius)
        assert d.min() >= need - 1e-9


def test_a_gantry_sweep_keeps_both_modes_of_the_same_row():
    from coplan.sweep.spec import parse_sweep

    text = ("name: modes\nbase: gantry\nfixed: {length: 8.0, density: 4.0, seed: 3}\n"
            "vary:\n  n_arms: [1, 2]\n  gantry: [stop-and-go, continuous]\nplanner: coordinated\n")
    items = parse_sweep(text, "arms.yaml").items()
    assert sorted((it.params["n_arms"], it.params["gantry"]) for it in items) == \
        [(1, "continuous"), (1, "stop-and-go"), (2, "continuous"), (2, "stop-and-go")]
    assert len({it.key for it in items}) == 4


@pytest.mark.parametrize("mode", ["continuous", "auto"])
def test_solving_a_row_without_fruit_on_the_move_says_so(tmp_path, mode):
    path = tmp_path / "empty.yaml"
    path.write_text(to_yaml(gantry_row(length=6.0, n_arms=2, density=0.0, seed=2)))
    res = CliRunner().invoke(app, ["solve", str(path), "--gantry", mode, "-o", str(tmp_path / "out")])
    assert res.exit_code == 4 and "internal error" not in res.output and "Traceback" not in res.output
    assert "status infeasible" in res.output  # nothing to harvest


def test_a_row_nothing_can_be_harvested_from_is_planned_once_on_the_move():
    """Fruit out of every arm's reach: no speed search (it planned three plans, one said to rest at
    the rail's end at 0.5 m/s while the summary said the carriage stays where it starts)."""
    d = gantry_row(length=6.0, n_arms=2, density=2.0, seed=2)
    for f in d["fruits"]:
        f["position"] = [f["position"][0], 4.0]  # (the arms reach 1.8 m)
    res = solve(parse_problem(to_yaml(d)), gantry="continuous")
    curve = res.plan.solver["row"]["speed_curve"]
    assert len(curve) == 1 and res.plan.metrics["row"]["harvested"] == 0 and res.plan.metrics["row"]["screened_out"]
    assert float(np.ptp(res.plan.gantry_x)) == 0.0  # (the carriage stays where it starts)


def test_the_summary_says_a_given_speed_was_not_searched(tmp_path):
    """(With --speed V the summary said '1 full plan tried by the speed search'.)"""
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=6.0, density=2.0, seed=1)))
    runner = CliRunner(env={"COLUMNS": "250"})
    res = runner.invoke(app, ["solve", str(path), "--gantry", "continuous", "--speed", "0.3", "-o", str(tmp_path / "a")])
    assert res.exit_code == 0 and "(1 full plan at the speed given, verified)" in res.output, res.output
    res = runner.invoke(app, ["solve", str(path), "--gantry", "continuous", "-o", str(tmp_path / "b")])
    assert res.exit_code == 0 and "tried by the speed search, each verified)" in res.output, res.output


def test_the_carriage_rests_at_the_end_with_the_tail_inside_the_front_arm_s_reach():
    """(The carriage came to rest where the last fruit first came into the front arm's reach, and
    that arm picked the row's tail alone from the edge of its reach: a 10 m row, 3 arms, seed 1,
    took 71.2 s; the live carriage, cruising on, beat the offline plan by 21 %.) It rests half
    the front arm's reach further on; the search also tries the early rest at the level it chose
    and keeps the faster."""
    from coplan.row.moving import plan_moving

    p = parse_problem(to_yaml(gantry_row(length=10, n_arms=3, density=4, seed=1)))
    r = row_reach(p)
    front = max(p.arms, key=lambda a: a.base[0])
    early, late = cruise_end(p, r, EndRest.EARLY), cruise_end(p, r)
    assert cruise_end(p, r, EndRest.RAIL) == p.gantry.end
    assert late == pytest.approx(min(p.gantry.end, early + front.reach / 2))
    level = 1.0
    a = plan_continuous(p, level, reach=r, demand=demand_stretches(p, r, late))
    b = plan_continuous(p, level, reach=r, demand=demand_stretches(p, r, late), rest=EndRest.EARLY)
    assert a.verification.passed and b.verification.passed
    assert a.info["carriage_rest_at"] == pytest.approx(late) and b.info["carriage_rest_at"] == pytest.approx(early)
    assert a.plan.metrics["harvested"] >= b.plan.metrics["harvested"]
    if a.plan.metrics["harvested"] == b.plan.metrics["harvested"]:
        assert a.plan.time[-1] < b.plan.time[-1]
    res = plan_moving(p)
    assert res.verification.passed and res.plan.metrics["harvested"] == len(p.fruits)
    assert res.plan.time[-1] < 71.2 * 0.9


def test_on_the_move_the_metrics_count_the_picks_made_with_the_carriage_at_rest():
    """(A 5 m row with one arm: 8 of its 12 picks came at the carriage's rest at the end while the
    summary said it never stops for a pick.) At a constant 0.1 m/s it picks every fruit, two of
    them at rest at the end."""
    p = parse_problem(to_yaml(gantry_row(length=5, n_arms=1, density=3, seed=2, trusses=False)))
    res = solve(p, gantry=GantryMode.CONTINUOUS, options=MovingOptions(level=0.1, profile=SpeedProfile.CONSTANT))
    r = res.plan.metrics["row"]
    x, t = np.asarray(res.plan.gantry_x), res.plan.time
    still = sum(1 for e in res.plan.events if e.kind == EventKind.PICK
                and np.ptp(x[(t >= e.t_start - 1e-9) & (t <= e.t_end + 1e-9)]) < 1e-9)
    assert r["picks_at_rest"] == still and 0 < still < res.plan.metrics["harvested"]


def test_the_row_shares_are_shares_of_the_row_time_on_the_move():
    """At a constant 0.2 m/s on a short row the carriage moves the whole row: its share is 1,
    not 1.0003 (counting samples, both ends of a stretch); the picking share is the pick dwells'
    time where no two overlap; the mode is in the plan's label."""
    d = gantry_row(length=10, n_arms=2, density=2, seed=2, trusses=False)
    prob = parse_problem(to_yaml(d))
    res = solve(prob, options=MovingOptions(profile=SpeedProfile.CONSTANT, level=0.2))
    r = res.plan.metrics["row"]
    assert 0.99 <= r["carriage_moving_share"] <= 1.0 and 0.0 < r["picking_share"] <= 1.0
    picks = sorted((e.t_start, e.t_end) for e in res.plan.events if e.kind == EventKind.PICK)
    union, end = 0.0, -1.0
    for a, b in picks:
        union += max(0.0, b - max(a, end))
        end = max(end, b)
    assert r["picking_share"] * r["row_time"] == pytest.approx(union, abs=res.plan.dt * len(picks))
    assert res.plan.label == "coordinated (on the move)"


def test_no_cell_planner_on_the_move_and_the_message_says_so(tmp_path):
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=10, n_arms=2, density=2, seed=2, trusses=False)))
    for planner in ("heuristic", "optimal"):
        r = CliRunner().invoke(app, ["solve", str(path), "--gantry", "continuous", "--planner", planner, "-o", str(tmp_path / "o")])
        assert r.exit_code == 2 and "on the move the row books its own coordinated moves" in r.output, r.output
        assert "coordinated or optimal do" not in r.output
    assert not (tmp_path / "o").exists()


def test_the_summary_of_a_plan_on_the_move_gives_no_ratio_to_the_stop_by_stop_bound(tmp_path):
    """(It read "49.31 s stop by stop, ratio 0.841": a ratio below 1 beside "lower bound" read
    as a broken bound, and that bound is for stop-and-go plans only.)"""
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=6, n_arms=2, density=2, seed=2, trusses=False)))
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["solve", str(path), "--gantry", "continuous", "--speed", "0.2",
                                                       "-o", str(tmp_path / "o")])
    out = " ".join(r.output.split())
    assert r.exit_code == 0, r.output
    assert "for a stop-and-go plan, which this one is not" in out and "stop by stop, ratio" not in out


def test_a_stop_by_stop_ratio_below_one_says_why(tmp_path):
    """(A newcomer's stop-and-go row read "19.08 s stop by stop, ratio 0.971" under "lower bound":
    that bound is for plans whose arms never work while the carriage moves, and coplan's own
    place and come out during the moves.) ``check`` and the summary say what the figure assumes,
    and a ratio below 1 comes with the plan's overlap, the seconds that explain it."""
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=10.0, n_arms=2, density=0.7, seed=3, trusses=False)))
    run = CliRunner(env={"COLUMNS": "200"})
    said = " ".join(run.invoke(app, ["check", str(path)]).output.split())
    assert "stop by stop with no arm working while the carriage moves" in said
    r = run.invoke(app, ["solve", str(path), "-o", str(tmp_path / "o")])
    out = " ".join(r.output.split())
    assert r.exit_code == 0, r.output
    m = json.loads((tmp_path / "o" / "plan.json").read_text())["metrics"]["row"]
    assert m["ratio_stop_and_go_bound"] < 1.0 and m["overlap_seconds"] > 0  # (this row's plan, on any machine)
    assert f"below 1, as this plan's arms work {m['overlap_seconds']:.2f} s while the carriage moves" in out


def test_gantry_auto_interrupted_says_so_and_compares_no_part(row, monkeypatch):
    """Ctrl-C in --gantry auto: a stop-and-go part row (its planning interrupted) is no
    comparison -- the kept plan is said interrupted (exit 130), whichever mode it is; an
    interrupted speed search stops there, stop and go never planned (a second Ctrl-C was
    needed, and a whole row on the move was then 'success' against a part)."""
    import coplan.row.moving as moving_mod
    import coplan.row.plan as plan_mod
    from coplan.kinds import ExitCode, PlanStatus
    from coplan.pipeline import status_exit_code

    real_row, real_moving = plan_mod.plan_row, moving_mod.plan_moving

    def cut(res):
        res.plan.status = PlanStatus.INTERRUPTED
        return res

    monkeypatch.setattr(plan_mod, "plan_row", lambda *a, **k: cut(real_row(*a, **k)))
    res = solve(row, gantry=GantryMode.AUTO)
    auto = res.plan.solver["row"]["auto"]
    assert auto["stop-and-go"]["interrupted"] and not auto["continuous"]["interrupted"] and auto["interrupted"]
    assert res.plan.status == PlanStatus.INTERRUPTED and status_exit_code(res.plan.status) == ExitCode.INTERRUPTED
    assert res.verification.passed  # (what it kept is verified; only the comparison was cut short)

    monkeypatch.setattr(plan_mod, "plan_row", lambda *a, **k: pytest.fail("stop and go planned after the interrupt"))
    monkeypatch.setattr(moving_mod, "plan_moving", lambda *a, **k: cut(real_moving(*a, **k)))
    res = solve(row, gantry=GantryMode.AUTO)
    auto = res.plan.solver["row"]["auto"]
    assert auto["chosen"] == "continuous" and auto["stop-and-go"] is None and "not planned" in auto["interrupted"]
    assert res.plan.status == PlanStatus.INTERRUPTED
    from rich.console import Console

    from coplan.cli.summary import print_row_summary

    con = Console(record=True, width=400)
    print_row_summary(con, res)
    said = " ".join(con.export_text().split())
    assert "nothing compared" in said and "compared it with" not in said, said
    # a whole row whose search alone was cut short keeps its ratios (it is not 'a part')
    assert "for the part planned" not in said and "ratio" in said

    # Ctrl-C where stop and go has no row yet (its screen, or its last verify): the verified plan on
    # the move is kept, said interrupted -- it was lost with nothing written
    monkeypatch.setattr(moving_mod, "plan_moving", real_moving)

    def stopped(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(plan_mod, "plan_row", stopped)
    res = solve(row, gantry=GantryMode.AUTO)
    auto = res.plan.solver["row"]["auto"]
    assert res.plan.status == PlanStatus.INTERRUPTED and res.verification.passed and auto["stop-and-go"] is None
    assert auto["interrupted"] == "interrupted before stop and go had a row: nothing compared"
    with pytest.raises(KeyboardInterrupt):  # (stop and go alone: nothing to keep, the interrupt goes on)
        solve(row, gantry=GantryMode.STOP_AND_GO)


def test_speed_auto_is_not_run_on_an_interrupted_search(row, monkeypatch):
    """``coplan run ROW --speed auto``: a speed search cut short (Ctrl-C) is not the speed the
    search chooses: live_speed raises KeyboardInterrupt (the run exits 130, nothing written)
    instead of running the whole live row on it."""
    import coplan.row.moving as moving_mod
    from coplan.kinds import PlanStatus

    real = moving_mod.plan_moving

    def cut(*a, **k):
        res = real(*a, **k)
        res.plan.status = PlanStatus.INTERRUPTED
        res.info["interrupted"] = "the speed search stopped after 2 plans"
        return res

    monkeypatch.setattr(moving_mod, "plan_moving", cut)
    with pytest.raises(KeyboardInterrupt, match="stopped after 2 plans"):
        moving_mod.live_speed(row)


@pytest.mark.parametrize("speed", [5.0, 1e-5])
def test_the_command_and_plan_moving_quote_one_range_of_speeds(tmp_path, speed):
    """(`coplan solve ROW --speed 5` said [0.000709, 0.5] m/s, plan_moving [0.000515, 0.5]: the
    quick estimate in Python, the planner's reckoning on the command line.) Both quote the
    planner's; a speed above any gantry's is refused when MovingOptions is built."""
    from coplan.row.moving import plan_moving

    prob = gantry_row(length=8.0, density=2.0, seed=3)
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(prob))
    said = CliRunner().invoke(app, ["solve", str(path), "--gantry", "continuous", "--speed", repr(speed), "-o",
                                    str(tmp_path / "o")], env={"COLUMNS": "400"})
    assert said.exit_code == 2, said.output
    quoted = said.output[said.output.index("expected a cruising speed in ["):].split("]")[0]
    with pytest.raises(OptionsError) as e:
        plan_moving(parse_problem(to_yaml(prob)), MovingOptions(profile="constant", level=speed))
    assert quoted in str(e.value), (quoted, str(e.value))
    with pytest.raises(OptionsError, match="level: expected a cruising speed of at most 10 m/s"):
        MovingOptions(profile="constant", level=1e9)


@pytest.mark.parametrize("seed", range(6))
def test_the_speed_search_brackets_the_fastest_complete_level_to_5_percent(seed):
    """next_levels against a row where every level up to L is complete and none above it (seeded
    L and start): the rounds close on L from both sides to 5 %, the start is planned only when
    every level below it is complete, and no level above the cap is planned."""
    from coplan.row.moving import next_levels

    rng = np.random.default_rng(seed)
    start, cap = rng.uniform(0.2, 2.0), 3.0
    limit = rng.uniform(0.02, 2.9)  # the fastest complete level
    ok = bad = None
    assumed, planned = start, []
    for _ in range(40):
        batch, assumed = next_levels(start, cap, ok, bad, assumed, 2)
        if batch is None:
            break
        assert len(batch) == 2 and all(0 < v <= cap for v in batch)
        planned += batch
        for v in batch:
            if v <= limit:
                ok = v if ok is None else max(ok, v)
            else:
                bad = v if bad is None else min(bad, v)
    else:
        pytest.fail("the search never closed its bracket")
    assert ok is not None and ok <= limit
    assert bad is None and ok >= cap or bad is not None and bad > limit and bad - ok <= 0.05 * ok
    if limit < start:
        assert all(abs(v - start) > 1e-12 for v in planned)  # the start: the top, never planned


def test_the_search_keeps_the_rest_at_the_rail_s_end_where_the_rear_arms_then_share_the_tail():
    """(On six_arm_row the carriage rested at 44.2 m while arm4-arm6 picked the row's tail for 43 s
    and arm1-arm3 stood idle: 324.59 s; resting at the rail's end, 305.89 s.) On a 25 m row with six
    arms the search's best level with the rest at the rail's end is complete and faster than with
    the default and the early rest there, and is the plan kept: at rest at the rail's end, verified.
    Its progress lines say which rest each plan of a level had (they read as one plan three times)."""
    from coplan.row.moving import plan_moving

    p = parse_problem(to_yaml(gantry_row(length=25, n_arms=6, density=8, seed=1)))
    lines: list[str] = []
    res = plan_moving(p, MovingOptions(workers=2), progress=lines.append)
    said = [ln for ln in lines if ln.startswith("row on the move")]
    assert sum(", resting at the rail's end" in ln for ln in said) == sum(pt["end_rest"] == EndRest.RAIL.value for pt in res.info["speed_curve"])
    assert any(", resting where the last fruit comes into reach" in ln for ln in said)
    assert sum("resting" not in ln for ln in said) == sum(pt["end_rest"] == EndRest.REACH.value for pt in res.info["speed_curve"])
    curve = res.info["speed_curve"]
    [rail] = [pt for pt in curve if pt["end_rest"] == EndRest.RAIL.value]
    others = [pt for pt in curve if pt["level"] == rail["level"] and pt["end_rest"] != EndRest.RAIL.value
              and pt["verified"] and pt["harvested"] == pt["harvestable"]]
    assert rail["verified"] and rail["harvested"] == rail["harvestable"] == len(p.fruits)
    assert others and all(rail["row_time"] < pt["row_time"] for pt in others)
    assert res.info["end_rest"] == EndRest.RAIL.value and res.info["carriage_rest_at"] == pytest.approx(p.gantry.end)
    assert res.verification.passed and res.plan.metrics["makespan"] == pytest.approx(rail["row_time"])


def test_where_the_rail_s_end_leaves_fruit_the_next_complete_level_down_tries_it():
    """(A 20 m row at 20 fruit per metre: at the rail's end the best level left fruit, while the level
    below was complete and faster, 448.30 s against 471.23 s.) On an 8 m row at 20 per metre the
    rail's end leaves fruit at the best level, so the highest complete level below it is planned at
    the rail's end too; the plan kept is the fastest complete one."""
    from coplan.row.moving import plan_moving

    p = parse_problem(to_yaml(gantry_row(length=8, n_arms=3, density=20, seed=11)))
    res = plan_moving(p, MovingOptions(workers=2))
    curve = res.info["speed_curve"]
    rails = sorted((pt for pt in curve if pt["end_rest"] == EndRest.RAIL.value), key=lambda pt: -pt["level"])
    assert len(rails) == 2 and rails[0]["harvested"] < rails[0]["harvestable"]
    plain = [pt for pt in curve if pt["end_rest"] == EndRest.REACH.value and not pt["refined"] and pt["assign"] == "greedy"]
    below = [pt["level"] for pt in plain if pt["level"] < rails[0]["level"] and pt["verified"] and pt["harvested"] == pt["harvestable"]]
    assert rails[1]["level"] == pytest.approx(max(below))
    complete = [pt["row_time"] for pt in curve if pt["verified"] and pt["harvested"] == pt["harvestable"]]
    assert res.verification.passed and res.plan.metrics["makespan"] == pytest.approx(min(complete))


def test_solve_with_a_speed_alone_plans_on_the_move_as_run_does(tmp_path):
    """(``coplan solve ROW --speed 0.2`` was refused -- a speed applies on the move -- where
    ``coplan run ROW --speed 0.2`` is on the move: a new user's trial found the two disagreeing.)
    A speed or a profile alone means on the move; beside a stop-and-go flag it is still refused."""
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=6.0, density=2.0, seed=7)))
    res = CliRunner().invoke(app, ["solve", str(path), "--speed", "0.2", "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    row = json.loads((tmp_path / "out" / "plan.json").read_text())["solver"]["row"]
    assert row["mode"] == "continuous" and row["profile"] == "constant" and row["level"] == 0.2


def test_an_interrupted_speed_search_verifies_the_plan_it_keeps_in_full(monkeypatch):
    """(Its candidates are screened -- each pair's certified least distance only to half its
    margin -- and the plan kept after a Ctrl-C was written with that coarse verdict: margin 13.8 mm
    where coplan verify of the file certified 20.2 mm.) The kept plan is verified in full."""
    import coplan.row.moving as moving
    from coplan.kinds import PlanStatus
    from coplan.verify.verifier import verify

    row = parse_problem(to_yaml(gantry_row(length=10.0, n_arms=3, density=8.0, seed=1)))

    def cut(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(moving, "_last_tries", cut)  # (the bracket made its plans: cut after it)
    res = moving.plan_moving(row, MovingOptions())
    assert res.plan.status == PlanStatus.INTERRUPTED and "margins_screened" not in res.info
    again = verify(row, res.plan)
    assert res.verification.certified_clearance == pytest.approx(again.certified_clearance, abs=1e-9)
    assert res.plan.metrics["margin"] == pytest.approx(again.margin, abs=1e-9)


def test_a_second_interrupt_keeps_the_screened_margins_and_the_summary_says_so(monkeypatch):
    """(A second Ctrl-C as the kept plan was verified in full kept the speed search's screened
    verdict and said so in plan.json alone: the summary printed its margin as certified.)"""
    import io

    from rich.console import Console

    import coplan.row.moving as moving
    from coplan.cli.summary import print_row_summary
    from coplan.kinds import PlanStatus
    from coplan.pipeline import solve

    def cut(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(moving, "_last_tries", cut)
    monkeypatch.setattr(moving, "certify", cut)
    row = parse_problem(to_yaml(gantry_row(length=6.0, n_arms=3, density=4.0, seed=1)))
    res = solve(row, gantry="continuous")
    assert res.plan.status == PlanStatus.INTERRUPTED
    assert "screen" in res.plan.solver["row"]["margins_screened"]
    out = io.StringIO()
    print_row_summary(Console(file=out, width=200), res)
    line = next(ln for ln in out.getvalue().splitlines() if ln.strip().startswith("margins screened"))
    assert "half its margin" in line
