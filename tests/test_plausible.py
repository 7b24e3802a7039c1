"""Plausibility (issue 10): values far outside any real cell are bad input with the reason,
never a MemoryError, an overflow warning or hours of compute."""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from coplan.allocate import lower_bound
from coplan.cli import app
from coplan.planners.heuristic import plan_heuristic
from coplan.plan import MAX_PLAN_BYTES
from coplan.plausible import (BOUNDS, BYTES_PER_CARRIAGE_SAMPLE, BYTES_PER_SAMPLE, MAX_PLAN_SECONDS, max_plan_seconds, move_times,
                              plan_duration_bound)
from coplan.problem.model import ProblemError
from coplan.problem.load import default_problem_path, load_problem, parse_problem
from coplan.kinematics import cubic_min_time, scurve_time

PROBLEMS = default_problem_path().parent
SINGLE = (PROBLEMS / "single_arm.yaml").read_text()


def _issues(text: str) -> list:
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # an overflow warning would be a failure
        with pytest.raises(ProblemError) as e:
            parse_problem(text, "p.yaml")
    return e.value.issues


def test_angles_in_degrees_are_refused_with_a_hint() -> None:
    text = SINGLE.replace("joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]]", "joint_limits: [[-180, 180], [-175, 175]]")
    text = text.replace("home: [0.7854, 0.7854]", "home: [45, 45]")
    issues = _issues(text)
    by_path = {i.path: i for i in issues}
    assert set(by_path) == {f"arms[0].joint_limits[{j}][{k}]" for j in range(2) for k in range(2)} | {"arms[0].home[0]", "arms[0].home[1]"}
    lim = by_path["arms[0].joint_limits[0][1]"]
    assert lim.line == 11
    assert "expected a joint angle within [-6.28319, 6.28319] rad" in lim.message and "found 180" in lim.message
    assert "it looks like degrees: 180 deg is 3.1416 rad" in lim.message
    assert "45 deg is 0.7854 rad" in by_path["arms[0].home[0]"].message


def test_lengths_in_millimetres_are_refused_with_a_hint() -> None:
    """(``clearance: 50`` -- millimetres -- said only "found 50".) A length beyond its range
    whose thousandth is within it is said to look like millimetres."""
    text = SINGLE.replace("clearance: 0.05", "clearance: 50").replace("links: [1.0, 0.8]", "links: [1000, 800]")
    by_path = {i.path: i.message for i in _issues(text)}
    assert "found 50 (it looks like millimetres: 50 mm is 0.05 m; lengths are in m)" in by_path["task.clearance"]
    assert "found 1000 (it looks like millimetres: 1000 mm is 1 m; lengths are in m)" in by_path["arms[0].links[0]"]
    # (a negative coordinate too: -2435 said only "a cell of this size is not a harvesting cell")
    text2 = SINGLE.replace("position: [1.2, 0.8]", "position: [-2435, 0.8]")
    assert "found -2435 (it looks like millimetres: -2435 mm is -2.435 m; lengths are in m)" in \
        {i.path: i.message for i in _issues(text2)}["fruits[0].position[0]"]
    text = SINGLE.replace("clearance: 0.05", "clearance: 20000")  # (20 m: no length in mm either)
    assert "millimetres" not in {i.path: i.message for i in _issues(text)}["task.clearance"]


@pytest.mark.parametrize("old, new, path, found", [
    ("max_velocity: [3.0, 4.0]", "max_velocity: [1.0e-9, 4.0]", "arms[0].max_velocity[0]", "found 1e-09"),
    ("max_velocity: [3.0, 4.0]", "max_velocity: [3.0, 1.0e+308]", "arms[0].max_velocity[1]", "found 1e+308"),
    ("max_acceleration: [8.0, 12.0]", "max_acceleration: [1.0e-9, 12.0]", "arms[0].max_acceleration[0]", "found 1e-09"),
    ("max_jerk: [80.0, 120.0]", "max_jerk: [80.0, 1.0e+308]", "arms[0].max_jerk[1]", "found 1e+308"),
    ("links: [1.0, 0.8]", "links: [1.0e+308, 0.8]", "arms[0].links[0]", "found 1e+308"),
    ("base: [0.0, 0.0]", "base: [-1.0e+308, 0.0]", "arms[0].base[0]", "found -1e+308"),
    ("bin: [-0.5, 1.0]", "bin: [-0.5, 1.0e+308]", "arms[0].bin[1]", "found 1e+308"),
    ("position: [1.2, 0.8]", "position: [1.0e+308, 0.8]", "fruits[0].position[0]", "found 1e+308"),
    ("pick_dwell: 0.3", "pick_dwell: 172800", "task.pick_dwell", "found 172800 (dwells are in s)"),
    ("place_dwell: 0.2", "place_dwell: 1.0e+300", "task.place_dwell", "found 1e+300"),
    ("clearance: 0.05", "clearance: 1.0e+300", "task.clearance", "found 1e+300"),
])
def test_absurd_values_are_refused_with_key_path_line_and_bound(old: str, new: str, path: str, found: str) -> None:
    assert old in SINGLE
    text = SINGLE.replace(old, new)
    issues = _issues(text)
    assert [i.path for i in issues] == [path]
    line = next(n for n, s in enumerate(text.splitlines(), 1) if new in s)
    assert issues[0].line == line
    assert found in issues[0].message and "the plausible range" in issues[0].message


