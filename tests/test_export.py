"""`coplan export`: a plan for a joint controller -- positions, velocities, accelerations per joint
at a chosen rate, as CSV and as ROS 2 JointTrajectory JSON/YAML per arm; the derivatives are the
plan's real ones (analytic S-curve, finite differences), never beyond what the verifier
accepted in the plan."""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from coplan.cli import app
from coplan.planners.coordinated import plan_coordinated
from coplan.report.export import export_plan, safe_names, trajectory
from coplan.kinds import EventKind, ExitCode
from coplan.plan import load_plan
from coplan.kinematics import SCurve


def run(*args: str):
    return CliRunner(env={"COLUMNS": "200"}).invoke(app, list(args))


@pytest.fixture(scope="module")
def single_plan(single_arm, tmp_path_factory):
    """The coordinated plan of the course's single-arm demo, as plan.json holds it."""
    out = tmp_path_factory.mktemp("single")
    return load_plan(plan_coordinated(single_arm).plan.save(out)["json"])


@pytest.fixture(scope="module")
def crossing_plan(problems_dir, tmp_path_factory):
    from coplan.problem import load_problem

    out = tmp_path_factory.mktemp("crossing")
    return load_plan(plan_coordinated(load_problem(problems_dir / "crossing_paths.yaml")).plan.save(out)["json"])


