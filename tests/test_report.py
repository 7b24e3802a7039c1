"""`coplan compare`: both planners solved, verified, tabulated; folders aggregated."""

from __future__ import annotations

import json
import shutil

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.errors import CoplanError, ProblemError
from coplan.pipeline import ExitCode
from coplan.problem import load_problem, shipped_problems
from coplan.report.comparison import PlannerSpec, compare
from coplan.verify import verify

PLANNERS = ["heuristic", "heuristic:makespan"]  # both allocations of the baseline: fast, and always available

FIELDS = (
    "status", "passed", "complete", "harvested", "reachable", "unreachable", "makespan", "cycle_time_worst",
    "cycle_time_mean", "throughput", "per_arm", "min_clearance", "certified_clearance", "collision_count",
    "collision_intervals", "peak_velocity", "peak_acceleration", "peak_jerk", "planning_time", "lower_bound",
    "makespan_ratio", "violation_count", "violation_kinds",
)


def shipped(name: str):
    return next(p for p in shipped_problems() if p.name == name)


@pytest.fixture(scope="module")
def crossing_report(tmp_path_factory):
    out = tmp_path_factory.mktemp("cmp")
    return out, compare(shipped("crossing_paths.yaml"), PLANNERS, out, figures=False)


def test_planner_specs():
    assert PlannerSpec.parse("heuristic").label == "heuristic"
    spec = PlannerSpec.parse("heuristic:makespan")
    assert (spec.planner.value, spec.allocation.value, spec.folder) == ("heuristic", "makespan", "heuristic-makespan")
    with pytest.raises(ValueError, match="planner"):
        PlannerSpec.parse("greedy")
    with pytest.raises(ValueError, match="allocation"):
        PlannerSpec.parse("optimal:fastest")


def test_compare_writes_every_figure(crossing_report):
    out, cmp = crossing_report
    doc = json.loads((out / "compare.json").read_text())
    assert doc["planners"] == PLANNERS
    assert [r["planner"] for r in doc["rows"]] == PLANNERS
    problem = load_problem(shipped("crossing_paths.yaml"))
    for row in doc["rows"]:
        assert row["error"] is None
        missing = [f for f in FIELDS if f not in row]
        assert not missing, missing
        assert row["harvested"] == row["reachable"] == 4 and row["unreachable"] == 0
        assert set(row["per_arm"]) == {"left", "right"}
        assert all({"fruit", "idle_fraction"} <= set(v) for v in row["per_arm"].values())
        assert row["throughput"] == pytest.approx(row["harvested"] / row["makespan"])
        assert row["makespan_ratio"] == pytest.approx(row["makespan"] / row["lower_bound"]) and row["makespan_ratio"] >= 1
        assert row["peak_jerk"] > 1 and row["peak_velocity"] <= 1 + 1e-6
        # the baseline collides here, and the report shows where
        assert row["status"] == "unsafe" and not row["passed"]
        assert row["collision_count"] == len(row["collision_intervals"]) > 0
        assert all(c["t_start"] <= c["t_end"] and c["penetration"] > 0 for c in row["collision_intervals"])
        assert row["min_clearance"] < 0 <= problem.task.clearance
        # the figures are the verifier's, for the plan that was written
        plan_file = row["files"]["json"]
        from coplan.plan import load_plan

        ver = verify(problem, load_plan(plan_file))
        assert ver.summary()["collision_count"] == row["collision_count"]
    assert doc["rows"][1]["makespan_vs_heuristic"] == pytest.approx(doc["rows"][1]["makespan"] / doc["rows"][0]["makespan"])
    md = (out / "compare.md").read_text()
    assert "| figure | heuristic | heuristic:makespan |" in md
    for title in ("makespan (s)", "throughput", "idle fraction per arm", "least clearance", "collision intervals",
                  "peak jerk / limit", "planning time", "makespan / lower bound", "fruit harvested / reachable / unreachable"):
        assert title in md
    assert "Collision intervals of **heuristic**" in md
    assert cmp.aggregate["heuristic"]["runs"] == 1


