"""The search's elbow-branch rules and its anchor (the lower bound's own allocation): every
rule's plan is verified, the anchor holds the bound's fruit in their fastest orders (checked
against every permutation), and the search begins and restarts there as documented."""

from __future__ import annotations

import itertools

import pytest

from coplan.allocate import bound_details
from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated
from coplan.planners.coordinated.planner import schedules_plan
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.planners.optimal.search import BranchRule, SearchOptions, Neighbourhood, improve
from coplan.plan import PlannerKind
from coplan.problem import default_problem_path, load_problem
from coplan.ties import TIME_QUANTUM
from coplan.verify import verify

MARGIN = 0.015


@pytest.fixture(scope="module")
def dense():
    prob = load_problem(default_problem_path().with_name("dense_overlap.yaml"))
    cache: dict = {}
    start = plan_coordinated(prob, "makespan", CoordinatedOptions(margin=MARGIN), lambda m: None, cache).candidate
    return prob, start, bound_details(prob), cache


def test_the_anchor_is_the_bound_allocation_in_each_arms_fastest_order(dense):
    prob, start, lb, cache = dense
    srch = Neighbourhood(prob, start, MARGIN, SearchOptions(), cache)
    s = srch.anchor(lb.assignment, tuple(srch.names))
    assert s is not None and s.variant == BranchRule.BRANCHES
    for i, n in enumerate(srch.names):
        assert sorted(s.assign[i]) == sorted(lb.assignment[n])
        every = min(srch.dp(i, p)[2] for p in itertools.permutations(lb.assignment[n]))
        assert srch.dp(i, s.assign[i])[2] == pytest.approx(every, abs=1e-12)
    # the slowest arm alone in its fastest order is the lower bound itself (whose MILP sees every
    # time rounded down to whole microseconds: at most one per fruit and one per first fruit less)
    assert lb.value - 1e-9 <= srch.estimate(s) <= lb.value + (len(prob.fruits) + 1) * TIME_QUANTUM
    other = dict(lb.assignment)
    other["left"] = other["left"][1:]  # a fruit missing: not an anchor for this start
    assert srch.anchor(other, tuple(srch.names)) is None


def test_every_branch_rule_makes_a_verified_plan(dense):
    prob, start, lb, cache = dense
    srch = Neighbourhood(prob, start, MARGIN, SearchOptions(), cache)
    s0 = srch.anchor(lb.assignment, tuple(srch.names))
    made = 0
    for rule in BranchRule:
        c = srch.evaluate(type(s0)(s0.assign, rule, s0.order))
        if c is None:
            continue
        made += 1
        assert c.variant == rule.value and srch.state_of(c).variant == rule  # the label round-trips
        assert c.makespan >= lb.value - 1e-9
        plan = schedules_plan(prob, c.alloc, c.schedules, PlannerKind.OPTIMAL, {})
        assert verify(prob, plan).passed
    assert made >= 4


def test_the_search_begins_at_the_anchor_when_it_is_faster_and_holds_its_allocation(dense):
    """From a slow start (the course's allocation, coordinated) the anchor is faster: the search
    begins there and, with no fresh start, keeps which arm takes which fruit."""
    prob, _, lb, _ = dense
    cache: dict = {}
    slow = plan_coordinated(prob, "heuristic", CoordinatedOptions(margin=MARGIN), lambda m: None, cache).candidate
    opts = SearchOptions(evaluations=30, work=10**7, patience=10**6, exhaustive=0)
    best, stats = improve(prob, slow, lb.value, MARGIN, opts, cache=cache, anchor=lb.assignment)
    assert stats.anchor_makespan is not None and stats.anchor_makespan < slow.makespan - 1e-9
    assert stats.anchored == 1 and stats.improvements >= 1
    assert best.makespan <= stats.anchor_makespan + 1e-9 < slow.makespan
    for n, fruit in lb.assignment.items():  # held: orders, branches and priorities only
        assert sorted(best.alloc.assignment[n]) == sorted(fruit)


