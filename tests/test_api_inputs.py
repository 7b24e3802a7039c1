"""Bad input through the Python API and the command line's edges: a problem or options built in
Python are checked as a file is (key path, what was expected, what was found); the facade says
which options a planner takes (found by trying the project as a new user)."""

from __future__ import annotations

import dataclasses
import json
import math
import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

import coplan
from coplan.cli import app
from coplan.errors import OptionsError, ProblemError
from coplan.generate import gantry_row, to_yaml
from coplan.kinematics import SCurve
from coplan.kinematics.arm import ik_one, singularity_proximity
from coplan.kinematics.timing import cubic_eval, cubic_min_time
from coplan.optimal import OptimalOptions
from coplan.planners.coordinated.planner import CoordinatedOptions
from coplan.problem import load_problem, parse_problem, shipped_problems
from coplan.problem.load import file_record
from coplan.row.continuous import MovingOptions
from coplan.row.plan import RowOptions
from coplan.output import OutputError
from coplan.report.comparison import compare
from coplan.row.live import run_live_row
from coplan.row.moving import plan_moving
from coplan.row.sensing import LiveRowOptions, RowFaults
from coplan.row.stops import StopWindow
from coplan.verify import VerifyOptions

CROSSING = next(p for p in shipped_problems() if p.stem == "crossing_paths")
runner = CliRunner()


@pytest.fixture(scope="module")
def cell():
    return load_problem(CROSSING)


@pytest.mark.parametrize("change, path", [
    (lambda p: dataclasses.replace(p, arms=(dataclasses.replace(p.arms[0], link_radius=math.nan),) + p.arms[1:]), "arms[0].link_radius"),
    (lambda p: dataclasses.replace(p, arms=(dataclasses.replace(p.arms[0], links=(math.nan, 0.8)),) + p.arms[1:]), "arms[0].links"),
    (lambda p: dataclasses.replace(p, fruits=(coplan.Fruit("x", (math.inf, 1.0)),)), "fruits[0].position"),
    (lambda p: dataclasses.replace(p, fruits=p.fruits + p.fruits[:1]), f"fruits[{4}].id"),
    (lambda p: dataclasses.replace(p, task=dataclasses.replace(p.task, clearance=-0.1)), "task.clearance"),
    (lambda p: dataclasses.replace(p, arms=(dataclasses.replace(p.arms[0], joint_limits=((1.0, -1.0), (-3.0, 3.0))),)
                                   + p.arms[1:]), "arms[0].joint_limits"),
    # (a home outside the joint limits was solved into an unsafe plan, an unreachable bin into a partial one)
    (lambda p: dataclasses.replace(p, arms=(dataclasses.replace(p.arms[0], home=(5.0, 0.0)),) + p.arms[1:]), "arms[0].home[0]"),
    (lambda p: dataclasses.replace(p, arms=(dataclasses.replace(p.arms[0], bin=(-2.0, -3.0)),) + p.arms[1:]), "arms[0].bin"),
    (lambda p: dataclasses.replace(p, name=""), "name"),  # (a file's empty name was refused, not a built one)
    (lambda p: dataclasses.replace(p, name="  "), "name"),
    (lambda p: dataclasses.replace(p, arms=(dataclasses.replace(p.arms[0], name=" "),) + p.arms[1:]), "arms[0].name"),
    # (a gantry or task of the wrong type raised AttributeError from inside the check)
    (lambda p: dataclasses.replace(p, gantry="x"), "gantry"),
    (lambda p: dataclasses.replace(p, task="x"), "task"),
])
def test_a_problem_changed_in_python_is_checked_as_a_file_is(cell, change, path):
    """(A NaN link radius reached the verifier, whose distances it made infinitely clear: a plan
    with a collision passed.)"""
    assert len(cell.fruits) == 4
    with pytest.raises(ProblemError) as e:
        change(cell)
    assert any(i.path == path for i in e.value.issues), e.value.issues
    assert "as changed in Python" in str(e.value)


def test_a_problem_changed_in_python_no_longer_names_its_file(cell):
    assert file_record(cell) is not None and file_record(cell)["path"] == str(CROSSING.resolve())
    moved = dataclasses.replace(cell, arms=tuple(dataclasses.replace(a, base=(a.base[0] - 1.2, a.base[1])) for a in cell.arms))
    assert file_record(moved) is None  # (a viewer drew the file's layout under the moved arms' plan)
    assert file_record(dataclasses.replace(cell, name=cell.name)) is not None  # the same problem: still that file's


@pytest.mark.parametrize("how", ["changed", "generated row", "from its file"])
def test_a_run_of_a_problem_from_no_file_keeps_the_problem_it_was_planned_on(cell, tmp_path, how):
    """(``solve`` of a problem made or changed in Python wrote no problem file and recorded none:
    ``coplan verify`` of its plan took the shipped crossing_paths in its place -- 4 picks missed on
    a plan verified as a success -- and said "not a shipped problem" of a generated row.) Such a
    run writes ``planned_problem.yaml`` beside the plan and records it; the plan's command-line
    checks then read it back and pass. A problem from its file, unchanged, still names that file."""
    from coplan.pipeline import PROBLEM_FILE

    f0 = cell.fruits[0]
    problem = {"changed": lambda: dataclasses.replace(cell, fruits=(dataclasses.replace(f0, position=(f0.position[0] + 0.05,
                                                                                                         f0.position[1])),)
                                                      + cell.fruits[1:]),
               "generated row": lambda: parse_problem(to_yaml(gantry_row(length=4.0, n_arms=2, density=3.0, seed=3))),
               "from its file": lambda: cell}[how]()
    out = tmp_path / "run"
    res = coplan.solve(problem, planner="coordinated", out_dir=out)
    assert res.plan.status.value == "success"
    record = json.loads((out / "plan.json").read_text())["problem_file"]
    if how == "from its file":
        assert record["path"] == str(CROSSING.resolve()) and not (out / PROBLEM_FILE).exists()
        return
    assert record["path"] == str((out / PROBLEM_FILE).absolute()) and res.files["problem"] == out / PROBLEM_FILE
    back = load_problem(out / PROBLEM_FILE)
    assert back == problem and back.digest == record["sha256"]
    r = CliRunner().invoke(app, ["verify", str(out / "plan.json")])
    assert r.exit_code == 0, r.output
    assert "pick_missed" not in r.output and "not a shipped problem" not in r.output
    again = coplan.solve(problem, planner="coordinated", out_dir=out)  # the folder is a run's: replaced whole
    assert again.previous is not None and (again.previous / PROBLEM_FILE).is_file()


@pytest.mark.parametrize("how", ["changed", "generated row"])
def test_a_plan_saved_in_python_keeps_the_problem_it_was_planned_on(cell, tmp_path, how):
    from coplan.output import OutputError

    """(A plan of crossing_paths with its fruit moved, solved without ``out_dir`` and written with
    ``Plan.save``, recorded no problem: ``coplan verify`` took the shipped crossing_paths -- 4 picks
    missed, exit 6 -- and ``coplan export`` refused it.) ``save`` writes the problem beside the plan
    and records it, as a run's folder does; a plan of a problem from its file still names that file."""
    f0 = cell.fruits[0]
    problem = {"changed": lambda: dataclasses.replace(cell, fruits=(dataclasses.replace(f0, position=(f0.position[0] * 0.9,
                                                                                                         f0.position[1] + 0.1)),)
                                                      + cell.fruits[1:]),
               "generated row": lambda: parse_problem(to_yaml(gantry_row(length=4.0, n_arms=2, density=3.0, seed=3)))}[how]()
    plan = coplan.solve(problem, planner="coordinated").plan
    first = plan.save(tmp_path / "a" / "mine.json")
    paths = plan.save(tmp_path / "mine.json")  # (a second save carries the problem too: the first folder may go)
    assert first["problem"] == tmp_path / "a" / "mine_problem.yaml" and paths["problem"] == tmp_path / "mine_problem.yaml"
    assert load_problem(paths["problem"]) == problem
    assert json.loads(paths["json"].read_text())["problem_file"]["path"] == str(paths["problem"].absolute())
    assert coplan.load_plan(paths["json"]) == plan
    import shutil

    shutil.rmtree(tmp_path / "a")
    r = CliRunner().invoke(app, ["verify", str(paths["json"])])
    assert r.exit_code == 0, r.output
    assert "taken to be the shipped problem" not in r.output and "not a shipped problem" not in r.output
    # a user's own file where the problem would go is never overwritten: refused before anything is written
    (tmp_path / "b").mkdir()
    (tmp_path / "b" / "plan_problem.yaml").write_text("# my hand-written problem\n")
    with pytest.raises(OutputError, match="expected nothing there or a problem coplan wrote, found another file"):
        plan.save(tmp_path / "b")
    assert sorted(p.name for p in (tmp_path / "b").iterdir()) == ["plan_problem.yaml"]
    plain = coplan.solve(cell, planner="coordinated").plan
    assert set(plain.save(tmp_path / "plain")) == {"json", "csv", "npz"} and plain.problem_file["path"] == str(CROSSING.resolve())


