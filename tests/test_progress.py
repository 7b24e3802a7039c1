"""Long runs say how far they are: the optimal planner's ticks (stage, share of its work budget,
incumbent, bound), those of compare, animate and the live run, and the CLI's bars: drawn on a
terminal, none when not a terminal, nothing at all under --json."""

from __future__ import annotations

import io

import pytest
from rich.console import Console

from coplan.cli.console import ProgressDisplay
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.problem import load_problem, shipped_problems
from coplan.progress import Reporter, Tick, nested, ticker

SHIPPED = {p.stem: p for p in shipped_problems()}


class Recorder:
    """A Reporter that keeps everything it is told."""

    def __init__(self):
        self.lines: list[str] = []
        self.ticks: list[Tick] = []

    def __call__(self, message: str) -> None:
        self.lines.append(message)

    def tick(self, t: Tick) -> None:
        self.ticks.append(t)


def test_a_plain_callable_gets_lines_and_no_ticks():
    lines: list = []
    assert not isinstance(lines.append, Reporter)
    ticker(lines.append)(Tick("search", 1, 2))
    assert lines == []
    assert isinstance(Recorder(), Reporter)


def test_tick_text_share_and_gap():
    t = Tick("search", 25, 100, "checks", incumbent=15.3, bound=15.0)
    assert t.share == 0.25 and t.gap == pytest.approx(0.02)
    assert t.text() == "search -- 25% of its budget, incumbent 15.300 s, 2.0% over the bound 15.000 s"
    assert Tick("coordinated").share is None and Tick("x", 5, 2).share == 1.0


def test_the_optimal_planner_ticks_its_stages_with_the_incumbent_and_the_bound():
    prob = load_problem(SHIPPED["dense_overlap"])
    rec = Recorder()
    res = plan_optimal(prob, options=OptimalOptions(search_work=3000, search_evaluations=120, refine_retimes=6),
                       progress=rec)
    stages = list(dict.fromkeys(t.stage for t in rec.ticks))
    assert stages[:4] == ["coordinated", "retime", "search", "refine"]
    for name in ("search", "refine"):
        shares = [t.share for t in rec.ticks if t.stage == name]
        assert shares and shares == sorted(shares) and 0.0 <= shares[0] and shares[-1] <= 1.0
    late = [t for t in rec.ticks if t.stage == "refine"]
    assert late[-1].share == pytest.approx(1.0)  # refine_retimes: 6 of 6
    lb = res.plan.metrics["lower_bound"]
    assert all(t.bound == pytest.approx(lb) for t in late)
    assert all(t.incumbent is not None and t.incumbent >= lb - 1e-9 for t in late)
    assert late[-1].incumbent == pytest.approx(res.plan.metrics["makespan"])
    assert rec.lines  # the messages still come as lines


def test_the_widening_stage_ticks_the_share_of_its_iterations_spent():
    """(Its bar stood at 0 % to the stage's end: no share of its work was ever said.) After each
    IPOPT solve the stage says the share of its iterations spent."""
    rec = Recorder()
    res = plan_optimal(load_problem(SHIPPED["crossing_paths"]), options=OptimalOptions(search_work=500, refine_retimes=0),
                       progress=rec)
    widen = [t.share for t in rec.ticks if t.stage == "widen"]
    spent = res.plan.solver["widen"]["iterations"]
    assert spent > 0 and widen[0] == 0.0 and widen == sorted(widen) and len(widen) >= 2
    assert widen[-1] == pytest.approx(min(1.0, spent / OptimalOptions().widen_iterations))


def test_compare_ticks_its_runs_and_the_solves_inside_one_level_down(tmp_path):
    from coplan.report.comparison import compare

    rec = Recorder()
    compare(SHIPPED["crossing_paths"], ["heuristic", "coordinated"], tmp_path, figures=False, progress=rec)
    outer = [t for t in rec.ticks if t.level == 0]
    assert [t.stage for t in outer] == ["compare", "compare"] and [t.done for t in outer] == [0, 1]
    assert all(t.total == 2 and t.unit == "runs" for t in outer)
    assert "coordinated" in outer[1].note
    assert all(t.level == 1 for t in rec.ticks if t.stage != "compare")


