"""Rows at their edges: every fruit in reach from where the carriage starts, a carriage that must
settle before a pick, and the summaries of such rows (found by trying the project as a new user)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from coplan.generate import gantry_row, to_yaml
from coplan.kinds import GantryMode, StopRule
from coplan.plan import EventKind
from coplan.problem import parse_problem
from coplan.row.continuous import MovingOptions
from coplan.row.moving import plan_moving
from coplan.row.cruise import Cruise
from coplan.row.live import LiveRowOptions, run_live_row
from coplan.row.metrics import row_metrics
from coplan.row.plan import RowOptions, plan_row
from coplan.row.reach import row_reach
from coplan.verify import verify
from coplan.verify.verdict import ViolationKind
from layouts import course_arms_row


def _row(fruits=None, **gantry):
    d = gantry_row(length=6.0, density=3.0, seed=2)
    d["gantry"].update(gantry)
    if fruits is not None:
        d["fruits"] = fruits
    return parse_problem(to_yaml(d))


@pytest.fixture(scope="module")
def single():
    """One fruit at x = 3 m: the right arm (base 2 m right of the carriage) reaches it from the start."""
    return _row([{"id": "only", "position": [3.0, 1.0]}])


def test_where_the_carriage_starts_serves_every_fruit_the_optimised_rule_does_not_move(single):
    res = plan_row(single)
    assert res.verification.passed and res.plan.metrics["harvested"] == 1
    assert [sp.stop.x for sp in res.stops] == [single.gantry.start]
    assert np.all(res.plan.gantry_x == single.gantry.start)
    fixed = plan_row(single, RowOptions(stops=StopRule.FIXED))  # (the baseline drives to its stride's stop)
    assert res.plan.metrics["makespan"] < fixed.plan.metrics["makespan"]
    m = row_metrics(single, res)
    # the row's first motion is the arms' -- once that stop's cell is planned -- and every stop is ready by then
    assert m["first_motion_seconds"] >= m["first_stop_seconds"] and m["kept_ahead"] and m["least_slack_seconds"] >= 0


def test_the_first_motion_waits_for_the_first_cell_its_arms_need(single):
    """Found by a new user: a first stop whose arms start shortly after the row's first motion
    (not at t = 0) was counted from the moment the stop was known, so the row was LATE at its
    first stop. The first motion now waits for that cell: its slack is 0, not negative."""
    res = plan_row(single)
    sp = res.stops[0]
    sp.start, sp.ready = 0.04, res.info["first_stop_seconds"] + 0.6  # (the arms start 0.04 s in; planned 0.6 s later)
    m = row_metrics(single, res)
    assert m["first_motion_seconds"] == pytest.approx(sp.ready - sp.start)
    assert m["least_slack_seconds"] == pytest.approx(0.0, abs=1e-9) and m["kept_ahead"]


@pytest.mark.parametrize("options", [MovingOptions(), MovingOptions(profile="constant", level=0.2)])
def test_on_the_move_a_fruit_only_the_start_serves_is_picked_while_the_carriage_rests_there(options):
    """A fruit only the carriage's start position serves was left out on the move (stop and go
    picked it): a carriage that ramps up at once gives it no window at any speed. The carriage
    now first rests where it starts, as long as the arms need for such fruit (the search's first
    plans find them); every fruit is harvested and the plan verified."""
    far = [{"id": f"f{i}", "position": [3.0 + 0.7 * i, 1.0]} for i in range(8)]
    row = _row([{"id": "edge", "position": [-3.45, 1.0]}] + far)
    reach = row_reach(row)
    assert reach.span("edge") == (0, 0)  # (only the start serves it)
    res = plan_moving(row, options)
    assert res.verification.passed and res.plan.metrics["harvested"] == 9 and not res.info["left_out"]
    hold = res.info["start_hold"]
    assert hold > 0 and np.all(res.plan.gantry_x[res.plan.time <= hold] == row.gantry.start)
    picks = [e for e in res.plan.events if e.kind == EventKind.PICK and e.fruit == "edge"]
    assert len(picks) == 1 and picks[0].t_end <= hold + 1e-9  # picked while the carriage rests there
    plain = plan_moving(_row(far), options)  # no such fruit: no hold
    assert plain.info["start_hold"] == 0.0 and plain.plan.gantry_x[1] > row.gantry.start


def test_on_the_move_a_fruit_the_first_centimetres_serve_is_held_for_too():
    """(A fruit served from 0-0.10 m of the rail was not held for -- only one the start alone
    serves was -- and the speed search slowed the whole row to 0.08 m/s, six times the row time.)
    The carriage at its fastest leaves it behind before an arm could pick it: it rests there first."""
    far = [{"id": f"f{i}", "position": [3.0 + 0.7 * i, 1.0]} for i in range(8)]
    row = _row([{"id": "edge", "position": [-3.35, 1.0]}] + far)
    assert row_reach(row).span("edge") == (0, 2)  # (0 to 0.10 m)
    res = plan_moving(row, MovingOptions())
    plain = plan_moving(_row(far), MovingOptions())
    assert res.verification.passed and res.plan.metrics["harvested"] == 9 and res.info["start_hold"] > 0
    pick = next(e for e in res.plan.events if e.kind == EventKind.PICK and e.fruit == "edge")
    assert pick.t_end <= res.info["start_hold"] + 1e-9
    # the rest of the row at the pace it has without that fruit: the hold, not a slower row
    assert res.plan.metrics["makespan"] <= plain.plan.metrics["makespan"] + res.info["start_hold"] + 1.0


def test_live_on_the_move_the_carriage_rests_where_it_starts_for_a_report_only_the_start_serves():
    """Live, the camera reports at the start a fruit only the start position serves: the carriage
    first rests there (as the offline plan, its reference, does), the fruit is picked, and the
    executed plan is verified against the true fruit."""
    far = [{"id": f"f{i}", "position": [3.0 + 0.7 * i, 1.0]} for i in range(8)]
    row = _row([{"id": "edge", "position": [-3.45, 1.0]}] + far)
    live = run_live_row(row, LiveRowOptions(seed=0, mode=GantryMode.CONTINUOUS, speed=0.2))
    assert live.verification.passed and live.metrics["harvested"] == 9 and live.metrics["of_offline"] == 1.0
    assert live.plan.gantry_x[live.plan.time <= 1.0].max() == row.gantry.start  # (resting where it starts)


def test_on_the_move_a_carriage_that_need_not_move_gives_a_verified_plan_and_shares_of_at_most_one(single):
    res = plan_moving(single, MovingOptions(search_rounds=2))  # (crashed: the speed profile had no stretch of rail)
    assert res.verification.passed and res.plan.metrics["harvested"] == 1
    m = row_metrics(single, res)
    assert m["carriage_moving_share"] == 0.0
    # on the move the carriage's speed and every cycle come from the whole search: the row starts once planned
    assert m["first_motion_seconds"] == m["planning_time"] > 0 and m["kept_ahead"] is None
    assert res.plan.solver["row"]["options"]["workers"] == 1  # (what the plan depends on is in plan.json)
    for arm, causes in m["idle_share"].items():
        assert 0.0 <= sum(causes.values()) <= 1.0 + 1e-12, (arm, causes)
    idle = [a for a, fs in res.plan.allocation.items() if not fs]
    assert idle and all(m["idle_share"][a]["no_fruit"] == pytest.approx(1.0) for a in idle)  # no fruit all row long


def test_a_locked_arm_s_idle_shares_add_up_to_the_whole_row(tmp_path):
    """(A locked arm's causes added up to 0.86 of the row while its idle fraction was 1: its moves
    out of a neighbour's way were no cause.) ``making_way``: moving where it has no fruit."""
    import coplan
    from coplan.generate import gantry_row, to_yaml

    d = gantry_row(length=10.0, density=2.0, seed=1)
    d["arms"][2]["base"], d["arms"][2]["bin"] = [0.3, 0.0], [0.3, -0.5]  # arm2 can no longer reach its bin
    path = tmp_path / "lock.yaml"
    path.write_text(to_yaml(d))
    res = coplan.solve(path)
    m = res.plan.metrics
    locked = [a for a, fs in res.plan.allocation.items() if not fs]
    assert locked == ["arm2"]
    assert sum(m["row"]["idle_share"]["arm2"].values()) == pytest.approx(m["per_arm"]["arm2"]["idle_fraction"], abs=0.01)
    assert m["row"]["idle_share"]["arm2"]["making_way"] > 0
    for arm, causes in m["row"]["idle_share"].items():
        assert sum(causes.values()) <= 1.0 + 1e-9 and causes["making_way"] >= 0


# --------------------------------------------------------------------------- settle
def _picks_after_rest(plan, settle):
    """(pick start - when the carriage last came to rest before it) for picks with the carriage at rest."""
    x, t = np.asarray(plan.gantry_x), plan.time
    moved = np.abs(np.diff(x)) > 1e-9
    rest_at = t[1:-1][moved[:-1] & ~moved[1:]]
    out = []
    for e in plan.events:
        if e.kind == EventKind.PICK:
            k = np.searchsorted(rest_at, e.t_end, side="right") - 1
            if k >= 0:
                out.append(e.t_start - rest_at[k])
    return out


@pytest.fixture(scope="module")
def settling():
    """A short row whose last fruit cluster only the front arm reaches, from the rail's end: some
    of it is picked with the carriage at rest there, in every mode."""
    d = gantry_row(length=6.0, density=3.0, seed=2)
    end = [{"id": f"e{i}", "position": [8.55 + 0.05 * (i % 3), 0.9 + 0.1 * (i // 3)]} for i in range(6)]
    return _row(d["fruits"] + end, settle=1.0)


def test_the_verifier_refuses_a_pick_before_the_carriage_has_settled(settling):
    unsettled = _row(list(map(_fruit, settling.fruits)))  # the same row, no settle asked
    plain = plan_row(unsettled)
    assert min(_picks_after_rest(plain.plan, 1.0)) < 0.5
    ver = verify(settling, plain.plan)
    bad = [v for v in ver.violations if v.kind == ViolationKind.CARRIAGE and "settle" in v.message]
    assert not ver.passed and bad
    assert verify(unsettled, plain.plan).passed


def _fruit(f):
    return {"id": f.id, "position": list(f.position)}


@pytest.mark.parametrize("how", ["offline stop and go", "live stop and go", "live on the move"])
def test_every_planner_waits_for_the_carriage_to_settle_before_a_pick(settling, how):
    if how == "offline stop and go":
        plan = plan_row(settling).plan
    else:
        mode = GantryMode.STOP_AND_GO if "stop" in how else GantryMode.CONTINUOUS
        res = run_live_row(settling, LiveRowOptions(speed=0.1, seed=0, mode=mode))
        assert res.verification.passed
        plan = res.plan
    gaps = _picks_after_rest(plan, 1.0)
    assert gaps and min(gaps) >= 1.0 - 2 * plan.dt - 1e-9
    assert verify(settling, plan).passed


def test_pick_windows_leave_out_the_settling_time_after_each_rest(settling):
    from coplan.kinematics.timing import Move1D
    from coplan.row.cruise import pick_windows
    from coplan.row.reach import row_reach

    g = settling.gantry
    cruise = Cruise.hops(settling, [(0.0, 2.0), (9.0, 4.0)])
    hop = Move1D.between(0.0, 2.0, g.max_velocity, g.max_acceleration, g.max_jerk).duration
    assert cruise.arrivals() == pytest.approx([hop, 9.0 + hop])
    dwell = settling.task.pick_dwell
    wins = pick_windows(settling, row_reach(settling), cruise, dwell)
    starts = [w.lo for ws in wins.values() for w in ws]
    assert starts and min(starts) >= 0.0
    for ws in wins.values():
        for w in ws:
            for ta in cruise.arrivals():  # no pick [s, s + dwell] with s in the window meets (ta, ta + settle)
                assert w.hi <= ta - dwell + 1e-9 or w.lo >= ta + g.settle - 1e-9, (w, ta)
    # and without settle the same windows run through the arrivals
    plain = pick_windows(_row(), row_reach(_row()), Cruise.hops(_row(), [(0.0, 2.0), (9.0, 4.0)]), dwell)
    assert any(w.lo < hop < w.hi for ws in plain.values() for w in ws)


def test_a_fruit_the_camera_never_sees_is_reported_as_never_reported_in_both_modes():
    """R lies where only the front arm at the rail's end reaches it, beyond what the camera (1.5 m
    ahead of the front arm) ever sees: its miss said 'the carriage never stands where an arm can
    pick it at this speed' in stop and go, for a report the camera never made."""
    row = _row([{"id": "m", "position": [3.0, 1.0]}, {"id": "R", "position": [9.78, 0.05]}])
    for mode in (GantryMode.STOP_AND_GO, GantryMode.CONTINUOUS):
        res = run_live_row(row, LiveRowOptions(speed=0.1, seed=0, mode=mode))
        assert res.verification.passed and res.outcome["m"] == "harvested"
        assert res.outcome["R"].startswith("missed: never reported"), (mode, res.outcome["R"])


def test_an_interrupted_row_keeps_its_stops_planned_so_far_verified(tmp_path, monkeypatch):
    """(Ctrl-C or SIGTERM during a row's solve saved nothing, while the message said it was
    saving.) The row as far as its first stops' cells are planned is assembled, verified and
    written with status interrupted (exit 130); nothing before the first stop: a plan that
    harvests nothing, still verified."""
    import coplan
    import coplan.row.plan as rp
    from coplan.cli import app
    from coplan.generate import gantry_row, to_yaml
    from coplan.kinds import ExitCode, PlanStatus
    from typer.testing import CliRunner

    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=24.0, density=2.0, seed=4)))
    full = coplan.solve(path, stops="fixed")
    assert len(full.row.stops) >= 3
    real = rp._cell_plan
    for after in (2, 0):
        calls = []

        def cell_plan(cell, opts, drive=None, after=after, calls=calls):
            calls.append(1)
            if len(calls) > after:
                raise KeyboardInterrupt
            return real(cell, opts, drive)

        monkeypatch.setattr(rp, "_cell_plan", cell_plan)
        res = coplan.solve(path, stops="fixed", out_dir=tmp_path / f"run{after}")
        assert res.plan.status == PlanStatus.INTERRUPTED and res.verification.passed
        assert len(res.row.stops) == after and "interrupted" in res.plan.solver["row"]
        got = {e.fruit for e in res.plan.events if e.kind.value == "place"}
        assert got == {f for sp in full.row.stops[:after] for f in sp.stop.fruit}
        left = res.plan.solver["row"]["left_out"]
        assert {f for f in left if "interrupted before a stop" in left[f] and left[f].startswith(f)} \
            == set(full.row.reach.harvestable()) - got
        assert (tmp_path / f"run{after}" / "plan.json").exists()
        # (no bounds after the interruption: a SIGTERM on a 200 m row spent 60 s on them, past a grace period)
        assert res.plan.metrics["row"]["lower_bound"] is None and res.plan.metrics["row"]["ratio_any_plan_bound"] is None
        if after == 0:  # a row of no time: no ratio to its bounds, no share of its time ("0.00 %" before)
            m = res.plan.metrics["row"]
            assert m["ratio_any_plan_bound"] is None and m["planning_over_row_time"] is None
    # (the interruption before the first stop, from the loop's last patch)
    res = CliRunner().invoke(app, ["solve", str(path), "--stops", "fixed", "-o", str(tmp_path / "cli")])
    assert res.exit_code == ExitCode.INTERRUPTED and (tmp_path / "cli" / "plan.json").exists(), res.output
    said = " ".join(res.output.split())
    # no ratio of a part of the row to the whole row's bound (0.271 was printed of one stop of dense_row)
    assert "no ratio for a part" in said and "ratio 0" not in said and "(the row has no time to set it against)" in said, said


def test_an_interrupted_speed_search_keeps_its_best_verified_plan(tmp_path, monkeypatch):
    """On the move, Ctrl-C / SIGTERM during the speed search keeps the best verified plan so far
    (status interrupted, written); before any plan, nothing (the interruption goes on)."""
    import coplan
    import coplan.row.moving as rc
    from coplan.generate import gantry_row, to_yaml
    from coplan.kinds import PlanStatus

    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=8.0, density=2.0, seed=4)))
    real = rc._Runner.map
    for after in (1, 0):
        calls = []

        def map_(self, *a, after=after, calls=calls, **k):
            calls.append(1)
            if len(calls) > after:
                raise KeyboardInterrupt
            return real(self, *a, **k)

        monkeypatch.setattr(rc._Runner, "map", map_)
        if after == 0:
            with pytest.raises(KeyboardInterrupt):
                coplan.solve(path, gantry="continuous", out_dir=tmp_path / "none")
            assert not (tmp_path / "none").exists()
            continue
        res = coplan.solve(path, gantry="continuous", out_dir=tmp_path / "one")
        assert res.plan.status == PlanStatus.INTERRUPTED and res.verification.passed
        # (the first round's levels: SEARCH_WIDTH of them, planned before the interruption)
        assert f"stopped after {rc.SEARCH_WIDTH} plans:" in res.plan.solver["row"]["interrupted"]
        assert res.plan.solver["status"] == "interrupted"
        assert (tmp_path / "one" / "plan.json").exists()


