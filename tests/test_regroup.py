"""The regroup stage: where the widened plan keeps less room than the widening's goal, the
planner runs again at a clearance raised by the shortfall, and its plan is kept only when the
verifier passes it at the problem's own clearance, no slower, harvesting as much, with more room."""

from __future__ import annotations

import time
from dataclasses import replace
from types import SimpleNamespace

import pytest

from coplan.generate import overlap_problem, to_yaml
from coplan.plan import EventKind
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.planners.optimal.regroup import ROOM_QUANTUM, home_room, regrouped
from coplan.problem import load_problem, parse_problem
from coplan.verify import verify


@pytest.fixture(scope="module")
def s28():
    """bench_widen's overlap-2x6-s28: two arms whose least room, once widened, is two picks held
    at the same instant (20.4 mm with the default options)."""
    d = overlap_problem(n_arms=2, n_fruits=6, spacing=1.5, seed=128, name="overlap-2x6-s28")
    return parse_problem(to_yaml(d), d["name"])


def test_other_events_keep_the_makespan_with_the_room_the_widening_could_not_give(s28):
    res = plan_optimal(s28, options=OptimalOptions(search_work=12_000, refine_retimes=8))
    w, rg = res.plan.solver["widen"], res.plan.solver["regroup"]
    want = min(2 * w["margin_before"], 0.05)
    assert w["accepted"] and w["margin"] < want  # the widening on the first plan's events fell short
    assert rg["status"] == "ran" and rg["accepted"], rg
    # planned again with the clearance raised by the shortfall, rounded up to a tenth of a millimetre
    raised = rg["clearance"] - s28.task.clearance
    assert want - rg["margin_before"] <= raised + 1e-9 < want - rg["margin_before"] + ROOM_QUANTUM
    # the plan kept: verified at the problem's own clearance (here, again), no slower, as much, more room
    again = verify(s28, res.plan)
    assert again.passed and res.verification.passed
    assert again.margin == pytest.approx(rg["margin"], abs=1e-9) and rg["margin"] > rg["margin_before"]
    assert rg["margin"] >= want  # here the goal is met: more than twice the room the widening started from
    assert res.plan.metrics["makespan"] <= rg["makespan_before"] + 1e-9
    assert res.plan.metrics["harvested"] == 6
    # faster too here (the search started elsewhere): an incumbent of its own, said so
    assert res.plan.metrics["makespan"] < rg["makespan_before"] - 1e-3
    assert res.plan.solver["incumbent_from"] == "regroup"
    assert res.plan.solver["incumbents"][-1]["source"] == "regroup"
    assert res.plan.solver["moved_by"] is None  # (its own plan: not the widened one moved)
    assert "incumbent from the regroup stage" in res.plan.solver["message"] and "moved by" not in res.plan.solver["message"]
    # the allocation returned is the plan's own (its events are the kept run's)
    picked = {e.fruit for e in res.plan.events if e.kind == EventKind.PICK}
    assert picked == {f for seq in res.allocation.assignment.values() for f in seq}
    # the inner run: the whole flow, this stage itself off in it
    assert [(s["stage"], s["result"]) for s in rg["stages"]][-2:] == [("widen", "accepted"), ("regroup", "skipped")]
    text = _summary(s28, res)  # what `coplan solve` prints
    assert (f"regrouped         margin {1000 * rg['margin_before']:.1f} -> {1000 * rg['margin']:.1f} mm, "
            f"{rg['makespan_before']:.3f} -> {rg['makespan']:.3f} s: other events, planned at a clearance of "
            f"{1000 * rg['clearance']:.1f} mm") in text
    assert "incumbent from the regroup stage, planned at a raised clearance" in text and ", regroup " in text


def test_a_plan_found_at_the_raised_clearance_that_is_slower_is_not_kept(s28):
    res = plan_optimal(s28, options=OptimalOptions(search_work=3000, refine_retimes=4))
    rg = res.plan.solver["regroup"]
    assert rg["status"] == "ran" and not rg["accepted"] and rg["reason"].startswith("slower")
    assert rg["verified"] and rg["margin"] > rg["margin_before"]  # more room, but slower: room never costs time here
    assert res.plan.metrics["makespan"] == pytest.approx(rg["makespan_before"], abs=1e-9)
    assert res.plan.verification["margin"] == pytest.approx(rg["margin_before"], abs=1e-9)
    assert res.plan.solver["incumbent_from"] != "regroup" and res.verification.passed
    text = _summary(s28, res)
    assert f"not regrouped     planned again at a clearance of {1000 * rg['clearance']:.1f} mm: slower (" in text


def _summary(problem, res) -> str:
    """The summary `coplan solve` prints of ``res`` (a plan_optimal result)."""
    import io

    from rich.console import Console

    from coplan.cli.summary import print_summary
    from coplan.pipeline import SolveResult

    buf = io.StringIO()
    print_summary(Console(file=buf, width=400), SolveResult(problem=problem, plan=res.plan, verification=res.verification))
    return buf.getvalue()


def test_the_stage_says_why_it_did_not_run():
    plan = SimpleNamespace(metrics={"makespan": 5.0})
    inc = SimpleNamespace(plan=plan, verification=SimpleNamespace(passed=True, margin=0.01), makespan=5.0)
    crossing = load_problem("crossing_paths")
    assert home_room(crossing) > 1.0  # (its arms at home: more than a metre apart beyond the clearance)

    def run(opts, widen, problem=crossing):
        return SimpleNamespace(problem=problem, opts=opts, inc=inc, reports={"widen": widen}, interrupted=False,
                               in_time=lambda: True, again=plan_optimal, deadline=None, t_start=0.0)

    widened = {"status": "solved", "accepted": True, "margin_before": 0.008}
    assert regrouped(run(OptimalOptions(regroup=False), widened))["reason"] == "the option regroup is false"
    assert regrouped(run(OptimalOptions(widen=False), widened))["reason"] == "the widening stage did not run"
    assert regrouped(run(OptimalOptions(), {"status": "skipped"}))["reason"] == "the widening stage did not run"
    alone = run(OptimalOptions(), widened)
    alone.again = None  # (a Run made without plan_optimal)
    assert regrouped(alone)["reason"] == "no planner to run again"
    # 10 mm kept from 8 mm: the goal is 16 mm
    late = run(OptimalOptions(), widened)
    late.in_time = lambda: False
    assert regrouped(late)["reason"] == "the time limit came before the regroup stage"
    # the arms at home, where every plan starts and ends, keep less room than the goal (16 mm)
    close = replace(crossing, task=replace(crossing.task, clearance=crossing.task.clearance + home_room(crossing) - 0.012))
    assert home_room(close) == pytest.approx(0.012)
    home = regrouped(run(OptimalOptions(), widened, close))
    assert home["status"] == "skipped" and home["reason"].startswith("the arms at home keep 12.0 mm")
    # a time limit with less left than the solve so far took
    short = run(OptimalOptions(), widened)
    short.t_start, short.deadline = time.perf_counter() - 10.0, time.perf_counter() + 5.0
    assert regrouped(short)["reason"].startswith("the time limit leaves 5.0 s, less than the solve so far took (10.0 s)")
    # 10 mm kept from 5 mm: doubled, the goal met
    done = regrouped(run(OptimalOptions(), widened | {"margin_before": 0.005}))
    assert done["status"] == "skipped" and "the widening's goal (10.0 mm)" in done["reason"]
