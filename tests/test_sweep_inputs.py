"""A sweep user's mistakes and what the sweep then says (found by a new user's trial): options
given to the heuristic planner, an infinite time limit, the wrong kind of file, a folder named
like a problem file, a resumed grid's positions, a report's count beside bad inputs."""

from __future__ import annotations

import json
import textwrap
from pathlib import Path

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.errors import ProblemError
from coplan.kinds import ExitCode, RowStatus
from coplan.problem import parse_problem
from coplan.sweep.params import PARAMETERS
from coplan.sweep.report import sweep_report
from coplan.sweep.spec import SweepError, parse_sweep
from coplan.sweep.table import read_table, write_table

_RUN = CliRunner(env={"COLUMNS": "200"})


def _spec(body: str) -> str:
    return textwrap.dedent(body).lstrip()


def test_solver_options_with_only_the_heuristic_planner_are_refused_at_their_key():
    """coplan solve --planner heuristic --options F is a usage error; in a sweep file each option
    value solved the same heuristic plan again, as rows that looked like different designs."""
    text = _spec("""
        name: h
        base: row
        planner: heuristic
        fixed: {n_fruits: 4}
        vary:
          options.search_work: [10, 20, 30]
        """)
    with pytest.raises(SweepError) as e:
        parse_sweep(text, "h.yaml")
    msg = str(e.value)
    assert "h.yaml:6: vary.options.search_work: expected no solver options with planner heuristic" in msg
    top = text.replace("vary:\n  options.search_work: [10, 20, 30]\n", "options: {search_work: 10}\n")
    with pytest.raises(SweepError, match=r"options: expected no solver options with planner heuristic"):
        parse_sweep(top, "h.yaml")


def test_a_heuristic_row_beside_varied_options_is_solved_once_with_no_options():
    """Planners varied: the options apply to the optimal rows; the heuristic's row is one, and
    the table does not say it used options it never read (nor the coordinated planner's:
    search_work is the optimal planner's, test_sweep.test_a_sweep_of_two_planners_keeps_them_apart)."""
    sw = parse_sweep(_spec("""
        name: h
        base: row
        fixed: {n_fruits: 4}
        vary:
          planner: [heuristic, optimal]
          options.search_work: [10, 20]
        """))
    items = sw.items()
    heur = [it for it in items if it.planner == "heuristic"]
    assert len(items) == 3 and len(heur) == 1
    assert heur[0].options == {} and not any(k.startswith("options.") for k in heur[0].params)
    assert sorted(it.options["search_work"] for it in items if it.planner == "optimal") == [10, 20]


@pytest.mark.parametrize("args, words", [
    (["--time-limit", "inf"], "--time-limit: expected a positive, finite number of seconds (leave it out for the sweep "
                              "file's, or 120 s), found inf"),
    (["--planner", "heuristic"], "--planner: the heuristic planner has no solver options"),
])
def test_the_sweep_command_refuses_before_any_work(args, words, tmp_path):
    spec = tmp_path / "s.yaml"
    spec.write_text(_spec("""
        name: s
        base: row
        planner: coordinated
        options: {search_work: 100}
        fixed: {n_arms: 2, n_fruits: 4}
        """))
    r = _RUN.invoke(app, ["sweep", str(spec), "--out", str(tmp_path / "o"), *args])
    assert r.exit_code == ExitCode.USAGE, r.output
    assert words in r.output
    assert not (tmp_path / "o").exists()


def test_a_sweep_file_given_as_a_problem_and_a_plan_given_as_a_sweep_are_named():
    sweep_text = _spec("""
        name: s
        base: row
        fixed: {n_arms: 2}
        vary:
          spacing: [1.4, 1.8]
        """)
    with pytest.raises(ProblemError) as e:
        parse_problem(sweep_text, "s.yaml")
    assert "expected a problem file (keys name, arms, fruits, task), found a sweep file" in str(e.value)
    assert "coplan sweep FILE" in str(e.value) and len(e.value.issues) == 1
    plan = json.dumps({"format": "coplan.plan/1", "problem": "x", "arms": [], "t": []})
    with pytest.raises(SweepError) as e:
        parse_sweep(plan, "plan.json")
    assert "expected a sweep file (keys base, vary, planner, ...), found a coplan plan file" in str(e.value)
    assert "swapped" in str(e.value) and len(e.value.issues) == 1


