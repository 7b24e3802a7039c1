"""The arrival bound (``coplan.allocate.row_bound.arrival_bound``): the carriage's time from rest
against time-optimal moves, the bound's value on a one-fruit row by hand, the row's tail shared
among arms that each reach it from their own time (the water level by hand, by bisection, and
the bound recomputed fruit by fruit), and every verified plan -- on the move and stop by stop, on
seeded rows -- no faster than it."""

from __future__ import annotations

import math

import numpy as np
import pytest

import coplan
from coplan.allocate.row_bound import arrival_bound, from_rest, row_bounds, water_level
from coplan.allocate.row_cycles import cell_cycles
from coplan.generate import gantry_row, to_yaml
from coplan.kinematics.timing import scurve_time
from coplan.problem import parse_problem


@pytest.mark.parametrize("v, a, j", [(0.5, 0.5, 5.0), (0.1, 1.0, 5.0), (1.2, 0.8, 2.0)])
def test_from_rest_is_half_a_rest_to_rest_move_over_twice_the_way(v, a, j):
    """A time-optimal rest-to-rest move over ``2 d`` is symmetric: at its middle it has covered
    ``d`` at full effort, so once it cruises half its time is the least time to cover ``d`` from
    rest; short of the cruise, ``d / v`` (a lower bound on that half)."""
    t1 = v / a + a / j if v >= a * a / j else 2.0 * math.sqrt(v / j)
    ramp = 0.5 * v * t1  # the way covered while the speed ramps up to v
    for d in np.linspace(ramp, ramp + 30.0, 7):
        assert from_rest(d, v, a, j) == pytest.approx(0.5 * scurve_time(2.0 * d, v, a, j), rel=1e-9, abs=1e-9)
    for d in np.linspace(0.0, ramp, 6)[:-1]:
        assert from_rest(d, v, a, j) == pytest.approx(d / v)
        assert from_rest(d, v, a, j) <= 0.5 * scurve_time(2.0 * d, v, a, j) + 1e-12
    assert from_rest(10.0, 0.5, 0.5, 5.0) == pytest.approx(10.0 / 0.5 + 0.5 * (1.0 + 0.1))  # 20.55 s


def _row(length, density, n_arms, seed, keep=None):
    doc = gantry_row(length=length, density=density, n_arms=n_arms, seed=seed)
    if keep is not None:
        doc["fruits"] = [f for f in doc["fruits"] if f["id"] in keep]
    return parse_problem(to_yaml(doc), "row.yaml")


def test_one_fruit_far_down_the_rail_is_the_way_there_then_its_pick_way_back_and_place():
    """A row with one fruit: the bound is the carriage's time from rest to the first cell an arm
    reaches it from, then the pick dwell, that arm's least way back to its bin and the place
    dwell -- the best arm's; more than the travel bound (no ramp, no way back)."""
    full = _row(20.0, 2.0, 3, 1)
    last = max(full.fruits, key=lambda f: f.position[0])
    row = _row(20.0, 2.0, 3, 1, keep={last.id})
    g, task = row.gantry, row.task
    cc = cell_cycles(row, 0.05)
    hand = []
    for a in range(len(row.arms)):
        cells, t = cc.band(a)
        inside = np.isfinite(t[0]) & cc.reach[a][0]
        if cc.cost[a] is None or not inside.any():
            continue
        d = max(0.0, float(cc.lo[cells[0][inside]].min()) - g.start)
        hand.append(float(from_rest(d, g.max_velocity, g.max_acceleration, g.max_jerk)) + task.pick_dwell
                    + float(cc.ways[a][0][inside].min()) + task.place_dwell)
    assert hand and arrival_bound(row, cc) == pytest.approx(min(hand))
    b = row_bounds(row, priced=False)
    assert b.arrival == pytest.approx(min(hand)) and b.any_plan == b.arrival > b.travel


@pytest.mark.parametrize("length, density, n_arms, seed", [(8.0, 2.0, 3, 3), (10.0, 2.0, 6, 0), (8.0, 6.0, 3, 5),
                                                         (12.0, 1.0, 2, 3)])
def test_no_verified_plan_beats_it_on_the_move_or_stop_by_stop(length, density, n_arms, seed):
    """Cross-check: the plans coplan makes, verified, in both modes, take at least the bound
    (and the bound is what ``any_plan`` takes, with the work and travel bounds). The last row's
    plan on the move comes within 4 % of it (20.41 s against 19.72 s when this was written)."""
    row = _row(length, density, n_arms, seed)
    b = row_bounds(row, priced=False)
    assert b.any_plan == pytest.approx(max(b.work, b.travel, b.arrival)) and b.arrival > 0
    for gantry in ("continuous", "stop-and-go"):
        res = coplan.solve(row, gantry=gantry)
        m = res.plan.metrics["row"]
        assert res.verification.passed and m["share_harvested"] == 1.0
        assert m["row_time"] >= b.arrival - 1e-9, (gantry, m["row_time"], b.arrival)