def test_the_first_move_matches_the_analytic_s_curve(single_arm, single_plan):
    """The coordinated plan's first move is the time-optimal S-curve from home to the pick pose:
    the export, one plan step later, follows its analytic profile -- positions within a sixth of
    a second difference (a_max dt^2 / 6), rates within a jerk step's blur."""
    arm = single_arm.arms[0]
    pick = next(e for e in single_plan.events if e.kind == EventKind.PICK)
    q_pick = single_plan.q[arm.name][round(pick.t_start / single_plan.dt)]
    move = SCurve.between(arm.home, q_pick, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
    assert move.duration == pytest.approx(pick.t_start, abs=2e-3)
    traj = trajectory(single_plan, rate=500.0)
    dt = single_plan.dt
    assert traj.delay == dt
    t = traj.time - traj.delay  # the plan's time of each exported point
    m = (t > 0.0) & (t < move.duration - 0.02)  # the move (the pick dwell follows: still, zero derivatives)
    pos, vel, acc, _ = move.derivatives(t[m])
    a_max, j_max = np.array(arm.max_acceleration), np.array(arm.max_jerk)
    assert np.all(np.abs(traj.q[arm.name][m] - pos).max(axis=0) <= a_max * dt**2 / 6 + 1e-9)
    # a cubic piece's B-spline velocity is off by j dt^2 / 6; the samples' own timing adds a little
    assert np.all(np.abs(traj.qd[arm.name][m] - vel).max(axis=0) <= j_max * dt**2 / 4)  # rad/s; peaks ~2-3 rad/s
    assert np.all(np.abs(traj.qdd[arm.name][m] - acc).max(axis=0) <= j_max * dt / 2 + 1e-6)
    assert np.abs(vel).max() > 0.5 * min(arm.max_velocity)  # a real move, not a trivial one
    dwell = (t > pick.t_start + 0.03) & (t < pick.t_end - 0.03)  # a held pose stands exactly still
    assert dwell.sum() > 10 and np.abs(traj.qd[arm.name][dwell]).max() < 1e-12 and np.abs(traj.qdd[arm.name][dwell]).max() < 1e-9
    held = single_plan.q[arm.name][round(0.5 * (pick.t_start + pick.t_end) / dt)]
    np.testing.assert_allclose(traj.q[arm.name][dwell], np.broadcast_to(held, traj.q[arm.name][dwell].shape), rtol=0, atol=1e-12)


def test_derivatives_agree_with_finite_differences_of_the_positions(crossing_plan):
    traj = trajectory(crossing_plan, rate=1000.0)
    h = 1e-3
    P, dt = crossing_plan.q, crossing_plan.dt
    for arm in crossing_plan.q:
        q, qd, qdd = traj.q[arm], traj.qd[arm], traj.qdd[arm]
        np.testing.assert_allclose((q[2:] - q[:-2]) / (2 * h), qd[1:-1], atol=1e-4)
        # within one piece (between two plan samples) the acceleration is linear: the second difference is exact
        inner = np.abs(np.round(traj.time[1:-1] / dt) * dt - traj.time[1:-1]) > 1.5 * h
        dd = (q[2:] - 2 * q[1:-1] + q[:-2]) / h**2
        np.testing.assert_allclose(dd[inner], qdd[1:-1][inner], atol=2e-3)
        np.testing.assert_allclose(dd, qdd[1:-1], atol=0.07)  # at a sample the acceleration has a kink
        # at each plan sample (one step later) the rates are the samples' own central differences
        k = np.arange(1, len(P[arm]) - 1)
        at = np.searchsorted(traj.time, crossing_plan.time[k] + traj.delay - 1e-9)
        np.testing.assert_allclose(qd[at], (P[arm][k + 1] - P[arm][k - 1]) / (2 * dt), atol=1e-9)
        np.testing.assert_allclose(qdd[at], (P[arm][k + 1] - 2 * P[arm][k] + P[arm][k - 1]) / dt**2, atol=1e-6)


@pytest.mark.parametrize("rate", [7.0, 100.0, 250.0, 1000.0])
def test_no_exported_rate_and_no_difference_of_the_export_exceeds_the_plans_own(crossing_plan, rate):
    """The export's velocity, acceleration and jerk -- its own columns and its positions'
    differences at the export's rate -- never exceed the plan's finite differences, which the
    verifier holds to the limits (an interpolating spline overshot them: 1 % in acceleration,
    11 % in jerk at 250 Hz). The grid is uniform, the ends exactly at rest."""
    traj = trajectory(crossing_plan, rate)
    h = 1.0 / rate
    np.testing.assert_allclose(np.diff(traj.time), h, rtol=0, atol=1e-12)
    assert traj.time[-1] >= crossing_plan.duration + 2 * crossing_plan.dt - 1e-12
    for arm, P in crossing_plan.q.items():
        pad = lambda x: np.concatenate([np.repeat(x[:1], 3, axis=0), x, np.repeat(x[-1:], 3, axis=0)])  # noqa: E731
        own = [np.abs(np.diff(pad(P), n=k, axis=0)).max(axis=0) / crossing_plan.dt**k for k in (1, 2, 3)]
        q = traj.q[arm]
        for k in (1, 2, 3):  # (up to the floating point rounding of the positions, over h^k)
            fp = 2.0 ** k * 16 * np.finfo(float).eps * np.abs(q).max() / h**k
            assert np.all(np.abs(np.diff(pad(q), n=k, axis=0)).max(axis=0) / h**k <= own[k - 1] + fp), (arm, k)
        assert np.all(np.abs(traj.qd[arm]).max(axis=0) <= own[0] * (1 + 1e-9))
        assert np.all(np.abs(traj.qdd[arm]).max(axis=0) <= own[1] * (1 + 1e-9))
        assert np.all(traj.qd[arm][[0, -1]] == 0.0) and np.all(traj.qdd[arm][[0, -1]] == 0.0)
        np.testing.assert_array_equal(q[[0, -1]], P[[0, -1]])


def test_positions_stay_within_a_sixth_of_a_second_difference_of_the_plans_samples(crossing_plan):
    traj = trajectory(crossing_plan, rate=100.0)  # the plan's own grid, one step later
    for arm, P in crossing_plan.q.items():
        at = traj.q[arm][1:1 + len(P)]
        np.testing.assert_allclose(at[1:-1], (P[:-2] + 4 * P[1:-1] + P[2:]) / 6, atol=1e-12)
        second = np.abs(np.diff(P, n=2, axis=0)).max()
        assert 0 < np.abs(at - P).max() <= second / 6 + 1e-12


def test_the_grid_is_uniform_to_the_end(single_plan):
    """(The last step was shorter: 27 ms at 7 Hz, which a verifier or a controller refuses.)"""
    traj = trajectory(single_plan, rate=7.0)
    assert np.diff(traj.time) == pytest.approx(1 / 7.0)
    assert traj.time[-2] < single_plan.duration + 2 * single_plan.dt <= traj.time[-1]


def test_an_export_of_a_saved_plan_passes_coplan_verify_at_a_controller_rate(problems_dir, tmp_path):
    """The CSV a controller is given is checked by ``coplan verify`` itself, at 250 Hz: the
    limits (from the plan.npz beside plan.json: no 1e-7 rounding for a finer grid to magnify),
    the clearance and every pick (inferred from the motion)."""
    from coplan.problem import load_problem

    plan = plan_coordinated(load_problem(problems_dir / "crossing_paths.yaml")).plan
    plan.save(tmp_path / "run")
    prob = ["-p", str(problems_dir / "crossing_paths.yaml")]  # (a plan made in Python records no problem file)
    res = run("export", str(tmp_path / "run" / "plan.json"), "--rate", "250", "--out", str(tmp_path / "e.csv"), *prob)
    assert res.exit_code == 0 and "note" not in res.stderr, res.output
    res = run("verify", str(problems_dir / "crossing_paths.yaml"), str(tmp_path / "e.csv"))
    out = " ".join(res.output.split())
    assert res.exit_code == 0 and "passed" in out and "4 picks and 4 places were inferred" in out, out
    assert "a coplan export table (its planner not recorded)" in out  # (it was "a plan.csv replay")
    # without its plan.npz (a plan.json sent on alone) the export says what it is of
    alone = tmp_path / "alone"
    alone.mkdir()
    (alone / "plan.json").write_bytes((tmp_path / "run" / "plan.json").read_bytes())
    res = run("export", str(alone / "plan.json"), "--rate", "250", "--out", str(tmp_path / "a.csv"), *prob)
    said = " ".join(res.stderr.split())
    assert res.exit_code == 0 and "no plan.npz with this plan's full-precision samples" in said
    # (its 1e-7 rad rounding ran over the limits in its differences, and so did the export: 1.0036 x in jerk, and coplan
    # verify refused it; the samples are moved back within their rounding so that their differences keep the limits)
    assert "each moved back within its rounding (at most 5e-8)" in said and "every limit holds" in said, said
    checked = run("verify", str(problems_dir / "crossing_paths.yaml"), str(tmp_path / "a.csv"))
    assert checked.exit_code == 0, (said, checked.output)
    assert "no plan.npz" not in run("export", str(alone / "plan.json"), "--rate", "50", "--out", str(tmp_path / "a50.csv"), *prob).stderr
    # from the plan.csv replay, and from Python, alike (load_plan takes the plan.npz's samples)
    res = run("export", str(tmp_path / "run" / "plan.csv"), "--rate", "250", "--out", str(tmp_path / "c.csv"), *prob)
    assert res.exit_code == 0, res.output
    export_plan(load_plan(tmp_path / "run" / "plan.json"), 250.0, "csv", tmp_path / "api.csv")
    for f in ("c.csv", "api.csv"):
        res = run("verify", str(problems_dir / "crossing_paths.yaml"), str(tmp_path / f))
        assert res.exit_code == 0 and "passed" in " ".join(res.output.split()), (f, res.output)


def test_csv_export(crossing_plan, tmp_path):
    path, events = export_plan(crossing_plan, 100.0, "csv", tmp_path / "traj.csv")
    rows = list(csv.reader(path.open()))
    arms = list(crossing_plan.q)
    assert rows[0] == ["t"] + [f"{a}_{c}" for a in arms for c in ("q1", "q2", "qd1", "qd2", "qdd1", "qdd2")]
    data = np.array(rows[1:], float)
    traj = trajectory(crossing_plan, 100.0)
    assert data.shape == (len(traj.time), 1 + 6 * len(arms))
    np.testing.assert_allclose(data[:, 1:3], traj.q[arms[0]], atol=1e-8)
    np.testing.assert_allclose(data[:, 3:5], traj.qd[arms[0]], rtol=1e-8, atol=1e-8)
    assert sorted(tmp_path.iterdir()) == sorted([path, events])  # no temporary file left
    # the picks and places on the export's clock: the plan's one step later (gripper timing was rebuilt by hand)
    got = list(csv.DictReader(events.open()))
    assert events.name == "traj.events.csv" and len(got) == len(crossing_plan.events)
    for e, g in zip(sorted(crossing_plan.events, key=lambda e: (e.t_start, e.arm)), got):
        assert (g["arm"], g["fruit"], g["kind"]) == (e.arm, e.fruit, e.kind.value)
        assert float(g["t_start"]) == pytest.approx(e.t_start + traj.delay) and float(g["t_end"]) == pytest.approx(e.t_end + traj.delay)
    # and the tip is on the fruit at those times in the export itself
    from coplan.kinematics.arm import fk
    from coplan.problem import load_problem
    from coplan.problem.load import default_problem_path

    prob = load_problem(default_problem_path().parent / "crossing_paths.yaml")
    for g in got:
        if g["kind"] == "pick":
            arm = next(a for a in prob.arms if a.name == g["arm"])
            k = int(round(0.5 * (float(g["t_start"]) + float(g["t_end"])) * 100.0))
            tip = np.asarray(fk(traj.q[arm.name][k], arm.links, arm.base)[1])
            fruit = next(f for f in prob.fruits if f.id == g["fruit"])
            assert np.hypot(*(tip - np.asarray(fruit.position))) < 1e-3
    # at rest the rates are exact zeros, not the spline's rounding (it wrote -1.07e-258)
    rates = np.concatenate([np.r_[traj.qd[a].ravel(), traj.qdd[a].ravel()] for a in arms])
    assert not np.any((rates != 0) & (np.abs(rates) < 1e-12)) and np.any(rates == 0)


@pytest.mark.parametrize("fmt", ["json", "yaml"])
def test_ros_joint_trajectory_per_arm(crossing_plan, tmp_path, fmt):
    paths = export_plan(crossing_plan, 20.0, fmt, tmp_path / "ros")
    assert [p.name for p in paths] == [f"events.{fmt}"] + [f"{a}.{fmt}" for a in crossing_plan.q]
    traj = trajectory(crossing_plan, 20.0)
    load = json.loads if fmt == "json" else yaml.safe_load
    assert len(load(paths[0].read_text())["events"]) == len(crossing_plan.events)
    paths = paths[1:]
    for arm, path in zip(crossing_plan.q, paths):
        msg = json.loads(path.read_text()) if fmt == "json" else yaml.safe_load(path.read_text())
        assert set(msg) == {"header", "joint_names", "points"}
        assert msg["joint_names"] == [f"{arm}_joint1", f"{arm}_joint2"]
        assert len(msg["points"]) == len(traj.time)
        p = msg["points"][3]
        assert set(p) == {"positions", "velocities", "accelerations", "effort", "time_from_start"}
        assert p["time_from_start"] == {"sec": 0, "nanosec": 150_000_000}
        last = msg["points"][-1]["time_from_start"]
        assert last["sec"] + last["nanosec"] * 1e-9 == pytest.approx(traj.time[-1], abs=1e-9)
        np.testing.assert_allclose([q["velocities"] for q in msg["points"]], traj.qd[arm], atol=1e-12)
        np.testing.assert_allclose([q["accelerations"] for q in msg["points"]], traj.qdd[arm], atol=1e-12)


def test_untrusted_arm_names_make_safe_distinct_file_names():
    names = safe_names(["left", "../../etc/passwd", "a b", "a_b", "", "Left"])
    assert names["../../etc/passwd"] == "etc_passwd"
    assert len(set(v.lower() for v in names.values())) == 6
    assert all("/" not in v and not v.startswith(".") and v for v in names.values())
    # a name that is safe as it is keeps it, wherever it comes: "a b" before "a_b" took a_b
    assert names["a_b"] == "a_b" and names["a b"] == "a_b_2" and names["left"] == "left" and names["Left"] == "Left_2"
    assert safe_names(["a b", "a_b"]) == {"a b": "a_b_2", "a_b": "a_b"}


def test_cli_export(single_plan, tmp_path):
    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(single_plan.to_dict()))
    res = run("export", str(plan_path), "--rate", "250")
    assert res.exit_code == 0, res.output
    assert (tmp_path / "plan_250hz.csv").exists()
    res = run("export", str(plan_path), "--format", "yaml", "--rate", "50", "--out", str(tmp_path / "ros"))
    assert res.exit_code == 0 and (tmp_path / "ros" / "arm.yaml").exists()
    for bad in ("0", "-5", "nan", "1e6"):
        res = run("export", str(plan_path), "--rate", bad)
        assert res.exit_code == ExitCode.USAGE and "--rate" in res.stderr
    # a CSV into a folder (one that exists, or a name ending with /): <plan>_<rate>hz.csv in it
    # (--out ex/ wrote a CSV file named ex)
    res = run("export", str(plan_path), "--out", str(tmp_path / "ros"))
    assert res.exit_code == 0 and (tmp_path / "ros" / "plan_100hz.csv").is_file(), res.output
    res = run("export", str(plan_path), "--out", str(tmp_path / "new") + "/")
    assert res.exit_code == 0 and (tmp_path / "new" / "plan_100hz.csv").is_file(), res.output
    (tmp_path / "ros" / "plan_50hz.csv").mkdir()  # that name is a folder: refused
    res = run("export", str(plan_path), "--rate", "50", "--out", str(tmp_path / "ros"))
    assert res.exit_code == ExitCode.USAGE and "expected a CSV file name, found a folder" in res.stderr
    for name in ("ex.json", "ex.yaml"):  # a folder of per-arm files under a file's name: refused, nothing made
        res = run("export", str(plan_path), "--format", name.split(".")[1], "--out", str(tmp_path / name))
        assert res.exit_code == ExitCode.USAGE and "give a folder name" in res.stderr and not (tmp_path / name).exists()
    res = run("export", str(tmp_path / "missing.json"))
    assert res.exit_code == ExitCode.BAD_INPUT
    # coplan's own plan.csv replay (or any other file) is not overwritten; an earlier export is
    replay = tmp_path / "plan.csv"
    replay.write_text("t,arm_q1,arm_q2\n0.0,0.1,0.2\n")
    res = run("export", str(plan_path), "--out", str(replay))
    assert res.exit_code == ExitCode.USAGE and "plan.csv replay" in res.stderr
    assert replay.read_text() == "t,arm_q1,arm_q2\n0.0,0.1,0.2\n"
    res = run("export", str(plan_path), "--out", str(tmp_path / "plan_250hz.csv"))
    assert res.exit_code == 0, res.output


