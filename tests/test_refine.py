"""Refinement (planners/optimal/refine.py): the search's neighbourhood again, each neighbour
ranked by its retimed makespan. Cross-checked with the independent verifier and with retiming
without the shared offsets memo; the caller's refusal, the stopping rules and determinism."""

from __future__ import annotations

import copy

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
    _PRISTINE[id(prob)] = copy.deepcopy((hood, stats.best_state, best))
    return prob, hood, stats.best_state, best, bound


_PRISTINE: dict = {}


def _fresh(dense):
    """A neighbourhood in the state the fixture's search left: a deep copy of it taken then (its
    caches and random generator with it), as a second search with the same seed would leave it --
    whatever the tests before did to the fixture's own."""
    return copy.deepcopy(_PRISTINE[id(dense[0])])


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

    got, st = refine(prob, hood, state, best, bound, MARGIN, RefineOptions(retimes=20), offer)
    assert st.retimes == 20 and st.stop == StopReason.BUDGET
    assert offered and all(ok for _, ok in offered)  # the sampled model agrees with the certified check
    ms = [m for m, _ in offered]
    assert all(b < a for a, b in zip(ms, ms[1:]))  # only ever strictly better
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
        got, st = refine(prob, hood, state, best, bound, MARGIN, RefineOptions(retimes=6))
        runs.append((got.makespan, st.summary()))
    assert runs[0] == runs[1]


def test_a_refused_candidate_is_dropped_and_the_start_is_returned(dense):
    prob, _, _, _, bound = dense
    hood, state, best = _fresh(dense)
    asked = []

    def refuse(c):
        asked.append(c.makespan)
        return False

    got, st = refine(prob, hood, state, best, bound, MARGIN, RefineOptions(retimes=8), offer=refuse)
    assert asked and all(m < best.makespan for m in asked)  # better candidates were offered ...
    assert got is best and st.improvements == 0  # ... and every one refused was dropped
    assert st.failed >= len(asked)


def test_it_stops_at_once_when_the_start_meets_the_bound(dense):
    prob, _, _, _, _ = dense
    hood, state, best = _fresh(dense)
    got, st = refine(prob, hood, state, best, best.makespan + 1.0, MARGIN, RefineOptions(retimes=50))
    assert got is best
    assert st.stop == StopReason.PROVEN_OPTIMAL and st.retimes == 0 and st.evaluations == 0


def test_the_shared_offsets_memo_changes_nothing(dense):
    """Several different plans (the search's best and its neighbours: other allocations, orders
    and branches) retimed through one shared memo, each against a retiming with none."""
    prob, _, state, best, _ = dense
    hood, _, _ = _fresh(dense)
    plans = [best]
    while len(plans) < 6:
        mv = hood.propose(state, len(plans) % len(prob.arms))
        c = hood.evaluate(mv[1]) if mv is not None else None
        if c is not None:
            plans.append(c)
    memo: dict = {}
    for c in plans:
        shared, alone = retime(prob, c.schedules, MARGIN, memo=memo), retime(prob, c.schedules, MARGIN)
        assert shared.makespan == alone.makespan
        for n in shared.schedules:
            assert [s.t0 for s in shared.schedules[n].steps] == [s.t0 for s in alone.schedules[n].steps]
    assert memo  # every move pair that can meet, shared between the plans


def test_the_planner_reports_the_refinement_and_can_turn_it_off():
    prob = load_problem(default_problem_path().with_name("dense_overlap.yaml"))
    small = dict(search_work=1500, search_evaluations=60, polish=False, widen=False)  # (refinement only)
    on = plan_optimal(prob, options=OptimalOptions(**small, refine_retimes=6))
    info = on.plan.solver["refine"]
    assert info["retimes"] == 6 and info["stopped_by"] == "budget"
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
    # other local bests, as a search with fresh starts leaves them (made here, so that the test
    # does not depend on where this machine's search went): neighbours of the best, coordinated
    others, k = [], 0
    while len(others) < 3 and k < 200:
        k += 1
        mv = hood.propose(state, k % len(prob.arms))
        c = hood.evaluate(mv[1]) if mv is not None and mv[1] != state else None
        if c is not None and all(mv[1] != s for _, s in others):
            others.append((c, mv[1]))
    assert len(others) == 3
    begun = []
    orig = hood.propose

    def propose(s, c):  # the state each start's first proposal comes from
        if not begun or begun[-1] is not s:
            begun.append(s)
        return orig(s, c)

    hood.propose = propose
    got, st = refine(prob, hood, state, best, bound, MARGIN, RefineOptions(retimes=25, patience=3), more=others)
    assert st.starts == 1 + len({s for _, s in others})
    firsts = [s for s in dict.fromkeys(begun) if s == state or any(s == o for _, o in others)]
    assert firsts[0] == state  # the search's best first ...
    est = [hood.estimate(s) for s in firsts[1:]]
    assert est == sorted(est)  # ... then the other local bests, lowest estimate first
    assert st.kicks >= 1 and st.retimes == 25
    assert got.makespan <= best.makespan


def test_ctrl_c_during_the_refinement_keeps_the_verified_incumbent(monkeypatch):
    """A KeyboardInterrupt from inside a retiming (where the refinement spends its time) ends
    the planner with the verified incumbent, and CP-SAT never takes Ctrl-C for itself."""
    import coplan.planners.optimal.refine as refine_mod
    from ortools.sat.python import cp_model

    prob = load_problem(default_problem_path().with_name("dense_overlap.yaml"))
    calls = []
    real = refine_mod.retime

    def interrupted_retime(*a, **k):
        calls.append(1)
        if len(calls) == 4:
            raise KeyboardInterrupt
        return real(*a, **k)

    catches = []
    real_solve = cp_model.CpSolver.Solve

    def solve(self, *a, **k):
        catches.append(self.parameters.catch_sigint_signal)
        return real_solve(self, *a, **k)

    monkeypatch.setattr(refine_mod, "retime", interrupted_retime)
    monkeypatch.setattr(cp_model.CpSolver, "Solve", solve)
    res = plan_optimal(prob, options=OptimalOptions(search_work=6000, search_evaluations=200))
    assert len(calls) == 4
    assert res.plan.solver["refine"]["stopped_by"] == "interrupted"
    assert res.plan.status.value == "interrupted" and res.plan.solver["stopped_by"] == "interrupted"
    assert res.verification.passed and verify(prob, res.plan).passed
    assert catches and not any(catches)  # Ctrl-C stays Python's (the planner saves the incumbent)