def test_sparse_rows_where_travel_sets_the_bound_are_lifted():
    """Where the carriage's travel sets the bound (sparse fruit, many arms), the arrival bound is
    above it: the ramp to top speed and the last fruit's way back count."""
    row = _row(20.0, 2.0, 6, 0)
    b = row_bounds(row, priced=False)
    assert b.travel > b.work and b.arrival > b.travel + 0.5


def test_water_level_by_hand():
    """Work shared among arms free from their starts, the last ending as early as it can: 4 s of
    work on arms free from 0 and 10 s is the first arm's alone (4 s); from 0 and 1 s, both
    (2.5 s each way: 2.5 + 1.5 = 4); an arm that takes no part (``inf``) changes nothing; none
    at all, ``inf``; several cases at once, one per column."""
    assert water_level(4.0, [0.0, 10.0]) == pytest.approx(4.0)
    assert water_level(4.0, [1.0, 0.0]) == pytest.approx(2.5)
    assert water_level(4.0, [0.0, 1.0, np.inf]) == pytest.approx(2.5)
    assert water_level(3.0, [-1.0, -1.0, -1.0]) == pytest.approx(0.0)
    assert water_level(1.0, [np.inf, np.inf]) == np.inf
    both = water_level(np.array([4.0, 4.0]), np.array([[0.0, 0.0], [10.0, 1.0]]))
    assert both == pytest.approx([4.0, 2.5])


def test_water_level_is_the_least_level_that_holds_the_work():
    """Seeded random cases against bisection on ``sum_a max(0, T - start_a) = work``."""
    rng = np.random.default_rng(7)
    for _ in range(200):
        n = int(rng.integers(1, 9))
        start = rng.uniform(-5.0, 30.0, n)
        start[rng.random(n) < 0.3] = np.inf
        work = float(rng.uniform(0.0, 40.0))
        level = float(water_level(work, start))
        fin = start[np.isfinite(start)]
        if fin.size == 0:
            assert level == np.inf
            continue
        lo, hi = float(fin.min()), float(fin.max()) + work + 1.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if np.maximum(0.0, mid - fin).sum() < work else (lo, mid)
        assert level == pytest.approx(hi, abs=1e-9)


def test_the_rows_tail_is_shared_from_each_arms_own_start():
    """The bound recomputed fruit by fruit from the cells (loops, not the bound's arrays): for
    every latest-first set of fruit, each arm that reaches some of them takes a share from the
    least over them of its earliest pick less its way out, levelled by bisection. On a 20 m row
    of 2 fruit per metre and 6 arms the rear arms reach the row's last fruit seconds after the
    front ones, so it is well above the same bound with every arm free from the set's first pick
    less the longest way out (27.90 s -> 31.13 s when this was written; the bound before 08ab870)."""
    row = _row(20.0, 2.0, 6, 0)
    g = row.gantry
    cc = cell_cycles(row, 0.05)
    A, F = cc.reach.shape
    lim = (g.max_velocity, g.max_acceleration, g.max_jerk)
    R, P, W = (np.full((A, F), np.inf) for _ in range(3))
    for a in range(A):
        if cc.cost[a] is None:
            continue
        cells, t = cc.band(a)
        for f in range(F):
            cols = [w for w in range(t.shape[1]) if np.isfinite(t[f, w]) and cc.reach[a][f]]
            if cols:
                R[a, f] = float(from_rest(max(0.0, min(float(cc.lo[cells[f, w]]) for w in cols) - g.start), *lim))
                P[a, f] = min(float(t[f, w]) for w in cols)
                W[a, f] = min(float(cc.ways[a][f, w]) for w in cols)
    fruit = [f for f in range(F) if np.isfinite(P[:, f]).any()]
    single = max(min(R[a, f] + P[a, f] - W[a, f] for a in range(A) if np.isfinite(P[a, f])) for f in fruit)
    r = {f: min(R[a, f] for a in range(A) if np.isfinite(P[a, f])) for f in fruit}

    def level(work, starts):
        lo, hi = min(starts), max(starts) + work + 1.0
        for _ in range(200):
            mid = 0.5 * (lo + hi)
            lo, hi = (mid, hi) if sum(max(0.0, mid - s) for s in starts) < work else (lo, mid)
        return hi

    own, common = single, single
    for f0 in fruit:
        later = [f for f in fruit if r[f] >= r[f0]]
        work = sum(min(P[a, f] for a in range(A) if np.isfinite(P[a, f])) for f in later)
        arms = [a for a in range(A) if any(np.isfinite(P[a, f]) for f in later)]
        starts = [min(R[a, f] - W[a, f] for f in later if np.isfinite(P[a, f])) for a in arms]
        own = max(own, level(work, starts))
        common = max(common, r[f0] + work / len(arms) - max(W[a, f] for a in arms for f in later if np.isfinite(P[a, f])))
    assert arrival_bound(row, cc) == pytest.approx(own, abs=1e-6)
    assert own > common + 2.0