@pytest.mark.parametrize("cls, kw, words", [
    (OptimalOptions, {"search_work": -5}, "search_work: expected a non-negative integer, found number -5"),
    (OptimalOptions, {"search_work": "lots"}, "search_work: expected a non-negative integer, found string 'lots'"),
    (OptimalOptions, {"time_limit": math.nan}, "time_limit: expected a positive number or null, found number nan"),
    (OptimalOptions, {"workers": 0}, "workers: expected a whole number of processes from 1 to 256, or auto; found number 0"),
    (RowOptions, {"workers": 10**6}, "workers: expected a whole number of processes from 1 to 256, or auto; found number 1000000"),
    (MovingOptions, {"workers": "many"}, "workers: expected a whole number of processes from 1 to 256, or auto; found string 'many'"),
    (RowOptions, {"planner": "heuristic"}, "planner: expected 'coordinated' or 'optimal' (the cell planner at each stop"),
    (OptimalOptions, {"margin": -1.0}, "margin: expected a non-negative number"),
    (CoordinatedOptions, {"margin": "a"}, "margin: expected a non-negative number, found string 'a'"),
    (RowOptions, {"resolution": -1}, "resolution: expected a spacing of the carriage positions from 0.01 to 0.5 m, found -1"),
    (RowOptions, {"stops": "bogus"}, "stops: stop rule: expected one of 'optimised', 'fixed', 'fewest'; found 'bogus'"),
    (MovingOptions, {"level": 0}, "level: expected a positive number or null"),
    (MovingOptions, {"profile": "x"}, "profile: speed profile: expected one of"),
    (LiveRowOptions, {"speed": 0}, "speed: expected a positive number"),
    (LiveRowOptions, {"speed": 1e9}, "speed: expected a cruising speed of at most 10 m/s"),
    (VerifyOptions, {"substeps": 0}, "substeps: expected a positive integer, found number 0"),
    (MovingOptions, {"rate": 1.0}, "rate: expected a plan sample rate from 100 to 10000 Hz, found 1"),
    (LiveRowOptions, {"false_rate": 2}, "false_rate: expected a share of the fruit from 0 to 1, found 2"),
    (LiveRowOptions, {"faults": "x"}, "faults: expected RowFaults(...), found str 'x'"),
    (RowFaults, {"camera_dark": -3}, "camera_dark: expected a non-negative number, found number -3"),
    (RowOptions, {"window": -1}, "window: expected StopWindow(...), found int -1"),
    (StopWindow, {"fractions": ()}, "fractions: expected strides as fractions of a carriage span, each above 0 and at most 1"),
    (StopWindow, {"fractions": (0.5, 5.0)}, "fractions: expected strides as fractions of a carriage span, each above 0 and at most 1"),
    (RowOptions, {"resolution": 100}, "resolution: expected a spacing of the carriage positions from 0.01 to 0.5 m, found 100"),
    (MovingOptions, {"resolution": 0.001}, "resolution: expected a spacing of the carriage positions from 0.01 to 0.5 m, found 0.001"),
    (StopWindow, {"spans": -1.0}, "spans: expected a positive number, found number -1"),
    (VerifyOptions, {"refine_factor": 1}, "refine_factor: expected an integer >= 2"),
    (VerifyOptions, {"position_tolerance": math.nan}, "position_tolerance: expected a positive number, found number nan"),
    (VerifyOptions, {"fcl": "bogus"}, "fcl: fcl mode: expected one of 'off', 'critical', 'full'; found 'bogus'"),
    (VerifyOptions, {"infer_events": "yes"}, "infer_events: expected true or false, found string 'yes'"),
])
def test_options_built_in_python_are_checked_as_an_options_file_is(cls, kw, words):
    with pytest.raises(OptionsError, match=re.escape(words)):
        cls(**kw)


@pytest.mark.parametrize("cls, kw", [
    (OptimalOptions, {"search_work": "x", "workers": 0, "widen_goal": 0.5}),
    (RowOptions, {"workers": 0, "resolution": -1}),
    (RowOptions, {"workers": 0, "resolution": 9.0}),
    (MovingOptions, {"workers": "many", "level": 0}),
])
def test_every_bad_option_is_said_at_once_workers_too(cls, kw):
    """A bad workers beside other bad fields: every one in one OptionsError (workers was raised
    alone, the others said only once it was mended)."""
    with pytest.raises(OptionsError) as e:
        cls(**kw)
    assert sorted(i.path for i in e.value.issues) == sorted(kw)


def test_the_row_resolution_range_is_the_command_lines():
    """RowOptions and MovingOptions take the spacings --resolution takes, no others."""
    from coplan.row.reach import RESOLUTION_RANGE

    lo, hi = RESOLUTION_RANGE
    assert RowOptions(resolution=lo).resolution == lo and MovingOptions(resolution=hi).resolution == hi
    for bad in (hi * 1.01, lo * 0.99):
        r = runner.invoke(app, ["check", "sparse_row", "--resolution", repr(bad)])
        assert r.exit_code == 2 and f"{lo:g}" in r.output and f"{hi:g}" in r.output, r.output


def test_options_given_as_their_values_become_them():
    assert OptimalOptions(workers="auto").workers >= 1
    assert RowOptions(workers=2.0).workers == 2 and type(RowOptions(workers=2.0).workers) is int  # (2.0 is 2, as in a file)
    assert RowOptions(stops="fewest").stops.value == "fewest" and MovingOptions(profile="constant").profile.value == "constant"


def test_the_facade_takes_a_generated_mapping_and_says_which_options_each_planner_takes(cell):
    row = gantry_row(length=6.0, density=2.0, seed=1)
    res = coplan.solve(row)
    assert res.verification.passed and res.plan.metrics["harvested"] == len(row["fruits"])
    with pytest.raises(TypeError, match="expected the path of a YAML problem file"):
        coplan.solve(None)
    for bad in (42, True, ["out"]):  # (42 gave os.fspath's bare 'expected str, bytes or os.PathLike object')
        with pytest.raises(TypeError, match=r"out_dir: expected the path of a folder \(str or Path\), found"):
            coplan.solve(row, out_dir=bad)
    with pytest.raises(TypeError, match=r"parse_problem\(coplan.generate.to_yaml\(mapping\)\)"):
        parse_problem(row)
    for planner, options, words in (("optimal", {"search_work": 10}, "the optimal planner takes OptimalOptions, found dict"),
                                    ("coordinated", RowOptions(), "takes CoordinatedOptions or OptimalOptions, found RowOptions"),
                                    ("heuristic", OptimalOptions(), "the heuristic planner takes no options")):
        with pytest.raises(TypeError, match=words):
            coplan.solve(cell, planner=planner, options=options)
    with pytest.raises(TypeError, match="a row on the move takes MovingOptions, found RowOptions"):
        coplan.solve(row, gantry="continuous", options=RowOptions())
    with pytest.raises(ValueError, match="allocation: a row's cells are allocated"):
        coplan.solve(row, allocation="makespan")
    # the cell planner of RowOptions is the one used (a new user's RowOptions(planner='optimal') was
    # planned with the coordinated planner); the planner argument, where given, wins (as stops= does)
    short = gantry_row(length=1.0, density=3.0, seed=1)  # (4 fruit: the optimal planner at each stop)
    opt = coplan.solve(short, options=RowOptions(planner="optimal", cell_search_work=50))
    assert opt.plan.solver["row"]["cell_planner"] == "optimal" and opt.verification.passed
    both = coplan.solve(short, planner="optimal", options=RowOptions(workers=2, cell_search_work=50))  # (RowOptions' default planner)
    assert both.plan.solver["row"]["cell_planner"] == "optimal" and both.plan.solver["row"]["workers"] >= 1


# --------------------------------------------------------------------------- the command line's edges
@pytest.fixture(scope="module")
def row_file(tmp_path_factory):
    d = tmp_path_factory.mktemp("rows")
    f = d / "short.yaml"
    f.write_text(to_yaml(gantry_row(length=6.0, density=2.0, seed=1)))
    return f


def test_compare_refuses_a_folder_of_rows_and_a_time_limit_on_a_row(row_file, tmp_path):
    r = runner.invoke(app, ["compare", str(row_file.parent), "--out", str(tmp_path / "c"), "--no-figures"])
    assert r.exit_code == 2 and "1 file is a row (short.yaml)" in r.output and "coplan compare ROW.yaml" in r.output
    r = runner.invoke(app, ["compare", str(row_file), "--time-limit", "5", "--out", str(tmp_path / "c2")])
    assert r.exit_code == 2 and "short.yaml is a row" in r.output
    assert not (tmp_path / "c").exists() and not (tmp_path / "c2").exists()


def test_a_folder_file_whose_gantry_is_no_mapping_is_a_bad_file_not_a_row(tmp_path):
    """(``gantry: yes`` made the folder a folder of rows: nothing was compared, exit 2.)"""
    from coplan.problem import default_problem_path

    src = tmp_path / "p"
    src.mkdir()
    (src / "single_arm.yaml").write_text((default_problem_path().parent / "single_arm.yaml").read_text())
    (src / "gantry_str.yaml").write_text((default_problem_path().parent / "single_arm.yaml").read_text() + "gantry: yes\n")
    r = runner.invoke(app, ["compare", str(src), "--planner", "heuristic", "--no-figures", "--out", str(tmp_path / "c")])
    assert r.exit_code == 3 and "is a row" not in r.output
    doc = json.loads((tmp_path / "c" / "compare.json").read_text())
    errors = {Path(p["file"]).name: p["error"] for p in doc["problems"]}
    assert errors["single_arm.yaml"] is None and "gantry" in errors["gantry_str.yaml"]
    # with --json the document says the exit code it ends with (3: nothing said so)
    r = runner.invoke(app, ["compare", str(src), "--planner", "heuristic", "--no-figures", "--json", "--out", str(tmp_path / "j")])
    doc = json.loads(r.stdout)
    assert r.exit_code == 3 and doc["exit_code"] == 3 and doc["verdict"] == "bad_input" and doc["format"] == "coplan.compare/1"


def test_compare_on_a_row_sets_its_stop_rules_side_by_side_on_workers(row_file, tmp_path):
    """``coplan compare ROW.yaml``: each stop rule planned, verified and written, the table in
    compare.json; ``--workers 2`` plans each rule's cells in two processes (the same plans)."""
    import json

    r1 = runner.invoke(app, ["compare", str(row_file), "--json", "--out", str(tmp_path / "one")])
    r2 = runner.invoke(app, ["compare", str(row_file), "--workers", "2", "--json", "--out", str(tmp_path / "two")])
    assert r1.exit_code == 0 and r2.exit_code == 0, r1.output + r2.output
    one, two = json.loads(r1.stdout), json.loads(r2.stdout)
    assert one["exit_code"] == 0 and one["verdict"] == "ok"  # (as every document of a command that ran)
    assert one["format"] == "coplan.compare-rows/2" and [r["rule"] for r in one["rows"]] == ["optimised", "fixed", "fewest", None]
    assert [r["name"] for r in one["rows"]] == ["optimised", "fixed", "fewest", "on the move"]  # (and on the move)
    # which cell planner made the table, in the file (it was recorded nowhere) and its heading
    assert one["cell_planner"] == "coordinated"
    assert (tmp_path / "two" / "compare.md").read_text().startswith(
        f"# {one['problem']}: stop rules and on the move side by side (coordinated cell planner at each stop)")
    assert all(r["verified"] and r["share_harvested"] == 1.0 for r in one["rows"] + two["rows"])
    assert [(r["stops"], r["row_time"]) for r in one["rows"]] == [(r["stops"], r["row_time"]) for r in two["rows"]]
    assert (tmp_path / "two" / "compare.json").is_file() and (tmp_path / "two" / "fixed" / "plan.json").is_file()
    assert (tmp_path / "two" / "continuous" / "plan.json").is_file()
    r = runner.invoke(app, ["compare", str(row_file), "--workers", "0", "--out", str(tmp_path / "bad")])
    assert r.exit_code == 2 and "--workers: expected a whole number of processes" in r.output


def test_feed_on_a_row_points_to_the_live_row(row_file, tmp_path):
    r = runner.invoke(app, ["feed", str(row_file), "--out", str(tmp_path / "f.yaml")])
    assert r.exit_code == 2 and "coplan run" in r.output and "--gantry stop-and-go" in r.output
    assert not (tmp_path / "f.yaml").exists()