def test_json_and_yaml_exports_never_overwrite_another_file_and_keep_a_rows_carriage(tmp_path):
    """(An arm named 'plan' exported into the run folder overwrote plan.json; an arm named
    'carriage' took the carriage's file, and the carriage's trajectory was lost.)"""
    from coplan.generate import gantry_row, to_yaml
    from coplan.pipeline import solve
    from coplan.problem import parse_problem, shipped_problems

    text = next(p for p in shipped_problems() if p.stem == "single_arm").read_text().replace("name: arm\n", "name: plan\n")
    prob = parse_problem(text)
    (tmp_path / "p.yaml").write_text(text)
    run = tmp_path / "run"
    solve(prob, planner="coordinated", out_dir=run)
    before = (run / "plan.json").read_bytes()
    for fmt in ("json", "yaml"):
        res = CliRunner().invoke(app, ["export", str(run / "plan.json"), "--format", fmt, "--out", str(run), "-p", str(tmp_path / "p.yaml")])
        if fmt == "json":
            assert res.exit_code == 2 and "found a coplan.plan file: it would be overwritten" in " ".join(res.output.split())
    assert (run / "plan.json").read_bytes() == before
    first = CliRunner().invoke(app, ["export", str(run / "plan.json"), "--format", "json", "--out", str(tmp_path / "ex"), "--unverified"])
    assert first.exit_code == 0, first.output
    again = CliRunner().invoke(app, ["export", str(run / "plan.json"), "--format", "json", "--out", str(tmp_path / "ex"), "-p", str(tmp_path / "p.yaml")])
    assert again.exit_code == 0, again.output  # an earlier export is replaced
    d = gantry_row(length=6.0, n_arms=2, density=2.0, seed=3)
    d["arms"][0]["name"] = "carriage"
    row = parse_problem(to_yaml(d))
    (tmp_path / "row.yaml").write_text(to_yaml(d))
    solve(row, out_dir=tmp_path / "rowrun")
    res = CliRunner().invoke(app, ["export", str(tmp_path / "rowrun" / "plan.json"), "-f", "json", "-o", str(tmp_path / "rowcli"),
                                   "-p", str(tmp_path / "row.yaml")])
    said = " ".join(res.output.split())
    assert res.exit_code == 0 and "note: arm 'carriage' is in carriage_2.json (joints carriage_2_joint1, carriage_2_joint2)" in said, said
    paths = export_plan(solve(row).plan, 100.0, "json", tmp_path / "row")
    names = {p.stem: json.loads(p.read_text())["joint_names"] for p in paths if p.stem != "events"}
    assert names == {"carriage": ["carriage_x"], "carriage_2": ["carriage_2_joint1", "carriage_2_joint2"],
                     "arm2": ["arm2_joint1", "arm2_joint2"]}


