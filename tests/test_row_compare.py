"""``coplan compare ROW``: the stop rules and on the move side by side (coplan.report.rows)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from typer.testing import CliRunner

import coplan
from coplan.cli import app
from coplan.generate import gantry_row, to_yaml
from coplan.plan import load_plan
from coplan.problem import parse_problem
from coplan.report.rows import ON_THE_MOVE, compare_rows
from coplan.verify.verifier import verify

runner = CliRunner()


@pytest.fixture(scope="module")
def row():
    return parse_problem(to_yaml(gantry_row(length=8.0, density=2.0, seed=3)), "row.yaml")


def test_on_the_move_is_compared_beside_the_stop_rules_as_solve_plans_it(row, tmp_path):
    """The plan on the move in the comparison is the one ``coplan.solve(gantry="continuous")``
    makes (a cross-check of the two paths), its file passes the verifier, the stop-by-stop
    bound is not applied to it, and ``best`` names the plan with the most fruit per hour."""
    cmp = compare_rows(row, tmp_path / "c", rules=("fixed",))
    assert [(r["name"], r["mode"], r["rule"]) for r in cmp.rows] == [("fixed", "stop-and-go", "fixed"),
                                                                      (ON_THE_MOVE, "continuous", None)]
    fixed, moving = cmp.rows
    alone = coplan.solve(row, gantry="continuous").plan.metrics["row"]
    assert moving["row_time"] == alone["row_time"] and moving["speed"] == alone["mean_speed"] > 0
    assert moving["ratio_stop_and_go_bound"] is None and moving["ratio_any_plan_bound"] > 1.0
    # (plan.json's own figure too: it gave 1.065 on the move where compare.json and the summary gave none)
    assert alone["ratio_stop_and_go_bound"] is None and alone["ratio_any_plan_bound"] == moving["ratio_any_plan_bound"]
    assert load_plan(cmp.rows[1]["plan"]).metrics["row"]["ratio_stop_and_go_bound"] is None
    assert fixed["speed"] is None and 1.0 <= fixed["ratio_stop_and_go_bound"] <= fixed["ratio_any_plan_bound"]
    for r in cmp.rows:  # every plan written is one the verifier passes, read back from its file
        assert r["verified"] and r["share_harvested"] == 1.0 and verify(row, load_plan(r["plan"])).passed
    top, other = sorted(cmp.rows, key=lambda r: -r["fruit_per_hour"])
    best = json.loads((tmp_path / "c" / "compare.json").read_text())["best"]
    assert best["name"] == top["name"] and best["gain"] == pytest.approx(top["fruit_per_hour"] / other["fruit_per_hour"] - 1)
    md = (tmp_path / "c" / "compare.md").read_text()
    assert "| speed, m/s |" in md and f"Most fruit per hour: {top['name']} (" in md
    # the table's cells: fruit per hour in whole fruit (as the summaries give it); the plan on
    # the move follows no stop rule, so it has no stop count (it read 0 beside picks made at rest)
    line = {r["name"]: next(ln for ln in md.splitlines() if ln.startswith(f"| {r['name']} |")) for r in cmp.rows}
    assert f"| {fixed['fruit_per_hour']:.0f} |" in line["fixed"] and f"| {moving['fruit_per_hour']:.0f} |" in line[ON_THE_MOVE]
    assert moving["stops"] is None and line[ON_THE_MOVE].startswith(f"| {ON_THE_MOVE} | - |") and fixed["stops"] >= 1


def test_one_mode_alone_and_what_each_refuses(row, tmp_path, problems_dir):
    cmp = compare_rows(row, tmp_path / "s", rules=("fewest",), gantry="stop-and-go")
    assert [r["name"] for r in cmp.rows] == ["fewest"] and cmp.best == {"name": "fewest", "mode": "stop-and-go",
                                                                        "fruit_per_hour": cmp.rows[0]["fruit_per_hour"]}
    md = (tmp_path / "s" / "compare.md").read_text()
    assert "speed" not in md and md.startswith(f"# {row.name}: stop rules side by side (coordinated")
    cmp = compare_rows(row, tmp_path / "m", gantry="continuous")
    assert [r["name"] for r in cmp.rows] == [ON_THE_MOVE] and not (tmp_path / "m" / "fixed").exists()
    assert (tmp_path / "m" / "compare.md").read_text().startswith(f"# {row.name}: on the move (the speed searched)\n")
    assert "stop by stop" not in (tmp_path / "m" / "compare.md").read_text()
    assert cmp.rows[0]["profile"] == "density"  # (the speed search's default, as solve's)
    # the stop rules into the same folder: the plan on the move left there is named as an earlier
    # comparison's, in no report (it stayed, unsaid)
    again = compare_rows(row, tmp_path / "m", rules=("fewest",), gantry="stop-and-go")
    said = [n for n in again.notes if "earlier comparison" in n]
    assert len(said) == 1 and said[0].startswith(str(tmp_path / "m" / "continuous"))
    assert "earlier comparison" in (tmp_path / "m" / "compare.md").read_text()
    assert (tmp_path / "m" / "continuous" / "plan.json").exists()
    cmp = compare_rows(row, tmp_path / "a", gantry="continuous", profile="auto")
    kept = json.loads(Path(cmp.rows[0]["plan"]).read_text())["solver"]["row"]["profiles"]["kept"]
    assert cmp.rows[0]["profile"] == kept and cmp.rows[0]["verified"]
    with pytest.raises(ValueError, match="profile: the speed search's profile applies on the move"):
        compare_rows(row, tmp_path / "x", gantry="stop-and-go", profile="constant")
    with pytest.raises(ValueError, match="a stop rule applies to stop and go"):
        compare_rows(row, tmp_path / "x", rules=("fixed",), gantry="continuous")
    with pytest.raises(ValueError, match="the cell planners apply to stop and go"):
        compare_rows(row, tmp_path / "x", planner="optimal", gantry="continuous")
    for bad, said in (({"problem": "crossing_paths"}, "'crossing-paths' is a stationary cell"),
                      ({"problem": row, "rules": ("nope",)}, "stop rule: expected one of"),
                      ({"problem": row, "gantry": "both"}, "gantry mode: expected one of")):
        with pytest.raises(ValueError, match=said):
            compare_rows(out_dir=tmp_path / "never", **bad)
    assert not (tmp_path / "never").exists()  # (refused before the folder is made)
    f = tmp_path / "row.yaml"
    f.write_text(to_yaml(gantry_row(length=8.0, density=2.0, seed=3)))
    for args, said in ((["--gantry", "continuous", "--planner", "optimal"], "--planner optimal: on the move"),
                       (["--gantry", "auto", "--clearance-sweep"], "--gantry: a row's comparison of its modes"),
                       (["--gantry", "stop-and-go", "--profile", "constant"], "--profile constant: the speed search's profile applies on the move")):
        r = runner.invoke(app, ["compare", str(f), *args, "--out", str(tmp_path / "y")])
        assert r.exit_code == 2 and said in r.output, r.output
    r = runner.invoke(app, ["compare", str(problems_dir / "crossing_paths.yaml"), "--gantry", "auto", "--out", str(tmp_path / "z")])
    assert r.exit_code == 2 and "--gantry: crossing_paths.yaml is not a row" in r.output, r.output
    assert not (tmp_path / "y").exists() and not (tmp_path / "z").exists()


def test_an_interrupt_before_the_plan_on_the_move_keeps_the_stop_rules_report(row, tmp_path, monkeypatch):
    """(A Ctrl-C before the speed search had a plan went up through compare_rows with the
    finished stop rules' report unwritten.)"""
    import coplan.row.moving as moving

    def cut(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(moving, "plan_moving", cut)
    with pytest.raises(KeyboardInterrupt):
        compare_rows(row, tmp_path / "c", rules=("fixed",))
    doc = json.loads((tmp_path / "c" / "compare.json").read_text())
    assert [r["name"] for r in doc["rows"]] == ["fixed"] and doc["rows"][0]["verified"]
    assert doc["notes"] == ["interrupted while planning on the move, before it had a plan: this report covers 1 of 2 plans"]


def test_a_second_row_comparison_into_a_folder_keeps_the_first_report_as_previous(row, tmp_path):
    """As for cells: the earlier report moves to ``compare.previous.*``, noted, not replaced unseen."""
    out = tmp_path / "c"
    compare_rows(row, out, rules=("fewest",), gantry="stop-and-go")
    text = (out / "compare.json").read_text()
    cmp = compare_rows(row, out, rules=("fewest",), gantry="stop-and-go")
    assert (out / "compare.previous.json").read_text() == text
    assert (out / "compare.previous.md").is_file()
    assert any("compare.previous.json" in n for n in cmp.notes)
    assert json.loads((out / "compare.json").read_text())["notes"] == cmp.notes


def test_the_table_has_each_plan_s_first_motion_and_a_late_winner_says_so():
    """(A new user's optimal-cell-planner row won on fruit per hour with its first motion 35.5 s
    after planning began -- a wait fruit per hour leaves out, and the table had no column for it.)"""
    from coplan.report.rows import RowComparison, to_markdown

    def plan(name, fph, row_time, first):
        return {"name": name, "mode": "stop-and-go", "rule": name, "stops": 2, "row_time": row_time,
                "fruit_per_hour": fph, "share_harvested": 1.0, "ratio_any_plan_bound": None, "ratio_stop_and_go_bound": None,
                "speed": None, "planning_time": first, "first_motion_seconds": first, "kept_ahead": True,
                "verified": True, "status": "success"}

    late = RowComparison("row", rows=[plan("optimised", 2679.0, 47.0, 35.5), plan("fixed", 2620.0, 48.1, 0.04)])
    assert late.best_text() == ("most fruit per hour: optimised (2679 fruit/h); its first motion 35.5 s after planning "
                                "starts, which fruit per hour does not count")
    text = to_markdown(late)
    assert "| first motion, s |" in text and "| 35.50 |" in text and "| 0.04 |" in text
    quick = RowComparison("row", rows=[plan("optimised", 2679.0, 47.0, 0.4), plan("fixed", 2620.0, 48.1, 0.04)])
    assert quick.best_text() == "most fruit per hour: optimised (2679 fruit/h)"


def test_an_interrupted_comparison_names_the_report_it_wrote(row, tmp_path, monkeypatch):
    """(coplan compare ROW, interrupted, exited 130 with nothing on its output: the report of the
    plans finished so far was written, and nothing said where.)"""
    import coplan.row.moving as moving

    def cut(*args, **kwargs):
        raise KeyboardInterrupt

    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=8.0, density=2.0, seed=3)))
    monkeypatch.setattr(moving, "plan_moving", cut)
    r = CliRunner().invoke(app, ["compare", str(path), "--gantry", "continuous", "--out", str(tmp_path / "c")])
    assert r.exit_code == 130
    said = " ".join(r.output.split())
    assert f"interrupted: the report of what was planned so far is in {tmp_path / 'c' / 'compare.json'} and compare.md" in said
    assert json.loads((tmp_path / "c" / "compare.json").read_text())["notes"]