def test_a_value_from_defaults_is_reported_once_at_defaults() -> None:
    text = (PROBLEMS / "greenhouse_row.yaml").read_text().replace("max_jerk: [80.0, 120.0]", "max_jerk: [80.0, 1.0e-9]")
    issues = _issues(text)
    assert [i.path for i in issues] == ["defaults.max_jerk[1]"]


def test_the_bounds_hold_every_shipped_problem() -> None:
    for path in PROBLEMS.glob("*.yaml"):
        p = load_problem(path)
        for a in p.arms:
            for f in ("links", "max_velocity", "max_acceleration", "max_jerk"):
                assert all(BOUNDS[f].holds(x) for x in getattr(a, f)), (path, f)


def test_a_baseline_too_long_for_its_grid_is_refused_up_front() -> None:
    text = (PROBLEMS / "five_arm_row.yaml").read_text().replace("max_velocity: [3.0, 4.0]", "max_velocity: [0.001, 0.001]")
    issues = _issues(text)  # (this file used to run its 38 h baseline: 2 minutes and gigabytes)
    assert len(issues) == 1 and issues[0].path == "arms[0]"  # (its joints: the arm whose limits the message lists)
    msg = issues[0].message
    assert msg.startswith("expected a problem whose plan fits in 1.4 h (plans are sampled at 100 Hz; with 5 arms, longer "
                          "plans make files over 64 MiB), found one whose baseline")
    assert re.search(r"lasts at least (\d+\.\d) h", msg) and float(re.search(r"lasts at least (\d+\.\d) h", msg)[1]) > 12
    assert "max_velocity [0.001, 0.001] rad/s" in msg
    # slow but sane joints (the issue's 0.01 rad/s single arm: a 455 s baseline) stay accepted
    slow = SINGLE.replace("max_velocity: [3.0, 4.0]", "max_velocity: [0.01, 0.01]")
    assert parse_problem(slow).arms[0].max_velocity == (0.01, 0.01)


def test_a_plan_too_long_is_reported_at_its_cause() -> None:
    """The dwell that makes the plan too long is named at its key and line; so is an arm's own
    too-slow joints (not defaults)."""
    base = (PROBLEMS / "greenhouse_row.yaml").read_text()
    text = base.replace("place_dwell: 0.2", "place_dwell: 3599")
    assert text != base
    issues = _issues(text)
    assert [i.path for i in issues] == ["task.place_dwell"]
    assert issues[0].line == next(n for n, l in enumerate(text.splitlines(), 1) if "place_dwell: 3599" in l)
    # the fruit's number (it said arms[0]): 33 fruit of five_arm_row, each 300 times, a little apart
    five = (PROBLEMS / "five_arm_row.yaml").read_text()
    head, _, fruit = five.partition("fruits:")
    rows = [ln for ln in fruit.splitlines() if ln.strip().startswith("- {id:")]
    tail = fruit[fruit.index(rows[-1]) + len(rows[-1]):]
    many = []
    for k in range(300):
        for ln in rows:
            m = re.search(r"id: ([^,]+), position: \[([-0-9.e]+), ([-0-9.e]+)\]", ln)
            many.append(f"  - {{id: {m[1]}_{k}, position: [{float(m[2]) + 2e-4 * k:.6f}, {m[3]}]}}")
    issues = _issues(head + "fruits:\n" + "\n".join(many) + tail)
    assert [i.path for i in issues] == ["fruits"]


def test_cli_check_exits_3_on_implausible_input(tmp_path: Path) -> None:
    p = tmp_path / "deg.yaml"
    p.write_text(SINGLE.replace("home: [0.7854, 0.7854]", "home: [45, 45]"))
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["check", str(p)])
    assert res.exit_code == 3
    assert f"{p}:15: arms[0].home[0]: expected a joint angle within" in res.output
    assert "Traceback" not in res.output


