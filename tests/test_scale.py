"""Planning at scale: the search on several processes (same input and N, same plan; worker 0 is
the one-process search), coordinator runs whose work cap grows with the row, and a clock limit
that the retiming keeps."""

from __future__ import annotations

import time

import pytest
from typer.testing import CliRunner

from coplan.cli import app
from coplan.generate import cell_problem, row_problem, to_yaml
from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated
from coplan.planners.coordinated.budget import CHECKS_PER_FRUIT, attempt_checks
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.planners.optimal.options import OptionsError, parse_options
from coplan.planners.optimal.portfolio import default_workers
from coplan.planners.optimal.retime import retime
from coplan.pipeline import ExitCode
from coplan.problem import default_problem_path, load_problem, parse_problem
from coplan.verify import verify

SEARCH = dict(search_work=4000, retime=False, widen=False)  # a short search, nothing after it that could mask it


@pytest.fixture(scope="module")
def row24():
    return parse_problem(to_yaml(row_problem(3, 24, seed=2, spacing=1.6, reachable_only=True)), "row-3x24")


def _events(plan):
    return [(e.arm, e.kind, e.fruit, e.t_start, e.t_end) for e in plan.events]


@pytest.fixture(scope="module")
def portfolio_runs(row24):
    one = plan_optimal(row24, options=OptimalOptions(**SEARCH))
    two = [plan_optimal(row24, options=OptimalOptions(workers=2, **SEARCH)) for _ in range(2)]
    return one, two


def test_the_same_input_and_workers_give_the_same_plan(portfolio_runs):
    _, (a, b) = portfolio_runs
    assert a.plan.metrics["makespan"] == b.plan.metrics["makespan"]
    assert _events(a.plan) == _events(b.plan)
    assert a.plan.solver["search"]["workers"] == b.plan.solver["search"]["workers"]


def test_worker_zero_is_the_one_process_search_and_the_best_worker_wins(row24, portfolio_runs):
    one, (two, _) = portfolio_runs
    workers = two.plan.solver["search"]["workers"]
    assert [w["seed"] for w in workers] == [0, 1]
    # worker 0 searched exactly as the search does in one process (same seed, budget, start)
    # (no retiming, so no refinement: the one-process plan is its search's best)
    assert workers[0]["makespan"] == pytest.approx(one.plan.metrics["makespan"], abs=1e-9)
    assert workers[0]["evaluations"] == one.plan.solver["search"]["evaluations"]
    assert workers[0]["checks"] == one.plan.solver["search"]["checks"]
    # the plan is the best worker's, verified; never slower than one process
    best = min(w["makespan"] for w in workers)
    assert two.plan.metrics["makespan"] == pytest.approx(best, abs=1e-9)
    assert two.plan.metrics["makespan"] <= one.plan.metrics["makespan"] + 1e-9  # (here worker 1's: 32.70 s to 33.65 s)
    assert verify(row24, two.plan).passed
    assert two.plan.solver["options"]["workers"] == 2


def test_workers_are_validated_in_options_files_and_on_the_command_line(tmp_path):
    with pytest.raises(OptionsError, match="workers: expected a whole number of processes from 1 to 256"):
        parse_options("workers: 0\n", "opts.yaml")
    assert parse_options("workers: 3\n").workers == 3
    assert parse_options("workers: auto\n").workers == default_workers()  # as on the command line
    with pytest.raises(OptionsError, match="workers: expected a whole number of processes from 1 to 256, or auto; found string 'two'"):
        parse_options("workers: two\n", "opts.yaml")
    runner = CliRunner()
    prob = str(default_problem_path())
    for bad in ("0", "-2", "two"):
        r = runner.invoke(app, ["solve", prob, "--workers", bad, "-o", str(tmp_path / "x")])
        assert r.exit_code == ExitCode.USAGE and "--workers: expected a whole number" in r.output
    r = runner.invoke(app, ["solve", prob, "--planner", "coordinated", "--workers", "2", "-o", str(tmp_path / "y")])
    assert r.exit_code == ExitCode.USAGE and "applies to --planner optimal" in r.output
    assert 1 <= default_workers() <= 8


def test_a_coordinator_run_may_spend_more_checks_on_a_longer_row():
    small = load_problem(default_problem_path())
    assert attempt_checks(small, 600) == 600  # shipped cells: the option, as before
    big = parse_problem(to_yaml(row_problem(5, 200, seed=5, reachable_only=True)))
    assert attempt_checks(big, 600) == CHECKS_PER_FRUIT * 200
    res = plan_coordinated(big, "makespan", CoordinatedOptions(budget_checks=1))
    assert res.tried[0]["allocation"] == "bound" and res.tried[0]["feasible"]  # the bound's own allocation, booked
    assert res.candidate is not None and not res.candidate.fallback
    assert verify(big, res.plan).passed and res.plan.metrics["harvested"] == 200
    assert res.plan.metrics["makespan"] <= 1.10 * res.plan.metrics["lower_bound"]
    # under the old fixed cap of 600 checks that first attempt runs out of work
    old = plan_coordinated(big, "makespan", CoordinatedOptions(budget_checks=600, checks_per_fruit=0))
    assert not old.tried[0]["feasible"] and "work budget" in old.tried[0]["reason"]
    assert res.plan.metrics["makespan"] <= old.plan.metrics["makespan"] + 1e-9