def test_an_interrupt_a_cell_planner_absorbed_still_interrupts_the_row_its_live_run_and_its_comparison(tmp_path, monkeypatch):
    """(The optimal cell planner turns Ctrl-C into its best plan: the row went on planning and
    saved a 'success'; a live stop-and-go run went on against a cut-short reference; compare ROW
    kept a cut-short rule in its table as a result and went on.)"""
    import coplan.row.plan as rp
    from coplan.generate import gantry_row, to_yaml
    from coplan.kinds import PlanStatus
    from coplan.problem import parse_problem
    from coplan.report.rows import compare_rows
    from coplan.row.live import LiveRowOptions, run_live_row
    from coplan.row.plan import RowOptions, plan_row

    row = parse_problem(to_yaml(gantry_row(length=24.0, density=2.0, seed=4)), "row.yaml")
    real = rp._cell_plan
    calls = []

    def absorbing(cell, opts, drive=None):  # as plan_optimal does: the interrupt becomes the plan's status
        calls.append(1)
        p = real(cell, opts, drive)
        if len(calls) > 1:
            p.status = PlanStatus.INTERRUPTED
        return p

    monkeypatch.setattr(rp, "_cell_plan", absorbing)
    res = plan_row(row, RowOptions(stops="fixed"))
    assert res.plan.status == PlanStatus.INTERRUPTED and len(res.stops) == 1 and res.verification.passed
    calls.clear()
    calls.append(1)  # (every cell interrupted from the first: the live run's reference is cut short)
    with pytest.raises(KeyboardInterrupt):
        run_live_row(row, LiveRowOptions(mode="stop-and-go"))
    calls.clear()
    with pytest.raises(KeyboardInterrupt):
        compare_rows(row, tmp_path / "cmp", rules=("fixed", "fewest"))
    md = (tmp_path / "cmp" / "compare.md").read_text()
    assert "| fixed (interrupted) |" in md and "Note: interrupted while planning stop rule fixed" in md and "fewest" not in md