def test_an_export_too_coarse_for_the_motion_says_how_far_a_controller_would_depart(crossing_plan, tmp_path):
    """(``--rate 0.001`` wrote two points, both at home: a trajectory that never moves, and said
    nothing.) The figure is checked against its definition: a cubic through the points with
    their velocities, against the plan's samples."""
    from scipy.interpolate import CubicHermiteSpline

    from coplan.report.export import FOLLOW_TOLERANCE, follow_error

    fine = trajectory(crossing_plan, 100.0)
    second = max(np.abs(np.diff(P, n=2, axis=0)).max() for P in crossing_plan.q.values())
    assert follow_error(crossing_plan, fine)[0] <= second / 6 + 1e-9  # near the plan's own samples
    coarse = trajectory(crossing_plan, 2.0)
    err, arm, t = follow_error(crossing_plan, coarse)
    k = int(np.searchsorted(crossing_plan.time, t))
    follow = CubicHermiteSpline(coarse.time, coarse.q[arm], coarse.qd[arm], axis=0)(crossing_plan.time[k] + coarse.delay)
    assert err == pytest.approx(float(np.abs(follow - crossing_plan.q[arm][k]).max())) and err > FOLLOW_TOLERANCE
    from coplan.problem.load import default_problem_path

    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(crossing_plan.to_dict()))
    prob = ["-p", str(default_problem_path().parent / "crossing_paths.yaml")]
    said = " ".join(run("export", str(plan_path), "--rate", "0.001", *prob).stderr.split())
    assert "note: at 0.001 Hz a controller following these points" in said and "departs from the plan by up to" in said
    assert "note" not in run("export", str(plan_path), "--rate", "100", *prob).stderr


def test_the_default_name_of_an_export_at_a_fractional_rate_keeps_its_rate(single_plan, tmp_path):
    """(``--rate 12.5`` wrote plan_12.csv, and 0.5 Hz and 0.2 Hz both plan_0.csv, the second over the first.)"""
    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(single_plan.to_dict()))
    for rate in ("12.5", "0.5", "0.2"):
        res = run("export", str(plan_path), "--rate", rate)
        assert res.exit_code == 0 and f"wrote {tmp_path / f'plan_{rate}hz.csv'}" in res.output, res.output
    assert sorted(p.name for p in tmp_path.glob("plan_*hz.csv")) == ["plan_0.2hz.csv", "plan_0.5hz.csv", "plan_12.5hz.csv"]


