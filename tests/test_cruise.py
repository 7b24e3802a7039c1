"""The carriage's motion (:class:`coplan.row.cruise.Cruise`): its quick paths give the bits of the
general ones -- a plan booked on either is the same plan."""

from __future__ import annotations

import math

import numpy as np

from coplan.problem import load_problem
from coplan.row.cruise import Cruise, _runs


def _cruises():
    pb = load_problem("course_row")
    g = pb.gantry
    yield Cruise.of(pb, 0.13, g.end)
    yield Cruise.of(pb, 0.4, 20.0, start_hold=3.0)
    yield Cruise.shaped(pb, [(10.0, 0.2), (12.0, 0.05, 4.0), (math.inf, 0.3)], g.end)  # (a hold at 12 m)
    yield Cruise.hops(pb, [(1.0, 2.0), (9.0, 5.5), (15.0, 9.0)])


def test_the_positions_alone_are_the_state_s_and_one_position_s_time_is_the_vector_bisection_s():
    rng = np.random.default_rng(5)
    for c in _cruises():
        for shape in [(), (1,), (7,), (3, 4)]:
            t = rng.uniform(-3.0, c.duration + 3.0, size=shape)
            assert np.array_equal(c.x(t), c.state(t)[0]) and c.x(t).shape == np.shape(t)
        xs = np.concatenate([rng.uniform(c.x0 - 1.0, c.x1 + 1.0, 200), [c.x0, c.x1, c.x0 + 1e-13, c.x1 + 2e-9]])
        vector = c.time_at(np.repeat(xs[:, None], 2, axis=1))[:, 0]  # (two at once: the vector path)
        one = np.array([c.time_at(np.array([x]))[0] for x in xs])
        assert np.array_equal(one, vector)
        assert c.time_at(np.array([[xs[0]]])).shape == (1, 1) and c.time_at(float(xs[0])).shape == (1,)


def test_the_runs_of_every_row_at_once_are_each_row_s_own():
    def one_row(ok):  # (how each row's runs were found before, one row at a time)
        d = np.diff(np.r_[0, ok.astype(np.int8), 0])
        return list(zip(np.flatnonzero(d == 1).tolist(), (np.flatnonzero(d == -1) - 1).tolist()))

    rng = np.random.default_rng(0)
    for _ in range(500):
        ok = rng.random((int(rng.integers(1, 7)), int(rng.integers(1, 40)))) < rng.random()
        assert _runs(ok) == [(r, a, b) for r in range(ok.shape[0]) for a, b in one_row(ok[r])]
