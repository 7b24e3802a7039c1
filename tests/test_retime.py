"""Retiming by CP-SAT (planners/optimal/retime.py): the same moves, picks and places, every
start chosen together. Checked against the independent verifier, against the coordinator's
greedy times, step for step against the plan it retimes, and the planner's acceptance rule."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from coplan.generate import row_problem, to_yaml
from coplan.plan import PlannerKind
from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated
from coplan.planners.coordinated.planner import schedules_plan
from coplan.planners.coordinated.schedule import StepKind
from coplan.planners.optimal import OptimalOptions, plan_optimal
from coplan.planners.optimal import retime as retime_module
from coplan.planners.optimal.retime import _allowed, retime, retime_rounds
from coplan.problem import default_problem_path, load_problem, parse_problem
from coplan.verify import verify

MARGIN = 0.015


@pytest.fixture(scope="module")
def dense():
    prob = load_problem(default_problem_path().with_name("dense_overlap.yaml"))
    return prob, plan_coordinated(prob, "makespan", CoordinatedOptions(margin=MARGIN), lambda m: None).candidate


def _work(sch):
    return [(s.kind, s.q0, s.q1, s.duration, s.fruit) for s in sch.steps if s.kind != StepKind.WAIT]


def test_allowed_offsets_are_the_complement_of_the_padded_forbidden_ones():
    assert _allowed(np.array([0, 1, 2, 10]), 2, 20) == [[-20, -3], [5, 7], [13, 20]]
    assert _allowed(np.array([], int), 2, 5) == [[-5, 5]]
    assert _allowed(np.array([-5, 5]), 0, 5) == [[-4, 4]]


def test_the_retimed_plan_has_the_same_work_in_the_same_order_and_is_verified(dense):
    prob, coord = dense
    r = retime(prob, coord.schedules, MARGIN)
    assert r.status == "OPTIMAL" and r.schedules is not None
    for n, sch in coord.schedules.items():
        new = r.schedules[n]
        assert _work(new) == _work(sch)  # only the waits differ
        ends = [s.t0 + s.duration for s in new.steps]
        assert all(b.t0 >= a - 1e-9 for a, b in zip(ends, new.steps[1:]))  # back to back or waiting
        assert new.steps[0].t0 == 0.0
    assert r.makespan == pytest.approx(max(s.last_place for s in r.schedules.values()))
    # the coordinator books leg by leg; choosing every start together is faster here (measured: 17.977 -> 17.891 s)
    assert r.makespan < coord.makespan - 0.05
    plan = schedules_plan(prob, coord.alloc, r.schedules, PlannerKind.OPTIMAL, {})
    assert verify(prob, plan).passed  # the sampled model agrees with the dense, certified check


def test_retiming_is_deterministic(dense):
    prob, coord = dense
    a, b = retime(prob, coord.schedules, MARGIN), retime(prob, coord.schedules, MARGIN)
    for n in a.schedules:
        assert [s.t0 for s in a.schedules[n].steps] == [s.t0 for s in b.schedules[n].steps]


def test_a_row_retimed_comes_close_to_the_bound():
    prob = parse_problem(to_yaml(row_problem(4, 24, seed=3, reachable_only=True)), "row-4-24")
    res = plan_coordinated(prob, "makespan", CoordinatedOptions(margin=MARGIN), lambda m: None)
    coord, bound = res.candidate, res.bound.value
    r = retime(prob, coord.schedules, MARGIN)
    assert r.schedules is not None and bound - 1e-9 <= r.makespan <= coord.makespan + 0.02
    assert verify(prob, schedules_plan(prob, coord.alloc, r.schedules, PlannerKind.OPTIMAL, {})).passed


def test_the_optimal_planner_keeps_a_retimed_plan_only_when_it_is_verified_and_faster(dense, monkeypatch):
    prob, coord = dense
    quick = OptimalOptions(search_work=0, polish=False, widen=False)  # (the widening stage, after it, has its own tests)
    res = plan_optimal(prob, options=quick)
    assert [k for k, _ in itertools.groupby(h["source"] for h in res.plan.solver["incumbents"])] == ["coordinated", "retime"]
    assert res.plan.metrics["makespan"] < res.coordinated.metrics["makespan"] and verify(prob, res.plan).passed
    assert res.plan.solver["retime"][0]["accepted"] is True
    off = plan_optimal(prob, options=OptimalOptions(search_work=0, polish=False, retime=False, widen=False))
    assert off.plan.metrics["makespan"] == pytest.approx(off.coordinated.metrics["makespan"])

    real = retime_module.retime

    def reckless(problem, schedules, margin, **kw):  # every wait dropped: fast, and colliding
        r = real(problem, schedules, margin, **kw)
        for sch in r.schedules.values():
            t, steps = 0.0, []
            for s in sch.steps:
                if s.kind != StepKind.WAIT:
                    steps.append(type(s)(s.kind, t, s.duration, s.q0, s.q1, s.fruit, s.curve))
                    t += s.duration
            sch.steps = steps
        r.makespan = max(s.last_place for s in r.schedules.values())
        return r

    monkeypatch.setattr(retime_module, "retime", reckless)
    bad = plan_optimal(prob, options=quick)
    assert {h["source"] for h in bad.plan.solver["incumbents"]} == {"coordinated"}  # refused by the verifier
    assert bad.plan.solver["retime"][0]["accepted"] is False
    assert bad.plan.metrics["makespan"] == pytest.approx(bad.coordinated.metrics["makespan"])


@pytest.mark.parametrize("pairs", [1_000_000, 37])
def test_the_screened_meetings_are_exactly_the_brute_force_ones(dense, pairs, monkeypatch):
    """Every start offset at which two moves meet, with the bounding-box screen, against every
    pair of samples tested exactly (the screen only skips pairs that cannot be too close); the
    same when the pairs are tested a few rows at a time (slow moves near each other all along
    had 38 million near pairs at once: 24 GB)."""
    import coplan.planners.optimal.retime as rt
    from coplan.planners.coordinated.schedule import points_too_close
    from coplan.planners.optimal.retime import _meetings, _moves

    monkeypatch.setattr(rt, "_PAIRS", pairs)

    prob, coord = dense
    arms = prob.arms
    tables: dict = {}
    need = prob.task.clearance + MARGIN
    compared = met = 0
    for i, j in prob.neighbour_pairs():
        radii = arms[i].link_radius + arms[j].link_radius
        for xa in _moves(coord.schedules[arms[i].name], 100.0, tables)[0]:
            for xb in _moves(coord.schedules[arms[j].name], 100.0, tables)[0]:
                na, nb = xa.T.size, xb.T.size
                p, q = np.repeat(np.arange(na), nb), np.tile(np.arange(nb), na)
                close = points_too_close(tuple(x[p] for x in xa.pts), tuple(x[q] for x in xb.pts), radii, need)
                brute = np.unique(np.round((xa.T[p[close]] - xb.T[q[close]]) * 1000).astype(int))
                got = _meetings(xa, xb, radii, need)
                assert np.array_equal(got, brute)
                compared += 1
                met += bool(brute.size)
    assert compared > 100 and met > 10  # both kinds of pair were compared


@pytest.fixture(scope="module")
def long_row():
    prob = parse_problem(to_yaml(row_problem(5, 60, seed=5, reachable_only=True)), "row-5-60")
    res = plan_coordinated(prob, "makespan", CoordinatedOptions(margin=MARGIN), lambda m: None)
    return prob, res.candidate, res.bound.value


def test_bounded_retiming_is_a_restriction_that_keeps_the_work_and_is_verified(long_row):
    """Long rows: every move may start at most ``shift`` s later than now (and as early as its
    own arm allows). The model has fewer constraints than the unbounded one, keeps the steps,
    is never later than the plan it retimes, and the verifier passes it."""
    prob, coord, bound = long_row
    full = retime(prob, coord.schedules, MARGIN)
    short = retime(prob, coord.schedules, MARGIN, shift=1.5)
    assert short.schedules is not None and short.status == "OPTIMAL"
    assert short.constraints < full.constraints / 3
    for n, sch in coord.schedules.items():
        assert _work(short.schedules[n]) == _work(sch)
        new = {(s.kind, s.fruit, s.q1): s.t0 for s in short.schedules[n].steps if s.kind != StepKind.WAIT}
        old = {(s.kind, s.fruit, s.q1): s.t0 for s in sch.steps if s.kind != StepKind.WAIT}
        assert all(new[k] <= old[k] + 1.5 + 1e-3 for k in old)  # no move more than the shift later
    assert bound - 1e-9 <= short.makespan <= coord.makespan + 1e-9
    assert verify(prob, schedules_plan(prob, coord.alloc, short.schedules, PlannerKind.OPTIMAL, {})).passed
    # a shift longer than the plan bounds nothing: the unbounded model's constraints and optimum
    wide = retime(prob, coord.schedules, MARGIN, shift=10 * coord.makespan)
    assert wide.constraints == full.constraints
    if full.status == "OPTIMAL" and wide.status == "OPTIMAL":
        assert wide.makespan == pytest.approx(full.makespan, abs=1e-3)


def test_retime_rounds_go_on_from_each_round_that_gains_and_stop_at_one_that_does_not(long_row):
    """The rounds the optimal planner and a row's cells share: each round retimes the last
    round's result, only while a round gains more than ``gain``; every round keeps the work and
    is never later than the one before; the caller can leave after any round."""
    prob, coord, bound = long_row
    tables, memo = {}, {}
    seen = list(retime_rounds(prob, coord, MARGIN, rounds=4, shift=1.5, work=5.0, tables=tables, memo=memo))
    assert 1 <= len(seen) <= 4 and memo  # (the meetings are kept between rounds)
    before = coord.makespan
    for j, (r, rc, gained, seconds) in enumerate(seen):
        assert r.schedules is not None and seconds >= 0.0
        assert rc.makespan == r.makespan <= before + 1e-9 and rc.alloc is coord.alloc
        assert gained == (r.makespan < before - 0.01)
        assert gained or j == len(seen) - 1  # a round that does not gain is the last
        for n, sch in coord.schedules.items():
            assert _work(rc.schedules[n]) == _work(sch)
        before = r.makespan
    assert bound - 1e-9 <= before
    # the first round is the single retiming of the plan, and one round asked for is one round given
    first = retime(prob, coord.schedules, MARGIN, shift=1.5, work=5.0)
    assert seen[0][0].makespan == pytest.approx(first.makespan, abs=1e-9)
    assert len(list(retime_rounds(prob, coord, MARGIN, rounds=1, shift=1.5, work=5.0, tables={}, memo={}))) == 1


def test_the_optimal_planner_bounds_retiming_only_beyond_refine_fruit(long_row):
    prob, _, _ = long_row
    opts = OptimalOptions(search_work=1, refine_fruit=40, widen=False)
    res = plan_optimal(prob, options=opts)
    entries = res.plan.solver["retime"]
    assert entries and all(r["shift"] == opts.retime_shift for r in entries)
    assert len(entries) <= opts.retime_rounds + 1  # the coordinated plan's rounds and the search's best
    for prev, r in zip(entries, entries[1:]):  # a further round only from a kept round that gained
        if "round" in r["of"]:
            assert prev["accepted"] and prev["makespan"] < prev["makespan_before"] - 0.01
            assert r["makespan_before"] == pytest.approx(prev["makespan"])
    res = plan_optimal(prob, options=OptimalOptions(search_work=1, refine_fruit=200, refine_retimes=0, widen=False))
    assert [r["shift"] for r in res.plan.solver["retime"]] == [None] * len(res.plan.solver["retime"])
    assert res.verification.passed