def test_retiming_stops_at_the_clock_limit():
    prob = parse_problem(to_yaml(cell_problem(7)))
    co = plan_coordinated(prob, "makespan", CoordinatedOptions())
    t = time.perf_counter()
    r = retime(prob, co.candidate.schedules, 0.015, deadline=time.perf_counter() - 1.0)
    assert r.schedules is None and "time limit" in r.status
    assert time.perf_counter() - t < 1.0
    ok = retime(prob, co.candidate.schedules, 0.015, deadline=time.perf_counter() + 60.0)
    assert ok.schedules is not None  # a deadline far off changes nothing


def test_the_search_and_its_anchor_stop_at_the_clock_limit():
    """Under a spent clock limit the search makes no evaluation and builds no anchor (a long
    row's anchor -- each fruit inserted where its arm finishes earliest -- took 18 s on 12 x 600
    fruit, past a 5 s limit); a limit far off changes nothing."""
    from coplan.planners.optimal.search import Neighbourhood, SearchOptions, StopReason, improve

    prob = parse_problem(to_yaml(row_problem(3, 30, seed=4, reachable_only=True)), "row-3x30")
    co = plan_coordinated(prob, "makespan", CoordinatedOptions())
    opts = SearchOptions(work=2000)
    best, st = improve(prob, co.candidate, co.bound.value, 0.015, opts, None, time.perf_counter() - 1.0, {},
                       co.bound.assignment)
    assert st.stop == StopReason.TIME_LIMIT and st.evaluations == 0 and best is co.candidate
    hood = Neighbourhood(prob, co.candidate, 0.015, opts, {})
    hood.deadline = time.perf_counter() - 1.0
    assert hood.anchor(co.bound.assignment, tuple(a.name for a in prob.arms)) is None
    hood.deadline = time.perf_counter() + 60.0
    assert hood.anchor(co.bound.assignment, tuple(a.name for a in prob.arms)) is not None


def test_a_sweep_keeps_one_process_per_problem():
    from coplan.sweep.spec import SweepError, parse_sweep

    text = "name: s\nbase: row\nfixed: {n_arms: 2, spacing: 2.0, seed: 3}\nvary:\n  n_fruits: [2, 3]\noptions: {workers: %s}\n"
    with pytest.raises(SweepError, match=r"options.workers.*expected 1 \(a sweep runs each problem in one process"):
        parse_sweep(text % 2, "s.yaml")
    assert len(parse_sweep(text % 1, "s.yaml").items()) == 2


@pytest.fixture(scope="module")
def alongside_runs():
    """A row longer than refine_fruit: with 2 workers the coordinated planner's candidates run in
    another process while the first candidate is retimed; a short search after it."""
    prob = parse_problem(to_yaml(row_problem(4, 32, seed=3, reachable_only=True)), "row-4x32")
    opts = dict(search_work=3000, refine_fruit=20, widen=False)
    one = plan_optimal(prob, options=OptimalOptions(**opts))
    two = [plan_optimal(prob, options=OptimalOptions(workers=2, **opts)) for _ in range(2)]
    return prob, one, two


def test_two_workers_retime_the_first_candidate_alongside_the_coordinated_planner(alongside_runs):
    prob, one, (a, b) = alongside_runs
    ra, r1 = a.plan.solver["retime"], one.plan.solver["retime"]
    assert "first candidate" in ra[0]["of"] and ra[0]["shift"] is not None  # the bounded retiming, first
    assert not any("first candidate" in r["of"] for r in r1)
    # the other process's candidates are the one-process coordinated stage's, exactly
    assert a.plan.solver["coordinated"]["candidates"] == one.plan.solver["coordinated"]["candidates"]
    assert a.plan.metrics["coordinated_makespan"] == one.plan.metrics["coordinated_makespan"]
    # ... and the same input and workers give the same plan; verified, never slower than one worker
    assert _events(a.plan) == _events(b.plan)
    assert [dict(r, wall_seconds=0) for r in ra] == [dict(r, wall_seconds=0) for r in b.plan.solver["retime"]]
    assert verify(prob, a.plan).passed
    assert a.plan.metrics["makespan"] <= one.plan.metrics["makespan"] + 1e-9


def test_when_the_other_process_gives_nothing_the_planner_goes_on_from_its_first_candidate(alongside_runs, monkeypatch):
    """The coordinated stage's other process may die (killed, out of memory): the planner says
    so and goes on from the first candidate it retimed itself, to a verified plan."""
    from coplan.planners.optimal import portfolio

    class Gone:
        def __init__(self, *args):
            pass

        def result(self):
            raise portfolio.AlongsideFailed("the coordinated planner's process ended (exit code -9)")

        def close(self):
            pass

    monkeypatch.setattr(portfolio, "Alongside", Gone)
    prob, one, (a, _) = alongside_runs
    said: list[str] = []
    r = plan_optimal(prob, options=OptimalOptions(workers=2, search_work=0, refine_fruit=20, widen=False),
                     progress=lambda m: said.append(str(m)))
    assert any("other process gave nothing" in m and "exit code -9" in m for m in said)
    assert r.plan.solver["retime"][0]["of"].endswith("(the others alongside)")
    # it goes on from that first candidate as with the other process: not retimed a second time
    assert {x["stage"]: x["result"] for x in r.plan.solver["stages"]}["retime"] == "retimed alongside the coordinated planner"
    assert verify(prob, r.plan).passed and r.plan.metrics["harvested"] == len(prob.fruits)
    # the first candidate's retiming is kept: no worse than what it made with the other process's help
    assert r.plan.metrics["makespan"] <= a.plan.solver["retime"][0]["makespan"] + 1e-9