def test_a_folder_named_like_a_problem_file_among_the_matches_is_said(tmp_path):
    (tmp_path / "bad.yaml").mkdir()
    (tmp_path / "good.yaml").write_text("x")
    with pytest.raises(SweepError, match=r"expected problem files, found a folder named like one among them: .*bad\.yaml"):
        parse_sweep("name: f\nbase: files\nproblems: '*.yaml'\n", "f.yaml", here=tmp_path)


def _row(key: str, index: int, status: str, **kw) -> dict:
    return {"key": key, "sweep": "s", "index": index, "status": status, **kw}


def test_a_resumed_grid_s_rows_take_their_places_in_it(tmp_path):
    """Two rows done by a run over spacing [1.4, 1.8] (positions 0, 1), then the grid grown to
    [1.4, 1.6, 1.8, 2.2]: the table's index is each row's place in the grid now run (it was
    0, 1, 1, 3: the old rows kept the smaller grid's)."""
    rows = [_row("a", 0, "success", spacing=1.4), _row("c", 1, "success", spacing=1.8),
            _row("b", 1, "success", spacing=1.6), _row("d", 3, "success", spacing=2.2)]
    write_table(tmp_path, rows, positions={"a": 0, "b": 1, "c": 2, "d": 3})
    got = read_table(tmp_path).to_pylist()
    assert [(r["index"], r["key"]) for r in got] == [(0, "a"), (1, "b"), (2, "c"), (3, "d")]


def test_the_report_s_success_rate_says_the_bad_inputs_it_does_not_count(tmp_path):
    rows = [_row("a", 0, RowStatus.SUCCESS.value, reachable=4, harvested=4, n_fruits=4, makespan=5.0, verified=True),
            *(_row(k, i, RowStatus.BAD_INPUT.value, message="x.yaml:1: arms: expected a list") for i, k in enumerate("bcd", 1))]
    write_table(tmp_path, rows)
    rep = sweep_report(tmp_path, tmp_path / "rep", figures=False)
    assert (tmp_path / "rep" / "report.md").read_text() == rep.text
    assert "success among problems with reachable fruit: 1/1 (100.0 %) (not counted: 3 bad inputs, no problem to solve)" in rep.text


def test_bin_offset_is_documented_as_the_signed_height_it_is():
    """A sweep's bin_offset of 0.5 put the bins 0.5 m *above* the bases, among the fruit, while
    the guide said 'below': the value is the generators' signed height (default -0.5)."""
    from coplan.generate import row_problem

    assert "signed" in PARAMETERS["bin_offset"][2]
    d = row_problem(2, 4, seed=0, bin_offset=-0.4)
    assert all(a["bin"][1] == pytest.approx(a["base"][1] - 0.4) for a in d["arms"])
    guide = (Path(__file__).resolve().parents[1] / "docs" / "usage.md").read_text()
    line = next(x for x in guide.splitlines() if x.startswith("| `bin_offset`"))
    assert "signed" in line and "below the base, m |" not in line


def test_a_row_s_columns_compare_no_planner_with_itself_and_an_empty_file_is_not_a_generator_s(tmp_path):
    """Regression (a new-user trial): in a row sweep "median coordinated / plan makespan" read
    1.000 -- each coordinated row against itself, the optimal rows having none -- and a problem
    file with no fruit was said to have had "its generator" draw none."""
    from coplan import solve
    from coplan.generate import gantry_row, to_yaml
    from coplan.sweep.columns import result_columns, why_not

    doc = gantry_row(length=2.0, n_arms=2, density=2.0, seed=1)
    row = tmp_path / "row.yaml"
    row.write_text(to_yaml(doc))
    res = solve(str(row), planner="coordinated")
    cols = result_columns(res, {"planner": "coordinated", "row_length": 2.0})
    assert cols["makespan"] and cols["coordinated_makespan"] is None and cols["heuristic_makespan"] is None
    doc["fruits"] = []
    empty = tmp_path / "empty.yaml"
    empty.write_text(to_yaml(doc))
    said = why_not(solve(str(empty), planner="coordinated"))
    assert "its file lists none" in said and "generator" not in said


