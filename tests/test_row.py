"""A whole greenhouse row on a mobile gantry: row files, the row's screen, the stop rules, the
row plan verified in the row frame, its lower bounds and metrics, the command line.

Rows here are short (10-14 m) so that the suite stays quick; the benchmark
(``benchmarks/bench_rows.py``) runs the shipped 50 m rows."""

from __future__ import annotations

import json
import math
import re
from dataclasses import replace

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from coplan.cli import app
from coplan.errors import PlanFileError, ProblemError
from coplan.generate import gantry_row, to_yaml
from coplan.kinematics.timing import Move1D, scurve_time, scurve_times
from coplan.kinds import StopRule
from coplan.plan import EventKind, load_plan
from coplan.problem import load_problem, parse_problem, shipped_rows
from coplan.problem.gantry import cell_at
from coplan.allocate.row_bound import cycle_bounds, row_bounds
from coplan.allocate.row_cycles import cell_cycles, home_savings
from coplan.row.plan import RowOptions, plan_row
from coplan.row.reach import row_reach
from coplan.row.stops import fewest_stops, round_trips
from coplan.verify import verify
from coplan.verify.verdict import ViolationKind


def _row(length=12.0, density=4.0, seed=5, **kw):
    return parse_problem(to_yaml(gantry_row(length=length, density=density, seed=seed, **kw)))


@pytest.fixture(scope="module")
def row():
    return _row()


@pytest.fixture(scope="module")
def planned(row):
    return {rule: plan_row(row, RowOptions(stops=rule)) for rule in StopRule}


# --------------------------------------------------------------------------- files
def test_the_shipped_rows_load_with_their_gantry():
    names = {p.stem for p in shipped_rows()}
    assert {"course_row", "sparse_row", "dense_row", "six_arm_row"} <= names
    for p in shipped_rows():
        prob = load_problem(p)
        assert prob.gantry is not None and prob.gantry.length == 50.0
        assert len(prob.fruits) >= 50 and all(0.0 <= f.position[0] <= 50.0 for f in prob.fruits)


def _with(text: str, **gantry) -> str:
    d = yaml.safe_load(text)
    d["gantry"].update(gantry)
    return to_yaml(d)


@pytest.mark.parametrize("change, path, words", [
    (dict(start=60.0), "gantry.end", "past its start"),
    (dict(max_velocity=0.0), "gantry.max_velocity", "speed limit > 0"),
    (dict(max_jerk=".nan"), "gantry.max_jerk", "found"),
    (dict(max_acceleration="fast"), "gantry.max_acceleration", "string 'fast'"),
    (dict(speed=1.0), "gantry.speed", "unknown key"),
    (dict(setle=1.0), "gantry.setle", "found unknown key 'setle'; did you mean 'settle'?"),
])
def test_bad_gantry_sections_are_refused_with_the_key_path_and_line(change, path, words):
    text = _with(to_yaml(gantry_row(length=10.0, density=2.0)), **change)
    if change.get("max_jerk") == ".nan":
        text = text.replace("max_jerk: '.nan'", "max_jerk: .nan")
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "row.yaml")
    issue = next(i for i in e.value.issues if i.path == path)
    assert words in issue.message and issue.line is not None
    assert text.splitlines()[issue.line - 1].strip().startswith(path.split(".")[-1]) or path in ("gantry.speed", "gantry.setle")


def test_every_bad_gantry_value_is_reported_at_once():
    """Regression (a new-user trial): ``start`` past ``end`` with ``max_velocity: 0`` reported only
    the speed; both now, each with its key path and line."""
    text = _with(to_yaml(gantry_row(length=10.0, density=2.0)), start=60.0, max_velocity=0.0)
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "row.yaml")
    paths = {i.path for i in e.value.issues}
    assert {"gantry.end", "gantry.max_velocity"} <= paths
    assert all(i.line is not None for i in e.value.issues)


def test_a_fruit_outside_the_rail_is_refused():
    d = gantry_row(length=10.0, density=2.0)
    d["fruits"][0]["position"] = [40.0, 1.0]
    with pytest.raises(ProblemError) as e:
        parse_problem(to_yaml(d), "row.yaml")
    issue = e.value.issues[0]
    assert issue.path == "fruits[0].position[0]" and "on this row" in issue.message and "40" in issue.message


def test_a_bad_row_file_writes_nothing(tmp_path):
    f = tmp_path / "row.yaml"
    f.write_text(_with(to_yaml(gantry_row(length=10.0, density=2.0)), max_velocity=0))
    r = CliRunner().invoke(app, ["solve", str(f), "--out", str(tmp_path / "o")])
    assert r.exit_code == 3 and "gantry.max_velocity" in r.output and not (tmp_path / "o").exists()


# --------------------------------------------------------------------------- the row's screen
def test_the_rows_screen_agrees_with_the_cell_screen_at_each_position(row):
    from coplan.allocate.screen import screened

    reach = row_reach(row)
    rng = np.random.default_rng(0)
    for k in rng.choice(reach.grid.size, 6, replace=False):
        cell = cell_at(row, float(reach.grid[k]))
        scr = screened(cell)
        for j, f in enumerate(cell.fruits):
            want = scr.reach[:, j]
            got = reach.cover[f.id][:, k] if f.id in reach.cover else np.zeros(len(row.arms), bool)
            assert np.array_equal(want, got), (f.id, k)


def test_a_fruit_no_stop_can_reach_is_left_out_with_its_reason():
    d = gantry_row(length=10.0, density=2.0)
    d["fruits"].append({"id": "high", "position": [5.0, 1.95]})  # above every arm's reach at any position
    prob = parse_problem(to_yaml(d))
    res = plan_row(prob, RowOptions(stops=StopRule.FEWEST))
    assert "high" in res.reach.reasons and "high" not in res.reach.cover
    assert "reach" in res.reach.reasons["high"]
    assert res.verification.passed and res.plan.status.value == "success"  # every harvestable fruit harvested
    assert res.info["left_out"]["high"] == res.reach.reasons["high"]


