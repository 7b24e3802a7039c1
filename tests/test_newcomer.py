"""What a newcomer hit, each fixed: numbers in scientific notation, plans that find their own
problem file, one vocabulary for fruit (reachable / harvestable / left out), reach boundaries
told apart, a partial plan proven optimal for what can be harvested, a shipped problem by its
bare name, the user's usual file permissions, and the small words of the reports."""

from __future__ import annotations

import math

import json
import os
import stat
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

import coplan
from coplan.allocate.screen import reach_reason, screened
from coplan.cli import app
from coplan.errors import ProblemError
from coplan.plan import load_plan
from coplan.problem import load_problem, parse_problem, shipped_problems

SHIPPED = {p.stem: p for p in shipped_problems()}


def run(*args: str, cwd: Path | None = None):
    old = os.getcwd()
    try:
        if cwd is not None:
            os.chdir(cwd)
        return CliRunner(env={"COLUMNS": "200", "COPLAN_DEBUG": None}).invoke(app, list(args))
    finally:
        os.chdir(old)


def _text(name: str) -> str:
    return SHIPPED[name].read_text()


# --------------------------------------------------------------------------- YAML numbers
def test_numbers_in_scientific_notation_are_numbers():
    text = _text("greenhouse_row").replace("max_jerk: [80.0, 120.0]", "max_jerk: [8e1, 1.2E+2]")
    text = text.replace("pick_dwell: 0.3", "pick_dwell: 3e-1")
    assert "8e1" in text and "3e-1" in text
    prob = parse_problem(text)
    assert prob.arms[0].max_jerk == (80.0, 120.0) and prob.task.pick_dwell == pytest.approx(0.3)


def test_an_implausible_number_in_scientific_notation_meets_the_plausibility_bound():
    text = _text("greenhouse_row").replace("max_velocity: [3.0, 4.0]", "max_velocity: [1e308, 4.0]")
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "x.yaml")
    msg = str(e.value)
    assert "max_velocity[0]" in msg and "plausible range" in msg and "1e+308" in msg and "string" not in msg


def test_ids_that_look_like_numbers_stay_text():
    text = _text("single_arm")
    prob = parse_problem(text)
    fid = prob.fruits[0].id
    prob2 = parse_problem(text.replace(f"id: {fid}", "id: 1e3", 1))
    assert prob2.fruits[0].id == "1e3"


# --------------------------------------------------------------------------- the plan's problem file
def test_a_plan_finds_its_own_problem_file_and_refuses_one_changed_since(tmp_path):
    mine = tmp_path / "my_cell.yaml"
    mine.write_text(_text("greenhouse_row").replace("name: greenhouse-row", "name: my-cell"))
    out = tmp_path / "run"
    r = run("solve", str(mine), "--planner", "coordinated", "--out", str(out))
    assert r.exit_code == 0, r.output
    plan = load_plan(out / "plan.json")
    assert plan.problem_file == {"path": str(mine.resolve()), "sha256": load_problem(mine).digest}
    for kind in ("gantt", "workspace"):
        r = run("plot", str(out / "plan.json"), "--kind", kind, "--out", str(tmp_path / f"{kind}.png"))
        assert r.exit_code == 0, r.output
    r = run("view", str(out / "plan.json"), "--out", str(tmp_path / "v.html"))
    assert r.exit_code == 0 and (tmp_path / "v.html").stat().st_size > 1000
    mine.write_text(mine.read_text() + "\n# edited\n")
    r = run("plot", str(out / "plan.json"), "--kind", "gantt", "--out", str(tmp_path / "g2.png"))
    assert r.exit_code == 2 and "has changed since" in r.output and "--problem" in r.output
    mine.unlink()
    r = run("plot", str(out / "plan.json"), "--kind", "gantt", "--out", str(tmp_path / "g3.png"))
    assert r.exit_code == 2 and "which is gone" in r.output
    # gone, and named like a shipped problem of another text: not checked against that one in silence
    twin = tmp_path / "twin.yaml"
    twin.write_text(_text("greenhouse_row").replace("clearance: 0.05", "clearance: 0.06"))
    assert twin.read_text() != _text("greenhouse_row")
    r = run("solve", str(twin), "--planner", "coordinated", "--out", str(tmp_path / "tw"))
    assert r.exit_code == 0, r.output
    twin.unlink()
    for cmd in (["plot", str(tmp_path / "tw" / "plan.json"), "--kind", "gantt", "--out", str(tmp_path / "g4.png")],
                ["export", str(tmp_path / "tw" / "plan.json"), "-o", str(tmp_path / "e.csv")]):
        r = run(*cmd)
        said = " ".join(r.output.split())
        assert r.exit_code == 2 and "which is gone; the shipped problem 'greenhouse-row' is another text" in said, said


