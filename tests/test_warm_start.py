"""The optimiser's warm start (coplan.schedule): conflict-free coordination, fast and total.

Independent checks only: clearances are recomputed from ``ArmSchedule.state`` (the S-curves'
own evaluation) on a uniform grid, not from the coordinator's internal samples, and the
dense_overlap warm start is run through the independent verifier.
"""

from __future__ import annotations

import time

import numpy as np
import pytest

from coplan import kinematics as kin
from coplan.allocate.allocation import AllocationMethod, allocate
from coplan.kinematics import segment_distance
from coplan.allocate.screen import screen
from layouts import IMPOSSIBLE
from coplan.planners.coordinated import CoordinatedOptions, find_coordinated
from coplan.plan import DEFAULT_RATE, Event, Plan, PlannerKind, PlanStatus, compute_metrics
from coplan.problem import Problem, load_problem, parse_problem
from coplan.planners.coordinated.coordinate import coordinate
from coplan.planners.coordinated.routing import choose_branches, route_moves
from coplan.planners.coordinated.schedule import ConflictError, StepKind, decoupled_schedules, pair_distances
from coplan.kinematics import SCurve
from coplan.verify import verify

MARGIN = 0.015
SHIPPED = ["greenhouse_row", "crossing_paths", "five_arm_row", "dense_overlap"]


def _load(problems_dir, name: str) -> Problem:
    return load_problem(problems_dir / f"{name}.yaml")


def _min_clearance(problem: Problem, schedules, rate: float = 1000.0) -> float:
    """Least clearance over neighbouring pairs on a uniform grid, from ArmSchedule.state."""
    names = [a.name for a in problem.arms]
    t_end = max((s.end for s in schedules.values()), default=0.0)
    t = np.arange(0.0, t_end + 1.0 / rate, 1.0 / rate)
    q = {n: schedules[n].state(t)[0] for n in names}
    out = np.inf
    for i, j in problem.neighbour_pairs():
        out = min(out, float(pair_distances(problem, q[names[i]], q[names[j]], i, j).min()))
    return out


def _check_well_formed(problem: Problem, before, after) -> None:
    """Contiguous steps from 0, at home at both ends, the same picks and places in the same order."""
    for arm in problem.arms:
        steps = after[arm.name].steps
        if not before[arm.name].steps:
            continue
        assert steps[0].t0 == pytest.approx(0.0, abs=1e-12)
        assert np.allclose(steps[0].q0, arm.home) and np.allclose(steps[-1].q1, arm.home)
        for a, b in zip(steps[:-1], steps[1:]):
            assert b.t0 == pytest.approx(a.t1, abs=1e-9)
            assert np.allclose(a.q1, b.q0, atol=1e-9)
        for s in steps:
            assert s.duration >= 0.0
            if s.kind == StepKind.WAIT:
                assert s.duration >= 0.05 - 1e-9  # no sliver waits for the NLP's grid
        ev = [(s.kind, s.fruit) for s in steps if s.kind in (StepKind.PICK, StepKind.PLACE)]
        ev0 = [(s.kind, s.fruit) for s in before[arm.name].steps if s.kind in (StepKind.PICK, StepKind.PLACE)]
        assert ev == ev0


def _prepared(problem: Problem):
    need = problem.task.clearance + MARGIN
    alloc = choose_branches(problem, allocate(problem), need)
    base, _ = route_moves(problem, decoupled_schedules(problem, alloc), need)
    return alloc, base


# --------------------------------------------------------------------------- geometry is exact
def test_pair_distances_match_segment_geometry(problems_dir):
    p = _load(problems_dir, "dense_overlap")
    rng = np.random.default_rng(3)
    qa, qb = rng.uniform(-3.1, 3.1, (5000, 2)), rng.uniform(-3.1, 3.1, (5000, 2))
    a, b = p.arms[0], p.arms[1]
    pa, pb = kin.fk_points(qa, a.links, a.base), kin.fk_points(qb, b.links, b.base)
    ref = np.min([segment_distance(pa[:, s], pa[:, s + 1], pb[:, u], pb[:, u + 1]) for s in range(2) for u in range(2)], axis=0)
    np.testing.assert_allclose(pair_distances(p, qa, qb, 0, 1), ref - a.link_radius - b.link_radius, atol=1e-12)


def test_tabulated_scurve_is_exact():
    from coplan.planners.coordinated.schedule import CurveTable

    rng = np.random.default_rng(0)
    for _ in range(50):
        q0, q1 = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        c = SCurve.between(q0, q1, (3.0, 4.0), (8.0, 12.0), (80.0, 120.0))
        t = np.linspace(-0.1, c.duration + 0.1, 301)
        np.testing.assert_allclose(CurveTable(c).eval(t), c.eval(t), atol=1e-12)


