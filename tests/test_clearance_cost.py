"""``coplan compare PROBLEM --clearance-sweep``: the makespan against the clearance asked for."""

from __future__ import annotations

import json

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.problem import shipped_problems
from coplan.report.clearance import clearance_cost


def _path(stem):
    return next(p for p in shipped_problems() if p.stem == stem)


def test_more_clearance_never_plans_with_less_and_an_impossible_one_says_why(tmp_path):
    cost = clearance_cost(_path("crossing_paths"), tmp_path, (0, 25, 5000), "coordinated", figures=True)
    rows = {r["extra_mm"]: r for r in cost.rows}
    assert rows[0.0]["clearance"] == 0.05 and rows[25.0]["clearance"] == 0.075
    for extra in (0.0, 25.0):
        r = rows[extra]
        assert r["verified"] and r["harvested"] == r["reachable"] == 4
        assert r["margin_mm"] >= 0.0  # certified against the raised clearance
    assert rows[0.0]["ratio"] == 1.0
    assert "home" in rows[5000.0]["error"] and rows[5000.0]["verified"] is False
    doc = json.loads((tmp_path / "clearance.json").read_text())
    assert doc["format"] == "coplan.clearance-cost/1" and len(doc["rows"]) == 3
    assert "| +25 | 0.075 |" in (tmp_path / "clearance.md").read_text()
    assert (tmp_path / "clearance_cost.png").stat().st_size > 1000
    assert (tmp_path / "plus_25mm" / "plan.json").exists()
    # the plan names the raised problem written beside it: verified from the files at 0.075 m
    plan = json.loads((tmp_path / "plus_25mm" / "plan.json").read_text())
    assert plan["problem_file"]["path"] == str((tmp_path / "plus_25mm.yaml").resolve()) == str((tmp_path / rows[25.0]["problem_file"]).resolve())
    assert rows[25.0]["problem_file"] == "plus_25mm.yaml"  # (relative to the report: it was the path as the command had it)
    r = CliRunner().invoke(app, ["verify", str(tmp_path / "plus_25mm.yaml"), str(tmp_path / "plus_25mm" / "plan.json"), "--json"])
    assert r.exit_code == 0, r.output
    ver = json.loads(r.stdout[r.stdout.index("{"):])
    assert ver["summary"]["required_clearance"] == 0.075 and ver["problem_file"]["same_text"] is True
    assert not (tmp_path / "plus_5000mm.yaml").exists()  # (no plan: no problem file either)