# --------------------------------------------------------------------------- stop rules
@pytest.mark.parametrize("rule", list(StopRule))
def test_every_harvestable_fruit_goes_to_exactly_one_stop_that_serves_it(row, planned, rule):
    res = planned[rule]
    seen = [f for sp in res.stops for f in sp.stop.fruit]
    assert sorted(seen) == sorted(res.reach.cover) and len(seen) == len(set(seen))
    for sp in res.stops:
        for f in sp.stop.fruit:
            assert res.reach.cover[f][:, sp.stop.k].any()
    xs = [sp.stop.x for sp in res.stops]
    assert xs == sorted(xs) and len(set(xs)) == len(xs)


def test_the_fewest_stops_are_no_more_than_any_other_rules(planned):
    n = {rule: len(res.stops) for rule, res in planned.items()}
    assert n[StopRule.FEWEST] <= n[StopRule.FIXED]
    reach = planned[StopRule.FEWEST].reach
    # a lower bound on any stop set: fruit whose serving spans are pairwise disjoint need a stop each
    spans = sorted((reach.span(f)[1], reach.span(f)[0]) for f in reach.cover)
    disjoint, end = 0, -1
    for hi, lo in spans:
        if lo > end:
            disjoint, end = disjoint + 1, hi
    assert n[StopRule.FEWEST] == disjoint == len(fewest_stops(reach))


# --------------------------------------------------------------------------- the row plan
@pytest.mark.parametrize("rule", list(StopRule))
def test_the_row_plan_is_verified_and_harvests_every_harvestable_fruit(planned, rule):
    res = planned[rule]
    assert res.verification.passed, [v.message for v in res.verification.violations[:5]]
    assert res.plan.status.value == "success" and res.plan.metrics["harvested"] == len(res.reach.cover)


def test_no_pick_happens_while_the_carriage_moves_and_it_stays_on_the_rail(row, planned):
    plan = planned[StopRule.OPTIMISED].plan
    x, dt = plan.gantry_x, plan.dt
    g = row.gantry
    assert x[0] == g.start and g.start - 1e-9 <= x.min() and x.max() <= g.end + 1e-9
    for e in plan.events:
        if e.kind == EventKind.PICK:
            seg = x[int(round(e.t_start / dt)):int(round(e.t_end / dt)) + 1]
            assert np.ptp(seg) == 0.0
    # the tip is over the fruit in row coordinates, independently of the verifier
    arms = {a.name: a for a in row.arms}
    for e in plan.events[:20]:
        if e.kind == EventKind.PICK:
            i = int(round(0.5 * (e.t_start + e.t_end) / dt))
            a = arms[e.arm]
            tip = a.fk(plan.q[a.name][i]) if hasattr(a, "fk") else None
            from coplan.kinematics import arm as kin

            tip = kin.fk(plan.q[a.name][i], a.links, (a.base[0] + x[i], a.base[1]))[1]
            assert math.dist(tip, row.fruit(e.fruit).position) < 1e-3


def test_the_verifier_catches_a_pick_on_the_move_a_fast_carriage_and_a_wrong_start(row, planned):
    plan = planned[StopRule.FEWEST].plan
    x = plan.gantry_x.copy()
    pick = next(e for e in plan.events if e.kind == EventKind.PICK)
    i0, i1 = int(round(pick.t_start / plan.dt)), int(round(pick.t_end / plan.dt))
    moved = x.copy()
    moved[i0:] += np.minimum(np.arange(moved.size - i0) * 0.004, 0.05)  # creeping on at 0.4 m/s during the pick
    v = verify(row, replace(plan, gantry_x=moved))
    kinds = {k.kind for k in v.violations}
    assert ViolationKind.PICK_DWELL in kinds or ViolationKind.PICK_MISSED in kinds
    jump = x.copy()
    jump[i1 + 1:] += 0.05  # a 5 cm step between two samples: 5 m/s
    assert ViolationKind.CARRIAGE in {k.kind for k in verify(row, replace(plan, gantry_x=jump)).violations}
    assert ViolationKind.CARRIAGE in {k.kind for k in verify(row, replace(plan, gantry_x=x + 0.01)).violations}
    with pytest.raises(PlanFileError):
        verify(row, replace(plan, gantry_x=None))
    with pytest.raises(PlanFileError):  # a row plan is not a plan of a cell
        verify(cell_at(row, 0.0), plan)


def test_clearance_is_the_same_in_the_row_frame_and_on_the_carriage(row, planned):
    """Arms on one carriage keep their distances whatever it does: the row-frame verdict equals
    the carriage-frame one (the plan's joints, the carriage left out), sample for sample."""
    plan = planned[StopRule.FEWEST].plan
    here = verify(row, plan)
    still = verify(cell_at(row, 0.0), replace(plan, gantry_x=None, events=[]), infer_events=False)
    assert here.summary()["min_clearance"] == pytest.approx(still.summary()["min_clearance"], abs=1e-9)
    assert here.summary()["certified_clearance"] == pytest.approx(still.summary()["certified_clearance"], abs=1e-9)


# --------------------------------------------------------------------------- bounds, metrics
def test_the_cycle_bound_is_below_every_sampled_cycle(row):
    cost, reach_any, _ = cycle_bounds(row)
    reach = row_reach(row, 0.01)
    c = round_trips(row, reach, list(reach.cover), np.arange(reach.grid.size))
    idx = {f.id: j for j, f in enumerate(row.fruits)}
    gaps = [v - cost[a, idx[f]] for (f, k, a), v in c.items()]
    assert min(gaps) >= -1e-9  # a bound over every position, not only the sampled ones
    best: dict = {}
    for (f, k, a), v in c.items():
        best[(f, a)] = min(best.get((f, a), np.inf), v - cost[a, idx[f]])
    assert np.median(list(best.values())) < 0.1  # and close to the best sampled position (1 cm apart)
    assert all(reach_any[a, idx[f]] for (f, k, a) in c)


def test_no_plan_beats_the_bounds(row, planned):
    """No plan beats the any-plan bound; coplan's stop-and-go plans beat the stop-by-stop bound
    (no cell work during a move) by at most the time their carriage moves while an arm works."""
    from coplan.row.metrics import row_metrics

    b = row_bounds(row)
    assert 0 < b.work <= b.any_plan <= b.stop_and_go
    assert b.stop_and_go == pytest.approx(max(b.any_plan, b.moves + b.work, b.priced)) and b.priced > 0
    for res in planned.values():
        m = row_metrics(row, res, b)
        assert m["row_time"] >= b.any_plan - 1e-9
        assert m["row_time"] >= b.stop_and_go - m["overlap_seconds"] - 1e-9
        assert 0 < m["overlap_seconds"] < m["row_time"]