def test_compare_folder_aggregates_and_records_bad_files(tmp_path):
    src = tmp_path / "problems"
    src.mkdir()
    for name in ("single_arm.yaml", "crossing_paths.yaml"):
        shutil.copy(shipped(name), src / name)
    (src / "broken.yaml").write_text("name: broken\narms: []\n")
    said: list[str] = []
    cmp = compare(src, PLANNERS, tmp_path / "out", figures=False, progress=said.append)
    assert [p["error"] is not None for p in cmp.problems] == [True, False, False]  # sorted: broken, crossing, single
    # the progress lines count the invalid file as done, not as compared
    counts = [m for m in said if "problem files done" in m]
    assert [m.split(";")[0] for m in counts] == ["1 of 3 problem files done, 0 compared (1 skipped: invalid)",
                                                 "2 of 3 problem files done, 1 compared (1 skipped: invalid)",
                                                 "3 of 3 problem files done, 2 compared (1 skipped: invalid)"]
    assert len(cmp.rows) == 4 and not cmp.failed_runs
    agg = json.loads((tmp_path / "out" / "compare.json").read_text())["aggregate"]
    for label in PLANNERS:
        a = agg[label]
        assert a["runs"] == 2 and a["errors"] == 0
        assert a["fruit_harvested"] == a["fruit_reachable"] == 5
        assert a["collision_free"] == 1  # the single arm cannot collide, the crossing paths do
        assert a["worst"]["min_clearance"]["problem"] == "crossing-paths"
        assert a["worst"]["collision_count"]["problem"] == "crossing-paths"
        assert a["median"]["makespan_ratio"] >= 1 and a["median"]["planning_time"] > 0
        assert sum(a["statuses"].values()) == 2
    md = (tmp_path / "out" / "compare.md").read_text()
    assert "## Aggregate over 2 problems" in md and "Invalid problem file" in md


