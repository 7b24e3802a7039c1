"""Files given in the wrong place: a plan or feed where a problem is expected (and the other
way round), a plan checked against another problem, an empty plan, a tab in YAML -- each one
clear sentence with the file, never a list of unknown keys or a parser's raw words."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.errors import PlanFileError, ProblemError
from coplan.live.feed import FeedError, load_feed
from coplan.plan import load_plan
from coplan.problem import default_problem_path, load_problem, parse_problem

PROBLEMS = default_problem_path().parent
runner = CliRunner()


@pytest.fixture(scope="module")
def crossing_plan(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("crossing")
    r = runner.invoke(app, ["solve", str(PROBLEMS / "crossing_paths.yaml"), "--planner", "coordinated", "--out", str(out)])
    assert r.exit_code == 0, r.output
    return out / "plan.json"


def test_a_plan_given_as_the_problem_says_the_arguments_look_swapped(crossing_plan):
    with pytest.raises(ProblemError) as e:
        load_problem(crossing_plan)
    assert len(e.value.issues) == 1  # one sentence, not one unknown key per plan field
    msg = str(e.value)
    assert str(crossing_plan) in msg and "found a coplan plan file (format 'coplan.plan/1')" in msg and "swapped" in msg
    r = runner.invoke(app, ["verify", str(crossing_plan), str(PROBLEMS / "crossing_paths.yaml")])
    assert r.exit_code == 3 and "swapped" in r.output and "Traceback" not in r.output


def test_a_problem_given_as_the_plan_says_the_arguments_look_swapped(tmp_path):
    """The other way round: a problem YAML where the plan is expected (also under another
    suffix); a JSON file that is merely broken gets no such hint."""
    for src in (PROBLEMS / "crossing_paths.yaml", tmp_path / "problem.txt"):
        if src.suffix == ".txt":
            src.write_text((PROBLEMS / "crossing_paths.yaml").read_text())
        with pytest.raises(PlanFileError) as e:
            load_plan(src)
        assert "looks like a problem file (YAML)" in str(e.value) and "swapped" in str(e.value)
    broken = tmp_path / "plan.json"
    broken.write_text('{"format": ')
    with pytest.raises(PlanFileError) as e:
        load_plan(broken)
    assert "expected JSON, found a syntax error" in str(e.value) and "swapped" not in str(e.value)


def test_a_problem_given_as_the_feed_says_so():
    with pytest.raises(FeedError) as e:
        load_feed(PROBLEMS / "crossing_paths.yaml")
    assert len(e.value.issues) == 1 and "found a problem file" in str(e.value) and "swapped" in str(e.value)


def test_a_feed_or_plan_csv_in_the_wrong_place_is_named_in_one_sentence(crossing_plan, tmp_path):
    """A feed where the plan is expected, a plan where the feed is expected, the plan CSV where
    the problem is expected: each is named for what it is (one issue, exit 3), not read as
    broken JSON, a list of unknown keys or a string."""
    feed = tmp_path / "feed.yaml"
    r = runner.invoke(app, ["feed", str(PROBLEMS / "crossing_paths.yaml"), "--out", str(feed)])
    assert r.exit_code == 0, r.output
    with pytest.raises(PlanFileError) as e:
        load_plan(feed)
    assert len(e.value.issues) == 1
    assert "expected a plan file (plan.json or plan.csv), found a coplan feed file (format 'coplan.feed/1')" in str(e.value)
    r = runner.invoke(app, ["verify", str(PROBLEMS / "crossing_paths.yaml"), str(feed)])
    assert r.exit_code == 3 and "found a coplan feed file" in r.output and "syntax error" not in r.output
    with pytest.raises(FeedError) as e:
        load_feed(crossing_plan)
    (issue,) = e.value.issues
    assert "expected a feed file (format coplan.feed/1, key 'detections'), found a coplan plan file (format 'coplan.plan/1')" \
        in issue.message and issue.line == 1
    r = runner.invoke(app, ["run", str(PROBLEMS / "crossing_paths.yaml"), "--feed", str(crossing_plan),
                            "--out", str(tmp_path / "run")])
    assert r.exit_code == 3 and "found a coplan plan file" in r.output and "unknown key" not in r.output
    res = runner.invoke(app, ["run", str(PROBLEMS / "crossing_paths.yaml"), "--feed", str(crossing_plan.with_name("plan.csv")),
                              "--out", str(tmp_path / "run2")])  # a CSV as the feed: one sentence, not the whole file
    assert res.exit_code == 3 and "found a CSV of joint samples" in res.output and len(res.output) < 2000
    ver = crossing_plan.with_name("verification.json")  # another coplan JSON file as the plan
    with pytest.raises(PlanFileError) as e:
        load_plan(ver)
    (issue,) = e.value.issues
    assert "found a coplan verification file (format 'coplan.verification/1')" in issue.message
    other = tmp_path / "plan2.json"  # another version of the plan format is not "another kind of file"
    other.write_text(crossing_plan.read_text().replace('"coplan.plan/1"', '"coplan.plan/2"', 1))
    with pytest.raises(PlanFileError) as e:
        load_plan(other)
    assert "swapped" not in str(e.value) and "expected 'coplan.plan/1'" in str(e.value)
    csv = crossing_plan.with_name("plan.csv")
    assert csv.read_text().startswith("t,left_q1,")
    with pytest.raises(ProblemError) as e:
        load_problem(csv)
    (issue,) = e.value.issues
    assert "found a coplan plan CSV" in issue.message and "swapped" in issue.message
    r = runner.invoke(app, ["check", str(csv)])
    assert r.exit_code == 3 and "found a coplan plan CSV" in r.output


def test_a_plan_checked_against_another_problem_names_both_files(crossing_plan):
    r = runner.invoke(app, ["verify", str(PROBLEMS / "greenhouse_row.yaml"), str(crossing_plan)])
    assert r.exit_code == 3
    assert str(crossing_plan) in r.output and "greenhouse_row.yaml" in r.output
    assert "expected the problem's arms ['left', 'center', 'right'], found ['left', 'right']" in r.output


def test_verify_notes_a_problem_file_other_than_the_one_the_plan_was_planned_from(crossing_plan, tmp_path):
    """The plan records its problem file's sha256: verified against other text of the same
    problem (here a wider clearance), verify says so before its verdict; against the same text
    (any path), nothing."""
    record = json.loads(crossing_plan.read_text())["problem_file"]
    changed = tmp_path / "crossing_wider.yaml"
    changed.write_text((PROBLEMS / "crossing_paths.yaml").read_text().replace("clearance: 0.05", "clearance: 0.06"))
    r = runner.invoke(app, ["verify", str(changed), str(crossing_plan)])
    assert r.exit_code == 0, r.output
    assert f"was planned from {record['path']}" in r.output and "its sha256 differs" in r.output
    assert "(required 0.060 m)" in r.output  # verified against the file given, as it is
    same = tmp_path / "copy.yaml"
    same.write_text((PROBLEMS / "crossing_paths.yaml").read_text())
    r = runner.invoke(app, ["verify", str(same), str(crossing_plan)])
    assert r.exit_code == 0 and "sha256" not in r.output
    # --json (and verification.json) carry it too: the text checked against and the plan's record
    for problem, same_text in ((changed, False), (same, True)):
        r = runner.invoke(app, ["verify", str(problem), str(crossing_plan), "--json"])
        assert r.exit_code == 0, r.output
        doc = json.loads(r.stdout)["problem_file"]
        assert doc["planned_from"] == record and doc["same_text"] is same_text
        assert (doc["sha256"] == record["sha256"]) is same_text


def test_verify_takes_the_plan_alone_as_the_other_plan_commands_do(crossing_plan, tmp_path):
    """``coplan verify plan.json`` (as ``plot``, ``export``: "Missing argument 'PLAN'" before):
    against the problem file the plan records, the same report as ``verify PROBLEM PLAN``;
    ``-p`` gives another; the problem twice, a problem without its plan, or a plan that does not
    say its problem (a plan.csv) is a usage error saying what to give."""
    problem = PROBLEMS / "crossing_paths.yaml"
    both = runner.invoke(app, ["verify", str(problem), str(crossing_plan), "--json"])
    alone = runner.invoke(app, ["verify", str(crossing_plan), "--json"])
    assert both.exit_code == alone.exit_code == 0, alone.output
    a, b = json.loads(both.stdout), json.loads(alone.stdout)
    assert a["summary"] == b["summary"] and a["problem_file"] == b["problem_file"] and b["problem_file"]["same_text"]
    wider = tmp_path / "crossing_wider.yaml"
    wider.write_text(problem.read_text().replace("clearance: 0.05", "clearance: 0.06"))
    r = runner.invoke(app, ["verify", str(crossing_plan), "-p", str(wider)])
    assert r.exit_code == 0 and "(required 0.060 m)" in r.output and "its sha256 differs" in r.output, r.output
    r = runner.invoke(app, ["verify", str(problem), str(crossing_plan), "-p", str(wider)])
    assert r.exit_code == 2 and "given twice" in r.output
    for name in (str(problem), "crossing_paths"):
        r = runner.invoke(app, ["verify", name])
        assert r.exit_code == 2 and "coplan verify PROBLEM PLAN" in r.output and "Traceback" not in r.output, r.output
    csv = crossing_plan.with_name("plan.csv")
    r = runner.invoke(app, ["verify", str(csv)])
    assert r.exit_code == 2 and "does not name its problem" in r.output and "--problem FILE" in r.output, r.output
    r = runner.invoke(app, ["verify", str(csv), "-p", str(problem)])
    assert r.exit_code == 0, r.output


def test_verify_and_export_of_a_plan_alone_say_which_problem_file_and_when_it_only_bears_a_shipped_name(tmp_path):
    """A plan solved from a copy of crossing_paths with faster joints, its name kept: `coplan verify
    PLAN` said "crossing-paths ... passed" and export wrote it, no word that the limits were the
    copy's, not the shipped problem's (a plan checked against the file it records)."""
    copy = tmp_path / "crossing_paths.yaml"
    copy.write_text((PROBLEMS / "crossing_paths.yaml").read_text().replace("max_velocity: [3.0, 4.0]", "max_velocity: [6.0, 8.0]"))
    r = runner.invoke(app, ["solve", str(copy), "--planner", "coordinated", "--out", str(tmp_path / "fast")])
    assert r.exit_code == 0, r.output
    plan = tmp_path / "fast" / "plan.json"
    r = runner.invoke(app, ["verify", str(plan)])
    said = " ".join(r.output.split())
    assert r.exit_code == 0 and f"problem {copy} (the file the plan records)" in said, said
    assert "bears the name of the shipped problem 'crossing-paths'" in said and "but is another text" in said, said
    r = runner.invoke(app, ["export", str(plan), "--out", str(tmp_path / "x.csv")])
    assert r.exit_code == 0 and "bears the name of the shipped problem 'crossing-paths'" in " ".join(r.output.split()), r.output
    r = runner.invoke(app, ["verify", "crossing_paths", str(plan)])
    assert r.exit_code != 0 and "(given)" in " ".join(r.output.split()), r.output  # the shipped limits: too fast
    shipped = runner.invoke(app, ["solve", "crossing_paths", "--planner", "coordinated", "--out", str(tmp_path / "own")])
    assert shipped.exit_code == 0
    r = runner.invoke(app, ["verify", str(tmp_path / "own" / "plan.json")])  # the shipped file itself: no note
    assert r.exit_code == 0 and "bears the name" not in r.output and "(the file the plan records)" in r.output, r.output


def test_an_empty_plan_file_is_called_empty(tmp_path):
    p = tmp_path / "plan.json"
    p.write_text("  \n")
    with pytest.raises(PlanFileError) as e:
        load_plan(p)
    assert "found an empty file" in str(e.value) and str(p) in str(e.value)


def test_a_tab_in_yaml_is_named_with_its_line_and_column():
    text = (PROBLEMS / "single_arm.yaml").read_text()
    lines = text.splitlines()
    k = next(i for i, s in enumerate(lines) if s.startswith("  - "))
    lines[k] = "\t" + lines[k][2:]
    with pytest.raises(ProblemError) as e:
        parse_problem("\n".join(lines) + "\n", "tabbed.yaml")
    (issue,) = e.value.issues
    assert issue.line == k + 1 and "found a tab character at column 1" in issue.message


def test_json_that_is_a_problem_still_loads(tmp_path):
    """A problem written as JSON (valid YAML) has no ``format`` key: it is not mistaken for a plan."""
    import yaml

    data = yaml.safe_load((PROBLEMS / "single_arm.yaml").read_text())
    p = tmp_path / "single.json"
    p.write_text(json.dumps(data))
    assert load_problem(p).name == "single-arm"


def test_check_says_there_is_nothing_to_plan_when_no_fruit_is_harvestable(tmp_path):
    text = (PROBLEMS / "single_arm.yaml").read_text().replace("position: [1.2, 0.8]", "position: [50.0, 50.0]")
    p = tmp_path / "far.yaml"
    p.write_text(text)
    r = runner.invoke(app, ["check", str(p)])
    assert r.exit_code == 4 and "nothing to plan" in r.output and "no plan can be faster" not in r.output
    r = runner.invoke(app, ["solve", str(p), "--out", str(tmp_path / "out")])
    assert r.exit_code == 4  # as check said


def test_verify_tells_the_makespan_from_the_plans_length(crossing_plan):
    """The plan goes on after the last place (the arms' way home): verify says both, so its
    length is not mistaken for the makespan solve reported."""
    r = runner.invoke(app, ["verify", str(PROBLEMS / "crossing_paths.yaml"), str(crossing_plan)])
    assert r.exit_code == 0
    plan = json.loads(crossing_plan.read_text())
    assert f"(makespan {plan['metrics']['makespan']:.2f} s: the last place)" in r.output
    assert f"plan of {plan['time'][-1]:.2f} s" in r.output and plan["time"][-1] > plan["metrics"]["makespan"] + 1.0


def test_a_shipped_problem_named_without_its_path_gets_its_path(tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)  # no such file here
    for given in ("dense_overlap", "dense_overlap.yaml"):  # (in Python too, as on the command line: it was an error)
        assert load_problem(given).source == str(PROBLEMS / "dense_overlap.yaml")
    with pytest.raises(ProblemError) as e:  # a path elsewhere: the error gives the shipped file's path
        load_problem("elsewhere/dense_overlap")
    msg = str(e.value)
    assert msg.startswith("elsewhere/dense_overlap:") and str(PROBLEMS / "dense_overlap.yaml") in msg and "coplan problems" in msg
    # the command line takes a shipped problem's bare name for that problem (and says which file)
    r = runner.invoke(app, ["check", "dense_overlap"])
    assert r.exit_code == 0 and str(PROBLEMS / "dense_overlap.yaml") in r.output and "Traceback" not in r.output
    r = runner.invoke(app, ["check", "elsewhere/dense_overlap.yaml"])  # a path is a path: no such file
    assert r.exit_code == 3 and str(PROBLEMS / "dense_overlap.yaml") in r.output
    with pytest.raises(ProblemError) as e:  # any other missing file: the plain message
        load_problem("no_such_cell.yaml")
    assert "shipped" not in str(e.value) and "found no file at this path" in str(e.value)


def test_a_plan_too_large_for_a_problem_file_is_named_as_a_plan(tmp_path):
    """(``coplan check`` on a 200 m row's 21 MB plan.json said only that the file was too large.)"""
    big = tmp_path / "plan.json"
    big.write_text('{"format":"coplan.plan/1","time":[' + ",".join(["0.0"] * 1_200_000) + "]}")
    with pytest.raises(ProblemError) as e:
        load_problem(big)
    assert "found a coplan.plan file" in str(e.value) and "swapped" in str(e.value)


def test_a_folder_named_like_a_shipped_problem_does_not_hide_it(tmp_path, monkeypatch):
    """(``coplan solve crossing_paths --out crossing_paths`` made a folder after which the bare
    name ``crossing_paths`` in that working folder meant the folder: "expected a YAML file, found a directory".)"""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "crossing_paths").mkdir()
    assert load_problem("crossing_paths").name == "crossing-paths"


def test_an_exported_joint_trajectory_given_as_a_plan_is_named(tmp_path):
    """(``coplan verify PROBLEM left.json`` -- one arm of ``coplan export --format json`` --
    listed five missing keys.)"""
    f = tmp_path / "left.json"
    f.write_text(json.dumps({"header": {}, "joint_names": ["left_joint1", "left_joint2"], "points": []}))
    with pytest.raises(PlanFileError) as e:
        load_plan(f)
    assert len(e.value.issues) == 1 and "found a JointTrajectory" in str(e.value) and "CSV export" in str(e.value)


def test_a_long_row_s_plan_given_as_the_problem_is_named_not_counted(tmp_path):
    """(``coplan verify course/plan.json course_row`` -- a 3.1 MB row plan, under the byte cap but
    over the YAML value cap -- was "arms.arm3.q[7071][0]: expected at most 300000 YAML values in a
    problem file, found more"; a smaller plan said "were the arguments swapped?".) A feed or an
    options file that large is still counted: only a file whose head names another coplan format
    is named."""
    from coplan.problem.yamlsafe import MAX_NODES

    plan = tmp_path / "plan.json"
    plan.write_text('{"format":"coplan.plan/1","problem":"course-row","time":[' + ",".join(["0.0"] * (MAX_NODES + 10)) + "]}")
    with pytest.raises(ProblemError) as e:
        load_problem(plan)
    (issue,) = e.value.issues
    assert "found a coplan.plan file (format 'coplan.plan/1'" in issue.message and "were the arguments swapped?" in issue.message
    assert "YAML values" not in str(e.value)
    r = CliRunner().invoke(app, ["verify", str(plan), "course_row"])
    assert r.exit_code != 0 and "were the arguments swapped?" in r.output and "Traceback" not in r.output
    feed = tmp_path / "feed.yaml"  # (a feed that large, read as a feed: its size, not a mix-up)
    feed.write_text('{"format":"coplan.feed/1","detections":[' + ",".join(["0"] * (MAX_NODES + 10)) + "]}")
    with pytest.raises(FeedError) as e:
        load_feed(feed)
    assert "YAML values" in str(e.value) and "swapped" not in str(e.value)


def test_a_feed_too_large_is_said_to_be_too_large_not_mixed_up(tmp_path):
    """(A 4.7 MB feed was "a coplan.feed file ...; were the arguments swapped?" to load_feed.)"""
    big = tmp_path / "feed.yaml"
    big.write_text('{"format":"coplan.feed/1","detections":[' + ",".join(["0"] * 2_400_000) + "]}")
    with pytest.raises(FeedError) as e:
        load_feed(big)
    assert "expected a file of at most" in str(e.value) and "swapped" not in str(e.value)


@pytest.mark.parametrize("char", ["\x07", "\x00", "\x1b"])
def test_a_control_character_in_yaml_is_named_with_its_line_and_column(char):
    """(PyYAML's reader said "unacceptable character #x0007 ... in "<unicode string>", position
    240", with no line: every other syntax error has one.)"""
    text = (PROBLEMS / "single_arm.yaml").read_text()
    lines = text.splitlines()
    k = next(i for i, s in enumerate(lines) if "name: arm" in s)
    col = lines[k].index("name: arm") + len("name: ar") + 1
    lines[k] = lines[k].replace("name: arm", f"name: ar{char}m")
    with pytest.raises(ProblemError) as e:
        parse_problem("\n".join(lines) + "\n", "ctrl.yaml")
    (issue,) = e.value.issues
    assert issue.line == k + 1 and f"found the control character U+{ord(char):04X} at column {col}" in issue.message
    assert "unicode string" not in str(e.value)


def test_a_plan_file_with_a_repeated_key_or_an_npz_is_refused_with_what_it_is(tmp_path):
    """(A repeated "planner" key was read as its last value, exit 0; plan.npz given as the plan
    was "an undecodable byte at offset 17".)"""
    from coplan.planners.heuristic import plan_heuristic

    plan = plan_heuristic(parse_problem((PROBLEMS / "single_arm.yaml").read_text()))
    plan.save(tmp_path / "run")
    text = (tmp_path / "run" / "plan.json").read_text()
    assert text.count('"planner":') == 1
    (tmp_path / "dup.json").write_text(text.replace('"planner":', '"planner": "optimal", "planner":', 1))
    with pytest.raises(PlanFileError) as e:
        load_plan(tmp_path / "dup.json")
    assert "found 'planner' twice" in str(e.value)
    with pytest.raises(PlanFileError) as e:
        load_plan(tmp_path / "run" / "plan.npz")
    assert "found a NumPy .npz archive" in str(e.value) and "give the plan.json beside it" in str(e.value)
    assert load_plan(tmp_path / "run" / "plan.json").same_motion(plan)  # (the file itself reads as before)


def test_a_near_miss_of_a_plan_files_key_is_named_other_keys_are_the_writers_own(tmp_path):
    """(A row plan with ``gantry`` misspelt ``gantri`` was "a plan without a carriage"; the
    schema leaves a plan open to a writer's own keys, which stay unread: a near miss is a typo
    only where the key it misses is not there.)"""
    from coplan.plan.files import PLAN_KEYS
    from coplan.planners.heuristic import plan_heuristic
    from coplan.schema import PlanFile

    assert set(PLAN_KEYS) == set(PlanFile.model_fields)  # (the reader's keys are the schema's)
    plan = plan_heuristic(parse_problem((PROBLEMS / "single_arm.yaml").read_text()))
    doc = plan.to_dict()
    (tmp_path / "typo.json").write_text(json.dumps(dict(doc, gantri={"x": [0.0] * len(doc["time"])})))
    with pytest.raises(PlanFileError) as e:
        load_plan(tmp_path / "typo.json")
    assert "gantri: expected one of the plan file's keys, found unknown key 'gantri'; did you mean 'gantry'?" in str(e.value)
    doc2 = {k: v for k, v in doc.items() if k != "events"}
    (tmp_path / "ev.json").write_text(json.dumps(dict(doc2, Events=doc["events"])))
    with pytest.raises(PlanFileError) as e:  # (a required key misspelt: named with it)
        load_plan(tmp_path / "ev.json")
    assert "events: expected a value, found nothing (required field); found 'Events': did you mean 'events'?" in str(e.value)
    (tmp_path / "events.json").write_text(json.dumps({"events": []}))
    with pytest.raises(PlanFileError) as e:  # (an export's events.json listed four missing keys)
        load_plan(tmp_path / "events.json")
    assert "found an export's events" in str(e.value) and len(e.value.issues) == 1
    (tmp_path / "st.json").write_text(json.dumps(dict({k: v for k, v in doc.items() if k != "status"}, Status="success")))
    with pytest.raises(PlanFileError) as e:  # (its verdict's key misspelt: read as no verdict, in silence)
        load_plan(tmp_path / "st.json")
    assert "found unknown key 'Status'; did you mean 'status'?" in str(e.value)
    # a writer's own keys, near to ours or not, beside ours: read past (problem_id, planned were refused)
    (tmp_path / "own.json").write_text(json.dumps(dict(doc, my_tool={"version": 3}, problem_id="x", planned="2024-05-01")))
    got = load_plan(tmp_path / "own.json")
    assert got.events == plan.events and abs(got.q["arm"] - plan.q["arm"]).max() < 1e-6  # (rounded to 1e-7 in JSON)


@pytest.mark.parametrize("doc, words", [({"events": []}, "found an export's events"),
                                        ({"header": {}, "joint_names": ["a_joint1"], "points": []}, "found an export's JointTrajectory")])
def test_an_exports_file_given_as_the_problem_is_named(tmp_path, doc, words):
    p = tmp_path / "x.json"
    p.write_text(json.dumps(doc))
    with pytest.raises(ProblemError) as e:
        load_problem(p)
    assert len(e.value.issues) == 1 and words in str(e.value) and "were the arguments swapped?" in str(e.value)


def test_an_exports_yaml_given_as_the_plan_is_named(tmp_path):
    """(A `coplan export --format yaml` file given as the plan was "it looks like a problem file
    (YAML): were the problem and the plan swapped?".)"""
    (tmp_path / "events.yaml").write_text("events:\n- {arm: left, fruit: f1, kind: pick, t_start: 0.1, t_end: 0.6}\n")
    (tmp_path / "left.yaml").write_text("header: {stamp: {sec: 0, nanosec: 0}, frame_id: ''}\njoint_names: [left_joint1, left_joint2]\npoints: []\n")
    for name, words in (("events.yaml", "found an export's events of a `coplan export --format yaml`"),
                        ("left.yaml", "found a JointTrajectory (one arm of a `coplan export --format yaml`)")):
        with pytest.raises(PlanFileError) as e:
            load_plan(tmp_path / name)
        assert words in str(e.value) and "swapped" not in str(e.value), str(e.value)


def test_every_shipped_problem_s_name_line_is_the_one_its_twin_is_found_by():
    """(The note on a recorded file bearing a shipped problem's name finds the shipped twin by its
    file's name line, not by loading every shipped problem: each must have one, and it must be
    the name the file loads with.)"""
    from coplan.problem.load import shipped_rows
    from coplan.problem.recorded import SHIPPED_NAME_LINE

    for path in list(PROBLEMS.glob("*.yaml")) + list(shipped_rows()):
        m = SHIPPED_NAME_LINE.search(Path(path).read_text(encoding="utf-8"))
        assert m is not None and m.group(1) == load_problem(path).name, path