def _locked_row_text() -> str:
    """Three arms 0.3 m apart on a 6 m row: the rear two cannot reach their bins (link 1 would
    cross the next arm's base on the way), the front one harvests every fruit."""
    doc = gantry_row(length=6.0, n_arms=3, density=2.0, seed=4)
    for arm, x in zip(doc["arms"], (-0.3, 0.0, 0.3)):
        arm["base"], arm["bin"] = [x, 0.0], [x, -0.5]
    return to_yaml(doc)


def test_a_row_whose_arms_are_locked_says_so_and_bounds_with_the_others(tmp_path):
    """Regression (a new-user trial: arms 0.3 m apart passed ``coplan check`` as a working row,
    its bound counting three arms, and stop and go was partial after 26.9 s): the row's screen
    names the locked arms with the cell screen's reason (bins ride with the carriage, so the
    verdict holds along the rail), ``coplan check`` says so in text and JSON, and the work bound
    is the unlocked arm's cycles alone (every harvest is one of its cycles, in turn)."""
    text = _locked_row_text()
    row = parse_problem(text)
    reach = row_reach(row)
    names = [a.name for a in row.arms]
    assert sorted(reach.locked) == names[:2]
    assert all("cannot reach its bin" in why for why in reach.locked.values())
    assert reach.cover and all(not c[:2].any() for c in reach.cover.values())  # (the screen already said so per fruit)
    cost, can, _ = cycle_bounds(row)
    assert not can[:2].any() and can[2].any()
    b = row_bounds(row)
    saving = home_savings(cell_cycles(row, 0.05))
    assert saving[2] > 0 and not saving[:2].any()  # (locked arms harvest nothing: nothing to save)
    # one arm: every cycle in turn, the first from home
    assert b.work == pytest.approx(float(cost[2, can[2]].sum()) - saving[2], rel=1e-6)
    path = tmp_path / "locked.yaml"
    path.write_text(text)
    out = CliRunner().invoke(app, ["check", str(path)])
    assert out.exit_code == 0, out.output  # (every fruit harvestable: the front arm reaches them all)
    assert "2 of 3 arms locked (arm1, arm2)" in out.output and "cannot reach its bin" in out.output
    doc = json.loads(CliRunner().invoke(app, ["check", str(path), "--json"]).output)
    assert sorted(doc["locked"]) == names[:2]
    # the priced-stops bound charges the one arm that harvests: at least its cycles and the carriage's way
    lb = doc["lower_bound"]
    assert lb["priced"] >= lb["work"] and lb["stop_and_go"] >= lb["priced"] and lb["priced_stops"] >= 1
    assert "where each fruit is picked from priced together" in out.output


def test_row_metrics_add_up(row, planned):
    from coplan.row.metrics import row_metrics

    res = planned[StopRule.FIXED]
    m = row_metrics(row, res, row_bounds(row))
    assert m["fruit_per_hour"] == pytest.approx(m["harvested"] / m["row_time"] * 3600)
    assert sum(m["fruit_per_hour_per_arm"].values()) == pytest.approx(m["fruit_per_hour"])
    assert m["time_per_metre"] == pytest.approx(m["row_time"] / row.gantry.length)
    assert m["stops"] == len(res.stops) and 0 < m["carriage_moving_share"] < 1 and 0 < m["picking_share"] < 1
    for causes in m["idle_share"].values():
        assert 0 <= sum(causes.values()) < 1
    assert m["ratio_any_plan_bound"] >= 1.0 and m["share_harvested"] == 1.0
    assert m["first_motion_seconds"] is not None and m["planning_over_row_time"] > 0


# --------------------------------------------------------------------------- the carriage's moves
def test_carriage_moves_are_time_optimal_s_curves_within_the_limits():
    rng = np.random.default_rng(3)
    for _ in range(20):
        x0, x1 = rng.uniform(-5, 5, 2)
        v, a, j = rng.uniform(0.2, 1.0), rng.uniform(0.2, 1.0), rng.uniform(1.0, 10.0)
        mv = Move1D.between(x0, x1, v, a, j)
        assert mv.duration == pytest.approx(scurve_time(abs(x1 - x0), v, a, j), abs=1e-12)
        t = np.linspace(0.0, mv.duration, 2001)
        p, vel, acc = mv.state(t)
        assert p[0] == pytest.approx(x0) and p[-1] == pytest.approx(x1) and abs(vel[-1]) < 1e-9
        assert np.max(np.abs(vel)) <= v * (1 + 1e-9) and np.max(np.abs(acc)) <= a * (1 + 1e-9)
        assert np.allclose(np.gradient(p, t), vel, atol=2e-3 * max(v, 1.0))
    d = rng.uniform(0, 3, 500)
    assert np.allclose(scurve_times(d, 0.5, 0.5, 5.0), [scurve_time(x, 0.5, 0.5, 5.0) for x in d], atol=1e-12)