# --------------------------------------------------------------------------- the duration bound
def test_move_time_bound_is_below_the_time_optimal_move_and_tight_in_each_regime() -> None:
    rng = np.random.default_rng(3)
    for _ in range(200):
        d, v, a, j = rng.uniform(0.01, 3.0), rng.uniform(0.1, 5), rng.uniform(0.1, 20), rng.uniform(1, 200)
        assert move_times(np.array([d, 0.0]), (v, 1), (a, 1), (j, 1)) <= scurve_time(d, v, a, j) + 1e-9
        assert move_times(np.array([d, 0.0]), (v, 1), (a, 1), (j, 1), cubic=True) == pytest.approx(
            cubic_min_time([d, 0.0], (v, 1), (a, 1)))
    # each limit alone: the bound is the exact time
    assert move_times(np.array([2.0, 0.0]), (0.01, 1), (1e9, 1), (1e12, 1)) == pytest.approx(scurve_time(2.0, 0.01, 1e9, 1e12), rel=1e-3)
    assert move_times(np.array([2.0, 0.0]), (1e9, 1), (0.5, 1), (1e12, 1)) == pytest.approx(scurve_time(2.0, 1e9, 0.5, 1e12), rel=1e-3)
    assert move_times(np.array([2.0, 0.0]), (1e9, 1), (1e9, 1), (3.0, 1)) == pytest.approx(scurve_time(2.0, 1e9, 1e9, 3.0), rel=1e-6)


def test_duration_bounds_are_lower_bounds_on_the_shipped_problems() -> None:
    for path in sorted(PROBLEMS.glob("*.yaml")):
        p = load_problem(path)
        any_plan = plan_duration_bound(p)
        assert 0 < any_plan.seconds <= lower_bound(p) + 1e-6, path  # the MILP's bound on the makespan
        base = plan_duration_bound(p, baseline=True)
        assert any_plan.seconds <= base.seconds <= plan_heuristic(p).time[-1] + 1e-6, path
    # one arm, one fruit: the baseline's length is exactly home -> fruit -> bin -> home + dwells
    slow = parse_problem(SINGLE.replace("max_velocity: [3.0, 4.0]", "max_velocity: [0.01, 0.01]"))
    assert plan_duration_bound(slow, baseline=True).seconds == pytest.approx(plan_heuristic(slow).time[-1], abs=0.011)
    assert MAX_PLAN_SECONDS == 12 * 3600 and math.isfinite(plan_duration_bound(slow).seconds)


def test_the_row_work_bound_is_below_every_row_plan() -> None:
    """:func:`row_work_bound` (each fruit's dwells and elbow turns on its cheapest arm, shared
    evenly) is a lower bound: below each shipped row's bound for any plan, and below the plans of
    seeded generated rows (stop and go, and on the move)."""
    import coplan
    from coplan.allocate.row_bound import row_bounds
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import shipped_rows
    from coplan.problem.plausible import row_work_bound

    for name in shipped_rows():
        p = load_problem(name)
        assert 0 < row_work_bound(p).seconds <= row_bounds(p, priced=False).any_plan, name
    for seed, n_arms, density in ((0, 2, 4.0), (1, 3, 8.0), (2, 1, 3.0)):
        p = parse_problem(to_yaml(gantry_row(length=5.0, n_arms=n_arms, density=density, seed=seed)))
        b = row_work_bound(p).seconds
        for gantry in ("stop-and-go", "continuous"):
            assert b <= coplan.solve(p, gantry=gantry).plan.metrics["makespan"] + 1e-9, (seed, gantry)


def test_the_row_work_bound_counts_only_fruit_an_arm_can_pick() -> None:
    """(A reviewer's counterexample: a shoulder limited to [0, pi] cannot turn down to 40 fruit below
    the base; they counted 2269 s each of a 0.001 rad/s shoulder's work, and a row whose one
    reachable fruit plans in seconds was refused when read.)"""
    from coplan.allocate.row_bound import row_bounds
    from coplan.problem.plausible import row_work_bound

    low = "".join(f"  - {{id: d{i}, position: [{0.2 + 0.2 * i:.1f}, -1.5]}}\n" for i in range(40))
    text = f"""name: low-fruit
defaults: {{links: [1.0, 0.8], link_radius: 0.04, joint_limits: [[0.0, 3.1416], [-3.0416, 3.0416]],
  max_velocity: [0.001, 4.0], max_acceleration: [8.0, 12.0], max_jerk: [80.0, 120.0], home: [1.0472, 0.7854]}}
arms:
  - {{name: a1, base: [0.0, 0.0], bin: [0.0, 0.5]}}
fruits:
  - {{id: ok, position: [5.0, 1.2]}}
{low}task: {{pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}}
gantry: {{start: 0.0, end: 10.0, max_velocity: 0.5, max_acceleration: 0.5, max_jerk: 5.0}}
"""
    p = parse_problem(text)
    assert p.reachable_ids() == ["ok"]
    assert row_work_bound(p).seconds <= row_bounds(p, priced=False).any_plan + 1e-9


