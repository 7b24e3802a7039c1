"""A plan file's own figures (``metrics``) against its motion's, in every command that reads one
back: the verifier measures the makespan and the fruit harvested from the motion (a truncated
plan's events after its end do not count); plot titles and the viewer show the measured figures;
figures of the wrong type are refused when the file is read; a partial plan has no ratio to a
bound that counts the fruit it left out. (Each found by a new user's trial.)"""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

import coplan
from coplan.cli import app
from coplan.cli.figures import checked
from coplan.errors import PlanFileError
from coplan.plan import load_plan
from coplan.problem import load_problem, shipped_problems
from coplan.verify.verifier import WarningKind, verify
from coplan.viz.plots import plan_title
from coplan.viz.viewer import read_viewer_data, render_html

run = CliRunner()


@pytest.fixture(scope="module")
def solved(tmp_path_factory):
    out = tmp_path_factory.mktemp("stated") / "p"
    assert run.invoke(app, ["solve", "greenhouse_row", "--planner", "coordinated", "-o", str(out)]).exit_code == 0
    return out / "plan.json", json.loads((out / "plan.json").read_text())


def _edited(solved, tmp_path, name, edit):
    doc = json.loads(json.dumps(solved[1]))
    edit(doc)
    path = tmp_path / name
    path.write_text(json.dumps(doc))
    return path


@pytest.mark.parametrize("key, value, words", [
    ("makespan", "fast", "metrics.makespan: expected a finite number or null, found string 'fast'"),
    ("makespan", [1, 2], "metrics.makespan: expected a finite number or null, found array [1, 2]"),
    ("harvested", -1, "metrics.harvested: expected a whole number of fruit (0 or more) or null, found number -1"),
    ("harvested", 2.5, "metrics.harvested: expected a whole number of fruit (0 or more) or null, found number 2.5"),
    ("lower_bound", True, "metrics.lower_bound: expected a finite number or null, found boolean True"),
])
def test_figures_of_the_wrong_type_are_refused_with_their_key_path(solved, tmp_path, key, value, words):
    """("fast" as the makespan stopped `coplan plot` with an internal error in its title.)"""
    path = _edited(solved, tmp_path, "bad.json", lambda d: d["metrics"].__setitem__(key, value))
    with pytest.raises(PlanFileError, match=words.replace("[", r"\[").replace("]", r"\]").replace("(", r"\(").replace(")", r"\)")):
        load_plan(path)
    r = run.invoke(app, ["plot", str(path), "-o", str(tmp_path / "g.png")])
    assert r.exit_code == 3 and "internal error" not in r.output and key in r.output, r.output


def test_a_plan_as_written_states_its_motions_figures(solved):
    plan = load_plan(solved[0])
    ver = verify(load_problem("greenhouse_row"), plan)
    assert ver.stated_figures == {}
    assert ver.measured == {"makespan": pytest.approx(plan.metrics["makespan"]), "harvested": plan.metrics["harvested"]}


def test_titles_and_the_viewer_show_the_motions_figures_not_the_files(solved, tmp_path):
    """An edited plan.json stating 5 s and 12 fruit beside a 12.88 s motion of 11: the plot's title
    said "makespan 5.00 s, 12/11 fruit", the viewer "makespan 5.000 s (lower bound 12.883 s,
    x0.388)"."""
    true_span = solved[1]["metrics"]["makespan"]

    def lie(d):
        d["metrics"]["makespan"], d["metrics"]["harvested"] = 5.0, 12

    path = _edited(solved, tmp_path, "lie.json", lie)
    prob, plan = load_problem("greenhouse_row"), load_plan(path)
    ver = checked(prob, plan)
    assert [w.kind for w in ver.warnings].count(WarningKind.STATED_FIGURES) == 1
    title = plan_title("coordinated", plan)
    assert f"makespan {true_span:.2f} s" in title and "11/11 fruit" in title, title
    page = read_viewer_data(render_html(prob, load_plan(path)))["plans"][0]
    assert page["makespan"] == pytest.approx(true_span) and page["harvested"] == 11
    r = run.invoke(app, ["plot", str(path), "-o", str(tmp_path / "g.png")])
    assert r.exit_code == 0 and "the measured ones are shown" in r.output, r.output


