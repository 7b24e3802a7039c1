"""Refinement (planners/optimal/refine.py): the search's neighbourhood again, each neighbour
ranked by its retimed makespan. Cross-checked with the independent verifier and with retiming
without the shared offsets memo; the caller's refusal, the stopping rules and determinism."""

from __future__ import annotations

import pytest

from coplan.plan import PlannerKind
from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated
from coplan.planners.coordinated.planner import schedules_plan
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.planners.optimal.refine import RefineOptions, refine
from coplan.planners.optimal.retime import retime
from coplan.planners.optimal.search import Neighbourhood, SearchOptions, StopReason, improve
from coplan.problem import default_problem_path, load_problem
from coplan.verify import verify

MARGIN = 0.015
SEARCH = SearchOptions(evaluations=400, work=15_000, patience=100, starts=1, temperature=0.3)


@pytest.fixture(scope="module")
def dense():
    """dense_overlap after a short search: the problem, the search's neighbourhood, its best
    state and candidate, and the lower bound."""
    prob = load_problem(default_problem_path().with_name("dense_overlap.yaml"))
    cache: dict = {}
    co = plan_coordinated(prob, "makespan", CoordinatedOptions(margin=MARGIN), lambda m: None, cache)
    bound = co.plan.metrics["lower_bound"]
    hood = Neighbourhood(prob, co.candidate, MARGIN, SEARCH, cache)
    best, stats = improve(prob, co.candidate, bound, MARGIN, SEARCH, None, None, cache, co.bound.assignment, hood)
    return prob, hood, stats.best_state, best, bound


def _fresh(dense):
    """A neighbourhood in the state the fixture's search left (same seed, same moves)."""
    prob, _, _, _, bound = dense
    cache: dict = {}
    co = plan_coordinated(prob, "makespan", CoordinatedOptions(margin=MARGIN), lambda m: None, cache)
    hood = Neighbourhood(prob, co.candidate, MARGIN, SEARCH, cache)
    best, stats = improve(prob, co.candidate, bound, MARGIN, SEARCH, None, None, cache, co.bound.assignment, hood)
    return hood, stats.best_state, best


def test_the_search_reports_the_state_of_its_best(dense):
    prob, hood, state, best, _ = dense
    again = hood.evaluate(state)
    assert again is not None
    assert again.makespan == pytest.approx(best.makespan, abs=1e-9)
    assert tuple(tuple(best.alloc.assignment[a.name]) for a in prob.arms) == state.assign


def test_refinement_beats_the_search_and_every_best_is_verified(dense):
    prob, _, _, _, bound = dense
    hood, state, best = _fresh(dense)
    offered = []

    def offer(c):
        v = verify(prob, schedules_plan(prob, c.alloc, c.schedules, PlannerKind.OPTIMAL, {}))
        offered.append((c.makespan, v.passed))
        return v.passed

    got, st = refine(prob, hood, state, best, bound, MARGIN, RefineOptions(retimes=40), offer)
    assert st.retimes == 40 and st.stop == StopReason.BUDGET
    assert offered and all(ok for _, ok in offered)  # the sampled model agrees with the certified check
    ms = [m for m, _ in offered]
    assert ms == sorted(ms, reverse=True)  # only ever better
    assert got.makespan == pytest.approx(ms[-1])
    assert got.makespan < best.makespan - 0.1  # measured: about 16.4 -> 15.3 s after this short search
    assert got.makespan >= bound - 1e-9
    plan = schedules_plan(prob, got.alloc, got.schedules, PlannerKind.OPTIMAL, {})
    v = verify(prob, plan)
    assert v.passed and not v.unharvested
    assert sorted(f for seq in got.alloc.assignment.values() for f in seq) == sorted(f.id for f in prob.fruits)


def test_refinement_is_deterministic(dense):
    prob, _, _, _, bound = dense
    runs = []
    for _ in range(2):
        hood, state, best = _fresh(dense)
        got, st = refine(prob, hood, state, best, bound, MARGIN, RefineOptions(retimes=12))
        runs.append((got.makespan, st.summary()))
    assert runs[0] == runs[1]


def test_a_refused_candidate_is_dropped_and_the_start_is_returned(dense):
    prob, _, _, _, bound = dense
    hood, state, best = _fresh(dense)
    got, st = refine(prob, hood, state, best, bound, MARGIN, RefineOptions(retimes=8), offer=lambda c: False)
    assert got is best
    assert st.improvements == 0 and st.failed >= 1


def test_it_stops_at_once_when_the_start_meets_the_bound(dense):
    prob, _, _, _, _ = dense
    hood, state, best = _fresh(dense)
    got, st = refine(prob, hood, state, best, best.makespan + 1.0, MARGIN, RefineOptions(retimes=50))
    assert got is best
    assert st.stop == StopReason.PROVEN_OPTIMAL and st.retimes == 0 and st.evaluations == 0


def test_the_shared_offsets_memo_changes_nothing(dense):
    prob, _, _, best, _ = dense
    memo: dict = {}
    a = retime(prob, best.schedules, MARGIN, memo=memo)
    assert memo  # every move pair that can meet
    b = retime(prob, best.schedules, MARGIN, memo=memo)  # from the memo
    c = retime(prob, best.schedules, MARGIN)
    assert a.makespan == b.makespan == c.makespan
    for n in a.schedules:
        assert [s.t0 for s in a.schedules[n].steps] == [s.t0 for s in b.schedules[n].steps] == \
            [s.t0 for s in c.schedules[n].steps]


def test_the_planner_reports_the_refinement_and_can_turn_it_off():
    prob = load_problem(default_problem_path().with_name("dense_overlap.yaml"))
    small = dict(search_work=6000, search_evaluations=200, polish=False)
    on = plan_optimal(prob, options=OptimalOptions(**small, refine_retimes=15))
    info = on.plan.solver["refine"]
    assert info["retimes"] == 15 and info["stopped_by"] == "budget"
    assert on.verification.passed
    off = plan_optimal(prob, options=OptimalOptions(**small, refine_retimes=0))
    assert off.plan.solver["refine"] is None
    assert [e["of"] for e in off.plan.solver["retime"]] == ["coordinated", "search"]
    assert on.plan.metrics["makespan"] <= off.plan.metrics["makespan"] + 1e-9
    few = plan_optimal(prob, options=OptimalOptions(**small, refine_fruit=14))  # 15 fruit: too many to refine
    assert few.plan.solver["refine"] is None


def test_other_local_bests_are_refined_lowest_estimate_first_and_then_the_best_kicked(dense):
    prob, _, _, _, bound = dense
    hood, state, best = _fresh(dense)
    others = [(c, s) for c, s in hood.stats.local_bests if s != state]
    assert others  # the short search had a fresh start
    got, st = refine(prob, hood, state, best, bound, MARGIN, RefineOptions(retimes=60, patience=3), more=others)
    assert st.starts == 1 + len({s for _, s in others})
    assert st.kicks >= 1 and st.retimes == 60
    assert got.makespan <= best.makespan