def test_an_export_whose_smoothing_departs_from_the_samples_does_not_blame_the_rate(tmp_path):
    """(Joints ten times as quick to accelerate: at 100 Hz and at 1000 Hz the note said "at 1000
    Hz a controller ... departs from the plan by up to 0.002 rad", as if a higher rate would cure
    it; it is the B-spline's own distance from the samples, at any rate.) The note says so, with
    the figure of its definition, a sixth of the samples' largest second difference."""
    from coplan.problem import load_problem
    from coplan.problem.load import default_problem_path
    from coplan.report.export import FOLLOW_TOLERANCE, follow_error, smoothing_error

    text = (default_problem_path().parent / "crossing_paths.yaml").read_text()
    fast = text.replace("max_acceleration: [8.0, 12.0]", "max_acceleration: [80.0, 120.0]").replace(
        "max_jerk: [80.0, 120.0]", "max_jerk: [8000.0, 12000.0]")
    assert fast.count("8000.0") == 1
    (tmp_path / "fast.yaml").write_text(fast)
    plan = plan_coordinated(load_problem(tmp_path / "fast.yaml")).plan
    smooth, arm, t = smoothing_error(plan)
    second = max(np.abs(np.diff(q, n=2, axis=0)).max() for q in plan.q.values())
    assert smooth == pytest.approx(second / 6) and smooth > FOLLOW_TOLERANCE
    k = int(np.searchsorted(plan.time, t))  # the B-spline's value at that sample, from the export at the plan's own rate
    assert float(np.abs(trajectory(plan, 100.0).q[arm][k + 1] - plan.q[arm][k]).max()) == pytest.approx(smooth)
    assert follow_error(plan, trajectory(plan, 1000.0))[0] - smooth <= FOLLOW_TOLERANCE
    plan.save(tmp_path / "o")
    for rate in ("100", "1000"):
        said = " ".join(run("export", str(tmp_path / "o" / "plan.json"), "--rate", rate, "-o",
                            str(tmp_path / f"e{rate}.csv"), "-p", str(tmp_path / "fast.yaml")).stderr.split())
        assert "passes up to" in said and "at any rate" in said and f"at {rate} Hz a controller" not in said


def test_the_point_cap_counts_the_export_s_own_points(single_plan):
    """(The cap was checked against the plan's duration, but the export runs two plan steps past
    it: at the limit it passed 2,000,200 points per arm.) At the rate where the export has
    MAX_POINTS points it is written; one point more is refused, before anything is computed."""
    import math
    from dataclasses import replace

    from coplan.report.export import MAX_POINTS, check_rate

    n = 20_001  # 200 s at 100 Hz, the arm at home (a long plan: the cap is met below the largest rate)
    plan = replace(single_plan, time=np.arange(n) / 100.0, q={a: np.repeat(q[:1], n, axis=0) for a, q in single_plan.q.items()},
                   events=[])
    length = plan.duration + 2 * plan.dt
    rate = (MAX_POINTS - 1) / length  # MAX_POINTS points: 0 to length
    assert math.ceil(length * rate - 1e-9) + 1 == MAX_POINTS
    check_rate(rate, plan)
    with pytest.raises(ValueError, match=f"at most {MAX_POINTS} points per arm, found {MAX_POINTS + 1}"):
        check_rate((MAX_POINTS - 0.5) / length, plan)
    assert trajectory(plan, 20.0).time.size == math.ceil(length * 20.0 - 1e-9) + 1


def test_an_unsafe_or_edited_plan_is_not_exported_for_a_controller(tmp_path):
    """(The heuristic's plan (an optimal run's baseline.json), unsafe, and a plan.json edited after its verdict were
    exported with exit 0 -- the second with a note that its rates kept the plan's limits; the
    export's jerk was 9.6 x the limit, its acceleration 61 x.) The plan is verified against its
    problem first: refused, exit 6, nothing written; --unverified exports it, and says so."""
    from coplan.pipeline import solve
    from coplan.problem.load import default_problem_path

    run_dir, heur = tmp_path / "run", tmp_path / "heur"
    solve(default_problem_path(), out_dir=run_dir, planner="coordinated")  # (plan.json records its problem file)
    solve(default_problem_path(), out_dir=heur, planner="heuristic")  # (the course's baseline: unsafe, its jerk)
    assert json.loads((heur / "plan.json").read_text())["status"] == "unsafe"
    res = run("export", str(heur / "plan.json"), "-o", str(tmp_path / "b.csv"))
    said = " ".join(res.output.split())
    assert res.exit_code == 6 and "does not pass the verifier against problem 'greenhouse-row'" in said and "jerk" in said, said
    assert "nothing written (--unverified exports it anyway)" in said and not (tmp_path / "b.csv").exists()
    res = run("export", str(heur / "plan.json"), "-o", str(tmp_path / "b.csv"), "--unverified")
    assert res.exit_code == 0 and (tmp_path / "b.csv").is_file() and "exported without verifying it (--unverified)" in " ".join(res.output.split())
    # edited after its verdict (it still says success; its plan.npz beside it is of the old motion)
    edited = tmp_path / "edited"
    edited.mkdir()
    doc = json.loads((run_dir / "plan.json").read_text())
    arm = next(iter(doc["arms"]))
    doc["arms"][arm]["q"][300][0] += 0.05
    (edited / "plan.json").write_text(json.dumps(doc))
    (edited / "plan.npz").write_bytes((run_dir / "plan.npz").read_bytes())
    res = run("export", str(edited / "plan.json"), "-o", str(tmp_path / "e.csv"))
    said = " ".join(res.output.split())
    assert res.exit_code == 6 and "does not pass the verifier" in said and not (tmp_path / "e.csv").exists(), said
    # the verified plan itself: exported, no word of a verdict
    res = run("export", str(run_dir / "plan.json"), "-o", str(tmp_path / "ok.csv"))
    assert res.exit_code == 0 and (tmp_path / "ok.csv").is_file() and "verif" not in res.output, res.output


