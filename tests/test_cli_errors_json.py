"""`--json` on any failure prints one JSON error document on stdout (solve, check, verify,
compare); flags take no value in --help; plurals; a closed stdout pipe is no error."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.errors import plural
from coplan.planners.heuristic import plan_heuristic
from coplan.kinds import ExitCode

BAD = """name: bad
arms:
  - {name: a, base: [0.0, 0.0], bin: [0.0, -0.5], links: [1.0, abc], link_radius: 0.04,
     joint_limits: [[-3.0, 3.0], [-3.0, 3.0]], max_velocity: [3.0, 4.0], max_acceleration: [8.0, 12.0],
     max_jerk: [80.0, 120.0], home: [1.0, 0.7]}
fruits:
  - {id: f1, position: [0.5, 1.2]}
task:
  pick_dwell: -0.3
  place_dwell: 0.2
  clearance: 0.05
"""
EXPECTED_ERRORS = [
    {"path": "arms[0].links[1]", "line": 3, "expected": "a number", "found": "string 'abc'"},
    {"path": "task.pick_dwell", "line": 9, "expected": "a number >= 0 in s", "found": "-0.3"},
]


def run(*args: str):
    return CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None}).invoke(app, list(args))


def coplan_cmd() -> list[str]:
    exe = Path(sys.executable).with_name("coplan")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "coplan.cli"]


def one_document(res) -> dict:
    doc = json.loads(res.stdout)  # the whole of stdout is one JSON document
    assert doc["format"] == "coplan.error/1" and doc["exit_code"] == res.exit_code
    return doc


@pytest.fixture
def bad_problem(tmp_path: Path) -> Path:
    p = tmp_path / "bad.yaml"
    p.write_text(BAD)
    return p


@pytest.fixture
def good_plan(tmp_path: Path, single_arm) -> Path:
    return plan_heuristic(single_arm).save(tmp_path / "plan")["json"]


@pytest.mark.parametrize("command", ["solve", "check", "verify", "compare"])
def test_bad_problem_with_json_prints_every_error_as_one_document(command, bad_problem, good_plan, tmp_path):
    args = {"solve": ["solve", str(bad_problem), "--out", str(tmp_path / "o")],
            "check": ["check", str(bad_problem)],
            "verify": ["verify", str(bad_problem), str(good_plan)],
            "compare": ["compare", str(bad_problem), "--out", str(tmp_path / "c"), "--no-figures"]}[command]
    res = run(*args, "--json")
    assert res.exit_code == ExitCode.BAD_INPUT
    doc = one_document(res)
    assert doc["command"] == command and doc["error"] == "bad_input"
    got = [{k: e[k] for k in ("path", "line", "expected", "found")} for e in doc["errors"]]
    assert got == EXPECTED_ERRORS
    assert all(e["file"] == str(bad_problem) for e in doc["errors"])


def test_bad_plan_file_with_json(single_arm, tmp_path):
    plan = tmp_path / "plan.json"
    plan.write_text('{"format": "coplan.plan/1",\n "t": [0, 0.01]\n oops')
    res = run("verify", str(single_arm.source), str(plan), "--json")
    assert res.exit_code == ExitCode.BAD_INPUT
    doc = one_document(res)
    (err,) = doc["errors"]
    assert err["file"] == str(plan) and err["line"] == 3 and err["expected"] == "JSON"
    assert err["found"].startswith("a syntax error")


@pytest.mark.parametrize("limit", ["-1", "inf"])
def test_usage_error_inside_a_command_with_json(single_arm, tmp_path, limit):
    res = run("solve", str(single_arm.source), "--time-limit", limit, "--out", str(tmp_path), "--json")
    assert res.exit_code == ExitCode.USAGE
    doc = one_document(res)
    assert doc["error"] == "usage" and "--time-limit" in doc["errors"][0]["message"]
    assert "--time-limit" in res.stderr  # the human message is still on stderr
    # the option and what was expected and found, as a problem file's issues give them
    err = doc["errors"][0]
    assert err["path"] == "--time-limit" and err["expected"].startswith("a positive, finite number of seconds")
    assert float(err["found"]) == float(limit)


def test_internal_error_with_json_is_a_document_not_a_traceback(single_arm, tmp_path, monkeypatch):
    import coplan.pipeline

    def broken(*a, **k):
        raise ZeroDivisionError("a bug")

    monkeypatch.setattr(coplan.pipeline, "solve", broken)
    res = run("solve", str(single_arm.source), "--planner", "heuristic", "--out", str(tmp_path), "--json")
    assert res.exit_code == ExitCode.INTERNAL
    doc = one_document(res)
    assert doc["error"] == "internal" and "ZeroDivisionError" in doc["message"]


def test_framework_usage_error_with_json_in_a_real_process(tmp_path):
    proc = subprocess.run(coplan_cmd() + ["solve", "--planner", "fastest", "--json", "--out", str(tmp_path / "o")],
                          capture_output=True, text=True, timeout=120)
    assert proc.returncode == ExitCode.USAGE
    doc = json.loads(proc.stdout)
    assert doc["exit_code"] == 2 and doc["command"] == "solve" and "--planner" in doc["message"]
    assert "Traceback" not in proc.stderr and not (tmp_path / "o").exists()
    (err,) = doc["errors"]  # the option, what it takes and what it was given (were all null)
    assert (err["path"], err["expected"], err["found"]) == ("--planner", "one of 'heuristic', 'coordinated', 'optimal'", "'fastest'")


def test_a_framework_usage_error_names_the_option_or_argument_it_is_about(tmp_path):
    """The JSON document of a usage error (the framework's: an option's bad value, an unknown
    option, a missing argument; or the command's own) names the option or argument in ``path``."""
    for argv, path, expected, found in (
            (["check", "sparse_row", "--resolution", "0", "--json"], "--resolution", "a number in [0.01, 0.5] m", "0"),
            (["solve", "single_arm", "--bogus", "3", "--json"], "--bogus", None, None),
            (["run", "--json"], "PROBLEM", None, None),
            # a command's own refusal, its value holding a colon (a file named a:b where the folder goes)
            (["solve", "single_arm", "--out", str(tmp_path / "a:b"), "--json"], "--out", "a folder", "a file")):
        (tmp_path / "a:b").write_text("mine")
        proc = subprocess.run(coplan_cmd() + argv, capture_output=True, text=True, timeout=120)
        assert proc.returncode == ExitCode.USAGE, (argv, proc.stderr)
        (err,) = json.loads(proc.stdout)["errors"]
        assert (err["path"], err["expected"], err["found"]) == (path, expected, found), (argv, err)


# ---- smaller things


@pytest.mark.parametrize("command", [[], ["solve"], ["verify"], ["check"], ["compare"], ["animate"]])
def test_flags_are_shown_without_a_value_in_help(command):
    res = run(*command, "--help")
    assert res.exit_code == 0
    assert "<bool>" not in res.stdout
    assert "--help" in res.stdout


def test_plural():
    assert [plural(n, "arm") for n in (0, 1, 2)] == ["0 arms", "1 arm", "2 arms"]
    assert plural(1, "fruit", "fruit") == "1 fruit"


def test_one_arm_is_not_one_arms(single_arm, tmp_path):
    res = run("check", str(single_arm.source))
    assert res.exit_code == 0
    assert "1 arm," in res.stdout and "0 of 1 arm locked" in res.stdout and "1 arms" not in res.stdout
    res = run("problems")
    line = next(x for x in res.stdout.splitlines() if x.startswith("single_arm.yaml"))
    assert " 1 arm, " in line
    plan = plan_heuristic(single_arm).save(tmp_path / "p")["json"]
    res = run("verify", str(single_arm.source), str(plan))
    assert "1 violations" not in res.stdout and "1 collision intervals" not in res.stdout


def _closed_pipe(args: list[str]) -> subprocess.CompletedProcess:
    """Run coplan with a stdout pipe whose reader is gone before coplan writes (``| head -c 0``)."""
    proc = subprocess.Popen(coplan_cmd() + args, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    proc.stdout.close()  # the reader exits at once: every write to stdout meets a broken pipe
    err = proc.stderr.read()
    proc.wait(timeout=300)
    return subprocess.CompletedProcess(args, proc.returncode, "", err)


def test_a_closed_pipe_keeps_the_commands_exit_code_and_prints_no_traceback(tmp_path, problems_dir, single_arm):
    p = _closed_pipe(["problems"])
    assert p.returncode == 0 and p.stderr == ""
    p = _closed_pipe(["solve", str(problems_dir / "single_arm.yaml"), "--planner", "coordinated", "--json",
                      "--out", str(tmp_path / "o")])
    assert p.returncode == 0, p.stderr
    assert "Traceback" not in p.stderr and "Broken pipe" not in p.stderr and "Exception ignored" not in p.stderr
    assert (tmp_path / "o" / "plan.json").exists()
    unsafe = plan_heuristic(single_arm).save(tmp_path / "h")["json"]  # the course's cubic: over the jerk limit
    for json_flag in ([], ["--json"]):  # Rich's console and typer's echo
        p = _closed_pipe(["verify", str(single_arm.source), str(unsafe), *json_flag])
        assert p.returncode == ExitCode.UNSAFE and p.stderr == ""


def test_a_closed_pipe_on_both_streams_still_writes_the_plan(tmp_path, problems_dir):
    """``coplan solve 2>&1 | head -1``: the progress lines on stderr meet the closed pipe too; the
    command still finishes its work, writes its files and exits with its own code."""
    out = tmp_path / "o"
    proc = subprocess.Popen(coplan_cmd() + ["solve", str(problems_dir / "greenhouse_row.yaml"), "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    proc.stdout.close()  # the reader of both streams is gone
    assert proc.wait(timeout=300) == 0
    assert (out / "plan.json").exists() and (out / "verification.json").exists()


def test_a_stream_closed_before_coplan_starts_is_no_error(tmp_path, problems_dir):
    """``coplan --version >&-``: Python starts with ``sys.stdout`` None (it died in a traceback,
    exit 120); the command's own exit code, its files written, either stream closed."""
    import os

    def closed(fd: int, args: list[str]) -> subprocess.CompletedProcess:
        keep = subprocess.PIPE
        return subprocess.run(coplan_cmd() + args, stdout=None if fd == 1 else keep, stderr=None if fd == 2 else keep,
                              text=True, timeout=300, preexec_fn=lambda: os.close(fd))

    p = closed(1, ["--version"])
    assert p.returncode == 0 and p.stderr == ""
    p = closed(1, ["solve", str(problems_dir / "single_arm.yaml"), "--planner", "coordinated", "--out", str(tmp_path / "o")])
    assert p.returncode == 0 and "Traceback" not in p.stderr and (tmp_path / "o" / "plan.json").exists()
    p = closed(2, ["solve", str(tmp_path / "no_such.yaml")])  # an error with its message's stream closed: its exit code
    assert p.returncode == ExitCode.BAD_INPUT and "Traceback" not in p.stdout


def test_verify_and_view_refuse_an_out_file_whose_folder_is_a_file_before_the_work(tmp_path):
    """``--out x/v.json`` where ``x`` is a file: said up front, with the path (it was found only
    after the work, as a bare "File exists")."""
    import coplan
    from coplan.problem import load_problem, shipped_problems

    res = coplan.solve(load_problem(next(p for p in shipped_problems() if p.stem == "single_arm")), planner="coordinated",
                       out_dir=tmp_path / "run")
    assert res.verification.passed
    blocker = tmp_path / "afile"
    blocker.write_text("")
    plan = str(tmp_path / "run" / "plan.json")
    for args in (["verify", "single_arm", plan, "--out", str(blocker / "v.json")],
                 ["view", plan, "--out", str(blocker / "x.html")]):
        r = CliRunner().invoke(app, args)
        assert r.exit_code == 2 and f"its folder {blocker}: expected a folder, found a file" in r.output, r.output
        assert "Traceback" not in r.output


@pytest.mark.parametrize("args, words", [
    (["plot", "PLAN", "--dpi", "5"], "--dpi': expected a number in [30, 600], found 5"),
    (["animate", "PLAN", "--fps", "0"], "--fps': expected a number in [1, 60], found 0"),
    (["feed", "single_arm", "--sigma", "5"], "--sigma': expected a number in [1e-06, 1] m, found 5"),
    (["feed", "single_arm", "--seed", "-3"], "--seed': expected a number >= 0, found -3"),
    (["run", "single_arm", "--false-burst", "-1"], "--false-burst': expected a number in [0, 1000], found -1"),
    (["sweep", "SWEEP", "--workers", "0"], "--workers: expected a whole number of processes from 1 to 256, or auto; found '0'"),
    (["solve", "sparse_row", "--workers", "2000"], "--workers: expected a whole number of processes from 1 to 256, or auto; found '2000'"),
])
def test_an_out_of_range_option_says_what_was_expected_and_what_was_found(args, words, tmp_path):
    plan = tmp_path / "plan.json"
    plan.write_text("{}")
    sweep = tmp_path / "sweep.yaml"
    sweep.write_text("{}")
    args = [str(plan) if a == "PLAN" else str(sweep) if a == "SWEEP" else a for a in args]
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, args)
    assert res.exit_code == 2 and words in res.output and "Traceback" not in res.output, res.output


@pytest.mark.parametrize("args, words", [
    (["--time-limit", "3", "--allocation", "makespan"], "--allocation, --time-limit are for a stationary cell"),
    (["--planner", "heuristic"], "--planner heuristic plans a cell, not a row's stops"),
])
def test_a_row_says_which_option_it_refuses_and_why(args, words, tmp_path):
    res = CliRunner(env={"COLUMNS": "300"}).invoke(app, ["solve", "sparse_row", "-o", str(tmp_path / "x"), *args])
    assert res.exit_code == 2 and words in res.output and not (tmp_path / "x").exists(), res.output


@pytest.mark.parametrize("args, path", [
    (["--time-limit", "3"], "--time-limit"),
    (["--time-limit", "3", "--allocation", "makespan"], "--allocation/--time-limit"),
    (["--planner", "heuristic"], "--planner"),
])
def test_a_row_s_refused_option_is_the_json_error_s_path(args, path, tmp_path):
    """(The message began with the file's name, and the JSON error's ``path`` was null.)"""
    res = CliRunner().invoke(app, ["solve", "sparse_row", "--json", "-o", str(tmp_path / "x"), *args])
    doc = json.loads(res.stdout)
    assert res.exit_code == 2 and doc["errors"][0]["path"] == path, res.output


@pytest.mark.parametrize("args, option, enum", [
    (["solve", "--planner", "fast"], "--planner", "PlannerKind"),
    (["solve", "--stops", "few"], "--stops", "StopRule"),
    (["solve", "--gantry", "moving"], "--gantry", "GantryMode"),
    (["verify", "p.yaml", "plan.json", "--fcl", "some"], "--fcl", "FclMode"),
    (["export", "plan.json", "--format", "xml"], "--format", "ExportFormat"),
    (["run", "p.yaml", "--gantry", "auto"], "--gantry", "LiveGantryMode"),
    (["sweep", "s.yaml", "--planner", "fast"], "--planner", "PlannerKind"),
    (["schema", "bogus"], "schema", "SchemaKind"),
])
def test_a_choice_option_s_bad_value_is_said_in_coplan_s_words_with_every_choice(args, option, enum):
    """(``--planner fast`` said "Value error, 'fast' is not one of ...": the validator's words.)
    Every choice option refuses as the rest of coplan does -- expected one of ..., found ... --
    and its help lists the choices."""
    import coplan.kinds as kinds

    cls = getattr(kinds, enum)
    if args[0] == "schema":  # (an argument: its value comes right after the command)
        option = "schema"
    r = CliRunner(env={"COLUMNS": "300"}).invoke(app, args)
    out = " ".join(r.output.split())
    assert r.exit_code == 2 and "Value error" not in out
    assert f"expected one of {', '.join(repr(m.value) for m in cls)}; found {args[args.index(option) + 1]!r}" in out
    helped = CliRunner(env={"COLUMNS": "300"}).invoke(app, [args[0], "--help"]).output
    assert "|".join(m.value for m in cls) in helped


def test_a_name_the_output_stream_cannot_encode_is_escaped_not_an_internal_error(tmp_path, problems_dir):
    """(On Windows a redirected stdout is the ANSI code page, strict: a problem named in Chinese
    ended `coplan check` and a finished `coplan solve` with "internal error (UnicodeEncodeError)",
    exit 1, no summary. cp1252 stands in for it here.)"""
    import os
    import subprocess
    import sys

    text = (problems_dir / "single_arm.yaml").read_text().replace("name: single-arm", 'name: "温室 single"', 1)
    (tmp_path / "u.yaml").write_text(text, encoding="utf-8")
    env = dict(os.environ, PYTHONIOENCODING="cp1252")
    for cmd in (["check", str(tmp_path / "u.yaml")],
                ["solve", str(tmp_path / "u.yaml"), "--planner", "coordinated", "--out", str(tmp_path / "o")]):
        p = subprocess.run([sys.executable, "-m", "coplan.cli", *cmd], capture_output=True, env=env)
        assert p.returncode == 0, p.stderr.decode("cp1252", "replace")
        assert b"\\u6e29\\u5ba4 single" in p.stdout and b"Traceback" not in p.stderr
        # and --json stays valid JSON (the stream's escapes are not JSON's: "Invalid \escape")
        p = subprocess.run([sys.executable, "-m", "coplan.cli", *cmd, "--json"], capture_output=True, env=env)
        assert json.loads(p.stdout)["problem"] == "温室 single", p.stdout[:200]


def test_a_closed_pipe_on_windows_reads_as_one(monkeypatch):
    """(On Windows a write to a closed pipe raises EINVAL, not EPIPE: `coplan problems | head -1`
    exited 8, "Invalid argument".) Silenced there as a broken pipe is; elsewhere EINVAL is an error."""
    import errno
    import io

    from coplan.cli.console import PipeSafeStream

    class Closed(io.StringIO):
        def write(self, text):
            raise OSError(errno.EINVAL, "Invalid argument")

    monkeypatch.setattr(sys, "platform", "win32")
    s = PipeSafeStream(Closed())
    assert s.write("x\n") == 2 and s.broken
    monkeypatch.setattr(sys, "platform", "linux")
    with pytest.raises(OSError):
        PipeSafeStream(Closed()).write("x\n")


def test_a_rows_compare_refusing_its_planner_prints_the_error_document(tmp_path):
    """(`coplan compare ROW --planner heuristic --json` exited 2 with nothing on stdout.)"""
    r = subprocess.run([sys.executable, "-m", "coplan.cli", "compare", "sparse_row", "--planner", "heuristic", "--json",
                        "--out", str(tmp_path / "x")], capture_output=True, text=True)
    doc = json.loads(r.stdout)
    assert r.returncode == 2 and doc["format"] == "coplan.error/1" and doc["exit_code"] == 2
    assert "a row takes one cell planner" in doc["message"] and "error: --planner" in r.stderr


def test_a_name_with_an_emoji_code_is_printed_as_written(tmp_path, problems_dir):
    """(An arm named ":warning:" was printed as the sign, a problem "cp:apple:x" as cp🍎x, while
    the JSON kept the names.)"""
    text = (problems_dir / "crossing_paths.yaml").read_text()
    text = text.replace("name: crossing-paths", 'name: "cp:apple:x"', 1).replace("name: left,", 'name: ":warning:",', 1)
    (tmp_path / "e.yaml").write_text(text)
    r = subprocess.run([sys.executable, "-m", "coplan.cli", "solve", str(tmp_path / "e.yaml"), "--planner", "coordinated",
                        "--out", str(tmp_path / "o")], capture_output=True, text=True)
    assert r.returncode == 0 and "cp:apple:x -- planner coordinated" in r.stdout and ":warning:-right" in r.stdout, r.stdout
    assert "\N{WARNING SIGN}" not in r.stdout + r.stderr and "\N{RED APPLE}" not in r.stdout


def test_check_and_run_json_documents_carry_their_exit_code(tmp_path, problems_dir):
    """(`check --json` and `run --json` exited 4, 5 or 6 with nothing in the document to say so.)"""
    import yaml

    doc = yaml.safe_load((problems_dir / "single_arm.yaml").read_text())
    doc["fruits"] = [{"id": "far", "position": [9.0, 9.0]}]
    far = tmp_path / "far.yaml"
    far.write_text(yaml.safe_dump(doc))
    cases = [(["check", "greenhouse_row"], 0, "ok"), (["check", "sparse_row"], 0, "ok"), (["check", str(far)], 4, "infeasible"),
             (["run", "sparse_row", "--gantry", "stop-and-go", "--out", str(tmp_path / "r")], None, None)]
    for cmd, code, verdict in cases:
        r = subprocess.run([sys.executable, "-m", "coplan.cli", *cmd, "--json"], capture_output=True, text=True)
        doc = json.loads(r.stdout)
        assert doc["exit_code"] == r.returncode and doc["verdict"] in ("ok", "partial", "infeasible", "unsafe"), (cmd, doc)
        if code is not None:
            assert (r.returncode, doc["verdict"]) == (code, verdict), cmd
        else:
            assert doc["status"] in ("success", "partial")


@pytest.mark.parametrize("args, said", [
    (["solve", "--time-limit", "abc"], "--time-limit': expected a number, found 'abc'"),
    (["animate", "p.json", "--fps", "fast"], "--fps': expected a number, found 'fast'"),
    (["feed", "p.yaml", "--seed", "2.5"], "--seed': expected a whole number, found '2.5'"),
    (["sweep", "s.yaml", "--workers", "two"], "--workers: expected a whole number of processes from 1 to 256, or auto; found 'two'"),
    (["verify", "p.yaml", "p.json", "--tolerance", "100"], "--tolerance': expected a number in [0.1, 50] mm, found 100"),
])
def test_a_number_option_that_is_not_one_says_what_it_found(args, said):
    """Every number option names the value it could not read (typer's own said only "Input should
    be a valid number, unable to parse string as a number"), before any file is read."""
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, args)
    assert res.exit_code == ExitCode.USAGE
    assert said in " ".join(res.output.split()), res.output


def test_a_ctrl_c_as_the_command_line_is_read_with_json_prints_the_error_document(monkeypatch, capsys):
    """(A Ctrl-C or SIGTERM in the first quarter second -- typer answers one that lands before the
    command runs with exit 130 -- left stdout empty under ``--json``.) The document says it, with
    the exit code the command ends with; where the command ran, it says its own ending."""
    import typer

    from coplan.cli import failures

    mini = typer.Typer()

    def cut(value):
        raise KeyboardInterrupt

    @mini.command()
    def solve(name: str = typer.Argument("x", callback=cut), as_json: bool = typer.Option(False, "--json")):
        raise AssertionError("never reached")

    @mini.command()
    def other():
        pass

    monkeypatch.setattr(failures, "STARTED", [])
    monkeypatch.setattr(failures, "TERMINATED", [])
    monkeypatch.setattr(sys, "argv", ["coplan", "solve", "x", "--json"])
    assert failures.run_with_json_usage_errors(mini) == int(ExitCode.INTERRUPTED)
    doc = json.loads(capsys.readouterr().out)
    assert doc["format"] == "coplan.error/1" and doc["command"] == "solve" and doc["exit_code"] == 130
    assert doc["error"] == "interrupted" and "nothing was done" in doc["message"]
    monkeypatch.setattr(failures, "TERMINATED", [15])  # (a SIGTERM: 143, as the command exits)
    assert failures.run_with_json_usage_errors(mini) == int(ExitCode.TERMINATED)
    assert json.loads(capsys.readouterr().out)["exit_code"] == 143
