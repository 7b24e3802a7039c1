"""Faults inside a solve (issue 10): the NLP on windows of a single time-scale segment or a
single interval, and an internal error in a stage, which must still save what was computed.
"""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import coplan
import coplan.planners.optimal.stages as optimal_mod  # (where the stages call the coordinator and the search)
from coplan.cli import app
from coplan.planners.coordinated import plan_coordinated
from coplan.kinds import ExitCode, PlanStatus
from coplan.planners.optimal.nlp import ConstraintPoint, build_grid, build_nlp
from coplan.planners.optimal.nlp_solve import solve_nlp
from coplan.planners.optimal.planner import OptimalOptions, nlp_plan
from coplan.plan import load_plan
from coplan.problem import default_problem_path, load_problem

PROBLEMS = default_problem_path().parent


def _windows_in_one_segment(grid):
    """A window of two intervals inside one segment, and one of a single interval."""
    counts = np.bincount(grid.segment)
    seg = int(np.flatnonzero(counts >= 2)[0])
    k = int(np.flatnonzero(grid.segment == seg)[0])
    return [(k, k + 2), (k, k + 1)]


@pytest.mark.parametrize("name", ["single_arm", "greenhouse_row"])
def test_nlp_window_with_one_segment_or_one_interval_builds_and_solves(name: str) -> None:
    # CasADi indexes a 1x1 expression with a list into a *row*: a window with one time-scale
    # segment (or one interval) crashed with "Dimension mismatch for (x*y)" before the fix
    prob = load_problem(PROBLEMS / f"{name}.yaml")
    cand = plan_coordinated(prob).candidate
    grid = build_grid(cand.schedules, 0.06)
    names = [a.name for a in prob.arms]
    for lo, hi in _windows_in_one_segment(grid):
        points = [ConstraintPoint(k=lo, tau=0.5, ia=0, ib=1, s=1, u=1)] if len(names) > 1 else []
        nlp = build_nlp(prob, cand.schedules, grid, points, 0.015, window=(lo, hi))
        sol = solve_nlp(nlp, names)
        assert sol.status.converged, sol.ipopt_status
        assert sol.t.size == hi - lo + 1
        # the warm start is feasible and the window is pinned at its end pose: same duration
        # within the time scale's bounds, and the end pose of the warm start is reached
        assert 0.3 * (grid.t[hi] - grid.t[lo]) - 1e-9 <= sol.t[-1] <= 2.0 * (grid.t[hi] - grid.t[lo]) + 1e-9
        for n in names:
            assert sol.X[n].shape == (6, hi - lo + 1)


def test_nlp_on_very_slow_joints_runs(single_arm) -> None:
    # the reproduction: max_velocity [0.01, 0.01] makes single moves of ~100 s, so the
    # 12 s receding windows each fall inside one segment
    slow = replace(single_arm, arms=(replace(single_arm.arms[0], max_velocity=(0.01, 0.01)),))
    cand = plan_coordinated(slow).candidate
    plan, info, status = nlp_plan(slow, cand.alloc, cand.schedules, OptimalOptions(), iterations=40)
    assert info["windows"] > 10  # (windows of ~12 s on a ~300 s schedule)
    assert info["iterations"] >= 40 and info["rounds"]  # it solved windows until the budget was spent
    assert all(r["status"] in ("optimal", "acceptable") for r in info["rounds"])


# --------------------------------------------------------------------------- internal errors
def _boom(*args, **kwargs):
    raise RuntimeError("boom in the search")


def test_internal_error_in_a_stage_keeps_the_incumbent_and_the_baseline(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(optimal_mod, "improve", _boom)
    res = coplan.solve(PROBLEMS / "crossing_paths.yaml", out_dir=tmp_path / "out")
    assert res.exit_code == ExitCode.INTERNAL
    assert not res.success  # (it said success beside exit code 1: the run is not, its kept plan is)
    assert res.error == "RuntimeError: boom in the search"
    assert "boom in the search" in res.error_trace
    # the verified coordinated incumbent is the plan, and it is on disk with the baseline
    plan = load_plan(tmp_path / "out" / "plan.json")
    assert plan.status == PlanStatus.SUCCESS and plan.verification["passed"]
    assert plan.metrics["makespan"] == pytest.approx(res.plan.metrics["coordinated_makespan"])
    assert plan.solver["internal_error"] == "RuntimeError: boom in the search"
    assert plan.solver["stopped_by"] == "internal_error"
    assert "kept the verified incumbent from the coordinated stage" in plan.solver["message"]
    assert load_plan(tmp_path / "out" / "baseline.json").metrics["makespan"] > 0
    assert (tmp_path / "out" / "verification.json").exists()


def test_internal_error_before_any_plan_keeps_the_baseline(tmp_path: Path, monkeypatch) -> None:
    def broken(*args, **kwargs):
        raise ValueError("boom in coordination")

    monkeypatch.setattr(optimal_mod, "plan_coordinated", broken)
    res = coplan.solve(PROBLEMS / "single_arm.yaml", out_dir=tmp_path / "out")
    assert res.exit_code == ExitCode.INTERNAL
    plan = load_plan(tmp_path / "out" / "plan.json")
    assert plan.status != PlanStatus.SUCCESS
    assert "no verified plan" in plan.solver["message"]
    assert load_plan(tmp_path / "out" / "baseline.json").metrics["harvested"] == 1


def test_cli_internal_error_exits_1_with_the_message_and_the_files(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(optimal_mod, "improve", _boom)
    out = tmp_path / "out"
    res = CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None}).invoke(
        app, ["solve", str(PROBLEMS / "crossing_paths.yaml"), "--out", str(out)])
    assert res.exit_code == 1, res.output
    assert "internal error (RuntimeError: boom in the search)" in res.output
    assert "COPLAN_DEBUG=1" in res.output and "Traceback" not in res.output
    assert (out / "plan.json").exists() and (out / "baseline.json").exists()
    res = CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None}).invoke(
        app, ["solve", str(PROBLEMS / "crossing_paths.yaml"), "--out", str(tmp_path / "o2"), "--json"])
    assert res.exit_code == 1
    doc = json.loads(res.stdout)
    assert doc["exit_code"] == 1 and doc["solver"]["internal_error"] == "RuntimeError: boom in the search"