def test_an_export_larger_than_verify_reads_says_so(single_plan, tmp_path, monkeypatch):
    """(A 270 MB export at 1 kHz was written in silence; coplan verify then refused it as over
    its 64 MiB.) The cap is lowered here to the size of a small export."""
    import coplan.plan
    from coplan.problem.load import default_problem_path

    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(single_plan.to_dict()))
    monkeypatch.setattr(coplan.plan, "MAX_PLAN_BYTES", 2000)
    res = run("export", str(plan_path), "-o", str(tmp_path / "e.csv"), "-p", str(default_problem_path().with_name("single_arm.yaml")))
    said = " ".join(res.stderr.split())
    assert res.exit_code == 0 and "more than coplan verify reads" in said and (tmp_path / "e.csv").stat().st_size > 2000, said


@pytest.mark.parametrize("name, rate, columns", [("crossing_paths", "250", ("left_qd1", "right_qdd2")),
                                                  ("locked_arms", "100", ("r2_qd1", "r1_qdd2"))])
def test_verify_holds_an_exports_velocities_and_accelerations_to_its_positions(tmp_path, name, rate, columns):
    """(The verifier checks an export's positions; its velocity columns -- what a controller
    follows for feed-forward -- were read past: five times the limit, 'passed'. Then the check
    refused coplan's own 100 Hz export of locked_arms, its time-optimal moves switching jerk:
    the differences' own error grows with it.)"""
    import csv

    from coplan.pipeline import solve
    from coplan.problem.load import default_problem_path

    problem = default_problem_path().parent / f"{name}.yaml"
    solve(problem, planner="coordinated", out_dir=tmp_path / "run")  # (with its plan.npz: the export at full precision)
    plan_path = tmp_path / "run" / "plan.json"
    assert run("export", str(plan_path), "--rate", rate, "-o", str(tmp_path / "e.csv")).exit_code == 0
    res = run("verify", str(problem), str(tmp_path / "e.csv"))
    assert res.exit_code == 0, res.output
    rows = list(csv.reader((tmp_path / "e.csv").open()))
    for column, factor in zip(columns, (5.0, 1.2)):
        bad = [list(r) for r in rows]
        j = bad[0].index(column)
        for r in bad[1:]:
            r[j] = repr(float(r[j]) * factor)
        with (tmp_path / "bad.csv").open("w", newline="") as f:
            csv.writer(f).writerows(bad)
        res = run("verify", str(problem), str(tmp_path / "bad.csv"))
        said = " ".join(res.output.split())
        assert res.exit_code == 3 and f"{column}: expected the {'velocity' if 'qd1' in column else 'acceleration'} of the positions" in said, said


@pytest.mark.parametrize("name", ["plan.json", "plan.csv"])
def test_a_plan_from_a_pipe_is_exported_as_verify_reads_it(tmp_path, name, fifo):
    """(Export read the plan twice -- once to export, once to verify -- and a pipe was empty the
    second time: "found an empty file", exit 3, while coplan verify read the same pipe.)"""
    from coplan.pipeline import solve
    from coplan.problem.load import default_problem_path

    solve(default_problem_path(), planner="coordinated", out_dir=tmp_path / "run")
    pipe = fifo((tmp_path / "run" / name).read_bytes())
    res = run("export", str(pipe), "-p", str(default_problem_path()), "-o", str(tmp_path / "e.csv"))
    assert res.exit_code == 0 and (tmp_path / "e.csv").is_file(), res.output
    assert len((tmp_path / "e.events.csv").read_text().splitlines()) == 1 + 22  # (11 picks, 11 places: inferred from a CSV too)


def test_an_export_of_a_plan_csv_carries_the_inferred_events_and_an_arm_named_events_keeps_its_file(tmp_path):
    """(A plan.csv's export wrote an events file of its header alone, while its note said the picks
    and places were inferred; an arm named Events became Events_2 beside the new events.json,
    its joint names with it, and the note blamed its name.)"""
    import csv

    from coplan.pipeline import solve
    from coplan.problem.load import default_problem_path

    problem = default_problem_path().parent / "crossing_paths.yaml"
    solve(problem, planner="coordinated", out_dir=tmp_path / "run")
    n = len(json.loads((tmp_path / "run" / "plan.json").read_text())["events"])
    res = run("export", str(tmp_path / "run" / "plan.csv"), "-p", str(problem), "-o", str(tmp_path / "c.csv"))
    assert res.exit_code == 0, res.output
    got = list(csv.DictReader((tmp_path / "c.events.csv").open()))
    assert len(got) == n and {g["kind"] for g in got} == {"pick", "place"}
    text = problem.read_text()
    odd = text.replace("name: left,", 'name: "Events",', 1)
    assert odd != text
    (tmp_path / "odd.yaml").write_text(odd)
    solve(tmp_path / "odd.yaml", planner="coordinated", out_dir=tmp_path / "odd")
    res = run("export", str(tmp_path / "odd" / "plan.json"), "-f", "json", "-o", str(tmp_path / "oj"))
    said = " ".join(res.output.split())
    assert res.exit_code == 0 and (tmp_path / "oj" / "Events.json").is_file() and (tmp_path / "oj" / "events_2.json").is_file(), said
    assert json.loads((tmp_path / "oj" / "Events.json").read_text())["joint_names"] == ["Events_joint1", "Events_joint2"]
    assert "note: arm" not in said and "note: the picks and places are in events_2.json" in said, said
    # another plan exported into that folder: the earlier export's files of arms it does not have are removed (a
    # controller loading the folder got two plans' trajectories), said; a rate verify does not read is said too
    res = run("export", str(tmp_path / "run" / "plan.json"), "-f", "json", "-o", str(tmp_path / "oj"), "--rate", "50")
    said = " ".join(res.output.split())
    assert res.exit_code == 0 and sorted(p.name for p in (tmp_path / "oj").iterdir()) == ["events.json", "left.json", "right.json"], said
    assert "note: removed the earlier export's Events.json, events_2.json" in said and "at 50 Hz coplan verify does not read" in said, said
    # a folder of someone's own trajectories (no coplan events file in it): theirs stay
    theirs = tmp_path / "theirs"
    theirs.mkdir()
    (theirs / "gripper.json").write_text(json.dumps({"header": {}, "joint_names": ["g"], "points": []}))
    res = run("export", str(tmp_path / "run" / "plan.json"), "-f", "json", "-o", str(theirs))
    assert res.exit_code == 0 and (theirs / "gripper.json").is_file() and "removed" not in res.output, res.output


