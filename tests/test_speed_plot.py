"""``coplan plot PLAN --kind speed``: a row on the move's speed search as a figure (coplan.viz.speed)."""

from __future__ import annotations

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