def test_animate_refuses_another_extension_before_any_work(tmp_path):
    r = runner.invoke(app, ["animate", str(tmp_path / "no-such-plan.json"), "--out", str(tmp_path / "a.txt")])
    assert r.exit_code == 2 and "expected a .gif or .mp4 file" in r.output and not (tmp_path / "a.txt").exists()


def test_a_problem_without_fruit_says_there_is_nothing_to_harvest(tmp_path):
    text = Path(CROSSING).read_text()
    head = text[:text.index("fruits:")] + "fruits: []\n" + text[text.index("task:"):]
    f = tmp_path / "nofruit.yaml"
    f.write_text(head)
    r = runner.invoke(app, ["solve", str(f), "--planner", "coordinated", "--out", str(tmp_path / "o")])
    assert "nothing to harvest: the problem lists no fruit" in r.output


def test_more_bad_arguments_say_what_was_expected(cell):
    import subprocess
    import sys

    import numpy as np

    from coplan.allocate.allocation import allocate
    from coplan.generate import row_problem
    from coplan.planners.coordinated.planner import plan_coordinated
    from coplan.planners.heuristic import plan_heuristic
    from coplan.verify import verify

    for bad in (0, -5, math.nan, 50.0):  # (below 100 Hz: a plan the verifier then refused as a file would be)
        with pytest.raises(ValueError, match="rate: expected a sample rate of at least 100 Hz"):
            plan_heuristic(cell, rate=bad)
    with pytest.raises(TypeError, match="found str"):
        plan_heuristic(cell, "makespan")
    with pytest.raises(TypeError, match="the coordinated planner allocates itself"):
        plan_coordinated(cell, allocate(cell))
    with pytest.raises(ValueError, match="density: expected finite numbers, found nan"):
        gantry_row(density=math.nan)
    with pytest.raises(ValueError, match="spacing: expected finite numbers"):
        row_problem(3, 5, spacing=math.nan)
    plan = plan_heuristic(cell)
    plan.q[cell.arms[0].name] = np.array(plan.q[cell.arms[0].name], float)
    plan.q[cell.arms[0].name][7, 1] = math.nan
    with pytest.raises(Exception, match=r"found a non-finite angle at row 7 \(t = "):
        verify(cell, plan)
    # the documented submodules of the row stage are attributes after `import coplan`
    code = "import coplan; print(coplan.row.moving.plan_moving.__name__)"
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "plan_moving"


@pytest.mark.parametrize("where, words", [
    ("file", "expected a folder, found a file"),
    ("file/under", "expected a folder, found the file"),
])
def test_an_output_folder_the_api_cannot_write_is_refused_before_any_work(tmp_path, monkeypatch, where, words):
    """(coplan.solve(out_dir=...) solved first and then raised the OS's NotADirectoryError: the
    solve was lost.) The facade and the report functions check where they write first."""
    (tmp_path / "file").write_text("somebody's data")
    out = tmp_path / where

    def no_work(*a, **k):
        raise AssertionError("worked before checking out_dir")

    monkeypatch.setattr("coplan.pipeline.as_problem", no_work)  # (where the facade reads its problem)
    monkeypatch.setattr("coplan.report.comparison._problem_files", no_work)
    for call in (lambda: coplan.solve(CROSSING, out_dir=out), lambda: compare(CROSSING, out_dir=out)):
        with pytest.raises(OutputError, match=f"out_dir {out}: {words}"):
            call()
    assert (tmp_path / "file").read_text() == "somebody's data"


def test_compare_takes_one_planner_by_its_name_and_a_planner_given_twice_once(tmp_path):
    """(A string was iterated: planners 'c', 'o', ... each refused. A planner given twice was
    solved twice, into the same run folder and under the same label.)"""
    cmp = compare(CROSSING, planners="coordinated", out_dir=tmp_path / "one", figures=False)
    assert cmp.planners == ["coordinated"] and len(cmp.rows) == 1
    cmp = compare(CROSSING, planners=["coordinated", "heuristic", "coordinated"], out_dir=tmp_path / "two", figures=False)
    assert cmp.planners == ["coordinated", "heuristic"] and len(cmp.rows) == 2
    assert cmp.notes == ["planner coordinated given more than once: compared once"]
    assert "coordinated given more than once" in (tmp_path / "two" / "compare.md").read_text()


def test_compare_again_into_a_folder_names_the_earlier_runs_it_does_not_write(tmp_path):
    compare(CROSSING, planners=["coordinated", "heuristic"], out_dir=tmp_path, figures=False)
    cmp = compare(CROSSING, planners="coordinated", out_dir=tmp_path, figures=False)
    stale = tmp_path / CROSSING.stem / "heuristic"
    assert cmp.notes == [f"{stale}: a run of an earlier comparison (not in this one; left as it was)",
                         f"the previous report in {tmp_path}: moved to compare.previous.json, compare.previous.md"]
    assert (stale / "plan.json").is_file()  # (nothing of the user's is moved or removed)
    assert f"{stale}: a run of an earlier comparison" in (tmp_path / "compare.md").read_text()


def test_compare_of_a_missing_problem_file_makes_no_output_folder(tmp_path):
    res = runner.invoke(app, ["compare", str(tmp_path / "nope.yaml"), "--out", str(tmp_path / "cmp")])
    assert res.exit_code == 3 and "expected an existing YAML file, found no file at this path" in res.output
    assert not (tmp_path / "cmp").exists()
    with pytest.raises(ProblemError):
        compare(tmp_path / "nope.yaml", out_dir=tmp_path / "api")
    assert not (tmp_path / "api").exists()


def test_a_cruising_speed_too_slow_for_any_plan_is_refused_before_any_work(row_file, tmp_path):
    """(--speed 1e-9 booked for ever; 0.0005 m/s on a 10 m row wrote a 94 MB plan.json that
    coplan verify then refused as too large.) The slowest speed brings the farthest fruit
    within reach in the longest plan coplan makes (its 100 Hz grid and file)."""
    from coplan.kinds import GantryMode, SpeedProfile
    from coplan.problem.plausible import slowest_speed

    row = load_problem(row_file)
    lo = slowest_speed(row)
    assert 0 < lo < 0.01
    for args in (["solve", str(row_file), "--gantry", "continuous", "--speed", "1e-9", "-o", str(tmp_path / "a")],
                 ["run", str(row_file), "--speed", f"{lo / 2:g}", "-o", str(tmp_path / "b")]):
        res = runner.invoke(app, args)
        assert res.exit_code == 2 and "--speed: expected a cruising speed in [" in res.output
        low = float(re.search(r"cruising speed in \[([0-9.e-]+),", res.output).group(1))
        assert low >= float(f"{lo:.3g}")  # (solve: the planner's own least speed, by the row's screen)
        assert not (tmp_path / args[-1]).exists()
    with pytest.raises(OptionsError, match=r"level: expected a cruising speed in \["):
        plan_moving(row, MovingOptions(profile=SpeedProfile.CONSTANT, level=1e-9))
    with pytest.raises(OptionsError, match=r"speed: expected a cruising speed in \["):
        run_live_row(row, LiveRowOptions(speed=1e-9, mode=GantryMode.CONTINUOUS))
    from coplan.problem.plausible import plan_seconds_limit

    rail = (row.gantry.end - row.gantry.start) / plan_seconds_limit(row)
    assert rail > lo  # live, the carriage cruises the whole rail, not knowing where the last fruit is
    with pytest.raises(OptionsError, match="cruises the whole rail"):
        run_live_row(row, LiveRowOptions(speed=(lo + rail) / 2, mode=GantryMode.CONTINUOUS))
    # the live range quoted is the one a live run holds to: just above its low end passes that check
    from coplan.problem.plausible import live_speed_issue

    msg = live_speed_issue(row, lo / 2)
    quoted = float(re.search(r"cruising speed in \[([0-9.e-]+),", msg).group(1))
    assert quoted == pytest.approx(rail, rel=1e-3) and "cruises the whole rail" in msg
    assert live_speed_issue(row, quoted * 1.001) is None and live_speed_issue(row, quoted * 0.999) is not None


def test_a_speed_within_the_quick_range_but_too_slow_for_the_cruise_is_a_usage_error(row_file, tmp_path):
    """The range checked before any work is necessary, not sufficient (the carriage comes to rest
    where the last fruit's window opens, and ramps): a speed inside it whose cruise outgrows the
    longest plan is refused once the row is screened -- as --speed, exit 2, with the least speed
    that fits -- not as 'MovingOptions: level' with exit 3."""
    from coplan.problem.plausible import slowest_speed

    row = load_problem(row_file)
    v = slowest_speed(row) * 1.0001
    with pytest.raises(OptionsError) as e:
        plan_moving(row, MovingOptions(profile="constant", level=v))
    (issue,) = e.value.issues
    need = float(re.search(r"of at least ([0-9.e-]+),", issue.message).group(1))
    assert issue.path == "level" and need > v
    res = runner.invoke(app, ["solve", str(row_file), "--gantry", "continuous", "--speed", f"{v:.6g}", "-o", str(tmp_path / "s")])
    assert res.exit_code == 2, res.output
    assert f"--speed: expected a cruising speed (m/s) of at least {need:.3g}" in res.output
    assert not (tmp_path / "s").exists()
    # a speed out of the range before any work names the same least speed (the quick estimate's
    # low end lay below it: [0.000918, 0.5] against 0.00103 on a 10 m row)
    for bad in ("1e-9", "0.9", "nan"):
        res = runner.invoke(app, ["solve", str(row_file), "--gantry", "continuous", "--speed", bad, "-o", str(tmp_path / "t")])
        assert res.exit_code == 2 and f"--speed: expected a cruising speed in [{need:.3g}, 0.5] m/s" in res.output, res.output


