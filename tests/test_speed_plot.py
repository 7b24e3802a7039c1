"""``coplan plot PLAN --kind speed``: a row on the move's speed search as a figure (coplan.viz.speed)."""

from __future__ import annotations

import re

import pytest
from typer.testing import CliRunner

import coplan
from coplan.cli import app
from coplan.generate import gantry_row, to_yaml
from coplan.plan import load_plan
from coplan.problem import parse_problem
from coplan.row.continuous import MovingOptions
from coplan.row.moving import plan_moving
from coplan.viz.speed import plot_speed_curve, speed_curve

runner = CliRunner()


@pytest.fixture(scope="module")
def row_text():
    return to_yaml(gantry_row(length=6.0, density=2.0, seed=1))


def test_the_speed_figure_draws_every_plan_the_search_tried_and_the_one_kept(row_text, tmp_path):
    """Each point is one of ``solver.row.speed_curve``'s (its share harvested from its counts);
    the star, computed from the kept plan's own makespan and harvest, is the fruit per hour the
    row metrics report (two computations of one figure); the command writes the image."""
    f = tmp_path / "row.yaml"
    f.write_text(row_text)
    res = coplan.solve(parse_problem(row_text, str(f)), gantry="continuous", out_dir=tmp_path / "out")
    plan = load_plan(tmp_path / "out" / "plan.json")
    raw = plan.solver["row"]["speed_curve"]
    pts = speed_curve(plan)
    assert len(pts) == len(raw) > 1 and [p["mean_speed"] for p in pts] == sorted(p["mean_speed"] for p in raw)
    assert all(p["share_harvested"] == pytest.approx(q["share_harvested"]) for p, q in
               zip(pts, sorted(raw, key=lambda q: q["mean_speed"])))
    fig = plot_speed_curve(plan)
    top = fig.axes[0]
    stars = [ln for ln in top.get_lines() if ln.get_marker() == "*"]
    assert len(top.get_lines()) == len(pts) + 1 and len(stars) == 1
    x, y = stars[0].get_xdata()[0], stars[0].get_ydata()[0]
    assert x == pytest.approx(res.plan.solver["row"]["mean_speed"]) and y == pytest.approx(res.plan.metrics["row"]["fruit_per_hour"])
    r = runner.invoke(app, ["plot", str(tmp_path / "out" / "plan.json"), "--kind", "speed", "--out", str(tmp_path / "s.png")])
    assert r.exit_code == 0, r.output
    assert (tmp_path / "s.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_both_profiles_are_told_apart(row_text):
    plan = plan_moving(parse_problem(row_text, "row.yaml"), MovingOptions(profile="auto")).plan
    labels = [t.get_text() for t in plot_speed_curve(plan).axes[0].get_legend().get_texts()]
    assert "constant profile" in labels and "density profile" in labels and any(t.startswith("kept (") for t in labels)


def test_a_plan_with_no_speed_search_is_refused(row_text, tmp_path, problems_dir):
    f = tmp_path / "row.yaml"
    f.write_text(row_text)
    coplan.solve(parse_problem(row_text, str(f)), out_dir=tmp_path / "stops")  # stop and go (the default)
    coplan.solve(problems_dir / "crossing_paths.yaml", planner="coordinated", out_dir=tmp_path / "cell")
    for folder, said in (("stops", "found a plan made stop and go"), ("cell", "found a stationary cell's plan")):
        r = runner.invoke(app, ["plot", str(tmp_path / folder / "plan.json"), "--kind", "speed", "--out", str(tmp_path / "x.png")])
        assert r.exit_code == 2 and said in " ".join(r.output.split()), r.output
        with pytest.raises(ValueError, match=said):
            speed_curve(load_plan(tmp_path / folder / "plan.json"))
    r = runner.invoke(app, ["plot", str(tmp_path / "stops" / "plan.json"), "--kind", "speed", "--arm", "arm1", "--out", str(tmp_path / "x.png")])
    assert r.exit_code == 2 and "--arm: expected with --kind joints or workspace" in r.output
    assert not (tmp_path / "x.png").exists()
    with pytest.raises(TypeError, match="expected a Plan"):
        speed_curve("plan.json")


@pytest.fixture(scope="module")
def moving_plan(row_text, tmp_path_factory):
    """A row planned on the move, saved: its plan.json's decoded document."""
    import json

    d = tmp_path_factory.mktemp("moving")
    (d / "row.yaml").write_text(row_text)
    coplan.solve(parse_problem(row_text, str(d / "row.yaml")), gantry="continuous", out_dir=d / "out")
    return d / "row.yaml", json.loads((d / "out" / "plan.json").read_text())


@pytest.mark.parametrize("edit, where, said", [
    (lambda d: d["solver"].__setitem__("row", [1]), "solver.row", "expected an object (how the row was planned), found array [1]"),
    (lambda d: d["solver"]["row"].__setitem__("speed_curve", "x"), "solver.row.speed_curve", "expected an array or null, found string 'x'"),
    (lambda d: d["solver"]["row"]["speed_curve"][0].__setitem__("mean_speed", None), "solver.row.speed_curve[0].mean_speed",
     "expected a finite number, found null"),
    (lambda d: d["solver"]["row"]["speed_curve"][1].__setitem__("fruit_per_hour", "a"), "solver.row.speed_curve[1].fruit_per_hour",
     "expected a finite number, found string 'a'"),
    (lambda d: d["solver"]["row"]["speed_curve"][0].__setitem__("harvested", 2.5), "solver.row.speed_curve[0].harvested",
     "expected a whole number of fruit (0 or more) or null, found number 2.5"),
    (lambda d: d["metrics"].__setitem__("row", "fast"), "metrics.row", "expected an object (the row's figures), found string 'fast'"),
    (lambda d: d["gantry"].__setitem__("v", [0.0]), "gantry.v", "expected only the key x"),
    (lambda d: d["solver"]["row"].__setitem__("mode", "teleport"), "solver.row.mode",  # (read as stop and go, and passed)
     "expected one of 'stop-and-go', 'continuous', 'stop-and-go-live', 'continuous-live' (how the carriage moved), found 'teleport'"),
])
def test_a_hand_edited_row_plan_is_bad_input_named_by_its_key(moving_plan, tmp_path, edit, where, said):
    """(A new-user trial: ``solver.row: [1]`` stopped `coplan view` and `plot --kind speed` with an
    internal error, a speed point's null mean_speed with a TypeError, "a" with a bare float
    message, and an extra ``gantry.v`` verified silently.) Each is now bad input, exit 3, naming
    the file and the key path, in every command that reads the plan."""
    import copy
    import json

    from coplan.errors import PlanFileError

    problem, doc = moving_plan
    doc = copy.deepcopy(doc)
    edit(doc)
    f = tmp_path / "plan.json"
    f.write_text(json.dumps(doc))
    with pytest.raises(PlanFileError, match=re.escape(where)):
        load_plan(f)
    for cmd in (["plot", str(f), "--kind", "speed", "--problem", str(problem), "--out", str(tmp_path / "s.png")],
                ["view", str(f), "--problem", str(problem), "--out", str(tmp_path / "v.html")],
                ["verify", str(problem), str(f)]):
        r = CliRunner(env={"COLUMNS": "300"}).invoke(app, cmd)
        text = " ".join(r.output.split())
        assert r.exit_code == 3 and where in text and said in text and "plan.json" in text, (cmd, r.output)
        assert r.exception is None or isinstance(r.exception, SystemExit)


def test_the_speed_figure_of_a_row_with_no_fruit_is_refused(tmp_path):
    """(A row with no fruit drew a flat chart at 0 fruit/h, exit 0.)"""
    doc = gantry_row(length=3.0, density=1.0, seed=2)
    doc["fruits"] = []
    f = tmp_path / "empty.yaml"
    f.write_text(to_yaml(doc))
    coplan.solve(parse_problem(f.read_text(), str(f)), gantry="continuous", out_dir=tmp_path / "out")
    r = runner.invoke(app, ["plot", str(tmp_path / "out" / "plan.json"), "--kind", "speed", "--out", str(tmp_path / "s.png")])
    assert r.exit_code == 2 and "no harvestable fruit" in " ".join(r.output.split()), r.output
    assert not (tmp_path / "s.png").exists()
    with pytest.raises(ValueError, match="harvested 0 of 0"):
        speed_curve(load_plan(tmp_path / "out" / "plan.json"))


def test_the_legend_stands_beside_the_axes_clear_of_every_point(row_text):
    """(A new-user trial: the legend, placed "best", could cover the kept plan's star.)"""
    plan = plan_moving(parse_problem(row_text, "row.yaml"), MovingOptions()).plan
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    fig = plot_speed_curve(plan)
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    top = fig.axes[0]
    legend = top.get_legend().get_window_extent(canvas.get_renderer())
    axes = top.get_window_extent(canvas.get_renderer())
    assert legend.x0 >= axes.x1 and legend.x1 <= fig.bbox.x1 + 1  # (beside, and inside the figure)
