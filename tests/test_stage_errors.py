"""An internal error in one of the optimal planner's stages (a bug) keeps the plan computed before
it and makes the run "not a success" (exit 1): every caller of the planner says so, not only
``coplan solve`` -- the comparison's row, the clearance table, a row whose stops' cells it plans
and the row comparison (each had dropped the error: a run with a crashed stage read as clean)."""

from __future__ import annotations

import pytest

import coplan
import coplan.planners.optimal.planner as planner
import coplan.planners.optimal.stages as stages
from coplan.generate import gantry_row
from coplan.kinds import PlannerKind, StopRule
from coplan.problem import default_problem_path


def _boom(run):
    raise RuntimeError("injected bug in a stage")


@pytest.fixture
def crashing(monkeypatch):
    """The optimal planner's coordinated stage, then a stage that raises."""
    monkeypatch.setattr(planner, "STAGES", (stages.STAGES[0], ("boom", _boom)))


def test_solve_keeps_the_plan_and_says_the_error(crashing):
    res = coplan.solve("single_arm")
    assert res.error == "RuntimeError: injected bug in a stage" and int(res.exit_code) == 1
    assert res.verification.passed and res.plan.solver["internal_error"] == res.error


def test_the_comparison_row_carries_the_error(crashing, tmp_path):
    from coplan.report.comparison import compare

    cmp = compare([default_problem_path().parent / "single_arm.yaml"], planners=["optimal"], out_dir=tmp_path / "c",
                  figures=False)
    (row,) = cmp.rows
    assert row["error"] == "RuntimeError: injected bug in a stage" and row["status"] == "success", row
    assert cmp.failed_runs == [row]


def test_the_clearance_table_notes_the_error(crashing, tmp_path):
    from coplan.report.clearance import clearance_cost

    cost = clearance_cost(default_problem_path().parent / "single_arm.yaml", tmp_path / "c", extras_mm=(0.0,),
                          planner=PlannerKind.OPTIMAL)
    assert any("+0 mm: the planner stopped on an internal error (RuntimeError: injected bug in a stage)" in n
               for n in cost.notes), cost.notes


def test_a_row_planned_with_optimal_cells_says_which_stops_crashed(crashing, tmp_path):
    from coplan.report.rows import compare_rows

    row = gantry_row(length=4.0, n_arms=2, density=2.0, seed=1)
    res = coplan.solve(row, planner=PlannerKind.OPTIMAL, gantry="stop-and-go", stops=StopRule.FIXED)
    assert res.verification.passed and int(res.exit_code) == 1, res
    errors = res.plan.solver["row"]["cell_errors"]
    assert errors and set(errors.values()) == {"RuntimeError: injected bug in a stage"}
    assert res.error.startswith(f"internal error in the cell planner at {len(errors)} stop") and "x = " in res.error
    cmp = compare_rows(row, tmp_path / "r", rules=(StopRule.FIXED,), planner=PlannerKind.OPTIMAL, gantry="stop-and-go")
    (r,) = cmp.rows
    assert r["error"] == res.error and any(n.startswith("fixed: internal error in the cell planner") for n in cmp.notes), cmp.notes