@pytest.mark.parametrize("keep", [1, 700])
def test_a_truncated_plans_makespan_counts_no_event_after_its_motion(solved, tmp_path, keep):
    """Cut to its first sample (or 7 s of 12.88): the header said "plan of 0.00 s (makespan 12.88 s:
    the last place)" and the stated makespan passed as the motion's."""
    def cut(d):
        d["time"] = d["time"][:keep]
        for a in d["arms"].values():
            a["q"] = a["q"][:keep]

    path = _edited(solved, tmp_path, f"cut{keep}.json", cut)
    plan = load_plan(path)
    ver = verify(load_problem("greenhouse_row"), plan)
    assert not ver.passed and ver.measured["makespan"] <= plan.duration
    assert ver.measured["harvested"] == 11 - len(ver.unharvested) < 11
    assert set(ver.stated_figures) == {"makespan", "harvested"}
    r = run.invoke(app, ["verify", "greenhouse_row", str(path)], env={"COLUMNS": "300"})
    assert r.exit_code == 6 and "makespan 12.88 s" not in r.output, r.output


def test_a_partial_plan_has_no_ratio_to_a_bound_counting_the_fruit_it_left(tmp_path):
    """crossing_paths at a 0.35 m clearance: one arm is locked, the other harvests 2 of the 3
    harvestable fruit in 6.44 s against a 9.79 s bound for all 3 -- "ratio 0.657" in the summary
    and plan.json (the comparison's table and the sweeps leave it out)."""
    src = next(p for p in shipped_problems() if p.stem == "crossing_paths").read_text()
    assert "clearance: 0.05" in src
    (tmp_path / "tight.yaml").write_text(src.replace("clearance: 0.05", "clearance: 0.35"))
    r = run.invoke(app, ["solve", str(tmp_path / "tight.yaml"), "--planner", "coordinated", "-o", str(tmp_path / "o")],
                   env={"COLUMNS": "300"})
    m = load_plan(tmp_path / "o" / "plan.json").metrics
    assert m["harvested"] < m["harvestable"] and m["lower_bound"] > 0, m
    assert m["gap_to_lower_bound"] is None
    assert "no ratio for a plan that harvests fewer" in r.output, r.output
    full = coplan.solve("crossing_paths", planner="coordinated").plan.metrics  # (a whole plan keeps its ratio)
    assert full["gap_to_lower_bound"] == pytest.approx(full["makespan"] / full["lower_bound"])


def test_a_row_plan_s_edited_grower_figures_are_said_as_its_makespan_is(tmp_path):
    """(From a user's trial: a row plan.json edited to 99999 fruit per hour and half its fruit
    harvested passed coplan verify without a word; only makespan, harvested and row time were
    compared.) Its row.harvested, row.fruit_per_hour and row.share_harvested are measured too."""
    import json

    import coplan
    from coplan.generate import gantry_row, to_yaml
    from coplan.verify import verify

    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=6.0, n_arms=3, density=3.0, seed=2)))
    coplan.solve(path, out_dir=tmp_path / "o")
    doc = json.loads((tmp_path / "o" / "plan.json").read_text())
    assert verify(path, tmp_path / "o" / "plan.json").stated_figures == {}  # (as written: they agree)
    row = doc["metrics"]["row"]
    fph = row["fruit_per_hour"]
    row.update(fruit_per_hour=99999.0, share_harvested=0.5, harvested=row["harvested"] + 1)
    (tmp_path / "edited.json").write_text(json.dumps(doc))
    ver = verify(path, tmp_path / "edited.json")
    assert ver.passed and set(ver.stated_figures) == {"row.fruit_per_hour", "row.share_harvested", "row.harvested"}
    assert ver.stated_figures["row.fruit_per_hour"]["measured"] == pytest.approx(fph)


def test_a_plan_whose_events_are_inferred_is_not_said_to_contradict_its_own_makespan(tmp_path):
    """(From a user's trial: a plan.json with its events removed was 'makespan 6.22316 stated, 6.23
    measured' -- inferred places end on samples, up to three after the true end.) Within that no
    warning; an edited makespan beyond it still is one."""
    import json

    import coplan
    from coplan.verify import verify

    coplan.solve("crossing_paths", planner="coordinated", out_dir=tmp_path / "o")
    doc = json.loads((tmp_path / "o" / "plan.json").read_text())
    doc["events"] = []
    (tmp_path / "bare.json").write_text(json.dumps(doc))
    ver = verify("crossing_paths", tmp_path / "bare.json")
    assert ver.inferred_events and ver.stated_figures == {}
    assert 0 <= ver.measured["makespan"] - doc["metrics"]["makespan"] <= 3 * 0.01 + 1e-9
    doc["metrics"]["makespan"] -= 0.1
    (tmp_path / "edited.json").write_text(json.dumps(doc))
    assert set(verify("crossing_paths", tmp_path / "edited.json").stated_figures) == {"makespan"}
