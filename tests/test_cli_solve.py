"""``coplan solve`` and ``coplan problems`` end to end.

Most runs use typer's in-process runner (fast); two run the installed console script in a
subprocess to prove that bad input gives exit code 3 and no traceback for real. The
heuristic plan may legitimately be unsafe (its cubic segments have unbounded jerk, and on
crowded problems its arms collide), so exit codes are checked against the plan's status
through :class:`coplan.pipeline.ExitCode`, never assumed to be 0.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.pipeline import ExitCode, status_exit_code
from coplan.plan import EventKind, PlanStatus, load_plan
from coplan.problem import default_problem_path, shipped_problems

pytest.importorskip("coplan.verify", reason="coplan solve needs coplan.verify")

ROW = re.compile(r"^  (?P<src>\S+?):(?P<line>\d+): (?P<path>\S+): expected .+, found .+$", re.M)
DOCUMENTED = {int(c) for c in ExitCode}


def run(*args: str):
    return CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None}).invoke(app, list(args))


def coplan_exe() -> list[str]:
    exe = Path(sys.executable).with_name("coplan")
    return [str(exe)] if exe.exists() else [sys.executable, "-m", "coplan.cli"]


def bad_problem(tmp_path: Path) -> Path:
    text = default_problem_path().read_text().replace("link_radius: 0.04", "link_radius: -0.04")
    text = text.replace("id: f07", "id: f03")
    p = tmp_path / "bad.yaml"
    p.write_text(text)
    return p


# --------------------------------------------------------------------------- solve
def test_solve_default_problem_writes_a_plan_that_loads(tmp_path: Path) -> None:
    out = tmp_path / "out"
    res = run("solve", "--planner", "heuristic", "--out", str(out))
    assert res.exit_code in DOCUMENTED, res.output
    plan = load_plan(out / "plan.json")
    assert plan.problem == "greenhouse-row"
    assert plan.status not in (PlanStatus.UNVERIFIED, PlanStatus.INFEASIBLE)
    assert res.exit_code == int(status_exit_code(plan.status))
    assert res.exit_code in (ExitCode.OK, ExitCode.PARTIAL, ExitCode.UNSAFE)
    assert len(plan.events_of("right", EventKind.PICK)) == 5 and plan.unreachable == ["f01"]
    assert (out / "verification.json").is_file()
    # the summary names the essentials and where the files went (compared without
    # whitespace: rich wraps long lines at 80 columns when stdout is not a terminal)
    flat = "".join(res.stdout.split())
    for words in ("greenhouse-row", "fruit 11 harvested of 11 harvestable", "makespan", "cycle time/fruit", "collisions found", str(out / "plan.json")):
        assert "".join(words.split()) in flat, res.stdout
    assert "Traceback" not in res.output


def test_solve_json_prints_one_document(tmp_path: Path, problems_dir: Path) -> None:
    out = tmp_path / "a very long folder name to make sure nothing wraps the printed json document" / "out"
    res = run("solve", str(problems_dir / "single_arm.yaml"), "--planner", "heuristic", "--out", str(out), "--json")
    assert res.exit_code in DOCUMENTED
    doc = json.loads(res.stdout)  # exactly one JSON document, nothing else on stdout
    assert doc["problem"] == "single-arm" and doc["planner"] == "heuristic"
    assert doc["exit_code"] == res.exit_code == int(status_exit_code(PlanStatus(doc["status"])))
    assert doc["metrics"]["harvested"] == 1
    assert Path(doc["files"]["json"]) == out / "plan.json" and load_plan(doc["files"]["json"]).problem == "single-arm"


@pytest.mark.parametrize("name", ["dense_overlap.yaml", "five_arm_row.yaml"])
def test_solve_shipped_coordination_problems(tmp_path: Path, problems_dir: Path, name: str) -> None:
    res = run("solve", str(problems_dir / name), "--planner", "heuristic", "--out", str(tmp_path), "--json")
    doc = json.loads(res.stdout)
    assert res.exit_code == doc["exit_code"] in (ExitCode.OK, ExitCode.PARTIAL, ExitCode.UNSAFE)
    assert doc["metrics"]["harvested"] == doc["metrics"]["reachable"] == len(load_plan(tmp_path / "plan.json").events) // 2


def test_bad_problem_exits_3_with_key_paths(tmp_path: Path) -> None:
    bad = bad_problem(tmp_path)
    res = run("solve", str(bad), "--planner", "heuristic", "--out", str(tmp_path / "out"))
    assert res.exit_code == ExitCode.BAD_INPUT == 3
    rows = [m.groupdict() for m in ROW.finditer(res.output)]
    assert [(r["path"], r["src"]) for r in rows] == [("defaults.link_radius", str(bad)), ("fruits[6].id", str(bad))]
    assert "Traceback" not in res.output
    assert not (tmp_path / "out" / "plan.json").exists()


def test_bad_problem_in_a_real_process_has_no_traceback(tmp_path: Path) -> None:
    bad = bad_problem(tmp_path)
    env = {k: v for k, v in os.environ.items() if k != "COPLAN_DEBUG"} | {"COLUMNS": "200"}
    proc = subprocess.run(
        coplan_exe() + ["solve", str(bad), "--planner", "heuristic", "--out", str(tmp_path / "o")],
        capture_output=True, text=True, env=env, timeout=120,
    )
    assert proc.returncode == 3
    out = proc.stdout + proc.stderr
    assert "Traceback" not in out
    assert f"{bad}:{bad.read_text().splitlines().index('  link_radius: -0.04') + 1}: defaults.link_radius: expected a number > 0" in out


def test_missing_problem_file_exits_3(tmp_path: Path) -> None:
    res = run("solve", str(tmp_path / "absent.yaml"), "--planner", "heuristic", "--out", str(tmp_path / "o"))
    assert res.exit_code == ExitCode.BAD_INPUT
    assert f"{tmp_path / 'absent.yaml'}: <top>: expected an existing YAML file" in res.output
    assert "Traceback" not in res.output


def test_problem_that_is_a_directory_exits_3(tmp_path: Path) -> None:
    res = run("solve", str(tmp_path), "--planner", "heuristic", "--out", str(tmp_path / "o"))
    assert res.exit_code == ExitCode.BAD_INPUT and "found a directory" in res.output


# --------------------------------------------------------------------------- problems
def test_problems_lists_every_shipped_problem() -> None:
    res = run("problems")
    assert res.exit_code == 0
    names = [p.name for p in shipped_problems()]
    assert {"greenhouse_row.yaml", "single_arm.yaml", "dense_overlap.yaml", "five_arm_row.yaml"} <= set(names)
    for n in names:
        assert n in res.stdout
    assert re.search(r"greenhouse_row\.yaml\s+3 arms,\s+12 fruit", res.stdout)
    assert re.search(r"five_arm_row\.yaml\s+5 arms,\s+33 fruit", res.stdout)


def test_console_script_is_installed() -> None:
    proc = subprocess.run(coplan_exe() + ["--help"], capture_output=True, text=True, timeout=120)
    assert proc.returncode == 0 and "solve" in proc.stdout and "problems" in proc.stdout


def test_verifying_a_row_plan_against_another_row_says_so_first_and_counts_what_it_leaves(tmp_path: Path) -> None:
    """Two rows with the same arm names: the plan of one checked against the other is verified
    (nothing in its form forbids it), but the report says first that it is another problem's
    plan and lists ten of the fruit it leaves with the count of the rest, not hundreds of ids."""
    r = CliRunner().invoke(app, ["solve", "sparse_row", "--stops", "fixed", "-o", str(tmp_path / "s")])
    assert r.exit_code == 0, r.output
    r = CliRunner(env={"COLUMNS": "400"}).invoke(app, ["verify", "course_row", str(tmp_path / "s" / "plan.json")])
    head = r.output.splitlines()
    verdict = next(i for i, line in enumerate(head) if line.startswith("course-row -- "))
    assert "another problem" in head[verdict + 1] and "'sparse-row'" in head[verdict + 1]
    m = re.search(r"not harvested: (\d+) fruit: ((?:f\d+, ){9}f\d+) and (\d+) more\)", head[verdict])
    assert m and int(m.group(1)) == 10 + int(m.group(3)), head[verdict]


def test_a_failed_verdict_names_the_violations_that_fail_it_before_what_is_left(tmp_path: Path) -> None:
    """A plan whose pick names a fruit the problem does not have: the headline says FAILED with
    the violations by kind (what fails it), not only the fruit left (a warning)."""
    r = CliRunner().invoke(app, ["solve", "single_arm", "--planner", "coordinated", "-o", str(tmp_path / "s")])
    assert r.exit_code == 0, r.output
    doc = json.loads((tmp_path / "s" / "plan.json").read_text())
    for e in doc["events"]:
        e["fruit"] = "nope"
    (tmp_path / "bad.json").write_text(json.dumps(doc))
    r = CliRunner(env={"COLUMNS": "400"}).invoke(app, ["verify", "single_arm", str(tmp_path / "bad.json")])
    assert r.exit_code != 0
    head = next(line for line in r.output.splitlines() if line.startswith("single-arm -- "))
    assert "FAILED (" in head and "unknown_fruit" in head, head
    assert head.index("unknown_fruit") < head.index("not harvested"), head


def test_a_table_into_a_pipe_is_printed_whole():
    """(Into a pipe Rich sets 80 columns: the clearance sweep's headers were cut to 'makesp...'
    and numbers split across lines.) Not on a terminal, a table is printed as wide as it needs."""
    import io

    from rich.console import Console
    from rich.table import Table

    from coplan.cli.summary import print_table

    buf = io.StringIO()
    console = Console(file=buf, width=80, soft_wrap=True)
    assert not console.is_terminal
    table = Table(title="sweep")
    for head in ("extra, mm", "clearance, m", "makespan, s", "x problem's", "certified margin, mm", "harvested",
                 "verified", "planning, s"):
        table.add_column(head)
    table.add_row("+0", "0.050", "12.895", "1.000", "70.0", "4 / 4", "yes", "0.53")
    print_table(console, table)
    text = buf.getvalue()
    assert "certified margin, mm" in text and "12.895" in text and "…" not in text
    assert max(len(line) for line in text.splitlines()) > 80


def test_a_plan_that_harvests_more_than_the_screen_allows_says_so():
    """(The course's heuristic, which does not screen, read '10 harvested of 8 harvestable':
    two of its picks were a locked arm's, placed only by colliding.)"""
    from coplan.cli.summary import fruit_line

    assert "(2 more than the screen allows" in fruit_line({"harvested": 10, "harvestable": 8, "fruit": 10})
    assert "more than" not in fruit_line({"harvested": 8, "harvestable": 8, "fruit": 10})


def test_the_solve_summary_counts_the_verifier_s_warnings(tmp_path):
    """(The summary said nothing of them: greenhouse_row's coordinated plan passes near singular
    poses 12 times, which verification.json and --json counted and `coplan verify` listed.)"""
    res = run("solve", "greenhouse_row", "--planner", "coordinated", "--out", str(tmp_path))
    assert res.exit_code == 0, res.output
    doc = json.loads((tmp_path / "verification.json").read_text())
    n = doc["summary"]["warning_count"]
    kinds = {w["kind"] for w in doc["warnings"]}
    assert n > 0 and kinds == {"singular"}
    assert f"warnings          {n}, which do not fail the plan: {n} singular (" in res.output


def test_every_commands_help_reads_as_prose():
    """(``coplan compare --help`` showed ``--clearance-sweep`` with its RST quotes and broke its
    sentences mid-line: the help keeps the line breaks of a docstring's later paragraphs.)"""
    import inspect

    import typer.main

    from coplan.cli import app

    for name, cmd in typer.main.get_command(app).commands.items():
        doc = inspect.getdoc(cmd.callback) or ""
        assert "``" not in doc, name
        assert all("\n" not in p.strip() for p in doc.split("\n\n")), name  # (the first too: `coplan --help` lists it)


def test_the_summary_shows_a_slow_joints_jerk_not_zero():
    """(Joints limited to 0.05 rad/s^3 were summarised "jerk RMS / peak A 0 / 0".)"""
    from coplan.cli.summary import _jerk

    assert [_jerk(v) for v in (0.05, 0.1234, 41.26, 80.0, 1234.5, 0.0)] == ["0.05", "0.123", "41.3", "80", "1234", "0"]


def test_solve_takes_p_for_its_planner_as_compare_does(tmp_path):
    """(`coplan solve -p coordinated` said "No such option: -p", while `coplan compare -p` takes it.)"""
    short = CliRunner().invoke(app, ["solve", "crossing_paths", "-p", "heuristic", "-o", str(tmp_path / "a"), "--json"])
    long = CliRunner().invoke(app, ["solve", "crossing_paths", "--planner", "heuristic", "-o", str(tmp_path / "b"), "--json"])
    assert short.exit_code == long.exit_code and json.loads(short.stdout)["planner"] == "heuristic"
