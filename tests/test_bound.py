"""The makespan lower bound: the one-arm relaxation with an exact first fruit per arm.

Relaxation: every arm works alone, home -> first fruit -> bin, then bin -> fruit -> bin for
the rest (per-joint time-optimal moves, best IK branches, both dwells per fruit). Its
optimum over assignments and orders is what :func:`coplan.allocation.bound_details` solves.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest

import coplan
from coplan.allocate.allocation import (
    LowerBound,
    _first_trip,
    _lb_time,
    _minmax_milp,
    _round_trip,
    _solve_minmax,
    allocate,
    arm_configs,
    bound_details,
    lower_bound,
    screened_reach,
)
from coplan.generate import overlap_problem, random_problem, row_problem, to_yaml
from coplan.problem import Problem, load_problem, parse_problem, shipped_problems
from coplan.ties import TIME_QUANTUM, quantised

SHIPPED = {p.stem: p for p in shipped_problems()}


def _costs(problem: Problem):
    """(reach (A, F), round trip + dwells, first trip from home + dwells), by the module's own trip functions
    (reach after the static feasibility screen, as the bound uses it)."""
    reach = screened_reach(problem)
    dw = problem.task.pick_dwell + problem.task.place_dwell
    rnd, first = np.full(reach.shape, np.inf), np.full(reach.shape, np.inf)
    for a, arm in enumerate(problem.arms):
        bins, fq = arm_configs(problem, arm)
        for j, f in enumerate(problem.fruits):
            if reach[a, j]:
                rnd[a, j] = _round_trip(arm, bins, fq[f.id], _lb_time) + dw
                first[a, j] = _first_trip(arm, bins, fq[f.id], _lb_time) + dw
    return reach, rnd, first


def _assignments(reach):
    """Every assignment of the reachable fruit to arms that reach them: (fruit cols, arm per col)."""
    cols = [j for j in range(reach.shape[1]) if reach[:, j].any()]
    for arms in itertools.product(*[np.flatnonzero(reach[:, j]) for j in cols]):
        yield cols, arms


def _brute_relaxation(reach, rnd, first) -> float:
    """min over assignments and orders of the slowest arm: first fruit from home, the rest round trips."""
    best = np.inf
    for cols, arms in _assignments(reach):
        span = 0.0
        for a in set(arms):
            mine = [j for j, b in zip(cols, arms) if b == a]
            span = max(span, min(first[a, o[0]] + sum(rnd[a, j] for j in o[1:]) for o in itertools.permutations(mine)))
        best = min(best, span)
    return 0.0 if best == np.inf else best


def _old_offset(reach, rnd, first) -> np.ndarray:
    """The previous bound's arm-wide offset min(0, min over reachable f of first - round)."""
    return np.minimum(0.0, np.subtract(first, rnd, out=np.full(reach.shape, np.inf), where=reach).min(axis=1))


def _brute_old(reach, rnd, first) -> float:
    """The previous bound: the arm-wide offset on every used arm."""
    offset = _old_offset(reach, rnd, first)
    best = np.inf
    for cols, arms in _assignments(reach):
        best = min(best, max(offset[a] + sum(rnd[a, j] for j, b in zip(cols, arms) if b == a) for a in set(arms)))
    return 0.0 if best == np.inf else best


def _old_bound(problem: Problem) -> float:
    """The previous bound by its formula (the same MILP, makespan objective alone)."""
    reach, rnd, first = _costs(problem)
    cols = reach.any(axis=0)
    offset = _old_offset(reach, rnd, first)
    return _solve_minmax(np.where(reach, rnd, 0.0)[:, cols], reach[:, cols], None, offset, tie_break=False)[2]


def _small(kind: str, seed: int) -> Problem:
    if kind == "random":
        d = random_problem(seed, n_arms=2 + seed % 2, n_fruits=2 + seed % 4)
    elif kind == "overlap":
        d = overlap_problem(2 + seed % 2, 3 + seed % 3, seed=seed)
    else:
        d = row_problem(2 + seed % 2, 3 + seed % 3, spacing=1.6, seed=seed, reachable_only=True)
    return parse_problem(to_yaml(d), f"{kind}-{seed}")


SMALL = [("random", s) for s in range(24)] + [("overlap", s) for s in range(6)] + [("row", s) for s in range(6)]


# --------------------------------------------------------------------------- exactness
@pytest.mark.parametrize("kind, seed", SMALL)
def test_bound_equals_brute_force_relaxation_and_beats_old(kind, seed):
    prob = _small(kind, seed)
    reach, rnd, first = _costs(prob)
    exact = _brute_relaxation(reach, rnd, first)
    bd = bound_details(prob)
    slack = (len(prob.fruits) + 1) * TIME_QUANTUM  # the MILP's times are rounded down to whole microseconds
    assert bd.proven
    assert exact - slack <= bd.value <= exact + 1e-12
    assert exact - slack <= bd.primal <= exact + 1e-12
    assert bd.value <= bd.dual_bound + 1e-12 and bd.value <= bd.primal + 1e-12
    assert lower_bound(prob) == bd.value
    # (b) never below the previous arm-wide-offset bound
    assert bd.value >= _brute_old(reach, rnd, first) - slack
    # the first fruit of every working arm is one it reaches; idle arms have none
    ids = [f.id for f in prob.fruits]
    for a, arm in enumerate(prob.arms):
        fid = bd.first_fruit[arm.name]
        assert fid is None or reach[a, ids.index(fid)]