def test_compare_single_bad_file_raises(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("name: x\n")
    with pytest.raises(ProblemError):
        compare(bad, PLANNERS, tmp_path / "out", figures=False)


def test_compare_records_a_failing_planner(tmp_path, monkeypatch):
    import coplan.pipeline as pipeline

    real = pipeline.solve

    def flaky(problem, planner, **kw):
        if kw.get("allocation") is not None:
            raise CoplanError("solver exploded")
        return real(problem, planner=planner, **kw)

    monkeypatch.setattr(pipeline, "solve", flaky)
    runner = CliRunner()
    res = runner.invoke(app, ["compare", str(shipped("single_arm.yaml")), "-p", "heuristic", "-p", "heuristic:makespan",
                              "--no-figures", "-o", str(tmp_path)])
    assert res.exit_code == ExitCode.SOLVER_FAILED, res.output
    doc = json.loads((tmp_path / "compare.json").read_text())
    assert doc["rows"][1]["error"] == "CoplanError: solver exploded"
    assert doc["aggregate"]["heuristic:makespan"]["errors"] == 1


def test_cli_compare(tmp_path):
    runner = CliRunner()
    path = str(shipped("crossing_paths.yaml"))
    res = runner.invoke(app, ["compare", path, "-p", "heuristic", "-p", "heuristic:makespan", "--no-figures", "-o", str(tmp_path)])
    assert res.exit_code == ExitCode.OK, res.output
    assert "makespan" in res.stdout and "crossing-paths" in res.stdout
    assert (tmp_path / "compare.json").is_file() and (tmp_path / "compare.md").is_file()
    res = runner.invoke(app, ["compare", path, "-p", "heuristic", "--no-figures", "--json", "-o", str(tmp_path / "j")])
    assert res.exit_code == ExitCode.OK
    assert json.loads(res.stdout)["rows"][0]["planner"] == "heuristic"
    assert runner.invoke(app, ["compare", path, "-p", "greedy", "-o", str(tmp_path)]).exit_code == ExitCode.USAGE
    assert runner.invoke(app, ["compare", str(tmp_path / "nope.yaml"), "-o", str(tmp_path)]).exit_code == ExitCode.BAD_INPUT


def test_compare_with_figures(tmp_path):
    pytest.importorskip("matplotlib")
    cmp = compare(shipped("single_arm.yaml"), PLANNERS, tmp_path, figures=True)
    assert not cmp.notes, cmp.notes  # the figures module exists and drew
    pngs = sorted(p.name for p in (tmp_path / "single_arm").glob("*.png"))
    assert "schedule_gantt.png" in pngs and "clearance.png" in pngs
    md = (tmp_path / "compare.md").read_text()
    assert "](single_arm/schedule_gantt.png)" in md


def test_the_aggregate_leaves_a_problem_with_nothing_to_plan_out_of_the_medians():
    """(A folder with a problem no arm reaches put its makespan 0 and throughput 0 into the
    medians; "most collision intervals 0 (blocked)" named one problem of many for a most of 0.)"""
    from coplan.report.aggregate import aggregate

    def row(problem, status, makespan, throughput):
        return {"problem": problem, "planner": "p", "status": status, "passed": True, "complete": True,
                "collision_count": 0, "harvested": 1, "reachable": 1, "makespan": makespan, "throughput": throughput}

    rows = [row("a", "success", 2.0, 0.5), row("b", "success", 4.0, 0.25), row("none", "infeasible", 0.0, 0.0)]
    agg = aggregate(rows, ["p"])["p"]
    assert agg["median"]["makespan"] == 3.0 and agg["median"]["throughput"] == 0.375
    assert agg["worst"]["collision_count"] is None and agg["runs"] == 3


def test_a_second_comparison_into_a_folder_keeps_the_first_report_as_previous(tmp_path):
    """A comparison into a folder that holds an earlier one's report moves it to
    ``compare.previous.json`` / ``.md`` (replacing an older one) and says so in its notes, as a
    solve keeps its previous run; a folder of the user's named like it is never replaced. In a
    folder of problems, each problem's own report is kept the same way."""
    out = tmp_path / "out"
    first = compare(shipped("crossing_paths.yaml"), ["heuristic"], out, figures=False)
    text = (out / "compare.json").read_text()
    assert not any("previous report" in n for n in first.notes)
    second = compare(shipped("crossing_paths.yaml"), ["heuristic"], out, figures=False)
    assert (out / "compare.previous.json").read_text() == text
    assert (out / "compare.previous.md").is_file()
    assert any("previous report" in n and "compare.previous.json" in n for n in second.notes)
    assert json.loads((out / "compare.json").read_text())["notes"] == second.notes
    newer = (out / "compare.json").read_text()
    compare(shipped("crossing_paths.yaml"), ["heuristic"], out, figures=False)
    assert (out / "compare.previous.json").read_text() == newer  # (the older one replaced)
    (out / "compare.previous.json").unlink()
    (out / "compare.previous.json").mkdir()  # the user's folder of that name: left alone, the report rewritten
    (out / "compare.previous.json" / "mine.txt").write_text("keep me")
    compare(shipped("crossing_paths.yaml"), ["heuristic"], out, figures=False)
    assert (out / "compare.previous.json" / "mine.txt").read_text() == "keep me"
    assert (out / "compare.json").is_file()
    src = tmp_path / "cells"
    src.mkdir()
    shutil.copy(shipped("crossing_paths.yaml"), src / "crossing_paths.yaml")
    compare(src, ["heuristic"], tmp_path / "agg", figures=False)
    own = (tmp_path / "agg" / "crossing_paths" / "compare.json").read_text()
    compare(src, ["heuristic"], tmp_path / "agg", figures=False)
    assert (tmp_path / "agg" / "crossing_paths" / "compare.previous.json").read_text() == own
    assert (tmp_path / "agg" / "compare.previous.json").is_file()