@pytest.mark.parametrize("start_kind", ["makespan", "searched"])
def test_the_search_begins_at_the_anchor_only_when_it_coordinates_faster(dense, start_kind):
    """Whichever of the bound's optima the MILP returned: the first start is the anchor exactly
    when the anchor coordinates faster than the start (a start already better -- a searched one --
    is kept, and the anchor waits for the fresh starts)."""
    prob, start, lb, cache = dense
    if start_kind == "searched":
        start, _ = improve(prob, start, lb.value, MARGIN, SearchOptions(evaluations=40, work=10**7, exhaustive=0),
                           cache=cache)
    opts = SearchOptions(evaluations=20, work=10**7, patience=10**6, exhaustive=0)
    best, stats = improve(prob, start, lb.value, MARGIN, opts, cache=cache, anchor=lb.assignment)
    faster = stats.anchor_makespan is not None and stats.anchor_makespan < start.makespan - 1e-9
    assert stats.anchored == int(faster)
    assert best.makespan <= start.makespan + 1e-9


def test_fresh_starts_alternate_between_the_anchor_and_the_start(dense):
    prob, start, lb, cache = dense
    opts = SearchOptions(evaluations=10_000, work=10**7, patience=3, starts=3, stall=1000, exhaustive=0)
    best, stats = improve(prob, start, lb.value, MARGIN, opts, cache=cache, anchor=lb.assignment)
    assert stats.fresh_starts == 3
    first = int(stats.anchor_makespan is not None and stats.anchor_makespan < start.makespan - 1e-9)
    # begun at the anchor: fresh starts 2 (and 4 ...) go there too; else fresh starts 1 and 3
    assert stats.anchored == (2 if first else 2 * (stats.anchor_makespan is not None))
    assert stats.summary()["anchored"] == stats.anchored
    assert best.makespan <= start.makespan + 1e-9


def test_the_optimal_planner_searches_from_the_bounds_allocation(dense, monkeypatch):
    """The planner hands the search the lower bound's own assignment as its anchor (whichever
    optimum the MILP returned), and the search's report says where it began."""
    import coplan.planners.optimal.stages as planner_mod  # (where the stages call the search)

    prob, _, lb, _ = dense
    anchors, starts = [], []
    real = planner_mod.improve

    def spy(*a, **k):
        anchors.append(a[8] if len(a) > 8 else k.get("anchor"))
        starts.append(a[1].makespan)
        return real(*a, **k)

    monkeypatch.setattr(planner_mod, "improve", spy)
    res = plan_optimal(prob, options=OptimalOptions(search_work=3000, polish=False, refine_retimes=0))
    assert anchors == [lb.assignment]
    search = res.plan.solver["search"]
    coordinated = res.plan.solver["coordinated"]
    faster = search["anchor_makespan"] is not None and search["anchor_makespan"] < starts[0] - 1e-9
    assert search["anchored"] >= int(faster)
    assert coordinated["lower_bound"]["value"] == pytest.approx(lb.value, abs=1e-12)
    assert verify(prob, res.plan).passed
    assert res.plan.metrics["makespan"] <= res.coordinated.metrics["makespan"] + 1e-3


def test_annealing_stops_after_its_cooling_work():
    """The temperature falls to 0 over the first ``cooling`` checks: with none, the search is
    the pure descent, move for move (the same random stream: no acceptance draws are made)."""
    from test_anytime import _row_start

    prob, start = _row_start()
    base = dict(evaluations=40, work=10**7, patience=10**6, exhaustive=0)
    hot, s_hot = improve(prob, start, 0.0, MARGIN, SearchOptions(temperature=0.3, cooling=0, **base))
    cold, s_cold = improve(prob, start, 0.0, MARGIN, SearchOptions(temperature=0.0, **base))
    assert hot.makespan == cold.makespan and s_hot.moves == s_cold.moves and s_hot.checks == s_cold.checks
    warm, s_warm = improve(prob, start, 0.0, MARGIN, SearchOptions(temperature=0.3, **base))
    assert s_warm.moves != s_cold.moves or s_warm.checks != s_cold.checks  # annealing does change the walk