def test_a_sweep_names_the_arms_its_screen_locks(tmp_path):
    """Regression (a new-user trial): two of three arms locked by their spacing was a success
    with an empty message and no column saying so; only coplan check named them."""
    from coplan import solve
    from coplan.generate import gantry_row, to_yaml
    from coplan.sweep.columns import result_columns
    from coplan.sweep.report import _text, summarise
    from coplan.sweep.table import normalise

    doc = gantry_row(length=1.0, n_arms=3, density=1.0, seed=1)
    for arm, x in zip(doc["arms"], (-0.3, 0.0, 0.3)):
        arm["base"], arm["bin"] = [x, 0.0], [x, -0.5]
    path = tmp_path / "locked.yaml"
    path.write_text(to_yaml(doc))
    res = solve(str(path), planner="coordinated")
    cols = result_columns(res, {"planner": "coordinated", "row_length": 1.0})
    names = [a["name"] for a in doc["arms"]]
    assert res.success and res.problem.fruits and cols["locked_arms"] == f"{names[0]}, {names[1]}"
    cell = solve("locked_arms", planner="coordinated")  # a cell: the screen's own list
    assert result_columns(cell, {"planner": "coordinated"})["locked_arms"] == ", ".join(cell.plan.solver["screen"]["locked"])
    rows = [normalise({**cols, "key": "k1", "name": "locked", "status": "success", "sweep": "s"}),
            normalise({**cols, "locked_arms": None, "key": "k2", "name": "free", "status": "success", "sweep": "s"})]
    text = _text(summarise(rows), "s")
    assert f"rows whose screen locks arms (they can never reach their bins: they harvest nothing): 1 -- locked (key k1): {names[0]}, {names[1]}" in text


def test_a_bad_base_hides_none_of_the_other_mistakes():
    """(`base: rows` was the only error said: the range, the bad arm counts and the unknown
    parameter came one at a time once it was mended.)"""
    text = 'base: rows\nvary:\n  spacing: {from: 1.2, to: 2.0, step: 0.3}\n  n_arms: [2, -1, "x"]\n  colour: [1]\n'
    with pytest.raises(SweepError) as e:
        parse_sweep(text, "s.yaml")
    assert [i.path for i in e.value.issues] == ["base", "vary.spacing", "vary.n_arms[1]", "vary.n_arms[2]", "vary.colour"]
    assert "did you mean 'row'?" in e.value.issues[0].message


def test_a_seed_no_generator_takes_and_a_key_that_is_no_string_are_said_where_they_are():
    """(A seed of 2**32 passed the file's check and failed row by row, exit 3 after solving; a
    parameter key `1:` was said at the line of `vary:`.)"""
    with pytest.raises(SweepError) as e:
        parse_sweep("base: row\nvary:\n  seed: [0, 4294967296]\n  1: [2, 3]\n", "s.yaml")
    said = {i.path: (i.line, i.message) for i in e.value.issues}
    assert said["vary.seed[1]"] == (3, "expected an integer >= 0 and <= 4294967295 (what a generator's seed may be), "
                                       "found number 4294967296")
    assert said["vary.1"][0] == 4
    assert parse_sweep("base: row\nvary:\n  seed: [0, 4294967295]\n", "s.yaml").vary["seed"] == [0, 4294967295]


def test_copies_of_a_problem_file_are_solved_once_and_said(tmp_path, problems_dir):
    """(A folder of four files, one a copy of another, made three rows and not a word.)"""
    import shutil

    for name in ("single_arm", "crossing_paths"):
        shutil.copy(problems_dir / f"{name}.yaml", tmp_path / f"{name}.yaml")
    shutil.copy(problems_dir / "single_arm.yaml", tmp_path / "single_arm_copy.yaml")
    r = _RUN.invoke(app, ["sweep", str(tmp_path), "--planner", "heuristic", "--workers", "1", "--out", str(tmp_path / "o")])
    assert r.exit_code == 0, r.output
    said = " ".join(r.output.split())
    assert "note: 1 of the 3 problem files give a problem another gives too" in said
    assert len(read_table(tmp_path / "o")) == 2


def test_an_optimal_solve_of_a_problem_with_no_fruit_says_so():
    """(It said "no arm reaches any fruit", which a sweep's row read as a layout fault.)"""
    import dataclasses

    import coplan

    empty = dataclasses.replace(coplan.load_problem("crossing_paths"), fruits=())
    res = coplan.solve(empty, planner="optimal")
    assert res.plan.solver["message"] == "nothing to plan: the problem has no fruit (every arm stays at home)"