def test_live_row_options_are_bounded_like_the_command_line(row_file, tmp_path):
    """(RowFaults(camera_dark=1e9) ran into a 1.46 TiB MemoryError; sigma 5 m and a 1e9 m
    look-ahead ran; a dict as the options failed with an AttributeError.) The Python options take
    what ``coplan run`` takes; faults that would make the run's plan longer than coplan reads back
    are refused before any work (exit 2 on the command line, nothing written)."""
    from coplan.row.sensing import MAX_FAULT_SECONDS, MAX_LOOK_AHEAD, MAX_SIGMA

    for bad, name in ((dict(camera_dark=1e9), "camera_dark"), (dict(late_replan=MAX_FAULT_SECONDS + 1), "late_replan")):
        with pytest.raises(OptionsError) as e:
            RowFaults(**bad)
        assert [i.path for i in e.value.issues] == [name] and "expected at most 3600 s" in str(e.value)
    for bad, name in ((dict(sigma=MAX_SIGMA * 5), "sigma"), (dict(look_ahead=MAX_LOOK_AHEAD * 10), "look_ahead")):
        with pytest.raises(OptionsError) as e:
            LiveRowOptions(**bad)
        assert [i.path for i in e.value.issues] == [name]
    for flag, top in (("--camera-dark", MAX_FAULT_SECONDS), ("--late-replan", MAX_FAULT_SECONDS), ("--look-ahead", MAX_LOOK_AHEAD),
                      ("--sigma", MAX_SIGMA)):  # the command line's own bounds are the same
        res = runner.invoke(app, ["run", str(row_file), "--gantry", "stop-and-go", flag, f"{top * 1.01:g}", "-o", str(tmp_path / "x")])
        assert res.exit_code == 2 and flag in res.output, res.output
    row = load_problem(row_file)
    with pytest.raises(TypeError, match=r"options: a live row takes LiveRowOptions\(...\), found dict"):
        run_live_row(row, {"speed": 0.2})
    with pytest.raises(TypeError, match=r"found dict"):
        plan_moving(row, {"level": 0.2})
    res = runner.invoke(app, ["run", str(row_file), "--gantry", "stop-and-go", "--camera-dark", "3600", "--late-replan", "3600",
                              "-o", str(tmp_path / "long")])
    assert res.exit_code == 2 and "expected faults whose run fits in" in res.output, res.output
    assert "--camera-dark/--late-replan:" in res.output and "--arm-stop" not in res.output  # (the options given)
    assert not (tmp_path / "long").exists()


def test_a_feed_reporting_later_than_the_longest_plan_is_refused(tmp_path):
    """(coplan feed --reveal-by 40000 made a feed whose run wrote a 152 MB plan.json that
    coplan verify refused.)"""
    from coplan.live.feed import FeedError, load_feed
    from coplan.problem.plausible import latest_report_time

    cell = next(p for p in shipped_problems() if p.stem == "crossing_paths")
    last, _ = latest_report_time(load_problem(cell))
    res = runner.invoke(app, ["feed", str(cell), "--reveal-by", f"{last + 10:.0f}", "--known", "0", "--out", str(tmp_path / "f.yaml")])
    assert res.exit_code == 2 and "--reveal-by: expected a time of at most" in res.output and not (tmp_path / "f.yaml").exists()
    res = runner.invoke(app, ["feed", str(cell), "--reveal-by", "100", "--known", "0", "--out", str(tmp_path / "ok.yaml")])
    assert res.exit_code == 0, res.output
    late = tmp_path / "late.yaml"
    late.write_text(re.sub(r"t: [0-9.]+", f"t: {last + 10:.1f}", (tmp_path / "ok.yaml").read_text(), count=1))
    with pytest.raises(FeedError) as e:
        load_feed(late).check_against(load_problem(cell))
    (issue,) = e.value.issues
    assert issue.path == "detections[0].t" and issue.line is not None and "expected a time of at most" in issue.message
    res = runner.invoke(app, ["run", str(cell), "--feed", str(late), "--out", str(tmp_path / "run")])
    assert res.exit_code == 3 and "detections[0].t" in res.output and not (tmp_path / "run").exists()


def test_a_row_whose_carriage_cannot_reach_its_last_fruit_in_any_plan_is_refused(tmp_path):
    """(A 1000 m rail at 1 mm/s with a fruit at its end: coplan check passed it with a bound of
    11.5 days, and coplan solve grew to 14 GB.)"""
    d = gantry_row(length=10.0, density=1.0, seed=2)
    d["gantry"].update(end=1000.0, max_velocity=0.001)
    d["fruits"].append({"id": "far", "position": [999.0, 1.0]})
    f = tmp_path / "slow.yaml"
    f.write_text(to_yaml(d))
    res = runner.invoke(app, ["check", str(f)])
    assert res.exit_code == 3
    assert "gantry.max_velocity: expected a carriage that covers the row in a plan of at most" in res.output
    assert "found max_velocity 0.001 m/s: the carriage alone takes at least" in res.output


@pytest.mark.parametrize("dwell", [600.0, 3600.0])
def test_a_row_whose_dwells_alone_outlast_the_longest_plan_is_refused_when_read_and_built(tmp_path, dwell):
    """(A 3600 s pick dwell on a 6 m row of 36 fruit: coplan check passed it, coplan solve planned
    43242 s for 2 minutes and wrote a 347 MB plan.json that coplan verify refused to read; 600 s:
    a live run of 7850 s, its file just under the 64 MiB cap.) 36 fruit x the dwells over 3 arms
    outlast the 1.8 h a 3-arm row's plan file holds; a 100 s dwell (1.0 h) is planned."""
    from coplan.problem.plausible import check_as_file

    d = gantry_row(length=6, n_arms=3, density=6, seed=1)
    assert len(d["fruits"]) == 36
    d["task"]["pick_dwell"] = dwell
    f = tmp_path / "slow.yaml"
    f.write_text(to_yaml(d))
    res = runner.invoke(app, ["check", str(f)])
    assert res.exit_code == 3, res.output
    assert "task.pick_dwell: expected a row whose plan fits in 1.8 h" in res.output
    assert f"36 fruit, each picked and placed (pick_dwell {dwell:g} s" in res.output
    for cmd in (["solve", str(f), "--out", str(tmp_path / "s")], ["run", str(f), "--out", str(tmp_path / "r")]):
        res = runner.invoke(app, cmd)
        assert res.exit_code == 3 and "task.pick_dwell" in res.output and not (tmp_path / cmd[-1]).exists()
    d["task"]["pick_dwell"] = 100.0
    ok = parse_problem(to_yaml(d))
    with pytest.raises(ProblemError) as e:  # (built in Python: held to the same)
        check_as_file(dataclasses.replace(ok, task=dataclasses.replace(ok.task, pick_dwell=dwell)))
    assert any(i.path == "task.pick_dwell" for i in e.value.issues)


SLOW_ARMS_ROW = """name: slow-arms
defaults: {links: [1.0, 0.8], link_radius: 0.04, joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]],
  max_velocity: [0.001, 0.001], max_acceleration: [8.0, 12.0], max_jerk: [80.0, 120.0], home: [1.0472, 0.7854]}
arms:
  - {name: a1, base: [-1.5, 0.0], bin: [-1.5, -0.5]}
  - {name: a2, base: [1.5, 0.0], bin: [1.5, -0.5]}
fruits:
  - {id: f1, position: [1.0, 1.0]}
  - {id: f2, position: [2.0, 1.2]}
  - {id: f3, position: [3.5, 0.9]}
  - {id: f4, position: [5.0, 1.1]}
""" + "".join(f"  - {{id: g{i}, position: [{1.2 + 0.6 * i:.1f}, 1.3]}}\n" for i in range(6)) + """task: {pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}
gantry: {start: 0.0, end: 6.0, max_velocity: 0.5, max_acceleration: 0.5, max_jerk: 5.0}
"""


def test_a_row_whose_arms_work_alone_outlasts_the_longest_plan_is_refused_when_read(tmp_path):
    """(From a user's trial: a two-arm row of 10 fruit with arms limited to 0.001 rad/s -- within
    the documented range -- passed coplan check, coplan solve planned 42205 s in 99 s and 3 GB and
    called it a success, and its 244 MB plan.json was refused by coplan verify.) The arms' work
    (both dwells and the elbow's turns from the bin's bend to a fruit's and back) is bounded when
    the file is read; the same row with the course's limits is planned."""
    from coplan.generate import gantry_row, to_yaml

    d = gantry_row(length=6, n_arms=2, density=1.5, seed=1)
    for arm in d["arms"]:
        arm["max_velocity"] = [0.001, 0.001]
    f = tmp_path / "slow.yaml"
    f.write_text(to_yaml(d))
    wide = CliRunner(env={"COLUMNS": "400"})
    res = wide.invoke(app, ["check", str(f)])
    assert res.exit_code == 3, res.output
    said = " ".join(res.output.split())
    assert "arms: expected a row whose plan fits in 2.4 h" in said and "its lower bound for any plan" in said, said
    assert "arm1 max_velocity [0.001, 0.001] rad/s" in said
    for cmd in (["solve", str(f), "--out", str(tmp_path / "s")],
                ["run", str(f), "--gantry", "stop-and-go", "--out", str(tmp_path / "r")]):
        res = wide.invoke(app, cmd)
        assert res.exit_code == 3 and "its lower bound for any plan" in " ".join(res.output.split()), res.output
        assert not (tmp_path / cmd[-1]).exists()
    with pytest.raises(ProblemError):  # (in Python too)
        coplan.solve(parse_problem(to_yaml(d)))
    # the plainest cases when the file is read, before any bound (the trial's row: fruit high above the bins)
    text = SLOW_ARMS_ROW
    with pytest.raises(ProblemError) as e:
        parse_problem(text)
    assert ":5: arms[0]: expected a row whose plan fits in 2.4 h" in str(e.value) and "arms' work alone takes at least" in str(e.value)
    assert parse_problem(text.replace("max_velocity: [0.001, 0.001]", "max_velocity: [0.05, 0.05]")).gantry is not None
    from coplan.allocate.row_bound import row_bounds
    from coplan.problem.plausible import plan_seconds_limit, row_work_bound
    from coplan.row.plan import check_row_work

    for arm in d["arms"]:
        arm["max_velocity"] = [0.002, 0.002]  # (slow: the bound is computed, and within the limit)
    p = parse_problem(to_yaml(d))
    assert plan_seconds_limit(p) / 4 < row_work_bound(p).seconds < row_bounds(p, priced=False).any_plan < plan_seconds_limit(p)
    check_row_work(p)


def test_the_row_entry_points_and_options_are_names_of_coplan_row():
    """(``from coplan.row import RowOptions`` raised ImportError; the docs name the options but
    not their modules.) Each is the object its module defines."""
    import coplan.row as row
    from coplan.row import LiveRowOptions as L, MovingOptions as M, RowFaults as F, RowOptions as R, plan_row

    assert (R, M, L, F) == (RowOptions, MovingOptions, LiveRowOptions, RowFaults)
    assert plan_row is coplan.row.plan.plan_row and row.run_live_row is run_live_row
    assert {"plan_row", "plan_moving", "run_live_row", "RowOptions", "MovingOptions", "LiveRowOptions", "RowFaults",
            "StopWindow"} <= set(row.__all__)
    with pytest.raises(AttributeError, match="no attribute 'RowOption'"):
        row.RowOption  # noqa: B018