def test_on_the_move_a_long_settle_at_the_rail_s_end_leaves_no_fruit():
    """(With gantry.settle 8 s or more, every speed left the fruit only the carriage's final
    rest serves -- 'no clear cycle was found': each arm gave them up after three tries, a second
    apart, before the settle let their windows open.) A window not open yet is no failed try."""
    d = gantry_row(length=10.0, density=2.0, seed=0)
    d["gantry"]["settle"] = 10.0
    row = parse_problem(to_yaml(d))
    res = plan_moving(row, MovingOptions(profile="constant", level=0.3))
    assert res.verification.passed and not res.info["left_out"]
    assert res.plan.metrics["harvested"] == len(row_reach(row).harvestable())
    rest = res.plan.time[np.flatnonzero(np.diff(res.plan.gantry_x) > 0)[-1] + 1]  # the carriage's final rest
    late = [e for e in res.plan.events if e.kind == EventKind.PICK and e.t_end > rest]
    assert late and all(e.t_start >= rest + 10.0 - 1e-6 for e in late)  # picked once the carriage settled


def test_fewest_stops_are_the_fewest_where_a_fruit_is_served_from_several_stretches_of_rail():
    """(``--stops fewest`` took 4 stops where 2 serve every fruit -- more than the fixed stride's 3:
    a fruit several arms serve has several stretches of rail it is served from, where the greedy
    is not exact.) The fewest is never more than any other rule's stops, serves every fruit, and
    is no fewer than a packing of fruit no one position serves two of; on the shipped rows it is
    the greedy's (the packing bound certifies it)."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import load_problem, parse_problem, shipped_rows
    from coplan.row.reach import row_reach
    from coplan.row.stops import _packing, fewest_stops, fixed_stops

    odd = row_reach(parse_problem(to_yaml(gantry_row(length=10, n_arms=3, density=2, seed=3, y_range=(0.5, 2.1)))))
    assert (len(fewest_stops(odd)), len(fewest_stops(odd, exact=True)), len(fixed_stops(odd))) == (4, 2, 3)
    for seed in range(6):
        reach = row_reach(parse_problem(to_yaml(gantry_row(length=10, n_arms=3, density=2, seed=seed, y_range=(0.5, 2.1)))))
        stops = fewest_stops(reach, exact=True)
        ks = [s.k for s in stops]
        assert all(reach.cover[f].any(axis=0)[ks].any() for f in reach.cover), seed  # every fruit served
        assert sorted(f for s in stops for f in s.fruit) == sorted(reach.cover)  # each by one stop
        cov = {f: reach.cover[f].any(axis=0) for f in reach.cover}
        assert _packing(cov) <= len(stops) <= min(len(fewest_stops(reach)), len(fixed_stops(reach))), seed
    for path in shipped_rows():
        reach = row_reach(load_problem(path))
        assert [s.x for s in fewest_stops(reach, exact=True)] == [s.x for s in fewest_stops(reach)], path.stem


# --------------------------------------------------------------------------- the screen's grid
def _narrow():
    """Fruit ``edge`` lies 1.7899 m from east's base when the carriage stands right below it: in
    reach (1.8 m less the 0.01 m margin) only from 3.007-3.043 m, between the 0.05 m grid's points."""
    d = gantry_row(length=10.0, density=1.0, seed=0, n_arms=2, spacing=2.5)
    d["fruits"] = [{"id": "edge", "position": [4.275, 1.7899]}, {"id": "ok", "position": [2.0, 1.0]},
                   {"id": "high", "position": [5.0, 2.5]}]
    return parse_problem(to_yaml(d))