# --------------------------------------------------------------------------- shipped problems
@pytest.mark.parametrize("name", SHIPPED)
def test_coordinate_is_conflict_free_on_shipped_problems(problems_dir, name):
    p = _load(problems_dir, name)
    _, base = _prepared(p)
    t0 = time.perf_counter()
    out, waits, extra = coordinate(p, base, MARGIN)
    assert time.perf_counter() - t0 < 5.0
    _check_well_formed(p, base, out)
    # the coordinator keeps clearance + margin at its own 200 Hz samples; on any other grid
    # the arms can have moved a little in between, never by the whole margin
    assert _min_clearance(p, out) >= p.task.clearance + MARGIN / 2
    # waiting can only delay the last place
    assert max(s.last_place for s in out.values()) >= max(s.last_place for s in base.values()) - 1e-9


def test_coordination_resolves_the_heuristic_allocation_of_crossing_paths(problems_dir):
    p = _load(problems_dir, "crossing_paths")
    base = decoupled_schedules(p, allocate(p, AllocationMethod.HEURISTIC))
    out, waits, extra = coordinate(p, base, MARGIN)
    assert waits + extra >= 1
    assert _min_clearance(p, out) >= p.task.clearance + MARGIN / 2


def test_choose_branches_keeps_the_work_and_reaches_the_targets(problems_dir):
    p = _load(problems_dir, "dense_overlap")
    alloc = allocate(p)
    new = choose_branches(p, alloc, p.task.clearance + MARGIN)
    assert new.assignment == alloc.assignment
    pos = {f.id: f.position for f in p.fruits}
    for arm in p.arms:
        for fid in new.assignment[arm.name]:
            _, tip = kin.fk(np.asarray(new.fruit_q[arm.name][fid]), arm.links, arm.base)
            assert np.allclose(tip, pos[fid], atol=1e-9)
            _, tip = kin.fk(np.asarray(new.place_q[arm.name][fid]), arm.links, arm.base)
            assert np.allclose(tip, arm.bin, atol=1e-9)


@pytest.mark.parametrize("name", ["dense_overlap", "five_arm_row"])
def test_choose_branches_memo_gives_the_same_branches(problems_dir, name):
    """The search shares one memo of move-vs-pose hits over many calls: with it, every call
    (the first, which fills it, and later ones over other allocations) chooses exactly the
    branches a call without it chooses."""
    from dataclasses import replace

    p = _load(problems_dir, name)
    need = p.task.clearance + MARGIN
    alloc = allocate(p)
    names = [a.name for a in p.arms]
    rng = np.random.default_rng(5)
    shuffled = replace(alloc, assignment={n: tuple(rng.permutation(alloc.assignment[n])) for n in names})
    memo: dict = {}
    for al in (alloc, shuffled, alloc):
        ref, fast = choose_branches(p, al, need), choose_branches(p, al, need, memo=memo)
        for n in names:
            for f in al.assignment[n]:
                assert np.array_equal(ref.fruit_q[n][f], fast.fruit_q[n][f])
                assert np.array_equal(ref.place_q[n][f], fast.place_q[n][f])
    assert memo


def test_route_moves_keeps_endpoints(problems_dir):
    p = _load(problems_dir, "dense_overlap")
    base = decoupled_schedules(p, allocate(p))
    routed, n = route_moves(p, base, p.task.clearance + MARGIN)
    assert n > 0  # dense_overlap has moves across a neighbour's base
    for arm in p.arms:
        a = [(s.kind, s.fruit, s.q1) for s in base[arm.name].steps if s.kind != StepKind.MOVE]
        b = [(s.kind, s.fruit, s.q1) for s in routed[arm.name].steps if s.kind != StepKind.MOVE]
        assert a == b
        lim = arm.limits
        for s in routed[arm.name].steps:
            assert np.all((np.asarray(s.q1) >= lim[:, 0]) & (np.asarray(s.q1) <= lim[:, 1]))


# --------------------------------------------------------------------------- the optimiser's choice
def _plan_of(problem: Problem, alloc, schedules) -> Plan:
    t_end = max(s.end for s in schedules.values())
    times = np.arange(int(np.floor(t_end * DEFAULT_RATE)) + 2) / DEFAULT_RATE
    events: list[Event] = sorted((e for s in schedules.values() for e in s.events()), key=lambda e: (e.t_start, e.arm))
    plan = Plan(problem=problem.name, planner=PlannerKind.OPTIMAL, status=PlanStatus.UNVERIFIED, time=times,
                q={n: s.state(times)[0] for n, s in schedules.items()}, events=events,
                allocation={a: list(v) for a, v in alloc.assignment.items()}, unreachable=list(alloc.unreachable))
    plan.metrics = compute_metrics(plan, len(problem.reachable_ids()))
    return plan


@pytest.mark.parametrize("name, baseline", [("dense_overlap", 42.0), ("crossing_paths", 9.2)])
def test_warm_start_exists_and_beats_the_heuristic(problems_dir, name, baseline):
    p = _load(problems_dir, name)
    best, tried, _ = find_coordinated(p, AllocationMethod.MAKESPAN, CoordinatedOptions(), lambda m: None)
    assert any(c["feasible"] for c in tried)
    alloc, sched = best.alloc, best.schedules
    span = max(s.last_place for s in sched.values())
    assert span < baseline
    # the warm start alone is a valid plan: the independent verifier passes it
    plan = _plan_of(p, alloc, sched)
    ver = verify(p, plan)
    assert ver.passed, ver.summary()
    assert not ver.unharvested