def test_the_sweep_entry_points_are_names_of_coplan_sweep():
    """(The design-sweep notebook imported them from four private-looking modules.)"""
    import coplan.sweep as sweep
    from coplan.sweep import load_sweep, parse_sweep, read_table, run_sweep, sweep_report
    from coplan.sweep import report, run, spec, table

    assert (load_sweep, parse_sweep, run_sweep) == (spec.load_sweep, spec.parse_sweep, run.run_sweep)
    assert (read_table, sweep_report) == (table.read_table, report.sweep_report)
    with pytest.raises(AttributeError, match="no attribute 'run_sweeps'"):
        sweep.run_sweeps  # noqa: B018
    # and tab completion lists them (dir() did not)
    assert {"run_sweep", "sweep_report"} <= set(dir(sweep))
    assert {"plan_row", "RowOptions", "continuous"} <= set(dir(coplan.row)) and {"solve", "load_plan", "row"} <= set(dir(coplan))


def test_the_generators_name_a_bad_count_seed_or_link_pair():
    """(row_problem('3', 5) raised "'<' not supported", links=(1,) an IndexError, seed=-1 NumPy's
    own message; cell_problem(0, n_arms=0) returned a problem of no arms, and n_fruits=10**5
    gave up after 200 draws over 4 MiB each.) Each is refused at once, naming the argument."""
    from coplan.generate import cell_problem, gantry_row, overlap_problem, random_problem, row_problem

    cases = [
        (lambda: row_problem("3", 5), r"row_problem: n_arms: expected a whole number from 1 to 64, found '3'"),
        (lambda: row_problem(3, 5, links=(1,)), r"row_problem: links: expected two positive finite numbers, found \(1,\)"),
        (lambda: row_problem(3, 5, seed=-1), r"row_problem: seed: expected a whole number from 0 to 4294967295, found -1"),
        (lambda: random_problem("a"), r"random_problem: seed: expected a whole number .* found 'a'"),
        (lambda: cell_problem(0, n_arms=0), r"cell_problem: n_arms: expected a whole number from 1 to 64, found 0"),
        (lambda: cell_problem(0, n_fruits=10**5), r"cell_problem: n_fruits: expected a whole number from 0 to 20000, found 100000"),
        (lambda: overlap_problem(n_arms=2.5), r"overlap_problem: n_arms: expected a whole number"),
        (lambda: gantry_row(n_arms=True), r"gantry_row: n_arms: expected a whole number .* found True"),
    ]
    for make, words in cases:
        with pytest.raises(ValueError, match=words):
            make()
    import numpy

    assert len(row_problem(3, 5, seed=numpy.int64(4))["fruits"]) == 5  # NumPy integers are whole numbers


def test_a_problem_given_as_a_mapping_is_named_by_key_path_without_lines_of_a_text_never_seen():
    """(Its issues carried line numbers of the YAML it was turned into: 'a problem given as a mapping:16'.)"""
    d = gantry_row(length=6.0, density=2.0, seed=1)
    d["fruits"][1]["position"][0] = "abc"
    with pytest.raises(ProblemError) as e:
        coplan.solve(d)
    assert "fruits[1].position[0]" in str(e.value) and not re.search(r"mapping:\d", str(e.value))
    assert all(i.line is None for i in e.value.issues)
    with pytest.raises(ProblemError) as e:  # (it said "found an empty file")
        coplan.solve({})
    assert "found an empty mapping" in str(e.value) and "file" not in str(e.value)


def test_an_empty_row_s_summary_gives_no_share_of_nothing(tmp_path):
    """(It printed '0 harvested of 0 harvestable (0.0 %)' while metrics.row.share_harvested is null.)"""
    f = tmp_path / "empty.yaml"
    f.write_text(to_yaml(gantry_row(length=6.0, density=0.0, seed=1)))
    r = runner.invoke(app, ["solve", str(f), "--out", str(tmp_path / "o")])
    assert "0 harvested of 0 harvestable (-)" in r.output, r.output


def test_a_result_shows_what_it_is_in_a_notebook_cell_not_its_samples():
    """(``result`` in a cell printed about 15,000 characters: every sample of the plan.)"""
    from coplan.viz.plots import plot_workspace

    path = next(p for p in shipped_problems() if p.stem == "crossing_paths")
    res = coplan.solve(str(path), planner="heuristic")
    text = repr(res)
    assert len(text) < 400 and "problem='crossing-paths'" in text and f"samples={res.plan.time.size}" in text
    assert f"harvested={res.plan.metrics['harvested']}/{res.plan.metrics['reachable']}" in text
    assert repr(res.plan) in text and "array(" not in text
    with pytest.raises(TypeError, match=r"plot_workspace: arm: expected an arm's name \(str\) or None, found Plan"):
        plot_workspace(res.problem, res.plan)  # (the plan where the arm's name goes: a KeyError printing the plan)


def test_a_problem_changed_in_python_is_held_to_the_ranges_and_plan_length_a_file_is():
    """(A joint velocity limit of 1e-6 rad/s set with dataclasses.replace ran out of memory after
    28 s; an 8 h dwell made a 78 MB plan file no coplan command reads back.)"""
    import dataclasses

    import coplan
    from coplan.errors import ProblemError
    from coplan.problem import load_problem, shipped_problems

    p = load_problem(next(f for f in shipped_problems() if f.stem == "single_arm"))
    a = p.arms[0]
    slow = dataclasses.replace(p, arms=(dataclasses.replace(a, max_velocity=(1e-6, 1e-6)),))
    with pytest.raises(ProblemError, match=r"arms\[0\]\.max_velocity\[0\]: expected a joint velocity limit within"):
        coplan.solve(slow, planner="coordinated")
    long = dataclasses.replace(p, task=dataclasses.replace(p.task, pick_dwell=8 * 3600.0))
    with pytest.raises(ProblemError, match="as changed in Python"):
        coplan.solve(long, planner="coordinated")
    assert coplan.solve(dataclasses.replace(p, name="changed"), planner="coordinated").plan.status.value == "success"


def test_a_row_changed_in_python_is_held_to_its_rail_as_a_file_is():
    """(A rail cut from 50 to 5 m with dataclasses.replace was planned: 'success' with 15 of 93
    fruit, the other 78 'screened out'; the same row as a file is refused, fruit by fruit.)"""
    import dataclasses

    import coplan
    from coplan.errors import ProblemError
    from coplan.problem import load_problem, shipped_rows

    r = load_problem(next(f for f in shipped_rows() if f.stem == "sparse_row"))
    cut = dataclasses.replace(r, gantry=dataclasses.replace(r.gantry, end=5.0))
    with pytest.raises(ProblemError) as e:
        coplan.solve(cut, planner="coordinated")
    far = [i for i in e.value.issues if i.message.startswith("expected a fruit on this row")]
    assert far and all(i.path.startswith("fruits[") and i.path.endswith("].position[0]") for i in far)
    assert len(far) == sum(f.position[0] > 5.0 + max(a.base[0] + a.reach for a in r.arms) for f in r.fruits)
    crawl = dataclasses.replace(r, gantry=dataclasses.replace(r.gantry, max_velocity=1e-5))
    with pytest.raises(ProblemError, match=r"gantry\.max_velocity: expected .* within the plausible range"):
        coplan.solve(crawl, planner="coordinated")


def test_lists_and_arrays_in_a_problem_built_in_python_are_its_tuples(cell):
    """(A list for a fruit's position was accepted, then coplan.solve died in a TypeError:
    unhashable type 'list'.)"""
    import numpy as np

    p = dataclasses.replace(cell, fruits=(coplan.Fruit("z", [0.1, 1.2]), coplan.Fruit("y", np.array([0.2, 1.1]))),
                            arms=(dataclasses.replace(cell.arms[0], links=[0.9, 0.7], joint_limits=[[-3.0, 3.0], [-2.8, 2.8]]),)
                            + cell.arms[1:])
    assert p.fruits[0].position == (0.1, 1.2) and p.fruits[1].position == (0.2, 1.1)
    assert p.arms[0].links == (0.9, 0.7) and p.arms[0].joint_limits == ((-3.0, 3.0), (-2.8, 2.8))
    assert hash(p) == hash(dataclasses.replace(p)) and p.fruit_positions.shape == (2, 2)
    with pytest.raises(ProblemError, match=r"arms: expected a non-empty tuple of Arm, found tuple \(\)"):
        dataclasses.replace(cell, arms=())  # (said "found list ()" of a tuple)


def test_a_progress_that_cannot_be_called_is_refused_before_any_work(cell):
    with pytest.raises(TypeError, match="progress: expected a callable taking one message"):
        coplan.solve(cell, planner="coordinated", progress="yes")


def test_findings_hold_python_numbers(cell):
    """(A violation read amount=np.float64(6.29), limit=np.float64(1.6) in a notebook.)"""
    from coplan.planners.heuristic import plan_heuristic
    from coplan.verify import verify

    ver = verify(cell, plan_heuristic(cell))
    found = ver.violations + ver.warnings + ver.intervals + ver.pairs
    assert ver.violations and "np." not in repr(found)
    assert all(type(v.amount) is float for v in ver.violations)


def test_load_plan_names_a_path_of_the_wrong_type():
    """(coplan.load_plan(5) gave os's bare 'expected str, bytes or os.PathLike object, not int'.)"""
    import coplan

    with pytest.raises(TypeError, match=r"path: expected the path of a plan file \(str or Path\), found int 5"):
        coplan.load_plan(5)


def test_public_functions_given_the_wrong_kind_of_thing_say_so(tmp_path):
    """(A researcher's calls that raised from deep inside: plan_moving and row_bounds of a cell
    -- "'NoneType' object has no attribute 'length'" --, compare of a Problem -- "'Problem'
    object is not iterable" --, a Plan made with lists, with_status("success"), whose repr and
    save then raised.) Each says what it expected, or takes what it was given for what it means."""
    import coplan
    from coplan.allocate.row_bound import row_bounds
    from coplan.kinds import PlanStatus
    from coplan.plan import Plan
    from coplan.report.comparison import compare
    from coplan.row import plan_moving

    cell = coplan.load_problem("single_arm")
    for call in (lambda: plan_moving(cell), lambda: row_bounds(cell)):
        with pytest.raises(ValueError, match="has no gantry"):
            call()
    with pytest.raises(TypeError, match="found Problem; a Problem made in Python is planned by coplan.solve"):
        compare(cell, ["coordinated"], tmp_path / "c")
    p = coplan.solve(cell, planner="coordinated").plan
    listed = Plan(problem=p.problem, planner="mine", status="unverified", time=p.time.tolist(),
                  q={a: v.tolist() for a, v in p.q.items()}, events=list(p.events), allocation={}, unreachable=[])
    assert listed.status == PlanStatus.UNVERIFIED and listed.time.dtype == float
    assert coplan.verify.verify(cell, listed).passed
    assert p.with_status("partial").status == PlanStatus.PARTIAL and "partial" in repr(p.with_status("partial"))
    with pytest.raises(ValueError, match="expected one of"):
        p.with_status("great")
    # (an edited plan kept its status, and with_status("success") was accepted on it)
    edited = coplan.solve(cell, planner="coordinated").plan
    edited.q[edited.arm_names[0]][30:40] += 0.5
    assert edited.changed_since_verified()
    with pytest.raises(ValueError, match="changed since it was verified"):
        edited.with_status("success")
    assert edited.with_status("unverified").status == PlanStatus.UNVERIFIED