def test_a_fruit_reachable_only_between_the_grid_s_positions_is_said_so_and_a_finer_grid_plans_it():
    """(Found by a new user: it read "no carriage position ... lets an arm harvest it; with the
    carriage at 3.03 m, blocked" -- from where it is in reach.)"""
    prob = _narrow()
    east = prob.arm("arm2")
    why = row_reach(prob).reasons["edge"]
    assert "narrower than the candidate stops' spacing (0.05 m" in why and "arm2 at 3.00" in why and "--resolution" in why
    lo, hi = (float(x) for x in why.split("arm2 at ")[1].split(" m")[0].split("-"))
    for c in (lo, hi):  # the window's ends are in reach; just outside them not
        assert math.dist((4.275 - c, 1.7899), east.base) <= east.reach - prob.task.reach_margin + 1e-9
    assert math.dist((4.275 - lo + 0.002, 1.7899), east.base) > east.reach - prob.task.reach_margin
    # a fruit too high for any position keeps the screen's own reason, at its nearest miss
    assert "beyond its outer reach" in row_reach(prob).reasons["high"]
    coarse = plan_row(prob)
    assert coarse.plan.unreachable == ["edge", "high"]
    # counted as a cell's are: 'edge' is within reach (reachable, screened out), 'high' is not
    assert (coarse.plan.metrics["reachable"], coarse.plan.metrics["unreachable"]) == (2, 1)
    fine = plan_row(prob, RowOptions(resolution=0.01))
    assert fine.verification.passed and {e.fruit for e in fine.plan.events} == {"edge", "ok"}
    assert fine.plan.unreachable == ["high"]


def test_a_row_plan_lists_what_its_screen_left_out_in_both_modes(tmp_path):
    import json

    import coplan

    prob = _narrow()
    for gantry in (GantryMode.STOP_AND_GO, GantryMode.CONTINUOUS):
        opts = MovingOptions(search_rounds=2) if gantry == GantryMode.CONTINUOUS else None  # (the screen, not the search)
        res = coplan.solve(prob, gantry=gantry, out_dir=tmp_path / gantry.value, options=opts)
        data = json.loads((tmp_path / gantry.value / "plan.json").read_text())
        assert data["unreachable"] == ["edge", "high"] == res.plan.unreachable
        assert data["metrics"]["unreachable"] == 1 and set(data["metrics"]["row"]["screened_out"]) == {"edge", "high"}


def test_a_row_summary_says_unreachable_and_screened_out_as_the_plan_s_metrics_count_them(tmp_path):
    """(From a grower's trial: a row's summary said "of 233 fruit 3 screened out" where its
    plan.json's metrics said unreachable 3, screened_out 0 -- out of every arm's reach, which
    every other command calls unreachable.)"""
    import json

    from typer.testing import CliRunner

    from coplan.cli import app

    path = tmp_path / "narrow.yaml"
    path.write_text(to_yaml(gantry_row(length=10.0, density=1.0, seed=0, n_arms=2, spacing=2.5)
                            | {"fruits": [{"id": "edge", "position": [4.275, 1.7899]}, {"id": "ok", "position": [2.0, 1.0]},
                                          {"id": "high", "position": [5.0, 2.5]}]}))
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["solve", str(path), "--out", str(tmp_path / "out")])
    m = json.loads((tmp_path / "out" / "plan.json").read_text())["metrics"]
    assert (m["unreachable"], m["screened_out"]) == (1, 1) and m["fruit_ids"]["unreachable"] == ["high"]
    line = next(ln for ln in r.output.splitlines() if ln.strip().startswith("fruit "))
    assert "of 3 fruit 1 unreachable (out of every arm's reach from every carriage position) and 1 screened out" in line, line


def test_the_mean_speed_on_the_move_is_over_the_time_the_carriage_moves():
    """(It divided by the whole cruise, the rest at the start included: 0.185 m/s for a cruise at 0.2.)"""
    prob = _row()
    hold = 3.0
    c = Cruise.of(prob, 0.2, prob.gantry.end, start_hold=hold)
    assert c.leaves_start == pytest.approx(hold)
    assert c.moving_seconds == pytest.approx(c.duration - hold)
    assert c.mean_speed == pytest.approx(prob.gantry.length / (c.duration - hold))
    assert c.mean_speed < 0.2 < prob.gantry.length / (c.duration - hold - 5.0)  # (the ramps at each end: below the cruise)