def test_the_longest_plan_allowed_fits_the_plan_file_cap(tmp_path: Path) -> None:
    # coplan must be able to read back every plan it makes: the per-sample size model is an
    # upper estimate of real plan files (JSON and CSV), so the longest plan allowed fits the cap
    for path in ("single_arm.yaml", "greenhouse_row.yaml"):
        p = load_problem(PROBLEMS / path)
        files = plan_heuristic(p).save(tmp_path / path, "plan")
        n = plan_heuristic(p).time.size
        for kind in ("json", "csv"):
            assert files[kind].stat().st_size / n <= BYTES_PER_SAMPLE[0] + BYTES_PER_SAMPLE[1] * len(p.arms)
    for arms in (1, 3, 64):
        samples = max_plan_seconds(arms) * 100
        assert samples * (BYTES_PER_SAMPLE[0] + BYTES_PER_SAMPLE[1] * arms) <= MAX_PLAN_BYTES * (1 + 1e-12)
    assert max_plan_seconds(1) == pytest.approx(MAX_PLAN_BYTES / 39 / 100)
    assert max_plan_seconds(3) < max_plan_seconds(1) < MAX_PLAN_SECONDS
    assert max_plan_seconds(3, carriage=True) == pytest.approx(MAX_PLAN_BYTES / (39 + 48 + 14) / 100)


def test_the_widest_samples_fit_the_per_sample_size_model(tmp_path: Path) -> None:
    """The model's widths are the widest values coplan writes: times near 12 h (plan.csv's seven
    decimals), angles at -2 pi (plan.json's pairs), a carriage at -1000 m. (It undercounted both
    once: a slow row on the move wrote a 70 MB plan.csv its own verifier refused.)"""
    from coplan.kinds import PlanStatus
    from coplan.plan import Plan

    n = 500
    t = MAX_PLAN_SECONDS - 5.0 + np.arange(n) / 100.0
    q = {f"arm{i}": np.full((n, 2), -2 * math.pi + 1e-7) for i in range(3)}
    for carriage in (None, np.full(n, -999.1234567)):
        plan = Plan(problem="wide", planner="optimal", status=PlanStatus.SUCCESS, time=t, q=q, events=[],
                    allocation={a: [] for a in q}, unreachable=[], gantry_x=carriage)
        files = plan.save(tmp_path / ("row" if carriage is not None else "cell"))
        per_sample = BYTES_PER_SAMPLE[0] + BYTES_PER_SAMPLE[1] * len(q) + (BYTES_PER_CARRIAGE_SAMPLE if carriage is not None else 0)
        for kind in ("json", "csv"):
            assert files[kind].stat().st_size <= n * per_sample + 2000, (kind, carriage is not None)  # (+ header, names)


def test_a_row_s_fruit_may_lie_as_far_along_as_its_rail_goes() -> None:
    """(A new-user trial: ``gantry.end: 2000`` was accepted, and a fruit at x 1500 on that rail
    refused as "a cell of this size is not a harvesting cell".) A row's fruit x has the range of a
    rail's ends; a cell's fruit, and any y, keep the coordinate range; the line is the fruit's."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem.plausible import problem_issues

    doc = gantry_row(length=6.0, n_arms=1, density=1.0, seed=3, trusses=False)
    doc["gantry"]["end"] = 2000.0
    doc["fruits"].append({"id": "far", "position": [1500.0, doc["fruits"][0]["position"][1]]})
    prob = parse_problem(to_yaml(doc), "row.yaml")
    assert "far" in prob.reachable_ids() and not problem_issues(prob)
    doc["fruits"][-1]["position"] = [20000.0, 1.0e6]
    issues = _issues(to_yaml(doc))
    assert [i.path for i in issues] == [f"fruits[{len(doc['fruits']) - 1}].position[0]", f"fruits[{len(doc['fruits']) - 1}].position[1]"]
    assert "a position along the rail within [-10000, 10000] m" in issues[0].message and "found 20000" in issues[0].message
    assert "a coordinate within [-1000, 1000] m" in issues[1].message and "found 1e+06" in issues[1].message
    assert all(i.line is not None for i in issues)
    # a cell's fruit at 1500 m stays refused
    cell = _issues(SINGLE.replace("position: [1.2, 0.8]", "position: [1500.0, 0.8]"))
    assert [i.path for i in cell] == ["fruits[0].position[0]"] and "a coordinate within [-1000, 1000] m" in cell[0].message


def test_a_singularity_threshold_beyond_any_arm_is_refused() -> None:
    """(1e300 was accepted, and every pose of every plan reported near-singular.)"""
    text = (PROBLEMS / "greenhouse_row.yaml").read_text().replace("place_dwell: 0.2", "place_dwell: 0.2\n  singularity_threshold: 1.0e300")
    issues = _issues(text)
    assert [i.path for i in issues] == ["task.singularity_threshold"]
    assert "expected a manipulability threshold within [0, 100] m^2" in issues[0].message
