"""`coplan compare FOLDER` loses nothing: each problem's report is written as it finishes, Ctrl-C
leaves the finished problems' files and the aggregate of what finished, and a planner failing in
any way (even a bug) is a row while the run goes on."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import coplan.pipeline as pipeline
from coplan.cli import app
from coplan.kinds import ExitCode
from coplan.report import compare

import yaml

parse_yaml, dump_yaml = yaml.safe_load, yaml.safe_dump

PLANNERS = ["heuristic", "heuristic:makespan"]


@pytest.fixture
def folder(tmp_path: Path, problems_dir: Path) -> Path:
    """Three one-arm problems (a, b, c), quick to solve with the heuristic planners."""
    src = (problems_dir / "single_arm.yaml").read_text()
    assert src.count("\nname: single-arm\n") == 1
    d = tmp_path / "problems"
    d.mkdir()
    for name in ("a", "b", "c"):
        (d / f"{name}.yaml").write_text(src.replace("\nname: single-arm\n", f"\nname: problem-{name}\n"))
    return d


def interrupt_on(name: str, monkeypatch):
    real = pipeline.solve

    def solve(problem, **kw):
        if problem.name == name:
            raise KeyboardInterrupt
        return real(problem, **kw)

    monkeypatch.setattr(pipeline, "solve", solve)


def test_ctrl_c_keeps_every_finished_problem_and_their_aggregate(folder, tmp_path, monkeypatch):
    interrupt_on("problem-c", monkeypatch)
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        compare(folder, PLANNERS, out, figures=False)
    doc = json.loads((out / "compare.json").read_text())
    assert [p["name"] for p in doc["problems"]] == ["problem-a", "problem-b"]
    assert [(r["problem"], r["planner"]) for r in doc["rows"]] == [(p, s) for p in ("problem-a", "problem-b") for s in PLANNERS]
    assert doc["aggregate"]["heuristic"]["runs"] == 2
    assert any("interrupted while comparing c.yaml" in n for n in doc["notes"])
    assert "interrupted while comparing c.yaml" in (out / "compare.md").read_text()
    for stem in ("a", "b"):  # each finished problem's own report
        mine = json.loads((out / stem / "compare.json").read_text())
        assert [p["name"] for p in mine["problems"]] == [f"problem-{stem}"] and len(mine["rows"]) == 2
        assert (out / stem / "heuristic" / "plan.json").exists()
    assert not (out / "c" / "compare.json").exists()


def test_ctrl_c_in_the_cli_exits_130_with_the_report_of_what_finished(folder, tmp_path, monkeypatch):
    interrupt_on("problem-b", monkeypatch)
    res = CliRunner().invoke(app, ["compare", str(folder), "-p", "heuristic", "--no-figures", "-o", str(tmp_path / "o")])
    assert res.exit_code == ExitCode.INTERRUPTED, res.output
    assert "interrupted by the user (Ctrl-C)" in res.output  # the message, not the kind again ("interrupted")
    # where what finished is (it said only "interrupted by the user"; a row's comparison said where)
    assert f"interrupted: the report of what finished is in {tmp_path / 'o' / 'compare.json'}" in " ".join(res.output.split())
    doc = json.loads((tmp_path / "o" / "compare.json").read_text())
    assert [p["name"] for p in doc["problems"]] == ["problem-a"] and doc["rows"][0]["status"]


def test_an_interrupted_plan_stops_the_comparison(folder, tmp_path, monkeypatch):
    """The optimal planner turns Ctrl-C into an interrupted (saved) plan: compare stops there too."""
    from coplan.kinds import PlanStatus

    real = pipeline.solve

    def solve(problem, **kw):
        res = real(problem, **kw)
        if problem.name == "problem-b":
            res.plan.status = PlanStatus.INTERRUPTED
        return res

    monkeypatch.setattr(pipeline, "solve", solve)
    with pytest.raises(KeyboardInterrupt):
        compare(folder, ["heuristic"], tmp_path / "o", figures=False)
    doc = json.loads((tmp_path / "o" / "compare.json").read_text())
    # problem-b's interrupted plan is kept, marked so (it was dropped with every row of its problem)
    assert [p["name"] for p in doc["problems"]] == ["problem-a", "problem-b"]
    assert [(r["problem"], r["status"]) for r in doc["rows"]] == [("problem-a", "unsafe"), ("problem-b", "interrupted")]
    assert any("covers the 1 of 3 problem files that finished, and of b.yaml the planners that finished (none) and "
               "heuristic's verified incumbent" in n for n in doc["notes"])


def test_ctrl_c_during_one_planner_keeps_the_planners_that_finished_on_that_problem(folder, tmp_path, monkeypatch):
    """(Ctrl-C while the optimal planner ran on a cell threw away the heuristic's and the
    coordinated planner's finished, verified rows: the report said 0 of 1 files.)"""
    real = pipeline.solve

    def solve(problem, **kw):
        if problem.name == "problem-a" and kw.get("allocation") is not None:
            raise KeyboardInterrupt
        return real(problem, **kw)

    monkeypatch.setattr(pipeline, "solve", solve)
    res = CliRunner().invoke(app, ["compare", str(folder / "a.yaml"), "-p", "heuristic", "-p", "heuristic:makespan",
                                   "--no-figures", "-o", str(tmp_path / "o")])
    assert res.exit_code == ExitCode.INTERRUPTED, res.output
    doc = json.loads((tmp_path / "o" / "compare.json").read_text())
    assert [(r["planner"], r["status"]) for r in doc["rows"]] == [("heuristic", "unsafe")]  # (the course's heuristic: jerk)
    md = (tmp_path / "o" / "compare.md").read_text()
    assert "of a.yaml the planners that finished (heuristic)" in md and "| status | unsafe |" in md


def test_a_planner_bug_is_a_row_and_the_run_goes_on(folder, tmp_path, monkeypatch):
    real = pipeline.solve

    def buggy(problem, **kw):
        if problem.name == "problem-a" and kw.get("allocation") is not None:
            raise ZeroDivisionError("division by zero in a planner")
        return real(problem, **kw)

    monkeypatch.setattr(pipeline, "solve", buggy)
    res = CliRunner().invoke(app, ["compare", str(folder), "-p", "heuristic", "-p", "heuristic:makespan", "--no-figures",
                                   "-o", str(tmp_path / "o")])
    assert res.exit_code == ExitCode.SOLVER_FAILED, res.output
    doc = json.loads((tmp_path / "o" / "compare.json").read_text())
    assert len(doc["problems"]) == 3 and len(doc["rows"]) == 6
    bad = [r for r in doc["rows"] if r["error"]]
    assert [(r["problem"], r["planner"], r["error"]) for r in bad] == [
        ("problem-a", "heuristic:makespan", "ZeroDivisionError: division by zero in a planner")]
    assert doc["aggregate"]["heuristic:makespan"]["errors"] == 1 and doc["aggregate"]["heuristic:makespan"]["runs"] == 3


def test_an_unreadable_problem_file_is_a_row(folder, tmp_path):
    (folder / "d.yaml").write_bytes(b"\xff\xfe not utf-8")
    (folder / "e.yaml").mkdir()  # a folder named like a problem file
    cmp = compare(folder, ["heuristic"], tmp_path / "o", figures=False)
    errors = {Path(p["file"]).name: p["error"] for p in cmp.problems if p["error"]}
    assert set(errors) == {"d.yaml", "e.yaml"}
    assert len([r for r in cmp.rows if not r.get("error")]) == 3


def test_files_that_share_a_problem_name_each_show_their_own_figures(tmp_path, problems_dir):
    """Design variants are often copies of one file under one ``name:``: each file's table shows
    its own plans' figures (its rows carry the file), and the headings tell them apart."""
    src = (problems_dir / "crossing_paths.yaml").read_text()
    d = tmp_path / "variants"
    d.mkdir()
    (d / "full.yaml").write_text(src)
    doc = parse_yaml(src)
    doc["fruits"] = doc["fruits"][:2]  # fewer fruit: another plan under the same name
    (d / "short.yaml").write_text(dump_yaml(doc))
    out = tmp_path / "out"
    cmp = compare(d, PLANNERS, out, figures=False)
    by_file = {Path(r["file"]).stem: r for r in cmp.rows if r["planner"] == "heuristic"}
    for stem, r in by_file.items():  # each row's figures are its own plan's
        plan = json.loads((out / stem / "heuristic" / "plan.json").read_text())
        assert r["makespan"] == pytest.approx(plan["metrics"]["makespan"]) and r["harvested"] == plan["metrics"]["harvested"]
    assert by_file["short"]["harvested"] == 2 < by_file["full"]["harvested"]
    md = (out / "compare.md").read_text()
    full, short = md.split("## crossing-paths (full.yaml)")[1], md.split("## crossing-paths (short.yaml)")[1]
    assert f"| {by_file['full']['harvested']} / " in full.split("##")[0]
    assert f"| {by_file['short']['harvested']} / " in short.split("##")[0]
    for r in cmp.rows:  # each ratio against its own file's first planner
        ref = next(x for x in cmp.rows if x["file"] == r["file"] and x["planner"] == "heuristic")
        assert r["makespan_vs_heuristic"] == pytest.approx(r["makespan"] / ref["makespan"])


def test_ctrl_c_while_the_figures_are_drawn_keeps_the_planners_that_finished(tmp_path, monkeypatch):
    """(Ctrl-C after every planner had finished, while the figures were drawn, wrote a report of
    'the 0 of 1 problem files that finished' over the earlier full one.)"""
    import coplan.report.comparison as comparison
    from coplan.problem import default_problem_path

    def figures_interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(comparison, "_figures", figures_interrupted)
    out = tmp_path / "out"
    with pytest.raises(KeyboardInterrupt):
        compare(default_problem_path().with_name("single_arm.yaml"), PLANNERS, out, figures=True)
    doc = json.loads((out / "compare.json").read_text())
    assert [r["planner"] for r in doc["rows"]] == list(PLANNERS) and doc["aggregate"]["heuristic"]["runs"] == 1
    assert any("interrupted while drawing the figures of single_arm.yaml: every planner of it finished" in n
               for n in doc["notes"]), doc["notes"]


def test_a_full_disk_stops_compare_as_an_io_error_not_a_failed_planner(tmp_path, monkeypatch):
    """(A full disk read 'crossing-paths: coordinated failed: OSError: No space left on device', exit 7.)"""
    from coplan.problem import default_problem_path

    def full(problem, **kw):
        raise OSError(28, "No space left on device", str(tmp_path / "out"))

    monkeypatch.setattr(pipeline, "solve", full)
    r = CliRunner().invoke(app, ["compare", str(default_problem_path().with_name("single_arm.yaml")), "-p", "heuristic",
                                 "--out", str(tmp_path / "out")])
    assert r.exit_code == int(ExitCode.IO_ERROR) and "No space left on device" in r.output, r.output
    assert str(tmp_path / "out") in " ".join(r.output.split())