def test_resolution_on_the_command_line(tmp_path):
    from typer.testing import CliRunner

    from coplan.cli import app

    path = tmp_path / "narrow.yaml"
    d = gantry_row(length=10.0, density=1.0, seed=0, n_arms=2, spacing=2.5)
    d["fruits"] = [{"id": "edge", "position": [4.275, 1.7899]}, {"id": "ok", "position": [2.0, 1.0]}]
    path.write_text(to_yaml(d))
    run = CliRunner(env={"COLUMNS": "200"}).invoke
    r = run(app, ["check", str(path)])
    assert r.exit_code == 5 and "1 harvestable from some carriage position, 1 not" in r.output and "--resolution" in r.output
    r = run(app, ["check", str(path), "--resolution", "0.01"])
    assert r.exit_code == 0 and "2 harvestable" in r.output, r.output
    r = run(app, ["solve", str(path), "--resolution", "0.01", "--out", str(tmp_path / "out")])
    assert r.exit_code == 0 and "2 harvested of 2 harvestable" in r.output and "none unreachable or screened out" in r.output, r.output
    import json  # recorded in the plan (stop and go recorded none: a plan made with another was not reproducible from its file)
    assert json.loads((tmp_path / "out" / "plan.json").read_text())["solver"]["row"]["resolution"] == 0.01
    r = run(app, ["solve", str(path), "--resolution", "0.001", "--out", str(tmp_path / "o2")])
    assert r.exit_code == 2 and "expected a number in [0.01, 0.5] m, found 0.001" in r.output
    r = run(app, ["solve", "crossing_paths", "--resolution", "0.01", "--out", str(tmp_path / "o3")])
    assert r.exit_code == 2 and "stationary cell" in r.output


def test_on_the_move_a_fruit_an_arm_free_all_along_could_not_fit_says_so():
    """(Found by a new user: a long arm 1.6 m from a short one, whose direct moves from its bin
    sweep through the short one at rest, was said to have passed the fruit 'before its first
    pick' or 'while waiting for a neighbour'; stop and go, which tucks round, picks them.)"""
    text = """
name: long-beside-short
gantry: {start: 2.0, end: 14.0, max_velocity: 0.4, max_acceleration: 0.3, max_jerk: 3.0, settle: 0.3}
defaults: {link_radius: 0.04, joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]], max_velocity: [3, 4],
           max_acceleration: [8, 12], max_jerk: [80, 120], home: [1.0472, 0.7854]}
arms:
  - {name: big, links: [1.2, 1.0], base: [-1.6, 0.0], bin: [-1.6, -0.5]}
  - {name: small, links: [0.8, 0.6], base: [0.0, 0.0], bin: [0.0, -0.5]}
fruits: [{id: p03, position: [4.0, 2.1]}, {id: p09, position: [8.0, 1.2]}]
task: {pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}
"""
    prob = parse_problem(text)
    moving = plan_moving(prob, MovingOptions(profile="constant", level=0.1))
    assert moving.verification.passed
    why = moving.info["left_out"].get("p03")
    assert why is not None and "big free all that time: no cycle fitted" in why and "--gantry stop-and-go, picks every fruit at rest" in why
    assert "first pick" not in why and "waiting for a neighbour" not in why
    stop = plan_row(prob)
    assert stop.verification.passed and "p03" in {e.fruit for e in stop.plan.events}


@pytest.mark.parametrize("mode", ["on the move", "stop and go"])
def test_a_live_row_whose_repeated_reports_coincide_runs(mode):
    """(A review found it: with no noise a repeated report lies on the first, and the live
    planners' problems of reports were refused as two fruit at one position.)"""
    prob = _row()
    how = {"speed": 0.2} if mode == "on the move" else {"mode": GantryMode.STOP_AND_GO}
    run = run_live_row(prob, LiveRowOptions(sigma=0.0, duplicate_rate=0.5, false_rate=0.0, seed=1, **how))
    assert run.verification.passed and run.plan.metrics["harvested"] > 0


def test_a_live_row_on_the_move_without_a_speed_says_what_it_expects(tmp_path):
    from typer.testing import CliRunner

    from coplan.cli import app

    r = CliRunner(env={"COLUMNS": "400"}).invoke(app, ["run", "sparse_row", "--out", str(tmp_path / "o")])
    said = " ".join(r.output.split())
    assert r.exit_code == 2 and "--speed: a live row on the move needs its cruising speed: give --speed V (m/s) or --speed auto" in said
    assert "--gantry stop-and-go" in said and "V: expected a cruising speed in [" in said
    assert "found nothing" not in said and "nan" not in r.output


def _refusing_a_fruit(prob, real, seen: dict, calls: list | None = None, interrupt_again: bool = False,
                      always: bool = False):
    """A stand-in for the row's cell planner: at the first stop with more than one fruit, its
    first fruit is left out (``seen``: which, and where); with ``interrupt_again``, planning that
    fruit's second chance is interrupted (Ctrl-C); with ``always``, it is left out at every stop.
    ``calls``: each cell's fruit, in turn."""
    from coplan.problem.gantry import cell_at as cell_of

    calls = [] if calls is None else calls

    def refusing(cell, opts, drive=None):
        ids = [f.id for f in cell.fruits]
        calls.append(ids)
        if interrupt_again and seen and ids == [seen["fruit"]]:
            raise KeyboardInterrupt
        if not seen and len(ids) > 1:
            x = cell.arms[0].base[0] - prob.arms[0].base[0]
            seen.update(fruit=ids[0], x=x)
            p = real(cell_of(prob, x, tuple(ids[1:])), opts, drive)
            p.solver["left_out"] = {ids[0]: "made to fail here by the test"}
            return p
        if always and seen and seen["fruit"] in ids:
            x = cell.arms[0].base[0] - prob.arms[0].base[0]
            p = real(cell_of(prob, x, tuple(i for i in ids if i != seen["fruit"])), opts, drive)
            p.solver["left_out"] = {seen["fruit"]: "made to fail again by the test"}
            return p
        return real(cell, opts, drive)

    return refusing


