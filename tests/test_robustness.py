"""Issue-10 behaviour: plans from anywhere are judged, outputs are checked before solving,
JSON is strict, options are validated -- each checked through the CLI a user runs."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.planners.heuristic import plan_heuristic
from coplan.kinds import ExitCode, PlannerKind, PlanStatus
from coplan.plan import load_plan
from coplan.problem import load_problem


def run(*args: str):
    return CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None}).invoke(app, list(args))


@pytest.fixture(scope="module")
def single(problems_dir: Path):
    return load_problem(problems_dir / "single_arm.yaml")


def _external_plan(single, tmp_path: Path, **changes) -> Path:
    """A coplan plan rewritten as another tool would hand it over: its own planner name, its
    own (or no) status."""
    plan = plan_heuristic(single)
    paths = plan.save(tmp_path / "src")
    doc = json.loads(paths["json"].read_text())
    for k, v in changes.items():
        if v is None:
            doc.pop(k, None)
        else:
            doc[k] = v
    out = tmp_path / "external.json"
    out.write_text(json.dumps(doc))
    return out


@pytest.mark.parametrize("changes", [{"planner": "my-own-planner", "status": None},
                                     {"planner": "ros-moveit", "status": "success"},
                                     {"planner": None, "status": "whatever-it-claims"}],
                         ids=["no-status", "claims-success", "no-planner"])
def test_verify_judges_a_plan_from_any_planner(single, tmp_path: Path, problems_dir: Path, changes) -> None:
    path = _external_plan(single, tmp_path, **changes)
    plan = load_plan(path)
    assert plan.planner_name == (changes["planner"] or "external")
    assert plan.status in (PlanStatus.UNVERIFIED, PlanStatus.SUCCESS)
    res = run("verify", str(problems_dir / "single_arm.yaml"), str(path), "--out", str(tmp_path / "ver.json"))
    # the verifier's verdict, not the file's claim: the course's cubic splines break the jerk limit
    assert res.exit_code == int(ExitCode.UNSAFE), res.output
    assert "internal error" not in res.output and "expected one of" not in res.output


def test_coplan_planner_names_stay_kinds(single, tmp_path: Path) -> None:
    plan = load_plan(_external_plan(single, tmp_path))
    assert plan.planner is PlannerKind.HEURISTIC and plan.planner_name == "heuristic"


def test_verify_out_never_overwrites_the_plan(single, tmp_path: Path, problems_dir: Path) -> None:
    path = _external_plan(single, tmp_path)
    before = path.read_bytes()
    res = run("verify", str(problems_dir / "single_arm.yaml"), str(path), "--out", str(path))
    assert res.exit_code == int(ExitCode.USAGE), res.output
    assert "the plan being verified" in res.output
    assert path.read_bytes() == before


def test_verify_out_never_overwrites_another_plan_or_file(single, tmp_path: Path, problems_dir: Path) -> None:
    """--out naming a baseline.json (a plan) or any file that is not a verification report is
    refused before any work, the file untouched; an earlier report is replaced."""
    path = _external_plan(single, tmp_path)
    baseline = tmp_path / "baseline.json"
    baseline.write_bytes(path.read_bytes())
    other = tmp_path / "other.json"
    other.write_text('{"a": 1}')
    prob = str(problems_dir / "single_arm.yaml")
    for target, kind in ((baseline, "a coplan.plan file"), (other, "a file of another kind")):
        before = target.read_bytes()
        res = run("verify", prob, str(path), "--out", str(target))
        assert res.exit_code == int(ExitCode.USAGE), res.output
        assert kind in res.output and "would be overwritten" in res.output
        assert target.read_bytes() == before
    report = tmp_path / "ver.json"
    for _ in range(2):  # written, then replaced
        res = run("verify", prob, str(path), "--out", str(report))
        assert res.exit_code == int(ExitCode.UNSAFE), res.output
    assert json.loads(report.read_text())["format"].startswith("coplan.verification/")


def test_verify_out_naming_a_file_not_ending_json_is_refused_before_any_work(single, tmp_path: Path, problems_dir: Path) -> None:
    """The report is a .json file or goes into a folder: an existing file without that ending
    (``afile``, ``notes.txt``) is neither -- exit 2 saying so, the file untouched (it said
    "expected a folder" of ``afile``, and ``notes.txt`` failed only at the write, exit 8)."""
    path = _external_plan(single, tmp_path)
    prob = str(problems_dir / "single_arm.yaml")
    for name, said in (("afile", "without an ending"), ("notes.txt", "ending .txt")):
        target = tmp_path / name
        target.write_text("mine")
        res = run("verify", prob, str(path), "--out", str(target))
        assert res.exit_code == int(ExitCode.USAGE), res.output
        assert "expected a folder or a file name ending .json" in res.output and said in res.output
        assert target.read_text() == "mine"
    # a new name with another ending is neither either (it made a folder report.txt/ holding verification.json)
    res = run("verify", prob, str(path), "--out", str(tmp_path / "report.txt"))
    assert res.exit_code == int(ExitCode.USAGE) and "found a new name ending .txt" in res.output, res.output
    assert not (tmp_path / "report.txt").exists()


def test_options_the_coordinated_planner_does_not_take_are_named_not_silently_dropped(tmp_path: Path, problems_dir: Path) -> None:
    """``--planner coordinated --options`` with an optimal-only field (search_work): a note names
    it and what the coordinated planner takes; with only those (margin), no note."""
    from dataclasses import fields

    from coplan.optimal import OptimalOptions
    from coplan.planners.coordinated.planner import CoordinatedOptions
    from coplan.planners.optimal.options import COORDINATED_FIELDS

    assert set(COORDINATED_FIELDS) <= {f.name for f in fields(OptimalOptions)}
    assert set(COORDINATED_FIELDS.values()) <= {f.name for f in fields(CoordinatedOptions)}
    prob = str(problems_dir / "crossing_paths.yaml")
    for body, noted in (("search_work: 100\nmargin: 0.02\n", True), ("margin: 0.02\n", False)):
        opts = tmp_path / "opts.yaml"
        opts.write_text(body)
        res = run("solve", prob, "--planner", "coordinated", "--options", str(opts), "--out", str(tmp_path / "o"))
        assert res.exit_code == int(ExitCode.OK), res.output
        assert ("search_work applies to the optimal planner only" in res.output) is noted, res.output


def test_version() -> None:
    from importlib.metadata import version

    res = run("--version")
    assert res.exit_code == 0 and res.output.strip() == f"coplan {version('coplan')}"


def test_json_stdout_and_plan_file_are_strict_json(tmp_path: Path, problems_dir: Path) -> None:
    """A single arm has no neighbour: its least clearance is infinite, printed as null."""
    res = run("solve", str(problems_dir / "single_arm.yaml"), "--planner", "coordinated", "--json", "--out", str(tmp_path))
    assert res.exit_code == 0, res.output

    def refuse(token):
        raise AssertionError(f"non-standard JSON token {token}")

    doc = json.loads(res.output, parse_constant=refuse)
    assert doc["verification"]["min_clearance"] is None
    json.loads((tmp_path / "plan.json").read_text(), parse_constant=refuse)


@pytest.mark.parametrize("limit", ["0", "-1", "nan", "inf"])
def test_time_limit_must_be_positive(tmp_path: Path, problems_dir: Path, limit: str) -> None:
    for cmd in ("solve", "compare"):
        res = run(cmd, str(problems_dir / "single_arm.yaml"), "--time-limit", limit, "--out", str(tmp_path / cmd))
        assert res.exit_code == int(ExitCode.USAGE), res.output
        assert "--time-limit: expected a positive, finite number of seconds" in res.output
        assert not (tmp_path / cmd).exists()  # refused before any work


def test_out_is_checked_before_solving(tmp_path: Path, problems_dir: Path) -> None:
    a_file = tmp_path / "taken"
    a_file.write_text("mine")
    for out, fragment in ((a_file, "expected a folder, found a file"),
                          (a_file / "sub", f"found the file {a_file} in its path")):
        res = run("solve", str(problems_dir / "single_arm.yaml"), "--out", str(out))
        assert res.exit_code == int(ExitCode.USAGE), res.output
        assert fragment in res.output
    assert a_file.read_text() == "mine"
    # a missing parent is simply created
    res = run("solve", str(problems_dir / "single_arm.yaml"), "--planner", "coordinated", "--out", str(tmp_path / "a" / "b"))
    assert res.exit_code == 0 and (tmp_path / "a" / "b" / "plan.json").exists()


def test_unwritable_out_is_refused(tmp_path: Path, problems_dir: Path, monkeypatch) -> None:
    """(This machine runs tests as root, who may write anywhere: the permission answer is
    simulated where the CLI asks for it.)"""
    import coplan.cli.commands

    locked = tmp_path / "locked"
    locked.mkdir()
    monkeypatch.setattr(coplan.cli.commands.os, "access", lambda path, mode: Path(path) != locked)
    res = run("solve", str(problems_dir / "single_arm.yaml"), "--out", str(locked / "run"))
    assert res.exit_code == int(ExitCode.USAGE), res.output
    assert f"found that {locked} is not writable" in res.output
    assert not (locked / "run").exists()


def test_names_with_markup_and_escape_sequences_are_printed_safely(tmp_path: Path, problems_dir: Path) -> None:
    """Strings from a problem file are untrusted: Rich markup in them is shown as written (no
    crash), and an escape sequence never reaches the terminal."""
    text = (problems_dir / "crossing_paths.yaml").read_text()
    import yaml

    doc = yaml.safe_load(text)
    doc["name"] = "row [/] [bold]x\x1b[31m"
    doc["arms"][0]["name"] = "a[/]\x1b]0;PWNED\x07"  # (the screen's lines printed arm names raw: a window title set)
    doc["arms"][1]["name"] = "c\x1b[31mred\nline"
    doc["fruits"][0]["id"] = "f[red]1\x1b[2J"
    bad = tmp_path / "hostile.yaml"
    bad.write_text(yaml.safe_dump(doc, allow_unicode=True))
    for args in (("solve", str(bad), "--planner", "heuristic", "--out", str(tmp_path / "o")),
                 ("solve", str(bad), "--planner", "coordinated", "--out", str(tmp_path / "o2")),
                 ("check", str(bad)),
                 ("verify", str(bad), str(tmp_path / "o" / "plan.json")),
                 ("compare", str(bad), "-p", "heuristic", "--no-figures", "--out", str(tmp_path / "c"))):
        res = run(*args)
        assert "internal error" not in res.output and res.exception is None or isinstance(res.exception, SystemExit), res.output
        assert res.exit_code in (0, int(ExitCode.PARTIAL), int(ExitCode.UNSAFE)), (args, res.output)
        assert "\x1b" not in res.output and "\x07" not in res.output and "red\nline" not in res.output, args
        if args[0] in ("solve", "check", "verify"):
            assert "row [/] [bold]x" in res.output, res.output


def test_sigterm_saves_the_incumbent_and_exits_143(tmp_path: Path, problems_dir: Path) -> None:
    """A job scheduler stops coplan with SIGTERM: handled like Ctrl-C (the verified incumbent is
    saved), exit code 143. Sent once the first incumbent is announced, in a real process."""
    import signal
    import subprocess
    import sys

    exe = Path(sys.executable).with_name("coplan")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "coplan.cli"]
    proc = subprocess.Popen(cmd + ["solve", str(problems_dir / "dense_overlap.yaml"), "--out", str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        for line in proc.stderr:
            if line.startswith("incumbent"):
                proc.send_signal(signal.SIGTERM)
                break
        out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    assert proc.returncode == int(ExitCode.TERMINATED), out + err
    assert "Traceback" not in err and "terminated (SIGTERM): stopping; what is finished is kept (a solve its best plan" in err
    plan = load_plan(tmp_path / "plan.json")
    assert plan.status == PlanStatus.INTERRUPTED and plan.metrics["harvested"] == 15
    assert json.loads((tmp_path / "verification.json").read_text())["summary"]["passed"] is True


def test_sigterm_with_json_says_143_in_the_document_as_the_command_exits(tmp_path: Path) -> None:
    """(After a SIGTERM, ``coplan solve --json`` exited 143 and its document said ``"exit_code": 130``:
    a scheduler's script reading the document read another code than the process's.)"""
    import signal
    import subprocess
    import sys
    import time

    exe = Path(sys.executable).with_name("coplan")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "coplan.cli"]
    # (by its shipped name: the command says which file that is, once it runs with its handlers set)
    proc = subprocess.Popen(cmd + ["solve", "dense_overlap", "--json", "--out", str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        assert "the shipped problem" in proc.stderr.readline()
        time.sleep(3.0)  # (well inside its solve: about 100 s)
        proc.send_signal(signal.SIGTERM)
        out, err = proc.communicate(timeout=300)
    finally:
        if proc.poll() is None:
            proc.kill()
    doc = json.loads(out)  # (the solve's document, or the error document where no plan was verified yet: a slow machine)
    assert proc.returncode == int(ExitCode.TERMINATED) == doc["exit_code"], (out, err)
    assert doc.get("status") == "interrupted" or doc.get("error") == "terminated", doc


@pytest.mark.skipif(not hasattr(__import__("os"), "fork"), reason="needs fork")
def test_sigterm_to_the_process_group_is_announced_once(tmp_path: Path) -> None:
    """A service manager's SIGTERM reaches coplan's worker processes too (the process group):
    forked from the command, they inherit its handler and each printed 'terminated (SIGTERM)'.
    A forked child stops quietly; the command says it once and exits 143."""
    import subprocess
    import sys

    script = tmp_path / "term.py"
    script.write_text(
        "import os, signal, time\n"
        "from rich.console import Console\n"
        "from coplan.cli.console import run_console\n"
        "def app():\n"
        "    pid = os.fork()\n"
        "    if pid == 0:  # a worker: SIGTERM, as the process group's\n"
        "        try:\n"
        "            os.kill(os.getpid(), signal.SIGTERM)\n"
        "            time.sleep(10)\n"
        "        except KeyboardInterrupt:\n"
        "            os._exit(7)\n"
        "        os._exit(1)\n"
        "    assert os.waitstatus_to_exitcode(os.waitpid(pid, 0)[1]) == 7\n"
        "    os.kill(os.getpid(), signal.SIGTERM)\n"
        "    time.sleep(10)\n"
        "run_console(app, Console(stderr=True))\n")
    proc = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, timeout=60)
    assert proc.returncode == int(ExitCode.TERMINATED), proc.stderr
    assert proc.stderr.count("terminated (SIGTERM)") == 1 and "Traceback" not in proc.stderr, proc.stderr


def test_summary_lists_every_file_written(tmp_path: Path, problems_dir: Path) -> None:
    res = run("solve", str(problems_dir / "single_arm.yaml"), "--planner", "coordinated", "--out", str(tmp_path))
    assert res.exit_code == 0, res.output
    written = {Path(line.split("wrote", 1)[1].strip()).name for line in res.output.splitlines() if line.strip().startswith("wrote")}
    from coplan.output import MARKER  # the hidden marker of a run folder is not a result file

    assert written == {p.name for p in tmp_path.iterdir() if p.name != MARKER} >= {"plan.json", "plan.csv", "plan.npz", "verification.json"}
    assert (tmp_path / MARKER).exists()


def test_a_time_limit_for_the_heuristic_alone_is_refused_by_compare_as_by_solve(tmp_path: Path, problems_dir: Path) -> None:
    """(``coplan compare --planner heuristic --time-limit 5`` ran and exited 0: the limit was ignored.)"""
    for cmd in (("solve", "--planner", "heuristic"), ("compare", "--planner", "heuristic")):
        res = run(*cmd, str(problems_dir / "single_arm.yaml"), "--time-limit", "5", "--out", str(tmp_path / cmd[0]))
        assert res.exit_code == int(ExitCode.USAGE) and "has no time limit" in res.output, res.output
        assert not (tmp_path / cmd[0]).exists()


@pytest.mark.parametrize("args", [["check", ""], ["solve", ""], ["verify", "", "plan.json"], ["plot", ""], ["view", ""],
                                  ["export", ""], ["run", ""], ["sweep", ""], ["compare", ""]])
def test_an_empty_file_argument_is_a_usage_error_not_the_current_folder(args) -> None:
    """(``coplan check ""`` -- an unset variable -- said "expected a YAML file, found a directory" of '.'.)"""
    res = run(*args)
    assert res.exit_code == int(ExitCode.USAGE) and "found an empty string" in " ".join(res.output.split()), (args, res.output)


def test_a_ctrl_c_while_the_command_loads_exits_130_without_a_traceback() -> None:
    """(A Ctrl-C in the first 0.3 s, while the commands were imported, printed Python's traceback
    of the import and the process died by the signal.)"""
    import subprocess
    import sys

    code = ("import builtins, sys\nreal = builtins.__import__\n"
            "def stopped(name, *a, **k):\n    if name == 'commands':\n        raise KeyboardInterrupt\n"
            "    return real(name, *a, **k)\nbuiltins.__import__ = stopped\nsys.argv = ['coplan', '--help']\n"
            "from coplan.cli import main\nmain()\n")
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert p.returncode == 130 and "Traceback" not in p.stderr, (p.returncode, p.stderr)


def _console_script(body: str) -> str:
    """A ``coplan``-like command (the console's handlers) whose one command runs ``body``."""
    return ("import time, weakref, typer\nfrom rich.console import Console\nfrom coplan.cli.console import run_console\n"
            "app = typer.Typer()\n@app.command()\ndef slow() -> None:\n"
            + "".join(f"    {ln}\n" for ln in body.splitlines())
            + "    print('finished')\nrun_console(app, Console(stderr=True))\n")


def test_a_ctrl_c_python_swallowed_still_interrupts() -> None:
    """(A Ctrl-C in the first second of ``coplan run``, while NumPy and SciPy load, now and then
    landed in a weakref callback -- printed as "Exception ignored" and dropped: the run went on,
    wrote its files and exited 0.) The command stops, exit 130, nothing printed of it."""
    import subprocess
    import sys

    body = "class A: pass\na = A()\ndef cb(ref): raise KeyboardInterrupt\nr = weakref.ref(a, cb)\ndel a\ntime.sleep(5)"
    p = subprocess.run([sys.executable, "-c", _console_script(body)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 130 and "finished" not in p.stdout and "Exception ignored" not in p.stderr, (p.returncode, p.stderr)
    # one swallowed just before a run's files are written waits for them (it cut a write short)
    body = ("from coplan.output import signals_deferred\nclass A: pass\na = A()\n"
            "def cb(ref): raise KeyboardInterrupt\nr = weakref.ref(a, cb)\ndel a\n"
            "with signals_deferred():\n    print('writing', flush=True)\n    time.sleep(0.3)\n    print('whole', flush=True)\n"
            "time.sleep(5)")
    p = subprocess.run([sys.executable, "-c", _console_script(body)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 130 and "whole" in p.stdout and "finished" not in p.stdout, (p.returncode, p.stdout, p.stderr)
    # one swallowed as the command ends, before it is sent again (the timer, left armed, killed
    # the process at exit: "Alarm clock", 142)
    body = "class A:\n    def __del__(self): raise KeyboardInterrupt\na = A()\ndel a"
    p = subprocess.run([sys.executable, "-c", _console_script(body)], capture_output=True, text=True, timeout=60)
    assert p.returncode == 130 and "Alarm" not in p.stderr, (p.returncode, p.stderr)


def test_an_import_error_after_a_ctrl_c_is_that_interruption(monkeypatch) -> None:
    """(A Ctrl-C landing in an extension's initialisation said "internal error (ImportError):
    initialization failed", exit 1.) With a Ctrl-C seen, it is the interruption, exit 130;
    without one, an internal error."""
    from coplan.cli import failures

    assert failures.failure_of(ImportError("initialization failed"))[0] == ExitCode.INTERNAL
    monkeypatch.setattr(failures, "INTERRUPTED", [2])
    assert failures.failure_of(ImportError("initialization failed")) == (ExitCode.INTERRUPTED, "interrupted by the user (Ctrl-C)")
    # a module missing after a Ctrl-C the planner absorbed is still what it is
    assert failures.failure_of(ModuleNotFoundError("No module named 'x'"))[0] == ExitCode.INTERNAL


def test_an_integer_option_out_of_range_is_shown_as_given():
    """(--false-burst 100000000 said 'found 1e+08'.)"""
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["run", "course_row", "--false-burst", "100000000"])
    assert res.exit_code == int(ExitCode.USAGE) and "found 100000000" in " ".join(res.output.split()), res.output


def test_check_of_a_large_cell_says_its_stages_and_a_small_one_stays_quiet(tmp_path, monkeypatch):
    """(coplan check of 1500 fruit ran a minute, 3000 two and a half, saying nothing.) From
    ``CHECK_STAGES_FROM`` fruit (500, about 20 s of checking) it says each stage; the mechanism is
    tested at 40 fruit with the threshold moved there (the 500-fruit check took 15 s of the suite)."""
    from coplan.cli import commands
    from coplan.generate import random_problem, to_yaml

    assert commands.CHECK_STAGES_FROM == 500
    big = tmp_path / "big.yaml"
    big.write_text(to_yaml(random_problem(3, n_arms=2, n_fruits=40)))
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["check", str(big)])
    assert res.exit_code in (0, 5) and "lower bound (MILP)" not in res.output, res.output  # below the threshold: quiet
    monkeypatch.setattr(commands, "CHECK_STAGES_FROM", 40)
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["check", str(big)])
    assert res.exit_code in (0, 5) and "lower bound (MILP)" in res.output and "verifying the baseline" in res.output, res.output
    res = CliRunner(env={"COLUMNS": "200"}).invoke(app, ["check", "crossing_paths"])
    assert res.exit_code in (0, 5) and "lower bound (MILP)" not in res.output, res.output


def _sigterm_is_default(_=None) -> bool:
    import signal

    return signal.getsignal(signal.SIGTERM) == signal.SIG_DFL


def test_worker_processes_end_quietly_on_sigterm(monkeypatch):
    """(A forked worker inherited the command line's SIGTERM handler, which raises
    KeyboardInterrupt: terminated once done, half the --workers 2 solves printed its traceback
    from multiprocessing's exit.)"""
    import signal

    from coplan.workers import process_pool

    def on_term(signum, frame):
        raise KeyboardInterrupt

    old = signal.signal(signal.SIGTERM, on_term)  # (as coplan.cli.console installs)
    try:
        with process_pool(2) as pool:
            assert all(pool.map(_sigterm_is_default, range(4)))
    finally:
        signal.signal(signal.SIGTERM, old)


def test_the_command_draws_whatever_mplbackend_the_shell_sets(tmp_path: Path) -> None:
    """(``MPLBACKEND=nonsense coplan plot ...`` was an internal error, exit 1: "Key backend:
    'nonsense' is not a valid value"; the CLI always draws with Agg.)"""
    import os
    import subprocess
    import sys

    import coplan

    coplan.solve("single_arm", planner="coordinated", out_dir=tmp_path / "run")
    exe = Path(sys.executable).with_name("coplan")
    cmd = [str(exe)] if exe.exists() else [sys.executable, "-m", "coplan.cli"]
    proc = subprocess.run(cmd + ["plot", str(tmp_path / "run" / "plan.json"), "--kind", "joints", "--out", str(tmp_path / "j.png")],
                          capture_output=True, text=True, env=dict(os.environ, MPLBACKEND="nonsense"), timeout=120)
    assert proc.returncode == 0 and (tmp_path / "j.png").read_bytes().startswith(b"\x89PNG"), proc.stderr