# --------------------------------------------------------------------------- command line
def test_coplan_solve_verify_and_check_a_row(tmp_path):
    f = tmp_path / "row.yaml"
    f.write_text(to_yaml(gantry_row(length=10.0, density=3.0, seed=2)))
    run = CliRunner(env={"COLUMNS": "200"}).invoke
    r = run(app, ["solve", str(f), "--stops", "fewest", "--out", str(tmp_path / "o"), "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    row = doc["metrics"]["row"]
    assert row["stops"] >= 1 and row["share_harvested"] == 1.0 and doc["solver"]["row"]["rule"] == "fewest"
    plan = load_plan(tmp_path / "o" / "plan.json")
    assert plan.gantry_x is not None and plan.gantry_x.size == plan.time.size
    r = run(app, ["verify", str(f), str(tmp_path / "o" / "plan.json")])
    assert r.exit_code == 0 and "passed" in r.output and "carriage" in r.output
    for line in r.output.splitlines():  # a peak shown over 1 on a passed plan says why it passes
        if line.strip().startswith("peaks") and max(float(v) for v in re.findall(r"(\d+\.\d+)", line)) > 1.005:
            assert "rounding of the plan file" in line
    r = run(app, ["check", str(f)])
    assert r.exit_code == 0 and "harvestable from some carriage position" in r.output
    r = run(app, ["solve", str(f), "--planner", "heuristic", "--out", str(tmp_path / "h")])
    assert r.exit_code == 2 and "row" in r.output
    r = run(app, ["solve", "greenhouse_row", "--stops", "fixed", "--out", str(tmp_path / "c")])
    assert r.exit_code == 2 and "stationary cell" in r.output


def _pick_span(p):
    picks = [e for e in p.events if e.kind == EventKind.PICK]
    return min(e.t_start for e in picks), max(e.t_end for e in picks), float(p.time[-1])


def test_retimed_cells_pick_the_same_fruit_at_the_same_stops_and_put_no_stop_later(row, planned):
    """Each stop's coordinated cell retimed by CP-SAT (``RowOptions.retime``, on by default) is
    kept only where it verifies and makes no stop of the row later: its last pick, its stay (last
    pick less first), its end and its end less its first pick no later than the coordinated
    cell's. So the same stops, each arm the same fruit, every departure and the row no later
    (to the plan's grid, a sample per stop); on this row some cells are retimed, and the row is
    shorter."""
    from coplan.plan import DEFAULT_RATE

    on = planned[StopRule.OPTIMISED]
    off = plan_row(row, RowOptions(retime=False))
    assert on.verification.passed and off.verification.passed
    assert [(sp.stop.x, sp.stop.fruit) for sp in on.stops] == [(sp.stop.x, sp.stop.fruit) for sp in off.stops]
    assert on.plan.allocation == off.plan.allocation
    dt = 1.0 / DEFAULT_RATE
    for k, (a, b) in enumerate(zip(on.stops, off.stops)):
        assert a.depart <= b.depart + (k + 1) * dt
        (fa, la, ea), (fb, lb, eb) = _pick_span(a.plan), _pick_span(b.plan)
        assert la <= lb + 1e-9 and la - fa <= lb - fb + 1e-9 and ea <= eb + 1e-9 and ea - fa <= eb - fb + 1e-9
        if a.plan.solver.get("retime"):
            assert a.plan.verification["passed"] and a.plan.solver["retime"]["rounds"][0]["makespan"] < eb
    assert off.info["retimed_cells"] == 0 and off.info["retime"] is False and on.info["retime"] is True
    assert on.info["retimed_cells"] >= 1
    assert on.plan.metrics["makespan"] < off.plan.metrics["makespan"]
    # the first stop's cell is retimed only where the carriage's drive there leaves it the time
    # (a rule on the row: FIRST_RETIME_PER_FRUIT_ARM s per fruit and arm): with no drive, never
    from coplan.row.plan import _cell_plan

    sp = next(sp for sp in on.stops if sp.plan.solver.get("retime"))
    cell = cell_at(row, sp.stop.x, sp.stop.fruit)
    assert _cell_plan(cell, RowOptions(), drive=1e6).solver.get("retime")
    assert not _cell_plan(cell, RowOptions(), drive=0.0).solver.get("retime")


def test_the_summary_says_how_many_cells_were_retimed(tmp_path):
    f = tmp_path / "row.yaml"
    f.write_text(to_yaml(gantry_row(length=12.0, density=4.0, seed=5)))
    r = CliRunner(env={"COLUMNS": "250"}).invoke(app, ["solve", str(f), "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    doc = json.loads((tmp_path / "o" / "plan.json").read_text())
    n, stops = doc["solver"]["row"]["retimed_cells"], doc["metrics"]["row"]["stops"]
    assert n >= 1 and f"cell planner coordinated ({n} of {stops} cells retimed by CP-SAT)" in r.output
    # the certified margin and each arm's jerk, as a cell's summary gives them (a row's had neither)
    ver, per = doc["verification"], doc["metrics"]["per_arm"]
    assert f"margin            {1000 * ver['margin']:.1f} mm certified beyond the clearance" in r.output
    assert "jerk RMS / peak   " + ", ".join(f"{a} {v['rms_jerk']:.1f}" for a, v in list(per.items())[:1]) in r.output


def test_cells_planned_in_two_processes_give_the_same_row_plan_as_in_one(row, planned):
    """The stops' cells in worker processes beside the stop rule (``workers``): the same stops,
    cells, events and samples as in one process, every stop's cell ready no earlier than its stop
    was kept; ``--workers`` on a stop-and-go row is accepted by the CLI."""
    one = planned[StopRule.OPTIMISED]
    two = plan_row(row, RowOptions(workers=2))
    assert two.verification.passed
    assert [sp.stop.x for sp in two.stops] == [sp.stop.x for sp in one.stops]
    assert [(e.arm, e.fruit, e.kind, e.t_start) for e in two.plan.events] == [(e.arm, e.fruit, e.kind, e.t_start) for e in one.plan.events]
    assert np.array_equal(two.plan.gantry_x, one.plan.gantry_x)
    assert all(np.array_equal(two.plan.q[a], one.plan.q[a]) for a in one.plan.q)
    assert all(sp.ready >= two.info["first_stop_seconds"] and sp.seconds > 0 for sp in two.stops)
    assert RowOptions(workers="auto").workers >= 1
    assert two.info["workers"] == 2 == two.plan.solver["row"]["workers"]


def test_a_row_plan_records_the_workers_asked_for_on_any_machine(row, monkeypatch):
    """(From a trial of the any-machine promise: plan.json's solver.row.workers was the processes
    used, min(asked, cores): 2 on two cores, 1 under taskset -c 0, for the same plan.)"""
    import coplan.row.plan as row_plan

    monkeypatch.setattr(row_plan, "cores", lambda: 1)
    one_core = plan_row(row, RowOptions(workers=2))
    assert one_core.info["workers"] == 2 and one_core.verification.passed


def test_workers_on_a_stop_and_go_row_from_the_command_line(tmp_path):
    f = tmp_path / "row.yaml"
    f.write_text(to_yaml(gantry_row(length=8.0, density=3.0, seed=5)))
    r = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["solve", str(f), "--workers", "2", "--out", str(tmp_path / "o"), "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout)
    assert doc["status"] == "success" and doc["metrics"]["row"]["share_harvested"] == 1.0


def test_a_long_stretch_without_fruit_is_crossed():
    """Fruit at both ends of a 40 m row and none between: every rule plans it, verified."""
    d = gantry_row(length=40.0, density=0.0)
    d["fruits"] = [{"id": f"a{i}", "position": [1.0 + 0.4 * i, 1.0]} for i in range(4)] + \
                  [{"id": f"b{i}", "position": [37.0 + 0.4 * i, 1.1]} for i in range(4)]
    prob = parse_problem(to_yaml(d))
    for rule in StopRule:
        res = plan_row(prob, RowOptions(stops=rule))
        assert res.verification.passed and res.plan.metrics["harvested"] == 8, rule
        assert res.plan.gantry_x.max() > 30.0


def test_a_rail_far_from_zero_keeps_one_grid():
    """A rail from -2000 m: the grid's spacing read back from its points differs from the one
    asked for in the last bits, and a stretch screened later on it had one point more (the
    optimised rule crashed). The spacing is kept as asked; the row is planned and verified."""
    d = gantry_row(length=6.0, density=0.0)
    d["gantry"]["start"] = -2000.0
    d["fruits"] = [{"id": f"f{i}", "position": [0.5 + 1.2 * i, 1.0]} for i in range(4)]
    prob = parse_problem(to_yaml(d))
    lazy = row_reach(prob, lazy=True)
    assert lazy.ensure(10.0) and lazy.resolution == 0.05
    assert all(c.shape[1] == lazy.grid.size for c in lazy.cover.values())
    res = plan_row(prob, RowOptions(stops=StopRule.OPTIMISED))
    assert res.verification.passed and res.plan.metrics["harvested"] == 4


def test_a_row_plan_exports_its_carriage_and_the_live_cell_refuses_a_row(tmp_path, planned, row):
    from coplan.report.export import export_plan, trajectory

    plan = planned[StopRule.FEWEST].plan
    traj = trajectory(plan, 100.0)
    x, v, a = traj.carriage
    # the carriage, like the arms, one plan step later (within a sixth of a second difference)
    assert np.allclose(x, np.interp(traj.time - traj.delay, plan.time, plan.gantry_x), atol=row.gantry.max_acceleration * plan.dt**2 / 6 + 1e-9)
    assert np.max(np.abs(v)) <= row.gantry.max_velocity * (1 + 1e-9)
    table, _ = export_plan(plan, 100.0, "csv", tmp_path / "e.csv")  # read back as a plan: the carriage and the arms (and its events)
    back = load_plan(table)
    assert np.array_equal(back.gantry_x, x) and all(np.array_equal(back.q[a], traj.q[a]) for a in plan.q)
    paths = export_plan(plan, 50.0, "json", tmp_path / "ros")
    car = json.loads((tmp_path / "ros" / "carriage.json").read_text())
    assert car["joint_names"] == ["carriage_x"] and len(paths) == len(row.arms) + 2  # (and events.json)
    f = tmp_path / "row.yaml"
    f.write_text(to_yaml(gantry_row(length=10.0, density=2.0)))
    r = CliRunner().invoke(app, ["feed", str(f), "--out", str(tmp_path / "feed.yaml")])
    assert r.exit_code == 2 and "is a row" in r.output


def test_last_stop_serves_every_fruit_and_trades_the_move_against_the_busiest_arm(row):
    """:func:`coplan.row.stops.last_stop` (a live row's end, stop and go): the stop it returns
    serves every fruit with the arms given; none when no candidate does; for one fruit it is the
    candidate of least move plus cheapest round trip, computed here independently."""
    from coplan.row.livestops import last_stop

    reach = row_reach(row)
    g = row.gantry
    x_of = {f.id: f.position[0] for f in row.fruits}
    tail = sorted(reach.harvestable(), key=lambda f: (x_of[f], f))[-4:]
    arms = list(range(len(row.arms)))
    ks = range(reach.grid.size)
    k = last_stop(row, reach, tail, ks, arms, float(reach.grid[0]))
    assert k is not None and all(reach.cover[f][:, k].any() for f in tail)
    # no candidate serves a fruit the given arms never reach
    only = [a for a in arms if not reach.cover[tail[-1]][a].any()]
    if only:
        assert last_stop(row, reach, tail, ks, only, float(reach.grid[0])) is None
    assert last_stop(row, reach, tail, [k for k in ks if not reach.cover[tail[0]][:, k].any()], arms, 0.0) is None
    # one fruit: the least move + round trip, over every serving index
    f = tail[0]
    x0 = float(reach.grid[0])
    trips = round_trips(row, reach, [f], np.arange(reach.grid.size))

    def est(kk):
        move = Move1D.between(0.0, abs(float(reach.grid[kk]) - x0), g.max_velocity, g.max_acceleration, g.max_jerk).duration
        return min(t for (_, k2, _), t in trips.items() if k2 == kk) + move

    serving = sorted({k2 for (_, k2, _) in trips})
    got = last_stop(row, reach, [f], ks, arms, x0)
    assert est(got) <= min(est(kk) for kk in serving) + 1e-5


def test_stop_share_takes_what_the_next_stop_cannot_and_leaves_it_only_what_it_keeps_in_reach(row):
    """:func:`coplan.row.stops.stop_share` (a live row, stop and go): every fruit in reach here
    that no working arm serves from ``inset`` steps beyond the next stop on is taken here; a fruit
    left to the next stop stays in reach that far; a stopped arm is given nothing; with the next
    stop the same as this one (the row's end in view), everything in reach here is taken."""
    from coplan.row.cruise import Cruise, pick_windows
    from coplan.row.livestops import stop_share

    reach = row_reach(row)
    k = int(np.searchsorted(reach.grid, 4.0))
    k_plan = int(np.searchsorted(reach.grid, 7.0))
    cruise = Cruise.hops(row, [(0.0, float(reach.grid[k]))])
    windows = {f: [w for w in ws if w.hi >= cruise.duration] for f, ws in
               pick_windows(row, reach, cruise, row.task.pick_dwell).items()}
    windows = {f: ws for f, ws in windows.items() if ws}
    todo = reach.harvestable()
    for stopped, inset in (set(), 0), ({1}, 0), (set(), 2):
        working = [a for a in range(len(row.arms)) if a not in stopped]
        order, keep = stop_share(row, reach, windows, todo, k, k_plan, stopped, inset)
        here = {f for fs in order.values() for f in fs}
        assert not (set(order) & stopped) and here <= set(windows)
        served_here = {f for f in windows if any(w.arm in working for w in windows[f])}
        forced = 0
        for f in served_here:
            last = int(np.flatnonzero(reach.cover[f][working].any(axis=0))[-1])
            if last - inset < k_plan:
                forced += 1
                assert f in here, (f, last, k_plan)
        assert 0 < forced < len(served_here)  # (both kinds present: the test means something)
        everything, _ = stop_share(row, reach, windows, todo, k, k, stopped, inset)
        priced = {f for (f, _, a) in round_trips(row, reach, sorted(served_here), np.array([k]))
                  if a in working and any(w.arm == a for w in windows[f])}
        assert {f for fs in everything.values() for f in fs} == priced and here <= priced and len(priced) > 0


def test_check_and_solve_agree_on_a_row_with_a_fruit_no_arm_reaches(tmp_path):
    """A fruit out of every arm's reach from anywhere on the rail is not counted (as in a cell):
    ``coplan check`` says why it is left out and exits 0, as ``coplan solve`` does (check said 5,
    partial, before)."""
    d = gantry_row(length=8.0, density=2.0, seed=1)
    d["fruits"].append({"id": "high", "position": [4.0, 2.5]})
    f = tmp_path / "row.yaml"
    f.write_text(to_yaml(d))
    run = CliRunner(env={"COLUMNS": "200"}).invoke
    c = run(app, ["check", str(f)])
    s = run(app, ["solve", str(f), "--stops", "fewest", "--out", str(tmp_path / "o")])
    assert c.exit_code == s.exit_code == 0, (c.output, s.output)
    assert "high" in c.output and "1 not" in c.output


def test_rebalance_never_lengthens_and_ends_where_no_single_move_shortens_the_stops():
    """:func:`coplan.row.balance.rebalance` on seeded random assignments (stops x arms, each fruit
    with its own (round trip, stop, arm) options, placed at random): the sum of the stops'
    busiest arms never grows; afterwards every fruit is in one of its options exactly once, the
    loads are the sums of what is placed (with each used arm's overhead once per stop), and no
    single fruit moved to another option shortens the sum (checked here by recomputing it)."""
    from coplan.row.balance import rebalance

    def total(placed, S, A, over):
        load = [[0.0] * A for _ in range(S)]
        used = set()
        for _, _, c, i, a, _ in placed:
            load[i][a] += c + (0.0 if (i, a) in used else over[a])
            used.add((i, a))
        return load, sum(max(r) for r in load)

    for seed in range(40):
        rs = np.random.default_rng(seed)
        S, A, F = int(rs.integers(1, 5)), int(rs.integers(1, 5)), int(rs.integers(1, 30))
        over = [float(rs.uniform(0.0, 2.0)) for _ in range(A)]
        chosen = []
        for j in range(F):
            keys = {(int(rs.integers(S)), int(rs.integers(A))) for _ in range(int(rs.integers(1, 5)))}
            o = [(round(float(rs.uniform(1.0, 4.0)), 6), i, a) for i, a in sorted(keys)]
            c, i, a = o[int(rs.integers(len(o)))]
            chosen.append([j, f"f{j}", c, i, a, o])
        load, before = total(chosen, S, A, over)
        peak = [max(r) for r in load]
        at = [[(j, f) for j, f, _, i, _, _ in chosen if i == s] for s in range(S)]
        rebalance(load, peak, at, chosen, over, passes=1000)
        again, after = total(chosen, S, A, over)
        assert after <= before + 1e-9
        assert np.allclose(load, again) and np.allclose(peak, [max(r) for r in again])
        assert sorted(f for s in at for _, f in s) == sorted(f"f{j}" for j in range(F))
        for ch in chosen:
            assert (ch[2], ch[3], ch[4]) in ch[5] and (ch[0], ch[1]) in at[ch[3]]
        for n, ch in enumerate(chosen):
            for c2, i2, a2 in ch[5]:
                moved = [list(x) for x in chosen]
                moved[n][2:5] = [c2, i2, a2]
                assert total(moved, S, A, over)[1] >= after - 1e-9
                # nor a chain: a fruit of a stop's busiest arm to (i2, a2), one of the fruit there
                # on to another of its options
                if again[ch[3]][ch[4]] < max(again[ch[3]]) - 1e-9:
                    continue
                for m, g in enumerate(chosen):
                    if m == n or (g[3], g[4]) != (i2, a2) or (i2, a2) == (ch[3], ch[4]):
                        continue
                    for c3, i3, a3 in g[5]:
                        two = [list(x) for x in moved]
                        two[m][2:5] = [c3, i3, a3]
                        assert total(two, S, A, over)[1] >= after - 1e-9


def test_rebalance_moves_a_chain_where_no_single_move_shortens():
    """The case that priced dense_row's stop at 28.7 m 15 % above its cell: the front arm is the
    busiest, its fruit would make the middle arm busier still, and the rear arm has time to
    spare only for the middle arm's fruit -- no single move shortens the stop, the chain of two
    does (16 s -> 15 s, the least any assignment of these fruit has)."""
    from coplan.row.balance import rebalance

    over = [0.0, 0.0, 0.0]
    chosen = [[0, "r", 10.0, 0, 0, [(10.0, 0, 0)]],  # only the rear arm
              [1, "m", 12.0, 0, 1, [(12.0, 0, 1)]],  # only the middle arm
              [2, "x", 3.0, 0, 1, [(3.0, 0, 0), (3.0, 0, 1)]],  # middle or rear
              [3, "y", 3.0, 0, 2, [(3.0, 0, 1), (3.0, 0, 2)]],  # front or middle
              [4, "g", 13.0, 0, 2, [(13.0, 0, 2)]]]  # only the front arm
    load, peak, at = [[10.0, 15.0, 16.0]], [16.0], [[(j, f) for j, f, *_ in chosen]]
    single = [list(c) for c in chosen]
    p1 = list(peak)
    rebalance([list(r) for r in load], p1, [list(a) for a in at], single, over, chains=False)
    assert p1 == [16.0] and [c[4] for c in single] == [0, 1, 1, 2, 2]  # no single move shortens it
    rebalance(load, peak, at, chosen, over)
    assert peak == [15.0] and load == [[13.0, 15.0, 13.0]]
    assert {c[1]: c[4] for c in chosen} == {"r": 0, "m": 1, "x": 0, "y": 1, "g": 2}


@pytest.mark.parametrize("n_arms, length", [(3, 16.0), (6, 24.0)])
def test_the_segment_that_reaches_the_rows_end_takes_every_fruit_left(n_arms, length):
    """The optimised rule's segment whose window reaches the end of the rail takes every fruit
    still to harvest: no stop of its own after it for the fruit that looked dear per fruit (a
    6-arm 24 m row had a third segment for 4 fruit). These rows are shorter than the first
    segment and the next: two segments, every harvestable fruit in exactly one stop."""
    from coplan.row.stops import optimised_stops

    for seed in range(4):
        row = _row(length=length, density=6.0, seed=seed, n_arms=n_arms)
        reach = row_reach(row, lazy=True)
        stops, info = optimised_stops(row, reach)
        assert info["segments"] == 2
        got = [f for s in stops for f in s.fruit]
        assert sorted(got) == sorted(reach.harvestable())


def test_an_optimal_cell_holds_the_carriage_no_longer_than_the_coordinated_one():
    """(With --planner optimal a 10 m row took 30.69 s against 30.47 s with coordinated cells: the
    optimal planner shortens the last place, and a cell whose last pick came later held the
    carriage longer.) Each stop keeps the optimal cell only where it holds the carriage no longer;
    the row is then no slower than with the coordinated cells at the same stops."""
    from coplan.kinds import PlannerKind

    row = parse_problem(to_yaml(gantry_row(length=8.0, density=2.0, seed=3)))
    coord = plan_row(row, RowOptions(stops=StopRule.FIXED))
    opt = plan_row(row, RowOptions(stops=StopRule.FIXED, planner=PlannerKind.OPTIMAL, cell_search_work=100))
    assert [sp.stop.x for sp in opt.stops] == [sp.stop.x for sp in coord.stops]
    assert opt.verification.passed and opt.plan.metrics["harvested"] == coord.plan.metrics["harvested"]

    def stay(sp):
        picks = [e for e in sp.plan.events if e.kind == EventKind.PICK]
        return max(e.t_end for e in picks) - min(e.t_start for e in picks) if picks else 0.0

    assert all(stay(o) <= stay(c) + 1e-9 for o, c in zip(opt.stops, coord.stops))
    assert opt.plan.metrics["makespan"] <= coord.plan.metrics["makespan"] + 1e-9
    # (nor widened: the stage keeps the makespan, and took 163 s of a 165 s stop on a 30 m row, the
    # carriage waiting 159 s for its first motion; a row refuses the options that would turn it off)
    widened = [sp.plan.solver.get("widen") for sp in opt.stops if sp.plan.planner_name == "optimal"]
    assert widened and all(w["status"] == "skipped" and "widen is false" in w["reason"] for w in widened), widened


def test_check_of_a_row_with_nothing_to_harvest_says_so(tmp_path):
    """(coplan check of a row with no fruit exited 4 with a lower bound of 0.00 s and no word of
    why.) It says there is nothing to plan, as a cell's check does."""
    d = gantry_row(length=6.0, density=2.0, seed=1)
    d["fruits"] = []
    path = tmp_path / "empty.yaml"
    path.write_text(to_yaml(d))
    r = CliRunner(env={"COLUMNS": "250"}).invoke(app, ["check", str(path)])
    assert r.exit_code == 4 and "nothing to plan" in r.output and "the problem lists no fruit" in r.output, r.output
    assert "lower bound" not in r.output


def test_a_row_problem_s_reach_is_from_every_carriage_position_on_its_rail():
    """(On sparse_row, ``reach_matrix()`` and ``unreachable()`` took the carriage at 0 alone:
    88 of 93 fruit "no arm can reach", a plan harvesting all 93.) A row's reach is from some
    position on the rail: the verifier's reachable fruit, and each arm's own a superset of what
    it reaches from any one position."""
    from coplan.problem import load_problem
    from coplan.problem.gantry import cell_at
    from coplan.verify.row import row_reachable_ids

    p = load_problem("sparse_row")
    m = p.reach_matrix()
    assert m.shape == (len(p.arms), len(p.fruits)) and p.unreachable() == []
    assert p.reachable_ids() == row_reachable_ids(p) and len(p.reachable_ids()) == len(p.fruits)
    for k in (0, 1234, 2500):  # (positions of its 1 cm grid)
        assert not (cell_at(p, p.gantry.start + 0.01 * k).reach_matrix() & ~m).any()
    # the screen given the row itself takes the arms where they stand (the carriage at 0); the
    # allocation refuses a row (it read the carriage as standing at 0 and left fruit
    # 'unreachable' without a word) and names the cell at a carriage position instead
    from coplan.allocate import allocate
    from coplan.allocate.screen import screened

    here = cell_at(p, 0.0)
    with pytest.raises(ValueError, match="is a row .*cell_at"):
        allocate(p, "heuristic")
    assert allocate(here, "heuristic").assignment
    assert (screened(p).reach == screened(here).reach).all()


def test_a_pace_price_keeps_the_optimised_rule_to_the_fixed_strides_count_where_it_runs_ahead(tmp_path):
    """``--pace-price S``: each stop of a segment that starts with the optimised rule ahead of
    the fixed stride's pace costs S s more. On sparse_row time alone takes 9 stops to the fixed
    stride's 8 (dense_row: 11 to 9, 4 x the time to plan); at 3 s it takes no more than the fixed
    stride, every fruit still taken, and its row is still faster than the fixed stride's (each
    verified). A row on which the rule never runs ahead keeps exactly its stops. The summary and
    plan.json say the price."""
    from coplan.kinds import StopRule
    from coplan.row.stops import StopWindow, fixed_stops, optimised_stops

    sparse = load_problem(next(p for p in shipped_rows() if p.stem == "sparse_row"))
    n_fixed = len(fixed_stops(row_reach(sparse)))
    plain, info = optimised_stops(sparse, row_reach(sparse, lazy=True))
    paced, paced_info = optimised_stops(sparse, row_reach(sparse, lazy=True), StopWindow(pace_price=3.0))
    assert len(paced) <= n_fixed < len(plain) and "paced" not in info and paced_info["paced"] >= 1
    # prices each within their limit, the sum too: a segment ahead of pace charges both (once;
    # 100 + 450 was refused there as 550 + 450 > 600 s)
    steep, steep_info = optimised_stops(sparse, row_reach(sparse, lazy=True), StopWindow(stop_price=100.0, pace_price=450.0))
    assert steep_info["paced"] >= 1 and sorted(f for s in steep for f in s.fruit) == sorted(f for s in plain for f in s.fruit)
    assert sorted(f for s in paced for f in s.fruit) == sorted(f for s in plain for f in s.fruit)
    fixed = plan_row(sparse, RowOptions(stops=StopRule.FIXED, workers=2))
    kept = plan_row(sparse, RowOptions(window=StopWindow(pace_price=3.0), workers=2))
    assert kept.verification.passed and len(kept.stops) <= len(fixed.stops)
    assert kept.plan.metrics["makespan"] < fixed.plan.metrics["makespan"]
    assert kept.info["pace_price"] == 3.0
    run = CliRunner(env={"COLUMNS": "200"}).invoke
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=8.0, density=2.0, seed=3)))
    prob = load_problem(path)
    same = optimised_stops(prob, row_reach(prob, lazy=True), StopWindow(pace_price=3.0))[0]
    assert [s.x for s in same] == [s.x for s in optimised_stops(prob, row_reach(prob, lazy=True))[0]]
    r = run(app, ["solve", str(path), "--pace-price", "3", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0 and "ahead of the fixed stride's pace priced 3.00 s more" in r.output, r.output
    assert json.loads((tmp_path / "o" / "plan.json").read_text())["solver"]["row"]["pace_price"] == 3.0
    for args, words in ((["--stops", "fixed"], "--pace-price: the optimised stop rule's price of a stop ahead of the fixed "
                                                "stride's pace applies to a row "
                                                "planned stop and go (--gantry stop-and-go, the default, with --stops "
                                                "optimised), not --stops fixed"),
                        (["--gantry", "continuous"], "not on the move"),
                        # (auto plans stop and go too: "not on the move" read as a contradiction)
                        (["--gantry", "auto"], "not --gantry auto, which compares the two modes each with its default options"),
                        (["--stop-price", "400", "--pace-price", "400"], "--stop-price + --pace-price: expected at most "
                                                                         "600 s together")):
        r = run(app, ["solve", str(path), "--pace-price", "3", *args, "--out", str(tmp_path / "x")])
        assert r.exit_code == 2 and words in " ".join(r.output.split()), r.output
    r = run(app, ["solve", "crossing_paths", "--pace-price", "3", "--out", str(tmp_path / "y")])
    assert r.exit_code == 2 and "stationary cell" in r.output
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_a_stop_price_buys_fewer_stops_and_only_applies_to_the_optimised_rule_stop_and_go(tmp_path):
    """``--stop-price S`` charges each stop S s beyond its estimated time in the optimised rule:
    on sparse_row 2 s takes 8 stops (the fixed stride's count) where time alone takes 9; each plan
    verified; the summary and plan.json say the price. It is refused where no optimised rule
    chooses stops (another rule, on the move, a cell)."""
    from coplan.row.stops import StopWindow, fixed_stops, optimised_stops

    prob = load_problem(next(p for p in shipped_rows() if p.stem == "sparse_row"))
    n_fixed = len(fixed_stops(row_reach(prob)))
    plain = optimised_stops(prob, row_reach(prob, lazy=True))[0]
    priced = optimised_stops(prob, row_reach(prob, lazy=True), StopWindow(stop_price=2.0))[0]
    assert len(priced) <= n_fixed < len(plain)
    assert sorted(f for s in priced for f in s.fruit) == sorted(f for s in plain for f in s.fruit)
    run = CliRunner(env={"COLUMNS": "200"}).invoke
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=8.0, density=2.0, seed=3)))
    r = run(app, ["solve", str(path), "--stop-price", "2", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0 and "each priced 2.00 s beyond its time" in r.output, r.output
    doc = json.loads((tmp_path / "o" / "plan.json").read_text())
    assert doc["solver"]["row"]["stop_price"] == 2.0 and doc["status"] == "success"
    for args, words in ((["--stops", "fixed"], "not --stops fixed"), (["--gantry", "continuous"], "not on the move"),
                        (["--stop-price", "-1"], "expected a number in [0, 600] s")):
        extra = args if "--stop-price" in args else ["--stop-price", "2", *args]
        r = run(app, ["solve", str(path), *extra, "--out", str(tmp_path / "x")])
        assert r.exit_code == 2 and words in r.output, r.output
    r = run(app, ["solve", "crossing_paths", "--stop-price", "2", "--out", str(tmp_path / "y")])
    assert r.exit_code == 2 and "stationary cell" in r.output
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_a_row_flag_on_a_cell_is_refused_by_its_own_name(tmp_path):
    """(A new-user trial: ``--speed`` alone on a cell was refused as
    "--gantry/--speed/--profile/--resolution/--stop-price/--pace-price: ...", six flags for one.)"""
    run = CliRunner(env={"COLUMNS": "250"}).invoke
    for args, said in ((["solve", "crossing_paths", "--speed", "0.3"], "--speed: crossing-paths is a stationary cell "
                                                                       "(no gantry section); it applies to a row"),
                       (["solve", "crossing_paths", "--gantry", "continuous", "--pace-price", "2"],
                        "--gantry/--pace-price: crossing-paths is a stationary cell (no gantry section); they apply to a row"),
                       (["compare", "crossing_paths", "--profile", "constant"], "--profile: crossing_paths.yaml is not a row "
                                                                                "(no gantry section): it applies to a row's file")):
        r = run(app, [*args, "--out", str(tmp_path / "x")])
        text = " ".join(r.output.split())
        assert r.exit_code == 2 and said in text, r.output
        assert "--resolution" not in text
    assert not (tmp_path / "x").exists()


def test_a_row_s_bounds_time_is_what_this_solve_spent_on_them():
    """A row's bounds are remembered for the row and its settings: the second solve of it spends
    (next to) nothing on them, and its timings say so -- they said the first solve's seconds, and
    the parts added up to more than the total."""
    import coplan

    row = parse_problem(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=23)))
    first, second = (coplan.solve(row) for _ in range(2))
    assert first.plan.metrics["lower_bound"] == second.plan.metrics["lower_bound"]
    assert second.timings["bounds"] < first.timings["bounds"]
    for res in (first, second):
        t = res.timings
        assert t["planning"] + t["verify"] + t["bounds"] <= t["total"] + 1e-9