def test_a_fruit_a_stops_cell_leaves_out_gets_a_second_chance_elsewhere_on_the_rail(monkeypatch, tmp_path):
    """(Three arms 0.35 m apart: a stop's coordination found no schedule for four fruit and the
    row left them out, "at the stop at 3.95 m", though a stop at 3.0 m harvests them.) Here the
    cell planner is made to leave one fruit out at the stop that first takes it: the row plans
    it at another stop, at least RETRY_AWAY[0] from there, verified, and says so."""
    import coplan.row.plan as rp
    from coplan.row.plan import RETRY_AWAY

    prob = parse_problem(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=5, trusses=False)))
    seen: dict = {}
    monkeypatch.setattr(rp, "_cell_plan", _refusing_a_fruit(prob, rp._cell_plan, seen))
    res = plan_row(prob, RowOptions(workers=1))
    f = seen["fruit"]
    assert res.verification.passed and res.plan.metrics["harvested"] == len(prob.fruits)
    assert res.info["second_chance"] == {"stops": 1, "fruit": 1, "harvested": 1, "dropped": 0} and f not in res.info["left_out"]
    again = next(sp for sp in res.stops if f in sp.stop.fruit and f not in sp.plan.solver.get("left_out", {}))
    assert abs(again.stop.x - seen["x"]) >= RETRY_AWAY[0] - 1e-9
    ahead = res.reach.grid[res.reach.cover[f].any(axis=0)] > seen["x"] + RETRY_AWAY[0]
    assert ahead.any() and again.stop.x > seen["x"]  # ahead of where it failed: the carriage has not passed it
    assert any(e.fruit == f and e.kind.value == "pick" for e in again.plan.events)
    seen.clear()  # the command line's summary says so too
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=5, trusses=False)))
    from typer.testing import CliRunner

    from coplan.cli import app

    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["solve", str(path), "--workers", "1", "-o", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    assert "1 of them a second chance for 1 fruit a stop's cell left out: 1 harvested there" in " ".join(r.output.split())


def test_a_second_chance_stop_whose_cell_picks_nothing_is_not_driven_to(monkeypatch, tmp_path):
    """(A second-chance stop whose cell left the fruit out too stayed in the row: the carriage
    drove to two stops and settled there for nothing, 3.0 s more than with no second chance.)
    The fruit is left out at every stop: the row is the one with no second chance, stop for
    stop, and the reason names every stop it was tried at."""
    import coplan.row.plan as rp

    prob = parse_problem(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=5, trusses=False)))
    runs = {}
    for away in (rp.RETRY_AWAY, ()):
        seen: dict = {}
        monkeypatch.setattr(rp, "RETRY_AWAY", away)
        monkeypatch.setattr(rp, "_cell_plan", _refusing_a_fruit(prob, rp._cell_plan, seen, always=True))
        runs[away] = (plan_row(prob, RowOptions(workers=1)), dict(seen))
        monkeypatch.undo()
    (res, seen), (alone, _) = runs[rp.RETRY_AWAY], runs[()]
    f = seen["fruit"]
    assert res.verification.passed and res.plan.metrics["harvested"] == len(prob.fruits) - 1
    assert all(any(e.kind.value == "pick" for e in sp.plan.events) for sp in res.stops)
    assert [sp.stop.x for sp in res.stops] == [sp.stop.x for sp in alone.stops]
    assert res.plan.metrics["makespan"] == pytest.approx(alone.plan.metrics["makespan"], abs=1e-9)
    again = res.info["second_chance"]
    assert again["stops"] == 0 and again["dropped"] >= 1 and again["harvested"] == 0
    why = res.info["left_out"][f]
    assert why.count("at the stop at") == 1 + again["dropped"] and "made to fail again by the test" in why


def test_the_stop_rules_price_each_stop_with_the_carriages_settle():
    """(The optimised rule priced a stop without the carriage's settle, which every stop waits: on
    a row with ``settle: 20`` it chose as many stops as with none.) Each moving stop costs
    ``settle`` more; a long settle makes the rule take fewer stops."""
    from dataclasses import replace

    from coplan.row.stops import TripCosts, arm_overheads, optimised_stops, price_stops

    prob = parse_problem(to_yaml(gantry_row(length=20.0, n_arms=2, density=3.0, seed=1, trusses=False)))
    slow = replace(prob, gantry=replace(prob.gantry, settle=20.0))
    reach = row_reach(prob)
    todo = reach.harvestable()
    ks = sorted({s.k for s in optimised_stops(prob, row_reach(prob))[0]})
    cost = TripCosts(prob, reach, todo)
    cost.add(ks)
    over = arm_overheads(prob)
    t0, st0, _ = price_stops(prob, reach, cost, todo, ks, over, prob.gantry.start, 0.0)
    t1, st1, _ = price_stops(slow, reach, cost, todo, ks, over, prob.gantry.start, 0.0)
    moving = sum(1 for i, s in enumerate(st0) if s.x != (st0[i - 1].x if i else prob.gantry.start))
    assert st0 == st1 and t1 - t0 == pytest.approx(20.0 * moving, abs=1e-6)
    assert len(optimised_stops(slow, row_reach(slow))[0]) < len(ks)


def test_an_interruption_during_the_second_chance_keeps_every_stop_planned(monkeypatch):
    """(Ctrl-C while a left-out fruit's second stop was planned kept the row's stops and said
    "after 2 of the 2 stops kept so far", not when it came.)"""
    import coplan.row.plan as rp
    from coplan.kinds import PlanStatus

    prob = parse_problem(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=5, trusses=False)))
    calls: list = []
    monkeypatch.setattr(rp, "_cell_plan", _refusing_a_fruit(prob, rp._cell_plan, {}, calls, interrupt_again=True))
    res = plan_row(prob, RowOptions(workers=1))
    assert res.plan.status == PlanStatus.INTERRUPTED
    assert "second chance" in res.info["interrupted"] and len(res.stops) == len(calls) - 1
    assert res.verification.passed and res.plan.metrics["harvested"] == len(prob.fruits) - 1


def test_a_partial_row_whose_harvestable_fruit_are_all_harvested_says_why(tmp_path):
    """(A fruit reachable only from a window between the candidate stops made the row partial
    beside "10 harvested of 10 harvestable (100.0 %)", exit 5, and said no more.)"""
    from typer.testing import CliRunner

    from coplan.cli import app

    d = gantry_row(length=6.0, n_arms=1, density=1.0, seed=3, trusses=False)
    arm = parse_problem(to_yaml(d)).arms[0]
    reach = sum(arm.links) - 0.01  # (the task's reach margin)
    d["fruits"].append({"id": "narrow", "position": [3.025, round(math.sqrt(reach**2 - 0.012**2), 6)]})  # a 24 mm window
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(d))
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["solve", str(path), "-o", str(tmp_path / "o")])
    said = " ".join(r.output.split())
    assert r.exit_code == 5 and "status partial" in said and "(100.0 %)" in said
    assert "why partial 1 screened-out fruit is still reachable" in said and "--resolution 0.022" in said


def test_a_partial_row_shows_no_ratio_to_bounds_that_count_fruit_it_left(tmp_path):
    """Regression (a new-user trial): a row whose bounds count a fruit the plan left out -- only
    a window of rail narrower than the candidate stops' spacing serves it -- printed "ratio
    0.774" to the stop-by-stop bound, "below 1, as this plan's arms work 0.55 s while the
    carriage moves", and on the move at a speed given, 78 of 93 fruit, "ratio 1.099". Now the
    summary and coplan compare give no ratio for a partial harvest, and say why."""
    import json

    from typer.testing import CliRunner

    from coplan.cli import app

    doc = gantry_row(length=4.0, n_arms=2, density=2.0, seed=3)
    doc["arms"] = doc["arms"][:1]
    doc["fruits"][-1]["position"] = [2.725, 1.7899]
    path = tmp_path / "narrow.yaml"
    path.write_text(to_yaml(doc))
    run = CliRunner(env={"COLUMNS": "250"})
    out = run.invoke(app, ["solve", str(path), "--out", str(tmp_path / "run")])
    text = " ".join(out.output.split())
    assert "status partial" in text and "no ratio for a partial harvest" in text, out.output
    assert "count all 6 fruit an arm reaches from some carriage position" in text
    assert ", ratio " not in text.split("row time", 1)[1].split("stops", 1)[0]
    # plan.json says the same (its metrics.row had "ratio_any_plan_bound": 0.941 beside the summary's
    # "no ratio"), and its gap_to_lower_bound is null too
    metrics = json.loads((tmp_path / "run" / "plan.json").read_text())["metrics"]
    assert metrics["harvested"] < metrics["row"]["lower_bound"]["fruit"]
    assert metrics["row"]["ratio_any_plan_bound"] is None and metrics["row"]["ratio_stop_and_go_bound"] is None
    assert metrics["gap_to_lower_bound"] is None
    cmp = run.invoke(app, ["compare", str(path), "--out", str(tmp_path / "cmp")])
    assert cmp.exit_code in (0, 5), cmp.output
    rows = json.loads((tmp_path / "cmp" / "compare.json").read_text())["rows"]
    assert rows and all(r["ratio_any_plan_bound"] is None and r["ratio_stop_and_go_bound"] is None for r in rows)