def test_row_bounds_hold_a_row_changed_in_python_to_its_file_as_solve_does():
    """(A rail cut short under its fruit: row_bounds gave bounds over the fruit left on it, where
    coplan.solve refuses the row naming each fruit off the rail.)"""
    from coplan.allocate.row_bound import row_bounds

    row = parse_problem(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=3)))
    cut = dataclasses.replace(row, gantry=dataclasses.replace(row.gantry, end=1.0))
    for call in (lambda: row_bounds(cut), lambda: coplan.solve(cut)):
        with pytest.raises(ProblemError, match=r"fruits\[\d+\]\.position\[0\]: expected a fruit on this row"):
            call()
    assert row_bounds(row).any_plan > 0


def test_a_problem_made_in_python_saves_as_a_file_that_reads_back_equal(tmp_path):
    """(``to_yaml(problem)`` raised "'Problem' object has no attribute 'items'": a problem
    changed in Python could not be saved.)"""
    import dataclasses

    import coplan
    from coplan.generate import to_yaml

    for name in ("crossing_paths", "sparse_row"):
        p = coplan.load_problem(name)
        p = dataclasses.replace(p, task=dataclasses.replace(p.task, clearance=0.07))
        (tmp_path / f"{name}.yaml").write_text(to_yaml(p))
        assert coplan.load_problem(tmp_path / f"{name}.yaml") == p
    with pytest.raises(TypeError, match="expected a problem mapping"):
        to_yaml(5)


def test_export_plan_takes_a_plan_file_s_path(tmp_path):
    """(A path raised "'str' object has no attribute 'time'".)"""
    import coplan
    from coplan.report.export import export_plan

    files = coplan.solve("single_arm", planner="coordinated", out_dir=tmp_path / "o").files
    out = export_plan(str(files["json"]), 100.0, "csv", tmp_path / "e.csv")
    assert out == [tmp_path / "e.csv", tmp_path / "e.events.csv"] and (tmp_path / "e.csv").read_text().startswith("t,")
    with pytest.raises(TypeError, match="expected a Plan or a plan file's path, found int"):
        export_plan(5, 100.0, "csv", tmp_path / "f.csv")


def test_row_entry_points_refuse_what_they_cannot_use_before_any_work(tmp_path):
    """(A new user's notebook: plan_row("sparse_row") raised "'str' object has no attribute
    'gantry'"; row_metrics of another row's problem gave "harvested 34 of 34" for a row of 30;
    row_metrics(problem, coplan.solve(...)) an AttributeError; coplan.allocate of a row read the
    carriage as standing at 0 and left fruit "unreachable"; a stop price with the fixed rule was
    silently ignored; coplan.report.compare of a row ran the cell planners on it; a live row's
    mode auto was refused only once the run started.)"""
    import coplan
    from coplan.errors import OptionsError
    from coplan.generate import gantry_row, to_yaml
    from coplan.planners.coordinated import plan_coordinated
    from coplan.problem import load_problem, parse_problem
    from coplan.report.comparison import compare
    from coplan.row.metrics import row_metrics
    from coplan.row.moving import plan_moving
    from coplan.row.plan import RowOptions, plan_row
    from coplan.row.sensing import LiveRowOptions
    from coplan.row.stops import StopWindow

    p = parse_problem(to_yaml(gantry_row(length=6, density=2, seed=3)))
    q = parse_problem(to_yaml(gantry_row(length=6, density=3, seed=4)))
    rr = plan_row(p)
    cases = [
        (lambda: plan_row("sparse_row"), TypeError, "plan_row: expected a Problem"),
        (lambda: plan_row(p, None, 5), TypeError, "progress: expected a callable"),
        (lambda: plan_moving(gantry_row(length=6, density=2, seed=3)), TypeError, "plan_moving: expected a Problem"),
        (lambda: row_metrics(q, rr), ValueError, "expected the row the result was planned for"),
        (lambda: row_metrics(load_problem("crossing_paths"), rr), ValueError, "a Problem with a gantry"),
        (lambda: row_metrics(p, coplan.solve(p)), TypeError, "result.plan.metrics['row']"),
        (lambda: row_metrics(p, rr.plan), TypeError, "expected a RowResult"),
        (lambda: row_metrics(p, rr, bounds=5), TypeError, "bounds: expected RowBounds"),
        (lambda: coplan.allocate(p, "makespan"), ValueError, "allocate: 'row-6m"),
        (lambda: plan_coordinated(p), ValueError, "is a row (it has a gantry)"),
        (lambda: RowOptions(stops="fixed", window=StopWindow(stop_price=2)), OptionsError, "window.stop_price: expected 0"),
        (lambda: coplan.solve(p, stops="fewest", options=RowOptions(window=StopWindow(stop_price=2))), OptionsError, "stop_price"),
        (lambda: StopWindow(stop_price=1e6), OptionsError, "at most 600 s"),
        (lambda: RowOptions(stops="fewest", window=StopWindow(pace_price=3)), OptionsError, "window.pace_price: expected 0"),
        (lambda: StopWindow(pace_price=-1.0), OptionsError, "pace_price"),
        (lambda: StopWindow(pace_price=1e6), OptionsError, "pace_price: expected a price per stop of at most 600 s"),
        (lambda: StopWindow(stop_price=400, pace_price=400), OptionsError, "stop_price + pace_price of at most 600 s"),
        (lambda: LiveRowOptions(mode="auto"), OptionsError, "mode: expected continuous or stop-and-go"),
        # (a bad mode was told the gantry's three choices, auto among them, which a live row then refused)
        (lambda: LiveRowOptions(mode="stop and go"), OptionsError,
         "mode: expected one of 'continuous', 'stop-and-go' for a live row, found 'stop and go'"),
        (lambda: coplan.solve(5), TypeError, "coplan.solve also takes a Problem or a mapping"),
        (lambda: compare(str(tmp_path / "row.yaml"), out_dir=tmp_path / "c"), ValueError, "compare_rows"),
    ]
    (tmp_path / "row.yaml").write_text(to_yaml(gantry_row(length=6, density=2, seed=3)))
    for call, kind, words in cases:
        with pytest.raises(kind) as e:
            call()
        assert words in str(e.value), (words, str(e.value))
    assert not (tmp_path / "c").exists()
    assert row_metrics(p, rr)["stops"] == len(rr.stops)  # (the right inputs still work)
    # verify takes a problem as a mapping, as solve does (coplan.generate's): the same verdict
    from coplan.verify import verify

    data = gantry_row(length=6, density=2, seed=3)
    assert verify(data, rr.plan).passed and verify(data, rr.plan).summary() == verify(p, rr.plan).summary()
    with pytest.raises(coplan.ProblemError, match="found an empty mapping"):
        verify({}, rr.plan)
    # the plan first and the problem second (`coplan verify PLAN` takes the plan alone first) says so
    for problem in (p, data):
        with pytest.raises(TypeError, match=r"the problem comes first, then the plan; found a Plan, then a .*swapped"):
            verify(rr.plan, problem)