def test_an_arm_named_like_a_windows_device_gets_a_file_windows_can_make():
    """(Arms named CON, nul, Com1 or aux became CON.json ...: a device there, not a file.)"""
    from pathlib import PureWindowsPath

    names = safe_names(["CON", "nul", "Com1", "aux", "console", "lpt9", "left", "nul.a"])
    assert not any(PureWindowsPath(v + ".json").is_reserved() for v in names.values()), names
    assert names["console"] == "console" and names["left"] == "left" and names["CON"] == "CON_"
    assert names["nul.a"] == "nul_.a"  # (NUL.anything is the device: nul.a_.json was one)


def test_exporting_an_unsafe_or_edited_plan_from_python_warns(problems_dir, crossing_plan, tmp_path):
    """(``coplan export`` refuses a plan the verifier refused; from Python the course's heuristic plan,
    collisions and all, was written as a controller's trajectory without a word.) It is written --
    the function writes what it is given -- with a UserWarning saying why it is no trajectory to send."""
    import warnings

    from coplan.planners.heuristic import plan_heuristic
    from coplan.plan import PlanStatus, finalize_plan
    from coplan.problem import load_problem
    from coplan.verify import verify

    prob = load_problem(problems_dir / "crossing_paths.yaml")
    bad = plan_heuristic(prob)
    bad = finalize_plan(bad, verify(prob, bad), len(prob.reachable_ids()))
    assert bad.status == PlanStatus.UNSAFE
    with pytest.warns(UserWarning, match=r"though the verifier refused it \(unsafe\): not a trajectory to send"):
        assert export_plan(bad, 100.0, "csv", tmp_path / "bad.csv")[0].is_file()
    import dataclasses

    edited = dataclasses.replace(crossing_plan, q={a: v.copy() for a, v in crossing_plan.q.items()})
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # the verified plan as it is: no warning
        export_plan(edited, 100.0, "csv", tmp_path / "good.csv")
    edited.q[edited.arm_names[0]][10:20] += 0.01
    with pytest.warns(UserWarning, match="its motion changed after it was verified"):
        export_plan(edited, 100.0, "csv", tmp_path / "edited.csv")


def test_rounded_samples_are_restored_within_their_rounding_to_keep_the_limits(problems_dir):
    """The samples of a plan at its limits, rounded to 1e-7 as plan.json keeps them, run over the
    limits in their differences; :func:`restored_samples` moves each back by at most half a step so
    that none does (the full-precision samples are such samples), keeps each held pose exactly, and
    says None where no samples within the rounding keep the limits."""
    from coplan.problem import load_problem
    from coplan.report.export import restored, restored_samples

    prob = load_problem(problems_dir / "dense_overlap.yaml")
    plan = plan_coordinated(prob).plan
    h = plan.dt
    for arm in prob.arms:
        for j in range(2):
            lim = (arm.max_velocity[j], arm.max_acceleration[j], arm.max_jerk[j])
            r = np.round(plan.q[arm.name][:, j] / 1e-7) * 1e-7
            before = max(np.abs(np.diff(r, n=k)).max() / (lim[k - 1] * h**k) for k in (1, 2, 3))
            x = restored_samples(r, h, lim)
            assert x is not None
            assert np.abs(x - r).max() <= 0.5e-7 * (1 + 1e-6)
            after = max(np.abs(np.diff(x, n=k)).max() / (lim[k - 1] * h**k) for k in (1, 2, 3))
            assert after <= 1 + 1e-6 < before, (arm.name, j, before, after)
            held = np.flatnonzero((r[1:-1] == r[:-2]) & (r[1:-1] == r[2:])) + 1
            assert np.array_equal(x[held], r[held])
    # a series over its jerk limit by more than any rounding can explain: None
    t = np.arange(0.0, 1.0, h)
    assert restored_samples(np.round(100.0 * t**3 / 6 / 1e-7) * 1e-7, h, (10.0, 10.0, 50.0)) is None
    # a plan with full-precision samples is left as it is
    same, ok = restored(plan, prob)
    assert same is plan and ok


def test_export_odds_and_ends_from_a_controls_engineer_s_trial(problems_dir, tmp_path):
    """A folder it cannot write into is refused before the work, exit 2 (it was "No such file or
    directory", exit 8, afterwards); rates that differ in their fifth digit get files of their own
    (333.3333 and 333.3334 Hz both wrote plan_333.333hz.csv, the second replacing the first); a
    rate of True is no rate; verifying an export against another problem calls it an export table
    and names only the arms that differ (it was "a plan.csv replay", "missing [], unknown [...]")."""
    from coplan.problem import load_problem
    from coplan.report.export import trajectory

    plan = plan_coordinated(load_problem(problems_dir / "crossing_paths.yaml")).plan
    files = plan.save(tmp_path / "run")
    prob = ["-p", str(problems_dir / "crossing_paths.yaml")]
    blocked = tmp_path / "file"
    blocked.write_text("a file, not a folder")
    res = run("export", str(files["json"]), "--out", str(blocked / "e.csv"), *prob)
    assert res.exit_code == 2 and "its folder" in res.output and not (blocked / "e.csv").exists(), res.output
    for rate in ("333.3333", "333.3334"):
        assert run("export", str(files["json"]), "--rate", rate, *prob).exit_code == 0
    assert {p.name for p in (tmp_path / "run").glob("plan_333*hz.csv")} == {"plan_333.3333hz.csv", "plan_333.3334hz.csv"}
    with pytest.raises(ValueError, match="expected a rate"):
        trajectory(plan, True)
    res = run("verify", str(problems_dir / "greenhouse_row.yaml"), str(tmp_path / "run" / "plan_333.3333hz.csv"))
    said = " ".join(res.output.split())
    assert res.exit_code == 3 and "a coplan export table (it names no problem)" in said and "missing ['center']" in said, said
    assert "unknown []" not in said and "plan.csv replay" not in said


