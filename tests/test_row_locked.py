"""A row with an arm the screen locks: on a moving carriage the booker parks it out of its
neighbour's way (before, it rested at home, leaning over the neighbour's fruit, and a live
stop-and-go run harvested 6 of the 17 fruit the offline plan harvests), and the row metrics
count its rest as no work, not as waiting for a neighbour."""

from __future__ import annotations

import numpy as np
import pytest

from coplan.generate import gantry_row, problem_dict, to_yaml
from coplan.kinds import GantryMode
from coplan.problem import parse_problem
from coplan.row.booking import Booker
from coplan.row.continuous import MovingOptions
from coplan.row.cruise import Cruise
from coplan.row.live import LiveRowOptions, run_live_row
from coplan.row.moving import plan_moving
from coplan.row.park import park_poses
from coplan.row.reach import locked_arms
from coplan.problem.gantry import cell_at
from coplan.planners.coordinated.routing import ArmGeometry


@pytest.fixture(scope="module")
def locked_row():
    """Two arms 0.3 m apart on an 8 m row (seed 7): ``a`` cannot reach its bin without link 1
    crossing ``b``'s base, so the screen locks it; at home it leans over ``b``'s fruit."""
    d = gantry_row(length=8, n_arms=2, density=2, seed=7)
    d["arms"] = [{"name": "a", "base": [-0.15, 0.0], "bin": [-0.15, -0.5]},
                 {"name": "b", "base": [0.15, 0.0], "bin": [0.15, -0.5]}]
    return parse_problem(to_yaml(d))


def test_the_locked_arm_is_parked_clear_of_its_neighbours_rests(locked_row):
    cell = cell_at(locked_row, 0.0, ())
    assert set(locked_arms(cell)) == {"a"}
    need = locked_row.task.clearance + MovingOptions().margin
    park = park_poses(locked_row, need)
    assert set(park) == {0} and not np.allclose(park[0], locked_row.arms[0].home)
    geo = ArmGeometry(cell, need)
    b = cell.arms[1]
    qb, vb = b.ik(np.asarray(b.bin, float))
    rests = np.vstack([np.asarray(b.home, float)[None, :], qb[vb]])
    assert geo.static_hits(0, park[0][None, :], 1, rests)[0] == 0  # b's home and bin poses stay clear
    assert park_poses(locked_row, need)[0].tolist() == park[0].tolist()  # deterministic
    # the booker moves it there first, and rests it there
    booker = Booker(locked_row, Cruise.of(locked_row, 0.1, 1.0), {}, 100.0, MovingOptions().margin)
    assert booker.at_home(0) and np.allclose(booker.arms[0].q[booker.arms[0].k_free], park[0])
    assert np.allclose(booker.arms[0].q[0], locked_row.arms[0].home)  # (from home, at t = 0)


def test_on_the_move_and_live_stop_and_go_harvest_every_fruit_beside_a_locked_arm(locked_row):
    res = plan_moving(locked_row)
    assert res.verification.passed and res.plan.metrics["harvested"] == 17
    live = run_live_row(locked_row, LiveRowOptions(mode=GantryMode.STOP_AND_GO, seed=0))
    assert live.verification.passed and live.metrics["of_offline"] == 1.0 and live.metrics["harvested"] == 17
    # the parked arm goes home at the end (it ended parked, which the verifier now refuses)
    for plan in (res.plan, live.plan):
        assert np.allclose(plan.q["a"][-1], locked_row.arms[0].home, atol=1e-12)
        assert not np.allclose(plan.q["a"][len(plan.time) // 2], locked_row.arms[0].home)


def test_the_locked_arms_rest_counts_as_no_work_not_as_waiting_for_a_neighbour(locked_row):
    import coplan

    res = coplan.solve(locked_row, gantry="continuous")
    idle = res.plan.metrics["row"]["idle_share"]["a"]
    assert idle["coordination"] == 0.0 and idle["carriage"] + idle["no_fruit"] > 0.9


def test_a_rows_solve_says_which_arm_the_screen_locks_and_why(locked_row, tmp_path):
    """`coplan check` named the locked arm; `coplan solve` of the same row said nothing of it (its
    fruit per hour 0 and 'no fruit' idle unexplained) and plan.json did not record it."""
    import json

    from typer.testing import CliRunner

    from coplan.cli import app

    path = tmp_path / "locked.yaml"
    path.write_text(to_yaml(problem_dict(locked_row)))
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["solve", str(path), "--out", str(tmp_path / "run")])
    said = " ".join(res.output.split())
    assert res.exit_code == 0, res.output
    assert "screen 1 of 2 arms locked (a): it harvests nothing from any carriage position" in said
    why = json.loads((tmp_path / "run" / "plan.json").read_text())["metrics"]["row"]["locked_arms"]
    assert list(why) == ["a"] and "bin" in why["a"] and why["a"] in said
    assert "(share of the row time each arm is idle: carriage -- at rest while the carriage moves" in said
    # on the move the legend speaks of no stop (it explained "no fruit -- at a stop" to a run that never stops)
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["solve", str(path), "--gantry", "continuous", "--out", str(tmp_path / "m")])
    said = " ".join(res.output.split())
    assert res.exit_code == 0 and "carriage -- waiting for the carriage to bring its next fruit into reach" in said
    assert "at a stop" not in said.split("(share of the row time")[1]


def test_a_row_plan_s_metrics_carry_the_cell_s_fruit_vocabulary_at_the_top():
    """(From a user's trial: plan.metrics['harvestable'] was a KeyError on a row -- fruit,
    fruit_ids, harvestable, screened_out and gap_to_lower_bound were only a cell plan's.) They
    agree with the row's own metrics, in both modes."""
    import coplan
    from coplan.generate import gantry_row

    for gantry in ("stop-and-go", "continuous"):
        m = coplan.solve(gantry_row(length=6.0, n_arms=3, density=3.0, seed=2), gantry=gantry).plan.metrics
        row = m["row"]
        assert m["fruit"] == row["fruit"] and m["harvestable"] == row["harvestable"], gantry
        assert m["screened_out"] == len(m["fruit_ids"]["screened_out"]) and set(m["fruit_ids"]["screened_out"]) <= set(row["screened_out"])
        assert m["fruit"] == m["harvestable"] + m["screened_out"] + m["unreachable"]
        assert m["fruit_ids"]["left_out"] == [] and m["gap_to_lower_bound"] == pytest.approx(m["makespan"] / m["lower_bound"])