def test_the_row_planners_hold_a_row_changed_in_python_to_what_a_file_is_held_to():
    """(A carriage of 1 um/s, refused by coplan.solve, was taken by plan_row -- 21 GB in 20 s --
    and plan_moving said 'math domain error'.) Both raise the ProblemError solve raises."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem
    from coplan.row import plan_moving, plan_row

    row = parse_problem(to_yaml(gantry_row(length=6.0, density=2.0, seed=1)))
    slow = dataclasses.replace(row, gantry=dataclasses.replace(row.gantry, max_velocity=1e-6))
    for call in (lambda: coplan.solve(slow), lambda: plan_row(slow), lambda: plan_moving(slow)):
        with pytest.raises(ProblemError, match="gantry.max_velocity"):
            call()


def test_cell_and_row_bound_functions_refuse_what_they_cannot_bound(tmp_path):
    """(From a trial: lower_bound of a row returned its cell's with the carriage at 0, 12 of its
    32 fruit; a name gave "cannot create weak reference to 'str' object" or "'str' object has no
    attribute 'gantry'"; row_bounds(step=0) a ZeroDivisionError, priced='no' was true.)"""
    from coplan.allocate import lower_bound, row_bounds
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem

    row = parse_problem(to_yaml(gantry_row(length=6.0, density=2.0, seed=1)))
    with pytest.raises(ValueError, match="lower_bound: .* is a row"):
        lower_bound(row)
    for call, words in ((lambda: coplan.allocate("crossing_paths", "makespan"), "allocate: expected a Problem"),
                        (lambda: lower_bound("crossing_paths"), "lower_bound: expected a Problem"),
                        (lambda: row_bounds("sparse_row"), "row_bounds: expected a Problem")):
        with pytest.raises(TypeError, match=words):
            call()
    for step in (0, -0.05, "0.05", 7.0):
        with pytest.raises(ValueError, match="step: expected the spacing of the carriage positions from 0.01 to 0.5 m"):
            row_bounds(row, step=step)
    with pytest.raises(TypeError, match="priced: expected True or False"):
        row_bounds(row, priced="no")


def test_compare_rows_takes_a_name_and_one_rule_as_solve_does(tmp_path):
    """(compare_rows("sparse_row", ...) raised "'str' object has no attribute 'name'";
    rules="fixed" iterated over its letters: "found 'f'".) A row's result has a short repr."""
    from coplan.generate import gantry_row
    from coplan.report.rows import compare_rows

    cmp = compare_rows(gantry_row(length=6.0, density=2.0, seed=1), tmp_path / "c", rules="fewest")
    assert [r["name"] for r in cmp.rows] == ["fewest", "on the move"]
    with pytest.raises(TypeError, match="compare_rows: expected a Problem, a problem file's path or a shipped name"):
        compare_rows(3, tmp_path / "d")
    res = coplan.solve(gantry_row(length=6.0, density=2.0, seed=1)).row
    assert len(repr(res)) < 300 and repr(res).startswith("RowResult(") and "verified=True" in repr(res), repr(res)


def test_row_metrics_export_and_plots_refuse_arguments_that_do_not_fit(tmp_path):
    """(From the third trial: row_metrics took another row's bounds -- a ratio of 1.959 for
    1.585 --; export_plan wrote at its trajectory's 50 Hz when 100 was asked; plot_joints(clip="3"),
    plot_clearance(y_max="1") raised from inside, and negative values were taken; workspace_maps
    took Arm objects only.)"""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem
    from coplan.report import export_plan, trajectory
    from coplan.row import plan_row, row_bounds, row_metrics
    from coplan.viz.plots import plot_clearance, plot_joints, workspace_maps

    a = parse_problem(to_yaml(gantry_row(length=6.0, density=2.0, seed=1)))
    b = parse_problem(to_yaml(gantry_row(length=6.0, n_arms=2, density=2.0, seed=9)))
    res = plan_row(a)
    with pytest.raises(ValueError, match="bounds: expected the bounds of .*, found those of"):
        row_metrics(a, res, row_bounds(b, priced=False))
    assert row_metrics(a, res, row_bounds(a, priced=False))["ratio_any_plan_bound"] > 1.0
    c = coplan.solve("crossing_paths", planner="coordinated")
    with pytest.raises(ValueError, match="traj: expected trajectory\\(plan, 100\\) at the rate asked, found one at 50 Hz"):
        export_plan(c.plan, 100, "csv", tmp_path / "e.csv", traj=trajectory(c.plan, 50))
    assert not (tmp_path / "e.csv").exists()
    for call, words in ((lambda: plot_joints(c.problem, c.plan, clip="3"), "plot_joints: clip: expected a positive number"),
                        (lambda: plot_joints(c.problem, c.plan, clip=-1), "plot_joints: clip: expected a positive number"),
                        (lambda: plot_clearance(c.problem, c.plan, y_max=-1), "plot_clearance: y_max: expected a positive"),
                        (lambda: workspace_maps(c.problem, arms=["lefft"]), "workspace_maps: arms: expected the problem's")):
        with pytest.raises(ValueError, match=words):
            call()
    import numpy as np

    by_name, by_arm = workspace_maps(c.problem, arms=["left"], resolution=40), workspace_maps(c.problem, arms=[c.problem.arms[0]], resolution=40)
    assert np.array_equal(by_name[3], by_arm[3])


def test_yaml_text_given_for_a_problem_s_path_points_to_parse_problem():
    """(From a user's trial: a generated problem's text given to coplan.solve or load_problem was
    OSError 'File name too long' from pathlib, or 'no file at this path' when short.)"""
    text = to_yaml(coplan.generate.random_problem(seed=1))
    for call in (coplan.load_problem, coplan.solve):
        with pytest.raises(ProblemError, match=r"found text of \d+ lines .*coplan.parse_problem\(text\)"):
            call(text)
    with pytest.raises(ProblemError, match="found text of 2 lines"):
        coplan.solve("name: x\narms: []")


def test_a_problem_mapping_with_arrays_solves_and_an_unwritable_value_is_named_by_its_key_path():
    """(From a user's trial: NumPy arrays in a problem mapping -- a notebook's positions -- were
    'TypeError: cannot write ndarray to a problem file', no key path.)"""
    import numpy as np

    d = coplan.generate.random_problem(seed=1)
    plain = coplan.problem.problem_from_mapping(d)
    d["fruits"] = [{"id": f["id"], "position": np.array(f["position"])} for f in d["fruits"]]
    d["arms"][0]["base"] = np.array(d["arms"][0]["base"])
    assert coplan.problem.problem_from_mapping(d) == plain
    d["fruits"][2]["position"] = [1.0, object()]
    with pytest.raises(ProblemError) as e:
        coplan.solve(d, planner="coordinated")
    assert [i.path for i in e.value.issues] == ["fruits[2].position[1]"] and "found object" in str(e.value)


def test_a_mapping_for_an_arm_or_a_fruit_in_a_problem_built_in_python_is_named():
    """(From a user's trial: Problem(arms=({"name": "a"},), ...) raised AttributeError "'dict'
    object has no attribute 'link_radius'" from the checks.)"""
    p = load_problem("crossing_paths")
    with pytest.raises(ProblemError, match=r"arms\[0\]: expected an Arm .*found mapping"):
        coplan.Problem(name="x", arms=({"name": "a"},), fruits=p.fruits, task=p.task)
    with pytest.raises(ProblemError, match=r"fruits\[1\]: expected a Fruit .*found mapping"):
        coplan.Problem(name="x", arms=p.arms, fruits=(p.fruits[0], {"id": "f", "position": (1, 1)}), task=p.task)


@pytest.mark.parametrize("planner", ["coordinated", "optimal"])
@pytest.mark.parametrize("once", [True, False])
def test_an_exception_in_the_caller_s_progress_callback_is_the_caller_s(planner, once):
    """(From a user's trial: a callback raising once inside the optimal planner was swallowed --
    status success, success False, error 'RuntimeError: bug in my callback' -- while one raising
    every time propagated.) Either way, whichever planner, it propagates as a
    ProgressCallbackError whose cause is the callback's own exception."""
    from coplan.progress import ProgressCallbackError

    calls = []
    nth = 2 if planner == "optimal" else 1  # (the coordinated planner says one line on this problem)

    def cb(msg):
        calls.append(msg)
        if (len(calls) == nth) if once else (len(calls) >= nth):
            raise RuntimeError("bug in my callback")

    with pytest.raises(ProgressCallbackError, match="the progress callable raised RuntimeError: bug in my callback") as e:
        coplan.solve("crossing_paths", planner=planner, options=OptimalOptions(search_work=1000, widen=False)
                     if planner == "optimal" else None, progress=cb)
    assert isinstance(e.value.__cause__, RuntimeError)


def test_the_allocation_stage_s_arguments_are_checked_expected_and_found():
    """(From a user's trial: lower_bound(time_limit=-1 or NaN) made HiGHS warn and ignore it,
    time_limit='5' was ignored, allocate(bound=nan) gave a NaN lower bound, territory=nan was
    taken, and a reach matrix of another shape or marking a fruit out of an arm's reach was a
    bare KeyError.)"""
    import numpy as np

    from coplan.allocate import allocate, bound_details, lower_bound

    p = load_problem("five_arm_row")
    for kw, words in [({"time_limit": -1}, "time_limit: expected a positive number of seconds or None, found -1"),
                      ({"time_limit": math.nan}, "found nan"), ({"time_limit": "5"}, "found '5'"),
                      ({"reach": np.ones((2, 2), bool)}, f"reach: expected a boolean array of shape ({len(p.arms)}, "
                                                         f"{len(p.fruits)}) (arms x fruit), found bool (2, 2)"),
                      ({"reach": np.ones((len(p.arms), len(p.fruits)), bool)}, "out of its reach")]:
        for fn in (lower_bound, bound_details):
            with pytest.raises(ValueError, match=re.escape(words)):
                fn(p, **kw)
    with pytest.raises(ValueError, match=r"allocate: territory: expected a number of 0 s or more, found nan; bound: "
                                         r"|allocate: bound: .*found nan; territory: .*found nan"):
        allocate(p, "makespan", bound=math.nan, territory=math.nan)
    assert lower_bound(p, reach=p.reach_matrix()) == pytest.approx(lower_bound(p), abs=1e-9)


@pytest.mark.parametrize("cls, kw, words", [
    (OptimalOptions, {"serch_work": 5}, "serch_work: expected a field of OptimalOptions, found 'serch_work'; did you mean 'search_work'?"),
    (RowOptions, {"stop": "fixed"}, "did you mean 'stops'?"),
    (MovingOptions, {"speed": 0.2}, "expected a field of MovingOptions, found 'speed'"),
    (LiveRowOptions, {"lookahead": 2.0}, "did you mean 'look_ahead'?"),
    (StopWindow, {"stop_prize": 2.0}, "did you mean 'stop_price'?"),
    (VerifyOptions, {"position_tolerence": 0.01}, "did you mean 'position_tolerance'?"),
])
def test_an_option_misspelt_in_python_gets_the_did_you_mean_an_options_file_gets(cls, kw, words):
    """(From a user's trial: OptimalOptions(serch_work=5) was Python's plain TypeError, 'unexpected
    keyword argument', where an options file's misspelt key gets a did-you-mean.)"""
    with pytest.raises(OptionsError, match=re.escape(words)):
        cls(**kw)


# ---------------------------------------------------------------- a Python user's mistakes (a new user's trial)
def test_segment_distances_take_planar_points_only_and_radii_of_at_least_zero():
    """3-D points lost their third coordinate without a word (two segments 1 m apart were 0 m
    apart); one number gave an IndexError; a negative radius was taken."""
    from coplan.kinematics.geometry import capsule_distance, segment_distance

    with pytest.raises(ValueError, match=r"segment_distance: p1: expected points of shape \(\.\.\., 2\).*found shape \(3,\)"):
        segment_distance([0, 0, 0], [1, 0, 0], [0, 0, 1], [1, 0, 1])
    with pytest.raises(ValueError, match=r"found shape \(1,\)"):
        segment_distance([0], [1], [0], [1])
    with pytest.raises(ValueError, match=r"capsule_distance: ra: expected a radius \(m\) of at least 0, found -0.1"):
        capsule_distance([0, 0], [1, 0], -0.1, [0, 1], [1, 1], 0.1)
    assert float(capsule_distance([0, 0], [1, 0], 0.1, [0, 1], [1, 1], 0.1)) == pytest.approx(0.8)  # (the analytic answer)


@pytest.mark.parametrize("call, match", [
    (lambda: SCurve.between([0, 0], [1, 1], [-1, 1], [1, 1], [1, 1]),
     r"SCurve.between: expected finite poses and limits > 0"),
    (lambda: SCurve.between(0, 1, 1, 1, 1),
     r"SCurve.between: expected q0, q1, vmax, amax and jmax as sequences of numbers"),
    (lambda: ik_one(1.0, 0.5, (1.0,), (0, 0), None, 0),
     r"ik_one: expected links \(l1, l2\) and base \(x, y\)"),
    (lambda: ik_one(1.0, 0.5, (1.0, 1.0), (0, 0), [-1, 1], 0),
     r"ik_one: joint_limits: expected \(\(t1_min, t1_max\), \(t2_min, t2_max\)\)"),
    (lambda: singularity_proximity([0.1, 0.2], (1.0,)),
     r"singularity_proximity: links: expected \(l1, l2\) in m"),
    (lambda: cubic_eval(0, 1, 0.0, 0.5),
     r"cubic_eval: expected q0 and q1 of shape \(2,\)"),
    (lambda: cubic_min_time(1.0, -1, 1),
     r"cubic_min_time: expected finite steps and limits > 0"),
])
def test_kinematics_and_timing_functions_say_what_they_expected(call, match):
    """Each gave an internal error (math domain error, IndexError, "'int' object is not
    iterable") or, for a negative speed limit, a duration."""
    with pytest.raises(ValueError, match=match):
        call()


def test_an_scurve_at_nan_times_is_refused_and_the_cubic_takes_one_time():
    s = SCurve.between([0, 0], [1, 1], [1, 1], [1, 1], [1, 1])
    with pytest.raises(ValueError, match=r"SCurve.derivatives: t: expected finite times"):
        s.derivatives([math.nan])  # (gave the start's state)
    q = cubic_eval([0.0, 0.0], [1.0, 2.0], 1.0, 0.5)  # (one time: the cubic's middle, half way)
    assert q.shape == (1, 2) and q[0].tolist() == pytest.approx([0.5, 1.0])


def test_generators_refuse_a_seed_of_none_and_a_height_range_of_one_number():
    from coplan.generate import overlap_problem, row_problem

    for fn, kw in ((gantry_row, dict(length=6)), (row_problem, dict(n_arms=2, n_fruits=5)), (overlap_problem, {})):
        with pytest.raises(ValueError, match=rf"{fn.__name__}: seed: expected a whole number from 0 to 4294967295, found None"):
            fn(seed=None, **kw)  # (drew another problem at every call, named ...-seedNone)
        with pytest.raises(ValueError, match=rf"{fn.__name__}: y_range: expected \(low, high\), two finite numbers with low < high, found 1.0"):
            fn(y_range=1.0, **kw)
    assert gantry_row(length=6, seed=1) == gantry_row(length=6, seed=1)  # (deterministic in its arguments)


def test_an_arm_name_with_spaces_around_it_is_refused_in_python_as_a_file_strips_it(greenhouse):
    """``' left '`` beside ``left`` was planned as a second arm; a file's names are stripped."""
    a1 = dataclasses.replace(greenhouse.arms[1], name=f" {greenhouse.arms[0].name} ")
    with pytest.raises(ProblemError, match=r"arms\[1\]\.name: expected a name with no spaces around it .*found ' left '"):
        dataclasses.replace(greenhouse, arms=(greenhouse.arms[0], a1, greenhouse.arms[2]))


def test_run_sweep_checks_its_arguments_before_any_work(tmp_path):
    """A path gave "'str' object has no attribute 'name'", workers 0 ran on the default and a
    time limit of -1 wrote a 'bad input' row per problem; a path is now loaded."""
    from coplan.sweep.run import run_sweep
    from coplan.sweep.spec import load_sweep

    f = tmp_path / "sweep.yaml"
    f.write_text("name: s\nbase: random\nvary:\n  seed: [0]\nplanner: coordinated\n")
    spec = load_sweep(f)
    with pytest.raises(TypeError, match=r"run_sweep\(\): spec: expected a SweepSpec .* or a sweep file's path, found int"):
        run_sweep(3, tmp_path / "o")
    with pytest.raises(ValueError, match=r"run_sweep\(\): workers: expected a whole number of processes from 1 to 256, or auto; found number 0"):
        run_sweep(spec, tmp_path / "o", workers=0)
    with pytest.raises(ValueError, match=r"run_sweep\(\): time_limit: expected a positive, finite number of seconds"):
        run_sweep(spec, tmp_path / "o", time_limit=-1)
    assert not (tmp_path / "o").exists()  # (nothing written)


def test_plotting_and_export_mistakes_say_what_was_expected(cell, tmp_path):
    from coplan.planners.coordinated import plan_coordinated
    from coplan.report.export import export_plan
    from coplan.viz.animate import render_frame
    from coplan.viz.plots import plot_joints, plot_workspace

    plan = plan_coordinated(cell).plan
    with pytest.raises(TypeError, match=r"plot_joints: plan: expected one Plan .* found a mapping of 1 \(opt\)"):
        plot_joints(cell, {"opt": plan})
    with pytest.raises(ValueError, match=r"render_frame: t: expected a plan time in s"):
        render_frame(cell, plan, "1")
    with pytest.raises(ValueError, match=r"render_frame: t: expected a plan time in \[0, .*\] s, found -1"):
        render_frame(cell, plan, -1.0)  # (it drew the first pose, as if at t = 0)
    with pytest.raises(ValueError, match=r"plot_workspace: arm: expected one of the problem's arms"):
        plot_workspace(cell, "lft")
    with pytest.raises(ValueError, match=r"out: expected a folder for json .* found the file name"):
        export_plan(plan, 100, "json", tmp_path / "ex.json")
    assert not (tmp_path / "ex.json").exists()


def test_a_researchers_notebook_sees_short_reprs_takes_lists_and_keeps_files_in_their_folder(cell, tmp_path):
    """(A new user's trial: a Problem of 26 fruit printed 2.4k characters, a Comparison 10k;
    ``dataclasses.replace(p, fruits=[...])`` was refused as "expected a tuple of Fruit, found
    list" where ``Fruit(position=[...])`` is taken; ``plan.save(folder, "../escape")`` wrote
    beside the folder.)"""
    row = load_problem("course_row")
    text = repr(row)
    assert len(text) < 250 and "fruits=301" in text and "row 0-50 m" in text and "arm1, arm2, arm3" in text
    listed = dataclasses.replace(cell, fruits=list(cell.fruits), arms=list(cell.arms))
    assert listed == cell and isinstance(listed.fruits, tuple) and isinstance(listed.arms, tuple)
    hash(listed)  # (the row bounds remember problems by hash)
    plan = coplan.solve(cell, planner="coordinated").plan
    for stem in ("../escape", "sub/plan", ".."):
        with pytest.raises(OutputError, match="expected a file name stem"):
            plan.save(tmp_path / "run", stem)
    assert not (tmp_path / "escape.json").exists()
    comp = compare(CROSSING, ["heuristic", "coordinated"], tmp_path / "c")
    assert len(repr(comp)) < 300 and "rows=2" in repr(comp)


def test_a_solve_result_is_taken_wherever_a_plan_is_and_views_arguments_swapped_are_named(cell, tmp_path):
    """(A trial: view took a SolveResult, verify and plot_gantt raised TypeError on one; view's
    order is plan then problem, verify's problem then plan.) verify and the plots take a result's
    plan; view(problem, plan) says the two are swapped, as verify(plan, problem) does."""
    from coplan.viz import plot_gantt

    res = coplan.solve(cell, planner="coordinated")
    assert coplan.verify(cell, res).passed
    plot_gantt(cell, res)
    with pytest.raises(TypeError, match=r"view\(plan, problem\): the plan comes first.*\(swapped\?\)"):
        coplan.view(cell, res)
    with pytest.raises(TypeError, match=r"the problem comes first, then the plan"):
        coplan.verify(res.plan, cell)


def test_input_errors_keep_their_message_when_pickled_or_copied():
    """(A ProblemError handed back from a worker process -- or copy.copy'd -- was rebuilt from its
    message alone, each character an issue: "<input>: 200 problems found\\n  c\\n  r ...".) Every
    input error and the CLI's Failure round-trip whole."""
    import copy
    import pickle

    import coplan
    from coplan.cli.failures import Failure
    from coplan.errors import Issue, OptionsError, PlanFileError, ProblemError
    from coplan.live.feed import FeedError
    from coplan.sweep.spec import SweepError
    from coplan.sweep.table import SweepTableError

    with pytest.raises(ProblemError) as caught:
        coplan.load_problem("crosing_paths")
    errors = [caught.value] + [cls([Issue("a.b", "expected x, found y", 3), Issue("c", "bad")], "f.yaml")
                               for cls in (PlanFileError, OptionsError, FeedError, SweepError, SweepTableError)]
    for e in errors:
        for back in (pickle.loads(pickle.dumps(e)), copy.copy(e), copy.deepcopy(e)):
            assert type(back) is type(e) and str(back) == str(e) and back.args == e.args
            assert back.issues == e.issues and back.source == e.source
    assert "did you mean the shipped problem 'crossing_paths'" in str(pickle.loads(pickle.dumps(caught.value)))
    f = pickle.loads(pickle.dumps(Failure(2, "no such plan")))
    assert (int(f.code), f.message, str(f)) == (2, "no such plan", "no such plan")


def test_an_empty_out_dir_string_is_refused_before_any_work(tmp_path, monkeypatch):
    """(``coplan.solve(..., out_dir="")`` -- an unset variable's default -- wrote the run into the
    folder the program ran in, and a second call renamed that folder ``<cwd>.previous``; ``--out ''``
    was refused.) An empty string is refused, as the command line does; ``"."`` is the current folder."""
    import coplan
    from coplan.output import OutputError

    monkeypatch.chdir(tmp_path)
    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(OutputError, match="out_dir: expected the path of a folder, found an empty string"):
        coplan.solve("crossing_paths", planner="coordinated", out_dir="")
    plan = coplan.solve("crossing_paths", planner="coordinated").plan
    with pytest.raises(OutputError, match="save: expected a folder or a .json file name, found an empty string"):
        plan.save("")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["notes.txt"]


def test_numpy_scalars_in_options_are_taken_as_the_python_values_they_hold():
    """(``OptimalOptions(widen=np.bool_(False))`` was refused -- "expected true or false, found
    bool" -- while an ``np.int64`` budget was kept as it was, no JSON value.)"""
    import numpy as np

    from coplan.optimal import OptimalOptions
    from coplan.row.plan import RowOptions

    o = OptimalOptions(widen=np.bool_(False), search_work=np.int64(10), margin=np.float64(0.01))
    assert (o.widen, o.search_work, o.margin) == (False, 10, 0.01)
    assert type(o.widen) is bool and type(o.search_work) is int and type(o.margin) is float
    assert RowOptions(retime=np.bool_(True)).retime is True
    with pytest.raises(OptionsError, match="widen: expected true or false, found ndarray"):
        OptimalOptions(widen=np.array([True, False]))
    with pytest.raises(OptionsError, match="search_work"):
        OptimalOptions(search_work=np.float64(2.5))
    # (a class's own range checks too: max_open=np.int64(40) was refused, a float32 gate of 5 m let by)
    from coplan.live.cell import LiveOptions

    assert LiveOptions(max_open=np.int64(40), horizon=np.float32(0.25)).max_open == 40
    with pytest.raises(OptionsError, match=r"gate: expected a number in \[0, 1\] m, found number 5"):
        LiveOptions(gate=np.float32(5.0))