# --------------------------------------------------------------------------- constructed cases
def test_waiting_is_inserted_when_paths_cross(problems_dir):
    # the course's allocation sends both arms of crossing_paths across each other at once
    p = _load(problems_dir, "crossing_paths")
    base = decoupled_schedules(p, allocate(p, AllocationMethod.HEURISTIC))
    assert _min_clearance(p, base, rate=200.0) < 0.0  # decoupled, they collide
    out, waits, _ = coordinate(p, base, MARGIN)
    assert waits >= 1
    assert any(st.kind == StepKind.WAIT for s in out.values() for st in s.steps)
    assert _min_clearance(p, out) >= p.task.clearance + MARGIN / 2
    _check_well_formed(p, base, out)


def test_conflict_error_not_a_hang_when_no_timing_can_separate():
    # f1 sits 0.1 m above b's base: only a reaches it, and a's tip there is within the
    # clearance of b's shoulder whatever pose b takes -- no wait, yield or route helps
    p = parse_problem(IMPOSSIBLE)
    # the static feasibility screen sees it before any planning: f1 is left out, with the reason
    assert allocate(p).assignment == {"a": (), "b": ()} and allocate(p).unreachable == ("f1",)
    assert screen(p).reasons["f1"] == "f1: only a reaches it and a cannot reach its bin"
    assert "link 1 would cross b's base" in screen(p).reasons["a"]
    # forced anyway (the course's allocation knows no screen), coordination ends with an error
    alloc = allocate(p, AllocationMethod.HEURISTIC)
    assert alloc.assignment == {"a": ("f1",), "b": ()}
    with pytest.raises(ConflictError):
        coordinate(p, decoupled_schedules(p, alloc), MARGIN)


def test_deadline_ends_the_search(problems_dir):
    p = _load(problems_dir, "dense_overlap")
    _, base = _prepared(p)
    t0 = time.perf_counter()
    with pytest.raises(ConflictError, match="time budget"):
        coordinate(p, base, MARGIN, deadline=time.perf_counter() - 1.0)
    assert time.perf_counter() - t0 < 1.0


@pytest.mark.parametrize("name", ["dense_overlap", "five_arm_row"])
def test_batched_hits_are_the_per_move_hits(problems_dir, name):
    """choose_branches tests every move of an arm against its neighbours' poses in one
    vectorised batch (small chunks here, so several batches); each (move, pose) answer must be
    the one the per-move test gives."""
    from coplan.planners.coordinated.routing import ArmGeometry, _hits, _prefetch_hits

    p = _load(problems_dir, name)
    need = p.task.clearance + MARGIN
    geo = ArmGeometry(p, need)
    rng = np.random.default_rng(11)
    for i, arm in enumerate(p.arms):
        if not geo.nbrs[i]:
            continue
        lim = arm.limits
        qs = rng.uniform(lim[:, 0], lim[:, 1], size=(12, 2))
        avoid = {j: rng.uniform(p.arms[j].limits[:, 0], p.arms[j].limits[:, 1], size=(6, 2)) for j in geo.nbrs[i]}
        keys = {j: [tuple(np.round(q, 9)) for q in v] for j, v in avoid.items()}
        moves = [(qs[a], qs[b]) for a in range(12) for b in range(12) if a != b]
        batched: dict = {}
        _prefetch_hits(geo, i, moves, avoid, keys, batched, chunk=500)
        one: dict = {}
        for q0, q1 in moves:
            key = (tuple(np.round(q0, 9)), tuple(np.round(q1, 9)))
            assert _hits(geo, i, q0, q1, key, avoid, keys, batched) == _hits(geo, i, q0, q1, key, avoid, keys, one)
        assert batched.keys() == one.keys() and batched == one
        assert any(one.values()) and not all(one.values())  # both answers occur


def test_schedule_state_is_the_step_by_step_state(problems_dir):
    """ArmSchedule.state evaluates each step over its own stretch of sorted times; it must give
    exactly what evaluating every step over every time gives, at step boundaries too, and the
    same for times out of order."""
    p = _load(problems_dir, "dense_overlap")
    sched = decoupled_schedules(p, allocate(p))
    rng = np.random.default_rng(3)
    for s in sched.values():
        bounds = np.array([x for st in s.steps for x in (st.t0, st.t1)])
        t = np.sort(np.r_[np.linspace(-0.5, s.end + 0.5, 2001), bounds, rng.uniform(0, s.end, 300)])
        ref = s._state_each(t, np.zeros((3, t.size, 2)) + np.r_[[np.asarray(s.arm.home, float)], np.zeros((2, 2))][:, None, :])
        assert np.array_equal(s.state(t), ref)
        perm = rng.permutation(t.size)
        assert np.array_equal(s.state(t[perm]), ref[:, perm])