def test_the_command_line_sweep_and_its_usage_errors(tmp_path):
    runner = CliRunner()
    r = runner.invoke(app, ["compare", str(_path("crossing_paths")), "--clearance-sweep", "-p", "coordinated",
                            "--extra", "10", "-o", str(tmp_path / "out"), "--no-figures", "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout[r.stdout.index("{"):])
    assert [row["extra_mm"] for row in doc["rows"]] == [0.0, 10.0]  # (the problem's own too: the ratios' reference)
    assert doc["rows"][1]["ratio"] is not None
    assert doc["exit_code"] == 0 and doc["verdict"] == "ok"  # (as every document of a command that ran)
    first = (tmp_path / "out" / "clearance.json").read_text()
    again = runner.invoke(app, ["compare", str(_path("crossing_paths")), "--clearance-sweep", "-p", "coordinated",
                                "--extra", "10", "-o", str(tmp_path / "out"), "--no-figures", "--json"])
    assert again.exit_code == 0, again.output  # a second sweep into the folder keeps the first one's report
    assert (tmp_path / "out" / "clearance.previous.json").read_text() == first
    assert any("clearance.previous.json" in n for n in json.loads(again.stdout[again.stdout.index("{"):])["notes"])
    bad = runner.invoke(app, ["compare", str(_path("crossing_paths")), "--extra", "10", "-o", str(tmp_path / "b")])
    assert bad.exit_code == 2 and "--clearance-sweep" in bad.output
    neg = runner.invoke(app, ["compare", str(_path("crossing_paths")), "--clearance-sweep", "--extra", "-5",
                              "-o", str(tmp_path / "c")])
    assert neg.exit_code == 2 and "0 to 1000 mm" in neg.output
    gone = runner.invoke(app, ["compare", str(tmp_path / "nope.yaml"), "--clearance-sweep", "-o", str(tmp_path / "d")])
    assert gone.exit_code == 3 and "no file at this path" in gone.output and "folder" not in gone.output


def test_an_interrupted_sweep_keeps_the_levels_that_finished_and_says_so(tmp_path, monkeypatch):
    """Ctrl-C (or SIGTERM) during a level: the planner returns its incumbent marked interrupted;
    the sweep stops there, writes the finished levels only, with a note, and raises the
    interruption (the command then exits 130 / 143) -- the cut-short level is not a row."""
    import pytest

    import coplan.pipeline as pipeline
    from coplan.kinds import PlanStatus

    real = pipeline.solve
    calls = []

    def solve(problem, **kw):
        res = real(problem, **kw)
        calls.append(problem.task.clearance)
        if len(calls) == 2:
            res.plan.status = PlanStatus.INTERRUPTED
        return res

    monkeypatch.setattr(pipeline, "solve", solve)
    with pytest.raises(KeyboardInterrupt):
        clearance_cost(_path("crossing_paths"), tmp_path, (0, 10, 25), "coordinated", figures=False)
    assert len(calls) == 2  # the third level never ran
    doc = json.loads((tmp_path / "clearance.json").read_text())
    assert [r["extra_mm"] for r in doc["rows"]] == [0.0]
    assert "interrupted at +10 mm" in doc["notes"][0] and "1 of 3" in doc["notes"][0]
    assert "interrupted at +10 mm" in (tmp_path / "clearance.md").read_text()


def test_a_clearance_at_which_the_screen_locks_an_arm_says_so_with_its_lower_bound(tmp_path):
    """(crossing_paths at +100 mm took 2.15 x as long with no word why: its left arm can no longer
    reach its bin clear of the other, and the lower bound doubles.)"""
    cost = clearance_cost(_path("crossing_paths"), tmp_path, (0, 100), "coordinated", figures=False)
    rows = {r["extra_mm"]: r for r in cost.rows}
    assert rows[100.0]["lower_bound"] > 1.5 * rows[0.0]["lower_bound"]
    assert rows[100.0]["makespan"] >= rows[100.0]["lower_bound"] - 1e-9
    note = next(n for n in cost.notes if n.startswith("+100 mm: the screen locks "))
    assert f"the lower bound is {rows[100.0]['lower_bound']:.3f} s" in note
    assert "lower bound, s" in (tmp_path / "clearance.md").read_text()


def test_less_clearance_than_the_problem_s_is_refused_before_any_work(tmp_path):
    with pytest.raises(ValueError, match="expected extra clearances >= 0 mm, found -10"):
        clearance_cost(_path("crossing_paths"), tmp_path / "c", (-10, 25), "coordinated", figures=False)
    assert not (tmp_path / "c").exists()


def test_a_smaller_clearance_s_plan_that_keeps_a_larger_one_is_its_row_when_faster(tmp_path, monkeypatch):
    """(The optimal plan of crossing_paths at its clearance keeps 70 mm beyond it, so it keeps
    +50 mm too, at 6.22 s; the +50 mm row said 6.50 s, "1.044 x": a cost of room that a plan
    already in the sweep does not pay.) Here the planner's own plan at +25 mm is made slower
    (its makespan figure raised 1 s): the row is the +0 mm plan, verified against 0.075 m, and
    says so; its own plan's figure is kept beside it."""
    import coplan.pipeline as pipeline

    real = pipeline.solve

    def solve(problem, **kw):
        res = real(problem, **kw)
        if problem.task.clearance > 0.06:
            res.plan.metrics["makespan"] += 1.0
        return res

    monkeypatch.setattr(pipeline, "solve", solve)
    cost = clearance_cost(_path("crossing_paths"), tmp_path, (0, 25), "coordinated", figures=False)
    zero, more = cost.rows
    assert more["plan_from_mm"] == 0.0 and more["makespan"] == zero["makespan"] and more["ratio"] == 1.0
    assert more["planned_makespan"] == pytest.approx(zero["makespan"] + 1.0) and more["verified"]
    assert more["margin_mm"] == pytest.approx(zero["margin_mm"] - 25.0, abs=1e-6)  # the same plan, 25 mm less room to spare
    md = (tmp_path / "clearance.md").read_text()
    assert "| +25 | 0.075 | 6.50 |" in md and "+0 mm's" in md
    # (and says whose files those are: plus_25mm/ holds the level's own, slower plan)
    assert "The rows at +25 mm give a smaller clearance's plan" in md and "this level's own plan" in md


def test_an_interruption_while_the_smaller_clearances_plans_are_verified_keeps_the_finished_levels(tmp_path, monkeypatch):
    """(A Ctrl-C while the sweep verified the +0 mm plan at +25 mm wrote no clearance.json at all.)"""
    import coplan.pipeline as pipeline
    import coplan.verify.verifier as verifier

    real_solve, real_verify = pipeline.solve, verifier.verify
    first: list = []

    def solve(problem, **kw):  # (the +25 mm plan made slower: the +0 mm one is verified there)
        res = real_solve(problem, **kw)
        first.append(res.plan)
        if problem.task.clearance > 0.06:
            res.plan.metrics["makespan"] += 1.0
        return res

    def verify(problem, plan, *a, **k):  # (the +0 mm plan at +25 mm: only the sweep verifies that)
        if problem.task.clearance > 0.06 and first and plan is first[0]:
            raise KeyboardInterrupt
        return real_verify(problem, plan, *a, **k)

    monkeypatch.setattr(pipeline, "solve", solve)
    monkeypatch.setattr(verifier, "verify", verify)
    with pytest.raises(KeyboardInterrupt):
        clearance_cost(_path("crossing_paths"), tmp_path, (0, 25), "coordinated", figures=False)
    assert len(first) == 2  # (both levels planned: it came after, as the +0 mm plan was verified at +25 mm)
    doc = json.loads((tmp_path / "clearance.json").read_text())
    assert [r["extra_mm"] for r in doc["rows"]] == [0.0] and "interrupted at +25 mm" in doc["notes"][0]


def test_a_rows_sweep_plans_its_cells_as_coplan_solve_does(tmp_path):
    """A row's --clearance-sweep without --planner plans each stop's cell with the coordinated
    planner, as ``coplan solve ROW`` does (it took the optimal one: 10 minutes on sparse_row);
    every level verified."""
    from coplan.generate import gantry_row, to_yaml

    row = tmp_path / "row.yaml"
    row.write_text(to_yaml(gantry_row(length=8.0, n_arms=2, density=2.0, seed=3)))
    r = CliRunner().invoke(app, ["compare", str(row), "--clearance-sweep", "--extra", "25", "-o", str(tmp_path / "out"),
                                 "--no-figures", "--json"])
    assert r.exit_code == 0, r.output
    doc = json.loads(r.stdout[r.stdout.index("{"):])
    assert doc["planner"] == "coordinated" and all(row["verified"] for row in doc["rows"])
    plan = json.loads((tmp_path / "out" / "plus_25mm" / "plan.json").read_text())
    assert plan["solver"]["row"]["cell_planner"] == "coordinated"


def test_a_partial_plan_s_row_says_it_is_partial():
    """(crossing_paths at +300 mm: '2 / 4' harvested beside a makespan below the lower bound, and
    no status in the table -- clearance.json alone said partial.)"""
    from coplan.report.clearance import cell

    assert cell({"harvested": 2, "reachable": 4, "status": "partial"}, "harvested") == "2 / 4 (partial)"
    assert cell({"harvested": 4, "reachable": 4, "status": "success"}, "harvested") == "4 / 4"


def test_the_figure_s_labels_sit_inside_its_axes():
    """(A new user's clearance_cost.png had its top point's label run into the title and the last
    point's past the right edge of the plot.)"""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from coplan.viz.plots import plot_clearance_cost

    rows = [{"extra_mm": 0.0, "clearance": 0.05, "makespan": 6.22, "verified": True, "harvested": 4, "reachable": 4},
            {"extra_mm": 10.0, "clearance": 0.06, "makespan": 6.22, "verified": True, "harvested": 4, "reachable": 4},
            {"extra_mm": 100.0, "clearance": 0.15, "makespan": 13.4, "verified": True, "harvested": 4, "reachable": 4},
            {"extra_mm": 300.0, "clearance": 0.35, "makespan": 6.44, "verified": True, "harvested": 2, "reachable": 4}]
    fig = plot_clearance_cost(rows)
    FigureCanvasAgg(fig).draw()
    ax, renderer = fig.axes[0], fig.canvas.get_renderer()
    labels = [t for t in ax.texts if t.get_text().startswith("+")]
    assert len(labels) == 4 and "2/4 fruit" in labels[-1].get_text()
    for t in labels:
        b = t.get_window_extent(renderer)
        assert ax.bbox.x0 <= b.x0 and b.x1 <= ax.bbox.x1 and ax.bbox.y0 <= b.y0 and b.y1 <= ax.bbox.y1, t.get_text()