def test_check_s_carriage_span_is_never_more_than_the_rail(tmp_path):
    """(A 0.05 m rail's two serving positions read "carriage span 0.10 m".)"""
    import json

    from typer.testing import CliRunner

    from coplan.cli import app

    path = tmp_path / "short.yaml"
    d = gantry_row(length=6.0, density=1.0, seed=0, n_arms=2)
    d["gantry"]["end"] = 0.05
    d["fruits"] = [{"id": "f1", "position": [0.3, 1.0]}]
    path.write_text(to_yaml(d))
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["check", str(path), "--json"])
    assert r.exit_code == 0, r.output
    assert json.loads(r.output)["carriage_span"] == pytest.approx(0.05)


def test_compare_on_a_row_says_why_a_rule_s_row_is_not_a_success(tmp_path):
    """(A row without fruit compared as three rows of "0.0 s, verified" and exit 0, where solve
    says infeasible, nothing to harvest.) Each rule's status is in compare.json, and a rule whose
    row is not a success gets a note, printed and in compare.md."""
    import json

    from typer.testing import CliRunner

    from coplan.cli import app

    path = tmp_path / "empty.yaml"
    d = gantry_row(length=6.0, density=1.0, seed=0, n_arms=2)
    d["fruits"] = []
    path.write_text(to_yaml(d))
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["compare", str(path), "--out", str(tmp_path / "c")])
    assert r.exit_code == 4, r.output  # (infeasible, as solve says of it; it exited 0 "ok")
    for rule in ("optimised", "fixed", "fewest"):
        line = f"stop rule {rule}: status infeasible: no fruit can be harvested from any carriage position (the problem lists no fruit)"
        assert f"note: {line}" in r.output and line in (tmp_path / "c" / "compare.md").read_text()
    line = "on the move: status infeasible: no fruit can be harvested from any carriage position (the problem lists no fruit)"
    assert f"note: {line}" in r.output
    doc = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert {row["status"] for row in doc["rows"]} == {"infeasible"} and len(doc["notes"]) == 4 and doc["best"] is None


def test_compare_on_a_row_says_which_fruit_no_plan_can_harvest(tmp_path):
    """(From a grower's trial: every line of a row's comparison read "harvested 100.0 %" of a row
    whose three fruit no arm reaches, and nothing said so.)"""
    from coplan.report.rows import compare_rows, to_markdown

    cmp = compare_rows(_narrow(), tmp_path / "c", rules=("fewest",), gantry="stop-and-go")
    note = ("2 of the row's 3 fruit no plan can harvest: 1 out of every arm's reach from every carriage position and "
            "1 screened out")
    assert any(n.startswith(note) for n in cmp.notes) and note in to_markdown(cmp)
    assert "harvested, of harvestable" in to_markdown(cmp)
    row = cmp.rows[0]
    assert row["share_harvested"] == 1.0 and row["share_of_all_fruit"] == pytest.approx(1 / 3)


TINY_FRUIT = {"f1": (0.8, 0.7), "f2": (1.3, 1.2), "f3": (2.5, 0.9), "f4": (3.5, 1.0)}


@pytest.mark.parametrize("end", [0.001, 0.03, 0.049, 0.07])
def test_a_rail_shorter_than_the_screen_s_spacing_keeps_every_position_and_stop_on_it(end):
    """(From a user's trial: on a rail of 1 mm the screen put a position at 0.05 m, past the
    rail's end; f4, served only from there, was called harvestable, and the stop-and-go plan
    stopped there -- unsafe, exit 6 -- while on the move it was 'success' with 3 of 4
    harvestable harvested.) Every screened position is on the rail, f4 (1.802 m from arm3's
    base even at the rail's end) is out of reach, and both modes plan a verified row."""
    row = parse_problem(course_arms_row(end, TINY_FRUIT, "tiny-rail"))
    reach = row_reach(row)
    assert reach.grid[0] == 0.0 and reach.grid[-1] == pytest.approx(end) and np.all(np.diff(reach.grid) > 0)
    served_from = 1.5 - math.sqrt(1.79**2 - 1.0)  # arm3 reaches f4 (outer reach 1.8 less the 0.01 margin) from here on
    assert ("f4" in reach.harvestable()) == (end >= served_from)
    for res in (plan_row(row, RowOptions()), plan_moving(row, MovingOptions())):
        assert res.verification.passed, res.verification.violations[:3]
        assert float(np.max(res.plan.gantry_x)) <= end + 1e-9


def test_on_a_row_its_first_segment_covers_the_optimised_rule_is_no_slower_than_the_baselines():
    """(From a user's trial: two fruit on an 8 m rail, one at the edge of reach, served only
    with an arm's base nearly under it: the optimised rule stopped at 5.90 m, the first fruit's
    last chance where a receding rule starts, 17.80 s; the fewest rule's 2.20 m took 10.51 s.)
    Where the whole row is the first segment the fewest rule's stops are priced beside the
    strides: no slower than either baseline, verified."""
    text = course_arms_row(8.0, {"mid": (4.0, 1.0), "rim": (4.025, 1.78)}, "two-fruit")
    row = parse_problem(text)
    times = {}
    for rule in (StopRule.OPTIMISED, StopRule.FEWEST, StopRule.FIXED):
        res = plan_row(row, RowOptions(stops=rule))
        assert res.verification.passed and res.plan.metrics["harvested"] == 2, rule
        times[rule] = res.plan.metrics["makespan"]
    assert times[StopRule.OPTIMISED] <= min(times[StopRule.FEWEST], times[StopRule.FIXED]) + 1e-9, times


def test_coplan_check_notes_a_rail_far_longer_than_where_its_fruit_lie(tmp_path):
    """(From a user's trial: gantry.end written in mm, 8000, was 'a row of 8000 m' without a word,
    where fruit coordinates and links in mm get a hint.)"""
    from typer.testing import CliRunner

    from coplan.cli import app

    for end, noted in (("8000.0", True), ("8.0", False)):
        p = tmp_path / f"r{end}.yaml"
        p.write_text(course_arms_row(float(end), TINY_FRUIT))
        r = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["check", str(p)])
        assert r.exit_code in (0, 5) and ("gantry.end in mm?" in r.output) == noted, r.output


