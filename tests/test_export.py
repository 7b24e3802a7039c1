"""`coplan export`: a plan for a joint controller -- positions, velocities, accelerations per joint
at a chosen rate, as CSV and as ROS 2 JointTrajectory JSON/YAML per arm; the derivatives are the
plan's real ones (analytic S-curve, finite differences)."""

from __future__ import annotations

import csv
import json

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
    the exported velocities and accelerations are its analytic ones."""
    arm = single_arm.arms[0]
    pick = next(e for e in single_plan.events if e.kind == EventKind.PICK)
    q_pick = single_plan.q[arm.name][round(pick.t_start / single_plan.dt)]
    move = SCurve.between(arm.home, q_pick, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
    assert move.duration == pytest.approx(pick.t_start, abs=2e-3)
    traj = trajectory(single_plan, rate=500.0)
    m = traj.time < move.duration - 0.02  # the move (the pick dwell follows: still, zero derivatives)
    pos, vel, acc, _ = move.derivatives(traj.time[m])
    assert np.abs(traj.q[arm.name][m] - pos).max() < 1e-5
    assert np.abs(traj.qd[arm.name][m] - vel).max() < 1e-3  # rad/s; peaks ~2-3 rad/s
    assert np.all(np.abs(traj.qdd[arm.name][m] - acc).max(axis=0) < 0.015 * np.array(arm.max_acceleration))
    assert np.abs(vel).max() > 0.5 * min(arm.max_velocity)  # a real move, not a trivial one
    dwell = (traj.time > pick.t_start + 0.05) & (traj.time < pick.t_end - 0.05)
    assert np.abs(traj.qd[arm.name][dwell]).max() < 1e-3 and np.abs(traj.qdd[arm.name][dwell]).max() < 0.05


def test_derivatives_agree_with_finite_differences_of_the_positions(crossing_plan):
    traj = trajectory(crossing_plan, rate=1000.0)
    h = 1e-3
    for arm in crossing_plan.q:
        q, qd, qdd = traj.q[arm], traj.qd[arm], traj.qdd[arm]
        np.testing.assert_allclose((q[2:] - q[:-2]) / (2 * h), qd[1:-1], atol=1e-4)
        # within one spline piece (between two plan samples) the second difference is exact
        inner = np.abs(np.round(traj.time[1:-1] / crossing_plan.dt) * crossing_plan.dt - traj.time[1:-1]) > 1.5 * h
        dd = (q[2:] - 2 * q[1:-1] + q[:-2]) / h**2
        np.testing.assert_allclose(dd[inner], qdd[1:-1][inner], atol=2e-3)
        np.testing.assert_allclose(dd, qdd[1:-1], atol=0.05)  # at a sample the acceleration has a kink
        # and the velocities are the plan's: central differences of its own 100 Hz samples
        P, dt = crossing_plan.q[arm], crossing_plan.dt
        k = np.arange(1, len(P) - 1)
        fd = (P[k + 1] - P[k - 1]) / (2 * dt)
        at = np.searchsorted(traj.time, crossing_plan.time[k] - 1e-9)
        np.testing.assert_allclose(qd[at], fd, atol=0.05)


def test_positions_are_the_plans_own_samples_and_start_and_end_at_rest(crossing_plan):
    traj = trajectory(crossing_plan, rate=50.0)  # every other sample of the 100 Hz grid
    assert traj.time[0] == 0.0 and traj.time[-1] == pytest.approx(crossing_plan.duration)
    for arm, P in crossing_plan.q.items():
        np.testing.assert_allclose(traj.q[arm], P[::2][: len(traj.time)], atol=1e-9)
        assert np.abs(traj.qd[arm][[0, -1]]).max() < 1e-12


def test_the_final_pose_is_always_a_point(single_plan):
    traj = trajectory(single_plan, rate=7.0)
    assert traj.time[-1] == pytest.approx(single_plan.duration)
    assert np.diff(traj.time)[:-1] == pytest.approx(1 / 7.0)


def test_csv_export(crossing_plan, tmp_path):
    (path,) = export_plan(crossing_plan, 100.0, "csv", tmp_path / "traj.csv")
    rows = list(csv.reader(path.open()))
    arms = list(crossing_plan.q)
    assert rows[0] == ["t"] + [f"{a}_{c}" for a in arms for c in ("q1", "q2", "qd1", "qd2", "qdd1", "qdd2")]
    data = np.array(rows[1:], float)
    traj = trajectory(crossing_plan, 100.0)
    assert data.shape == (len(traj.time), 1 + 6 * len(arms))
    np.testing.assert_allclose(data[:, 1:3], traj.q[arms[0]], atol=1e-8)
    np.testing.assert_allclose(data[:, 3:5], traj.qd[arms[0]], rtol=1e-8, atol=1e-8)
    assert list(tmp_path.iterdir()) == [path]  # no temporary file left
    # at rest the rates are exact zeros, not the spline's rounding (it wrote -1.07e-258)
    rates = np.concatenate([np.r_[traj.qd[a].ravel(), traj.qdd[a].ravel()] for a in arms])
    assert not np.any((rates != 0) & (np.abs(rates) < 1e-12)) and np.any(rates == 0)


@pytest.mark.parametrize("fmt", ["json", "yaml"])
def test_ros_joint_trajectory_per_arm(crossing_plan, tmp_path, fmt):
    paths = export_plan(crossing_plan, 20.0, fmt, tmp_path / "ros")
    assert [p.name for p in paths] == [f"{a}.{fmt}" for a in crossing_plan.q]
    traj = trajectory(crossing_plan, 20.0)
    for arm, path in zip(crossing_plan.q, paths):
        msg = json.loads(path.read_text()) if fmt == "json" else yaml.safe_load(path.read_text())
        assert set(msg) == {"header", "joint_names", "points"}
        assert msg["joint_names"] == [f"{arm}_joint1", f"{arm}_joint2"]
        assert len(msg["points"]) == len(traj.time)
        p = msg["points"][3]
        assert set(p) == {"positions", "velocities", "accelerations", "effort", "time_from_start"}
        assert p["time_from_start"] == {"sec": 0, "nanosec": 150_000_000}
        last = msg["points"][-1]["time_from_start"]
        assert last["sec"] + last["nanosec"] * 1e-9 == pytest.approx(crossing_plan.duration, abs=1e-9)
        np.testing.assert_allclose([q["velocities"] for q in msg["points"]], traj.qd[arm], atol=1e-12)
        np.testing.assert_allclose([q["accelerations"] for q in msg["points"]], traj.qdd[arm], atol=1e-12)


def test_untrusted_arm_names_make_safe_distinct_file_names():
    names = safe_names(["left", "../../etc/passwd", "a b", "a_b", "", "Left"])
    assert names["../../etc/passwd"] == "etc_passwd"
    assert len(set(v.lower() for v in names.values())) == 6
    assert all("/" not in v and not v.startswith(".") and v for v in names.values())


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
    run = tmp_path / "run"
    solve(prob, planner="coordinated", out_dir=run)
    before = (run / "plan.json").read_bytes()
    for fmt in ("json", "yaml"):
        res = CliRunner().invoke(app, ["export", str(run / "plan.json"), "--format", fmt, "--out", str(run)])
        if fmt == "json":
            assert res.exit_code == 2 and "found a coplan.plan file: it would be overwritten" in " ".join(res.output.split())
    assert (run / "plan.json").read_bytes() == before
    first = CliRunner().invoke(app, ["export", str(run / "plan.json"), "--format", "json", "--out", str(tmp_path / "ex")])
    assert first.exit_code == 0, first.output
    again = CliRunner().invoke(app, ["export", str(run / "plan.json"), "--format", "json", "--out", str(tmp_path / "ex")])
    assert again.exit_code == 0, again.output  # an earlier export is replaced
    d = gantry_row(length=6.0, n_arms=2, density=2.0, seed=3)
    d["arms"][0]["name"] = "carriage"
    row = parse_problem(to_yaml(d))
    paths = export_plan(solve(row).plan, 100.0, "json", tmp_path / "row")
    names = {p.stem: json.loads(p.read_text())["joint_names"] for p in paths}
    assert names == {"carriage": ["carriage_x"], "carriage_2": ["carriage_2_joint1", "carriage_2_joint2"],
                     "arm2": ["arm2_joint1", "arm2_joint2"]}


def test_an_export_too_coarse_for_the_motion_says_how_far_a_controller_would_depart(crossing_plan, tmp_path):
    """(``--rate 0.001`` wrote two points, both at home: a trajectory that never moves, and said
    nothing.) The figure is checked against its definition: a cubic through the points with
    their velocities, against the plan's samples."""
    from scipy.interpolate import CubicHermiteSpline

    from coplan.report.export import FOLLOW_TOLERANCE, follow_error

    fine = trajectory(crossing_plan, 100.0)
    assert follow_error(crossing_plan, fine)[0] < 1e-9  # the plan's own samples
    coarse = trajectory(crossing_plan, 2.0)
    err, arm, t = follow_error(crossing_plan, coarse)
    k = int(np.searchsorted(crossing_plan.time, t))
    follow = CubicHermiteSpline(coarse.time, coarse.q[arm], coarse.qd[arm], axis=0)(crossing_plan.time[k])
    assert err == pytest.approx(float(np.abs(follow - crossing_plan.q[arm][k]).max())) and err > FOLLOW_TOLERANCE
    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(crossing_plan.to_dict()))
    said = " ".join(run("export", str(plan_path), "--rate", "0.001").stderr.split())
    assert "note: at 0.001 Hz a controller following these points" in said and "departs from the plan by up to" in said
    assert "note" not in run("export", str(plan_path), "--rate", "100").stderr


def test_the_default_name_of_an_export_at_a_fractional_rate_keeps_its_rate(single_plan, tmp_path):
    """(``--rate 12.5`` wrote plan_12.csv, and 0.5 Hz and 0.2 Hz both plan_0.csv, the second over the first.)"""
    plan_path = tmp_path / "plan.json"
    plan_path.write_text(json.dumps(single_plan.to_dict()))
    for rate in ("12.5", "0.5", "0.2"):
        res = run("export", str(plan_path), "--rate", rate)
        assert res.exit_code == 0 and res.output.strip().endswith(f"plan_{rate}hz.csv"), res.output
    assert sorted(p.name for p in tmp_path.glob("plan_*")) == ["plan_0.2hz.csv", "plan_0.5hz.csv", "plan_12.5hz.csv"]