@pytest.mark.parametrize("case, code", [("nothing to harvest", 4), ("a fruit no candidate stop serves", 5)])
def test_compare_row_exits_as_solve_does_where_no_plan_harvests_it_all(tmp_path, case, code):
    """(A new user's trial: a row with no fruit, every plan infeasible, and a row where every plan
    left a fruit, each exited 0 "ok"; solve gives 4 and 5.) No best plan: the verdict says why."""
    if case == "nothing to harvest":
        d = gantry_row(length=4.0, n_arms=2, density=0.0, seed=1)
    else:  # one fruit where the arms reach it only from 36 mm of rail, between the 50 mm candidate stops
        d = gantry_row(length=10.0, n_arms=3, density=4.0, seed=2)
        d["fruits"][3]["position"] = [5.025, 1.7899]
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(d))
    res = CliRunner().invoke(app, ["compare", str(path), "--gantry", "stop-and-go", "-o", str(tmp_path / "c"), "--json"])
    assert res.exit_code == code, res.output
    doc = json.loads(res.output)
    assert doc["exit_code"] == code and doc["best"] is None
    assert CliRunner().invoke(app, ["solve", str(path), "-o", str(tmp_path / "s")]).exit_code == code


def test_compare_on_a_row_refuses_a_time_limit_or_options_naming_the_flag_given(tmp_path):
    """(It said "--time-limit/--options: ..." to a user who gave only --time-limit.)"""
    opts = tmp_path / "opts.yaml"
    opts.write_text("seed: 1\n")
    run = CliRunner(env={"COLUMNS": "300"}).invoke
    for flags, named in ((["--time-limit", "5"], "--time-limit: "), (["--options", str(opts)], "--options: "),
                         (["--time-limit", "5", "--options", str(opts)], "--time-limit/--options: ")):
        r = run(app, ["compare", "course_row", *flags, "--out", str(tmp_path / "c")])
        said = " ".join(r.output.split())
        assert r.exit_code == 2 and f"{named}course_row.yaml is a row" in said, said
        assert not (tmp_path / "c").exists()