@pytest.mark.parametrize("end", [0.001, 8.0])
def test_on_the_move_the_row_s_top_speed_is_the_one_the_carriage_reaches(end):
    """(From a user's trial: on a 1 mm rail the summary said 'top 0.181 m/s', the speed profile's,
    which no carriage reaches in 1 mm.) metrics.row.top_speed is the most the carriage's samples
    reach, never above the profile's."""
    row = parse_problem(course_arms_row(end, TINY_FRUIT))
    res = plan_moving(row, MovingOptions())
    m = row_metrics(row, res)
    x, t = np.asarray(res.plan.gantry_x), np.asarray(res.plan.time)
    reached = float(np.max(np.abs(np.diff(x) / np.diff(t))))
    assert m["top_speed"] == pytest.approx(reached, abs=1e-12) and m["top_speed"] <= res.info["top_speed"] + 1e-12
    if end < 0.01:
        assert m["top_speed"] < 0.05  # (1 mm at the gantry's 0.5 m/s^2 and 5 m/s^3)


def test_check_of_a_partial_row_says_why_it_exits_5(tmp_path):
    """(A new-user trial: `coplan check` of a row with a fruit served only from a window narrower
    than the screen's positions exited 5 and said nothing of why.) It now names the fruit that
    make it partial and the way out; --json lists them; a finer --resolution serves the fruit."""
    import json

    from typer.testing import CliRunner

    from coplan.cli import app

    d = gantry_row(length=6.0, n_arms=1, density=1.0, seed=3, trusses=False)
    arm = parse_problem(to_yaml(d)).arms[0]
    reach = sum(arm.links) - 0.01  # (the task's reach margin)
    d["fruits"].append({"id": "narrow", "position": [3.025, round(math.sqrt(reach**2 - 0.012**2), 6)]})  # a 24 mm window
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(d))
    run = CliRunner(env={"COLUMNS": "200"}).invoke
    r = run(app, ["check", str(path)])
    said = " ".join(r.output.split())
    assert r.exit_code == 5 and "partial solve would exit 5: 1 fruit an arm reaches" in said and "(narrow; why above)" in said, said
    assert "a finer --resolution" in said
    doc = json.loads(run(app, ["check", str(path), "--json"]).output)
    assert doc["reachable_not_harvestable"] == ["narrow"] and doc["exit_code"] == 5
    fine = run(app, ["check", str(path), "--resolution", "0.01"])
    assert fine.exit_code == 0 and "would exit 5" not in fine.output, fine.output


@pytest.mark.parametrize("gantry", ["stop-and-go", "continuous"])
def test_a_ctrl_c_once_the_row_is_planned_keeps_it_written(tmp_path, monkeypatch, gantry):
    """(A new user's trial: Ctrl-C while a planned row's lower bounds were computed, or while it
    was assembled and verified, exited 130 and wrote nothing -- the whole row thrown away.) The
    row is kept and written whole, said interrupted (exit 130): without its bounds where they
    were cut short; assembled and verified in full where the Ctrl-C came during that (held)."""
    import json
    import os
    import signal

    import coplan.allocate.row_bound as rb
    import coplan.row.plan as rp
    from coplan.cli import app
    from coplan.generate import gantry_row, to_yaml
    from coplan.kinds import ExitCode
    from typer.testing import CliRunner

    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=6.0, density=2.0, seed=4)))

    def no_bounds(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(rb, "row_bounds", no_bounds)
    res = CliRunner().invoke(app, ["solve", str(path), "--gantry", gantry, "-o", str(tmp_path / "b")])
    assert res.exit_code == ExitCode.INTERRUPTED, res.output
    doc = json.loads((tmp_path / "b" / "plan.json").read_text())
    assert doc["status"] == "interrupted" and doc["metrics"]["lower_bound"] is None
    assert doc["metrics"]["harvested"] == doc["metrics"]["harvestable"] > 0  # the whole row, planned and verified
    assert "no lower bounds: interrupted (Ctrl-C) while its lower bounds were computed" in " ".join(res.output.split())
    monkeypatch.undo()
    if gantry != "stop-and-go":
        return
    real = rp.finalize_row

    def ctrl_c_midway(*a, **k):  # the signal itself, as the terminal sends it, halfway through
        os.kill(os.getpid(), signal.SIGINT)
        return real(*a, **k)

    monkeypatch.setattr(rp, "finalize_row", ctrl_c_midway)
    res = CliRunner().invoke(app, ["solve", str(path), "-o", str(tmp_path / "f")])
    assert res.exit_code == ExitCode.INTERRUPTED, res.output
    doc = json.loads((tmp_path / "f" / "plan.json").read_text())
    assert doc["status"] == "interrupted" and doc["verification"]["passed"]
    assert doc["solver"]["row"]["interrupted"].startswith("while the planned row was assembled and verified")
    assert doc["metrics"]["harvested"] == doc["metrics"]["harvestable"] > 0


def test_a_ctrl_c_ends_an_idle_pool_worker_without_a_traceback():
    """(``coplan solve ROW --workers 2`` interrupted: a worker waiting for its next task printed a
    KeyboardInterrupt traceback under the command's own message.) A pool worker between tasks
    ends quietly; inside a task the Ctrl-C is a KeyboardInterrupt there, as before."""
    import subprocess
    import sys

    code = (
        "import multiprocessing, os, signal, time\n"
        "from coplan.workers import process_pool\n"
        "pool = process_pool(2)\n"
        "pool.submit(time.sleep, 0.2).result()\n"
        "procs = multiprocessing.active_children()\n"
        "assert len(procs) == 2, procs\n"
        "for p in procs: os.kill(p.pid, signal.SIGINT)\n"
        "time.sleep(1.0)\n"
        "pool.shutdown(wait=True)\n"
        "print('left', len(multiprocessing.active_children()))\n"
    )
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert "Traceback" not in res.stderr and "KeyboardInterrupt" not in res.stderr, res.stderr
    assert res.returncode == 0 and "left 0" in res.stdout, (res.stdout, res.stderr)


def test_the_summary_says_how_long_the_carriage_stood_for_its_first_stop_where_that_is_long():
    """(A new user's trial: --planner optimal on a 10 m row, its first motion after 42.29 s of a
    47 s row, was summed up "least slack 0.00 s (kept ahead of the carriage)".) Beyond 5 % of the
    row time the wait is said beside it; a short one, as before."""
    from coplan.cli.summary import _row_planning

    def said(first: float) -> str:
        lines: list[str] = []
        r = {"first_motion_seconds": first, "first_stop_seconds": first, "row_time": 47.04, "kept_ahead": True,
             "planning_time": 50.5, "slowest_stop_seconds": 8.0, "least_slack_seconds": 0.0}
        _row_planning(lambda text, **k: lines.append(text), r, {}, moving=False)
        return " ".join(lines)

    assert "kept ahead of the carriage once it moved; it stood 42.29 s first, 90 % of the row time" in said(42.29)
    assert said(0.4).endswith("(kept ahead of the carriage)")
