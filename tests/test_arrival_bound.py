"""The arrival bound (``coplan.allocate.row_bound.arrival_bound``): the carriage's time from rest
against time-optimal moves, the bound's value on a one-fruit row by hand, and every verified
plan -- on the move and stop by stop, on seeded rows -- no faster than it."""

from __future__ import annotations

import math

import numpy as np
import pytest

import coplan
from coplan.allocate.row_bound import arrival_bound, from_rest, row_bounds
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


@pytest.mark.parametrize("length, density, n_arms, seed", [(8.0, 2.0, 3, 3), (10.0, 2.0, 6, 0), (8.0, 6.0, 3, 5)])
def test_no_verified_plan_beats_it_on_the_move_or_stop_by_stop(length, density, n_arms, seed):
    """Cross-check: the plans coplan makes, verified, in both modes, take at least the bound
    (and the bound is what ``any_plan`` takes, with the work and travel bounds)."""
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