def test_nested_passes_plain_callables_through():
    lines: list = []
    assert nested(lines.append) == lines.append
    rec = Recorder()
    nested(rec).tick(Tick("search", 1, 2))
    assert rec.ticks[0].level == 1


def test_animate_ticks_every_frame(tmp_path):
    from coplan.planners.coordinated import plan_coordinated
    from coplan.viz.animate import animate_plan

    prob = load_problem(SHIPPED["single_arm"])
    plan = plan_coordinated(prob).plan
    rec = Recorder()
    animate_plan(prob, plan, tmp_path / "a.gif", fps=5, dpi=40, progress=rec)
    frames = [t for t in rec.ticks if t.stage == "frames"]
    assert frames and frames[-1].done == frames[-1].total and [t.done for t in frames] == sorted(t.done for t in frames)


def test_the_live_run_ticks_its_detections():
    from coplan.live.feed import make_feed
    from coplan.live.sim import simulate

    prob = load_problem(SHIPPED["greenhouse_row"])
    rec = Recorder()
    simulate(prob, make_feed(prob, seed=1), progress=rec)
    live = [t for t in rec.ticks if t.stage == "live run"]
    assert live and live[-1].share == 1.0 and "re-plans" in live[-1].note


def _display(terminal: bool, quiet: bool = False, hint: str | None = None, hint_after: float = 10.0):
    buf = io.StringIO()
    console = Console(file=buf, force_terminal=terminal, width=140, color_system=None)
    return ProgressDisplay(console, quiet=quiet, hint=hint, hint_after=hint_after), buf


def test_on_a_terminal_the_display_draws_bars_with_the_incumbent():
    disp, buf = _display(terminal=True)
    with disp:
        disp("incumbent 15.4 s (search)")
        disp.tick(Tick("search", 40, 100, "of its work budget", incumbent=15.4, bound=14.8))
        disp.bars.refresh()
        text = buf.getvalue()
    assert "incumbent 15.4 s (search)" in text
    assert "search" in text and "40%" in text and "incumbent 15.400 s (4.1% over the bound)" in text


def test_not_on_a_terminal_there_are_lines_and_no_bars_and_under_json_nothing():
    disp, buf = _display(terminal=False, hint="use --time-limit", hint_after=0.0)
    with disp:
        disp("a message")
        disp.tick(Tick("search", 40, 100, incumbent=15.4, bound=14.8))
    assert disp.bars is None
    out = buf.getvalue()
    assert "a message" in out and "40%" not in out and "note: use --time-limit" in out
    quiet, qbuf = _display(terminal=True, quiet=True, hint="x", hint_after=0.0)
    with quiet:
        quiet("a message")
        quiet.tick(Tick("search", 40, 100))
    assert qbuf.getvalue() == "" and quiet.bars is None


def test_the_cli_prints_no_progress_under_json(tmp_path):
    import json

    from typer.testing import CliRunner

    from coplan.cli import app

    r = CliRunner().invoke(app, ["solve", str(SHIPPED["crossing_paths"]), "--planner", "coordinated", "--json",
                                 "--out", str(tmp_path / "o")])
    json.loads(r.stdout)  # stdout is the document alone


def test_a_row_solve_says_when_it_computes_the_row_s_bounds():
    """The stop-by-stop bound's weight rounds take seconds on a long row, after the plan: the
    solve says so rather than sit silent between its last stop and its summary."""
    from coplan import solve
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem

    row = parse_problem(to_yaml(gantry_row(length=4.0, n_arms=2, density=2.0, seed=3)))
    said = []
    res = solve(row, planner="coordinated", progress=said.append)
    assert res.verification.passed
    i = next(k for k, m in enumerate(said) if m.startswith("row: the lower bounds"))
    assert any(m.startswith("row: ") and "stop" in m for m in said[:i])  # (after the row's own line)