def test_small_problems_cover_positive_savings_and_strict_gains():
    """The brute-force set above exercises what the MILP models: a first trip dearer than the
    round trip (first > round), and problems where the exact first fruit raises the bound."""
    positive = strict = 0
    for kind, seed in SMALL:
        reach, rnd, first = _costs(_small(kind, seed))
        positive += bool(np.any(reach & (first > rnd)))
        strict += _brute_relaxation(reach, rnd, first) > _brute_old(reach, rnd, first) + 1e-3
    assert positive >= 3 and strict >= 3


@pytest.mark.parametrize("seed", range(30))
def test_milp_matches_brute_force_on_synthetic_costs(seed):
    """Random costs and savings of both signs, fruit only one arm reaches, idle arms: the
    pruned first-fruit MILP still finds the exact relaxation optimum."""
    rng = np.random.default_rng(seed)
    A, F = int(rng.integers(2, 4)), int(rng.integers(1, 6))
    reach = rng.random((A, F)) < 0.6
    reach[rng.integers(0, A, F), np.arange(F)] = True
    rnd = rng.uniform(1.0, 4.0, (A, F))
    saving = rng.uniform(-1.5, 1.0 if seed % 3 else -0.1, (A, F))  # every third seed: all savings < 0
    res, assign, dual = _minmax_milp(rnd, reach, None, saving=saving, tie_break=False)
    exact = _brute_relaxation(reach, rnd, rnd + saving)
    q_rnd, q_saving = quantised(rnd), quantised(saving)  # what the MILP sees: whole microseconds, rounded down
    assert res.status == 0
    assert dual == pytest.approx(_brute_relaxation(reach, q_rnd, q_rnd + q_saving), abs=1e-9)
    assert exact - (F + 1) * TIME_QUANTUM <= dual <= exact + 1e-12  # a bound still, and as tight
    assert all(reach[a, f] for f, a in enumerate(assign))


# --------------------------------------------------------------------------- shipped problems
@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_bound_not_below_old_bound(name):
    prob = load_problem(SHIPPED[name])
    assert lower_bound(prob) >= _old_bound(prob) - 1e-6


def test_crossing_paths_bound_models_the_first_fruit():
    prob = load_problem(SHIPPED["crossing_paths"])
    bd = bound_details(prob)
    assert isinstance(bd, LowerBound) and bd.proven
    assert bd.value > 5.6 and bd.value == pytest.approx(5.6642, abs=1e-3)
    assert _old_bound(prob) < bd.value - 0.1  # the arm-wide offset is looser (5.06 s before the screen)
    assert set(bd.first_fruit) == {"left", "right"} and None not in bd.first_fruit.values()


def test_greenhouse_bound_and_allocation_stores_it(greenhouse):
    bd = bound_details(greenhouse)
    assert bd.proven and bd.value == pytest.approx(12.883, abs=1e-3)
    assert bd.dual_bound == pytest.approx(bd.primal, abs=1e-6)
    alloc = allocate(greenhouse)
    assert type(alloc.lower_bound) is float and alloc.lower_bound == pytest.approx(bd.value, abs=1e-9)
    assert alloc.lower_bound <= alloc.estimated_makespan + 1e-9


@pytest.mark.parametrize("name", sorted(SHIPPED))
def test_bound_below_every_safe_plan_makespan(name):
    """The bound holds for every plan that keeps the clearance: the coordinated plan (always
    verified) and the heuristic one where it is safe. On locked_arms the heuristic plan is
    faster than the bound only because it drives r1 through r2's base: the verifier says so."""
    prob = load_problem(SHIPPED[name])
    bound = lower_bound(prob)
    coord = coplan.solve(prob, planner="coordinated")
    assert coord.verification.passed and coord.plan.metrics["makespan"] >= bound - 1e-6
    heur = coplan.solve(prob, planner="heuristic")
    if heur.plan.metrics["makespan"] < bound - 1e-6:
        assert not heur.verification.passed and heur.verification.summary()["collision_count"] > 0


# --------------------------------------------------------------------------- limits and speed
def test_time_limited_bound_reports_a_valid_dual_bound():
    prob = parse_problem(to_yaml(row_problem(5, 100, seed=2, reachable_only=True)))
    full = bound_details(prob)
    cut = bound_details(prob, time_limit=1e-4)  # HiGHS needs ~0.1 s here: it stops early
    assert full.proven and not cut.proven
    assert 0.8 * full.value < cut.value <= full.value + 1e-9
    assert cut.value <= cut.dual_bound + 1e-12


def test_five_arms_hundred_fruit_bound_is_proven():
    """(Its speed is measured by benchmarks/bench_screen_bound.py, not here.)"""
    prob = parse_problem(to_yaml(row_problem(5, 100, seed=11, reachable_only=True)))
    bd = bound_details(prob)
    assert bd.proven and bd.value == pytest.approx(64.5892, abs=1e-3)