@pytest.mark.parametrize("fmt", ["csv", "json"])
@pytest.mark.parametrize("fault", [KeyboardInterrupt, OSError])
def test_an_export_cut_short_leaves_the_earlier_export_whole(problems_dir, tmp_path, monkeypatch, fmt, fault):
    """(A SIGTERM or a full disk while the export's files were written left one file of the new
    plan beside the others of the old one, or three arms' files of four; exit 143 or 8.) The
    files go into place together or not at all, the earlier export whole, no staging file left,
    a full disk naming the file it was writing."""
    import tempfile

    from coplan.problem import load_problem

    prob = load_problem(problems_dir / "greenhouse_row.yaml")
    first, second = plan_coordinated(prob).plan, plan_heuristic_like(prob)
    out = tmp_path / ("e.csv" if fmt == "csv" else "e")
    export_plan(first, 100.0, fmt, out)
    files = sorted(out.parent.glob("e*")) if fmt == "csv" else sorted(out.iterdir())
    before = {p: p.read_bytes() for p in files}
    real, calls = tempfile.mkstemp, []

    def cut(*a, **k):
        calls.append(1)
        if len(calls) == 2:
            raise fault() if fault is KeyboardInterrupt else OSError(28, "No space left on device")
        return real(*a, **k)

    monkeypatch.setattr(tempfile, "mkstemp", cut)
    with pytest.raises(fault) as e:
        export_plan(second, 100.0, fmt, out)
    monkeypatch.undo()
    after = sorted(out.parent.glob("e*")) if fmt == "csv" else sorted(out.iterdir())
    assert after == files and all(p.read_bytes() == before[p] for p in files)
    assert not [p for p in tmp_path.rglob("*") if p.name.endswith(".partial")]
    if fault is OSError:
        assert e.value.errno == 28 and Path(e.value.filename) in before, e.value  # (the file, not its staging name)


def plan_heuristic_like(prob):
    """Another plan of the same problem (the course's heuristic): other times, other files."""
    from coplan.planners.heuristic import plan_heuristic

    return plan_heuristic(prob)


def test_an_export_or_a_figure_of_a_plan_replaced_meanwhile_is_refused_and_said(problems_dir, tmp_path, monkeypatch):
    """(A ``coplan solve`` into the folder while ``coplan export``, ``plot`` or ``view`` read its
    plan left their files of the old plan in the new run's folder, every command exit 0.) Exit 8,
    saying why: an export puts nothing in place (an earlier export stays whole), a page that was
    not there before is removed; on a plan left alone nothing changes."""
    import os
    import shutil

    import coplan.report.export as export_mod
    import coplan.viz.viewer as viewer_mod
    from coplan.problem import load_problem

    prob = load_problem(problems_dir / "crossing_paths.yaml")
    files = plan_coordinated(prob).plan.save(tmp_path / "run")
    other = tmp_path / "other.json"
    prob_arg = ["-p", str(problems_dir / "crossing_paths.yaml")]
    assert run("export", str(files["json"]), *prob_arg).exit_code == 0  # (an earlier export, kept whole below)
    earlier = {p: p.read_bytes() for p in (tmp_path / "run").glob("plan_100hz*")}
    assert len(earlier) == 2

    def replaced(real):
        def call(*a, **k):
            shutil.copy(files["json"], other)  # (the same plan, another file: what a new run's rename does to the path)
            os.replace(other, files["json"])
            return real(*a, **k)
        return call

    monkeypatch.setattr(export_mod, "trajectory", replaced(export_mod.trajectory))
    res = run("export", str(files["json"]), *prob_arg)
    assert res.exit_code == 8 and "changed while it was read" in " ".join(res.output.split()), res.output
    assert {p: p.read_bytes() for p in (tmp_path / "run").glob("plan_100hz*")} == earlier
    assert not [p for p in (tmp_path / "run").iterdir() if p.name.endswith(".partial")]
    monkeypatch.undo()
    monkeypatch.setattr(viewer_mod, "write_view", replaced(viewer_mod.write_view))
    res = run("view", str(files["json"]), *prob_arg)
    assert res.exit_code == 8 and not (tmp_path / "run" / "plan.html").exists(), res.output
    monkeypatch.undo()
    assert run("view", str(files["json"]), *prob_arg).exit_code == 0  # (left alone: written, exit 0)
    assert (tmp_path / "run" / "plan.html").exists()


def test_files_beside_a_plan_ignore_the_run_folder_rules_and_a_folder_in_the_way_is_refused(problems_dir, tmp_path):
    """(A user's file in ``<run>.previous`` made export, view and animate refuse the run folder
    itself, exit 2: the rules of a run's .previous are a run's, not a file's. A folder named as one
    of an export's files stopped it half-way, exit 8.)"""
    from coplan.problem import load_problem

    prob = load_problem(problems_dir / "crossing_paths.yaml")
    files = plan_coordinated(prob).plan.save(tmp_path / "run")
    (tmp_path / "run.previous").mkdir()
    (tmp_path / "run.previous" / "mine.txt").write_text("mine")
    prob_arg = ["-p", str(problems_dir / "crossing_paths.yaml")]
    for args in (["export", str(files["json"])], ["view", str(files["json"])]):
        res = run(*args, *prob_arg)
        assert res.exit_code == 0, res.output
    (tmp_path / "ej" / "right.json").mkdir(parents=True)
    res = run("export", str(files["json"]), "--format", "json", "--out", str(tmp_path / "ej"), *prob_arg)
    assert res.exit_code == 2 and "found a folder of that name" in " ".join(res.output.split()), res.output
    assert sorted(p.name for p in (tmp_path / "ej").iterdir()) == ["right.json"]