def test_a_shipped_problem_by_its_bare_name(tmp_path, monkeypatch):
    r = run("solve", "crossing_paths", "--planner", "coordinated", "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert r.exit_code == 0, r.output
    assert load_plan(tmp_path / "o" / "plan.json").problem == "crossing-paths"
    r = run("check", "dense_overlap.yaml", cwd=tmp_path)
    assert r.exit_code == 0 and "dense-overlap" in r.output
    (tmp_path / "crossing_paths").write_text("not a problem")  # a file of that name here wins
    r = run("check", "crossing_paths", cwd=tmp_path)
    assert r.exit_code == 3
    # a plan.csv names no problem: the viewer asks for it (it quoted a problem '' before)
    r = run("view", str(tmp_path / "o" / "plan.csv"), "--out", str(tmp_path / "v.html"))
    assert r.exit_code == 2 and "does not name its problem" in r.output and "''" not in r.output
    r = run("view", str(tmp_path / "o" / "plan.csv"), "--problem", "crossing_paths", "--out", str(tmp_path / "v.html"))
    assert r.exit_code == 0, r.output
    assert "says it is a plan of" not in r.output  # (a plan.csv names no problem: nothing to disagree with)
    # its picks and places are inferred, as `coplan verify` does: 4 fruit, 4 picks and 4 places
    assert "declares no picks or places: 8 inferred" in r.output
    # in Python, a bare name is the shipped problem, as on the command line (it was an error);
    # elsewhere, the error gives the shipped file, a row's too
    for name in ("crossing_paths", "sparse_row"):
        with pytest.raises(ProblemError, match=f"{name!r} is a shipped problem, its file is .*{name}.yaml"):
            load_problem(tmp_path / "nowhere" / name)
    (tmp_path / "empty").mkdir()
    monkeypatch.chdir(tmp_path / "empty")  # (tmp_path holds a file named crossing_paths: above)
    assert load_problem("crossing_paths") == load_problem(next(p for p in shipped_problems() if p.stem == "crossing_paths"))
    assert load_problem("sparse_row.yaml").source.endswith("sparse_row.yaml")
    assert coplan.solve("single_arm", planner="coordinated").plan.status.value == "success"
    # a file of the name here comes first (the user's own dense_overlap.yaml was passed over)
    own = next(p for p in shipped_problems() if p.stem == "crossing_paths").read_text().replace("name: crossing-paths", "name: mine")
    (tmp_path / "empty" / "dense_overlap.yaml").write_text(own)
    assert load_problem("dense_overlap").name == "mine"
    r = run("check", "dense_overlap")
    assert r.exit_code == 0 and "the file dense_overlap.yaml here" in r.output and "mine" in r.output, r.output
    # a shipped problem's name misspelt: did you mean (none for a name like no shipped one)
    r = run("check", "cours_row", cwd=tmp_path)
    assert r.exit_code == 3 and "did you mean the shipped problem 'course_row'?" in r.output, r.output
    r = run("check", "zebra", cwd=tmp_path)
    assert r.exit_code == 3 and "did you mean" not in r.output


# --------------------------------------------------------------------------- one vocabulary
def _partial_at_the_bound() -> str:
    """locked_arms with one fruit r4 harvests alone and one only the locked r1 reaches."""
    d = yaml.safe_load(_text("locked_arms"))
    d["fruits"] = [{"id": "p001", "position": [1.3549, 1.4612]}, {"id": "p005", "position": [-3.0, 0.5]}]
    return yaml.safe_dump(d)


def test_check_and_solve_count_fruit_with_the_same_words(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text(_partial_at_the_bound())
    r = run("check", str(f))
    assert "2 fruit: 2 reachable, 1 harvestable" in r.output
    assert "p005: only r1 reaches it and r1 cannot reach its bin" in r.output
    r = run("solve", str(f), "--out", str(tmp_path / "o"), "--json")
    doc = json.loads(r.output)
    m = doc["metrics"]
    assert (m["fruit"], m["reachable"], m["harvestable"], m["harvested"]) == (2, 2, 1, 1)
    assert m["fruit_ids"] == {"unreachable": [], "screened_out": ["p005"], "left_out": []}
    # the counts agree with the ids: a fruit only a locked arm reaches is reachable, not unreachable
    assert (m["unreachable"], m["screened_out"]) == (0, 1) and m["reachable"] + m["unreachable"] == m["fruit"]
    r = run("solve", str(f), "--out", str(tmp_path / "o2"))
    assert "1 harvested of 1 harvestable; of 2 fruit 1 screened out (p005)" in r.output


def test_a_partial_plan_at_the_bound_is_proven_optimal_for_what_can_be_harvested(tmp_path):
    f = tmp_path / "p.yaml"
    f.write_text(_partial_at_the_bound())
    r = run("solve", str(f), "--out", str(tmp_path / "o"))
    assert "status partial" in r.output
    assert "proven" in r.output and "for the 1 harvestable fruit" in r.output
    plan = load_plan(tmp_path / "o" / "plan.json")
    assert plan.metrics["optimality"] == "proven" and plan.solver["stopped_by"] == "proven_optimal"


def test_reach_boundaries_are_told_apart_and_name_reach_margin():
    prob = load_problem(SHIPPED["single_arm"])
    arm = prob.arms[0]
    bx, by = arm.base
    R, r, m = arm.reach, arm.inner_radius, prob.task.reach_margin
    on_outer = reach_reason(prob, (bx + R, by))
    just_in = reach_reason(prob, (bx + R - m / 2, by))
    beyond = reach_reason(prob, (bx + R + 0.2, by))
    assert "exactly on" in on_outer and "outer reach" in on_outer and "reach_margin" in on_outer
    assert "by less than task.reach_margin" in just_in and "outer" in just_in
    assert "beyond" in beyond and "exactly" not in beyond
    if r > 0:
        on_inner = reach_reason(prob, (bx + r, by))
        assert "exactly on" in on_inner and "inner reach" in on_inner and "reach_margin" in on_inner
        # just outside the folded arm's hole, by less than the margin: "outside", not "within", its inner reach
        near_inner = reach_reason(prob, (bx + r + m / 2, by))
        assert "outside its inner reach (|l1 - l2|, the arm folded)" in near_inner and "within" not in near_inner, near_inner
    assert "within its outer reach (l1 + l2)" in just_in
    # the screen's sentence for a fruit out of every arm's reach is this one
    d = yaml.safe_load(_text("single_arm"))
    d["fruits"] = [{"id": "edge", "position": [bx + R, by]}, {"id": "ok", "position": list(prob.fruits[0].position)}]
    moved = parse_problem(yaml.safe_dump(d))
    assert moved.fruits[0].position == (bx + R, by)
    assert screened(moved).reasons["edge"] == f"edge: out of every arm's reach: {on_outer}"


def test_one_arm_has_no_least_clearance_to_print(tmp_path):
    r = run("solve", "single_arm", "--planner", "coordinated", "--out", str(tmp_path / "o"), cwd=tmp_path)
    assert "least clearance - (no two arms can touch)" in r.output and "inf" not in r.output


def test_check_says_why_the_heuristic_can_be_below_the_bound():
    r = run("check", str(SHIPPED["locked_arms"]))
    line = next(x for x in r.output.splitlines() if x.startswith("heuristic baseline"))
    assert "unsafe" in line and "below the lower bound only because it breaks these limits" in line


def test_verify_explains_its_warnings(tmp_path):
    run("solve", str(SHIPPED["greenhouse_row"]), "--planner", "heuristic", "--out", str(tmp_path / "o"))
    r = run("verify", str(SHIPPED["greenhouse_row"]), str(tmp_path / "o" / "plan.json"))
    line = next((x for x in r.output.splitlines() if "warnings" in x), "")
    if "singular" in line:
        assert "singularity_threshold" in line and "do not fail the plan" in line


# --------------------------------------------------------------------------- files
def test_run_files_get_the_users_usual_permissions(tmp_path):
    old = os.umask(0o022)
    try:
        out = tmp_path / "o"
        r = run("solve", str(SHIPPED["single_arm"]), "--planner", "coordinated", "--out", str(out), "--animate")
        assert r.exit_code == 0, r.output
    finally:
        os.umask(old)
    assert stat.S_IMODE(out.stat().st_mode) == 0o755
    for f in out.iterdir():
        assert stat.S_IMODE(f.stat().st_mode) == 0o644, f.name
    assert (out / "plan.gif").exists()


# --------------------------------------------------------------------------- figures
def test_the_gantt_legend_shows_the_bars_colours():
    from matplotlib.colors import to_rgba

    from coplan.viz.plots import plot_gantt
    from coplan.viz.style import arm_colors
    from coplan.planners.coordinated import plan_coordinated

    prob = load_problem(SHIPPED["crossing_paths"])
    plan = plan_coordinated(prob).plan
    fig = plot_gantt(prob, {"coordinated": plan})
    legend = fig.legends[0]
    moving = next(h for h, t in zip(legend.legend_handles, legend.get_texts()) if t.get_text().startswith("moving"))
    first = arm_colors(prob)[prob.arms[0].name]
    assert np.allclose(moving.get_facecolor()[:3], to_rgba(first)[:3])
    bars = [p for p in fig.axes[0].patches if abs(p.get_alpha() or 1.0 - 0.35) < 1e-9 or p.get_alpha() == 0.35]
    assert any(np.allclose(b.get_facecolor()[:3], to_rgba(first)[:3]) for b in bars)


def test_the_workspace_plot_shows_locked_arms_and_the_fruit_they_leave():
    from coplan.viz.plots import plot_workspace

    prob = parse_problem(_partial_at_the_bound())
    fig = plot_workspace(prob)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    assert any("locked arm" in x for x in labels) and any("screened out" in x for x in labels)
    assert any(t.get_text() == "r1 (locked)" for t in fig.axes[0].texts)


def test_an_edited_copy_of_a_shipped_problem_here_is_named_when_the_shipped_one_is_read(tmp_path, monkeypatch):
    """(A newcomer edited the clone's problems/greenhouse_row.yaml, ran ``coplan check``, and
    the installed copy was read without a word.) The command says which file it reads and how
    to use the edited one; an unedited copy says nothing."""
    from coplan.problem.load import default_problem_path

    monkeypatch.chdir(tmp_path)
    (tmp_path / "problems").mkdir()
    shipped = default_problem_path()
    copy = tmp_path / "problems" / shipped.name
    copy.write_bytes(shipped.read_bytes())
    run = CliRunner(env={"COLUMNS": "300"})
    for args in ([], [shipped.stem], [shipped.name]):
        assert "differs from the shipped copy" not in run.invoke(app, ["check", *args]).output
    copy.write_text(shipped.read_text().replace("clearance: 0.05", "clearance: 0.07", 1))
    assert copy.read_text() != shipped.read_text()
    for args in ([], [shipped.stem], [shipped.name]):
        out = " ".join(run.invoke(app, ["check", *args]).output.split())
        assert f"note: problems/{shipped.name} here differs from the shipped copy this command reads ({shipped})" in out
    out = " ".join(run.invoke(app, ["check", f"problems/{shipped.name}"]).output.split())
    assert "differs" not in out  # its path given: that file is read
    # a shipped row lives in problems/rows/ (the note looked in problems/ alone)
    from coplan.problem import shipped_rows

    row = next(r for r in shipped_rows() if r.stem == "sparse_row")
    (tmp_path / "problems" / "rows").mkdir()
    (tmp_path / "problems" / "rows" / row.name).write_text(row.read_text().replace("clearance: 0.05", "clearance: 0.06", 1))
    out = " ".join(run.invoke(app, ["check", "sparse_row"]).output.split())
    assert f"note: problems/rows/{row.name} here differs from the shipped copy this command reads" in out


def test_a_fruit_on_an_arm_s_base_is_said_to_be_inside_that_arm_s_inner_reach():
    """(From a user's trial: a fruit at right's base, which misses left's outer reach by as much,
    0.21 m, was '2.000 m from left's base, beyond its outer reach'.) A tie goes to the nearer base."""
    d = yaml.safe_load(_text("crossing_paths"))
    for arm, x in zip(d["arms"], (-1.0, 1.0)):  # (2 m apart: the base of one is 0.21 m beyond the other's reach)
        arm["base"], arm["bin"] = [x, 0.0], [x, -0.5]
    d["fruits"] = [f for f in d["fruits"] if all(math.dist(f["position"], (x, 0.0)) > 0.3 for x in (-1.0, 1.0))]
    prob = parse_problem(yaml.safe_dump(d))
    right = max(prob.arms, key=lambda a: a.base[0])
    why = reach_reason(prob, right.base)
    assert why.startswith(f"0.000 m from {right.name}'s base, inside its inner reach"), why


def test_a_plan_no_shorter_than_the_coordinated_one_is_improved_by_0_not_minus_0_percent():
    """(A final makespan 5.9e-11 s longer than the coordinated plan's printed "improved by -0.0 %".)"""
    import io

    from rich.console import Console

    import coplan
    from coplan.cli.summary import print_summary

    res = coplan.solve("greenhouse_row")
    res.plan.metrics["improvement_over_coordinated"] = -5.9e-11 / res.plan.metrics["coordinated_makespan"]
    buf = io.StringIO()
    print_summary(Console(file=buf, width=250), res)
    assert "improved by 0.0 %" in buf.getvalue() and "-0.0" not in buf.getvalue(), buf.getvalue()
