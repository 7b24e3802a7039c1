"""Timing laws: the course's cubic and the jerk-limited S-curve, against closed forms.

Closed forms of the time-optimal rest-to-rest S-curve over a distance D with limits v, a, j
(derived from the 7-phase profile: jerk phases of a_p / j, constant-acceleration phases,
a cruise at v_p):

* cruise at v, acceleration a reached (v >= a^2 / j):   T = D / v + v / a + a / j,
  valid for D >= v (v / a + a / j);
* cruise at v, a never reached (v < a^2 / j):           T = D / v + 2 sqrt(v / j),
  valid for D >= 2 v sqrt(v / j);
* no cruise, a reached (peak speed v_p from v_p^2 / a + v_p a / j = D):
                                                         T = a / j + sqrt(a^2 / j^2 + 4 D / a),
  valid for 2 a^3 / j^2 <= D;
* no cruise, a not reached (pure jerk, four phases):     T = (32 D / j)^(1/3).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

from coplan.kinematics import SCurve, cubic_eval, cubic_min_time, move_lower_bound, scurve_time
from coplan.kinematics.timing import sync_duration

V, A, J = 3.0, 8.0, 80.0  # the greenhouse arm's shoulder limits


# --------------------------------------------------------------------------- cubic
@pytest.mark.parametrize(
    "dq,T,binding,kind",
    [
        # joint 0 acceleration-bound: sqrt(6 * 2 / 8) > 1.5 * 2 / 3
        ((2.0, 0.1), math.sqrt(6 * 2.0 / 8.0), 0, "acc"),
        # joint 1 acceleration-bound: sqrt(6 * 3 / 12) = 1.2247 > 1.5 * 3 / 4 = 1.125
        ((0.5, -3.0), math.sqrt(6 * 3.0 / 12.0), 1, "acc"),
        # joint 0 velocity-bound: 1.5 * 4 / 3 = 2 > sqrt(6 * 4 / 8) = 1.732
        ((-4.0, 0.0), 2.0, 0, "vel"),
        # joint 1 velocity-bound: 1.5 * 6 / 4 = 2.25 > sqrt(6 * 6 / 12) = 1.732
        ((1.0, 6.0), 2.25, 1, "vel"),
    ],
)
def test_cubic_min_time_analytic(dq, T, binding, kind) -> None:
    vmax, amax = (3.0, 4.0), (8.0, 12.0)
    got = cubic_min_time(dq, vmax, amax)
    assert got == pytest.approx(T, rel=1e-12)
    # peak velocity 1.5 D / T and peak acceleration 6 D / T^2, from dense samples
    t = np.linspace(0.0, T, 20001)
    q = cubic_eval((0.0, 0.0), dq, T, t)
    dt = t[1] - t[0]
    vel = np.gradient(q, dt, axis=0)
    acc = np.diff(q, 2, axis=0) / dt**2
    d = np.abs(np.asarray(dq))
    np.testing.assert_allclose(np.abs(vel).max(axis=0), 1.5 * d / T, rtol=1e-6, atol=1e-9)
    np.testing.assert_allclose(np.abs(acc).max(axis=0), 6 * d / T**2, rtol=1e-3, atol=1e-9)
    limit = vmax[binding] if kind == "vel" else amax[binding]
    peak = (1.5 * d / T if kind == "vel" else 6 * d / T**2)[binding]
    assert peak == pytest.approx(limit, rel=1e-12)  # the binding joint hits its limit exactly
    other = 1 - binding
    assert 1.5 * d[other] / T <= vmax[other] + 1e-12 and 6 * d[other] / T**2 <= amax[other] + 1e-12
    assert 1.5 * d[binding] / T <= vmax[binding] + 1e-12 and 6 * d[binding] / T**2 <= amax[binding] + 1e-12


def test_cubic_eval_is_the_lessons_profile() -> None:
    """q0 + (3 tau^2 - 2 tau^3)(q1 - q0), held at q1 after T (the lesson's ``cubic_trajectory``)."""
    q0, q1, T = np.array([0.2, -1.0]), np.array([1.4, 0.5]), 1.7
    t = np.array([0.0, 0.25 * T, 0.5 * T, T, 2 * T])
    tau = np.clip(t / T, 0, 1)
    ref = q0 + (3 * tau**2 - 2 * tau**3)[:, None] * (q1 - q0)
    np.testing.assert_allclose(cubic_eval(q0, q1, T, t), ref, atol=1e-15)
    np.testing.assert_allclose(cubic_eval(q0, q1, T, t)[2], (q0 + q1) / 2)


def test_cubic_zero_move() -> None:
    assert cubic_min_time((0.0, 0.0), (3.0, 4.0), (8.0, 12.0)) == 0.0


# --------------------------------------------------------------------------- S-curve closed forms
@pytest.mark.parametrize(
    "D,expected,regime",
    [
        (2.0, 2.0 / V + V / A + A / J, "cruise"),  # 1.141666...
        (V * (V / A + A / J), 2 * (V / A + A / J), "cruise edge"),  # D = 1.425, T = 0.95
        (0.5, A / J + math.sqrt((A / J) ** 2 + 4 * 0.5 / A), "no cruise"),  # 0.609902
        (2 * A**3 / J**2, 4 * A / J, "a just reached"),  # D = 0.16, T = 0.4
        (0.1, (32 * 0.1 / J) ** (1 / 3), "tiny"),  # 0.341995
        (1e-6, (32e-6 / J) ** (1 / 3), "tiny"),
    ],
)
def test_scurve_time_reference_values(D, expected, regime) -> None:
    assert scurve_time(D, V, A, J) == pytest.approx(expected, rel=1e-12)
    assert scurve_time(-D, V, A, J) == scurve_time(D, V, A, J)  # direction does not matter


def test_scurve_time_printed_numbers() -> None:
    assert scurve_time(2.0, V, A, J) == pytest.approx(1.1416666666666667, rel=1e-12)
    assert scurve_time(0.5, V, A, J) == pytest.approx(0.6099019513592785, rel=1e-12)
    assert scurve_time(0.16, V, A, J) == pytest.approx(0.4, rel=1e-12)
    assert scurve_time(0.1, V, A, J) == pytest.approx(0.3419951893353394, rel=1e-12)
    assert scurve_time(0.0, V, A, J) == 0.0


def test_scurve_time_when_acceleration_limit_is_never_reached() -> None:
    """v < a^2 / j (1 < 8^2 / 20): the cruise formula uses 2 sqrt(v / j), short moves are pure jerk."""
    v, a, j = 1.0, 8.0, 20.0
    edge = 2 * v * math.sqrt(v / j)
    assert scurve_time(1.0, v, a, j) == pytest.approx(1.0 / v + 2 * math.sqrt(v / j), rel=1e-12)
    assert scurve_time(edge, v, a, j) == pytest.approx(2 * edge / v, rel=1e-9)
    assert scurve_time(0.2, v, a, j) == pytest.approx((32 * 0.2 / j) ** (1 / 3), rel=1e-12)


def test_scurve_time_is_continuous_and_increasing() -> None:
    D = np.linspace(0.0, 4.0, 4001)
    T = np.array([scurve_time(d, V, A, J) for d in D])
    assert (np.diff(T) > 0).all()
    # no jump where the regime changes: a reached at D = 2 a^3 / j^2, cruise from v (v/a + a/j)
    for edge in (2 * A**3 / J**2, V * (V / A + A / J)):
        below, above = scurve_time(edge * (1 - 1e-10), V, A, J), scurve_time(edge * (1 + 1e-10), V, A, J)
        assert 0 < above - below < 1e-8


def test_scurve_is_never_slower_than_needed_but_never_beats_the_trapezoid() -> None:
    """Cross-check with two other timing laws: with jerk unlimited the S-curve becomes the
    time-optimal trapezoid (D / v + v / a or 2 sqrt(D / a)); the lesson's cubic keeps the same
    v and a limits, so it can never be faster than that trapezoid."""
    for D in np.linspace(0.01, 5.0, 60):
        trapezoid = D / V + V / A if D >= V * V / A else 2 * math.sqrt(D / A)
        assert scurve_time(D, V, A, 1e12) == pytest.approx(trapezoid, rel=1e-5)
        assert scurve_time(D, V, A, J) >= trapezoid - 1e-12
        assert cubic_min_time([D], [V], [A]) >= trapezoid - 1e-12


# --------------------------------------------------------------------------- SCurve moves
LIM = st.tuples(st.floats(0.5, 5.0), st.floats(1.0, 20.0), st.floats(5.0, 200.0))
POSE = st.tuples(st.floats(-3.0, 3.0), st.floats(-3.0, 3.0))


def sample(move: SCurve, n: int = 6001):
    t = np.linspace(0.0, move.duration, n)
    return t, move.derivatives(t)


@settings(max_examples=40, deadline=None)
@given(q0=POSE, q1=POSE, l0=LIM, l1=LIM)
def test_scurve_move_respects_limits_and_ends_at_rest(q0, q1, l0, l1) -> None:
    vmax, amax, jmax = (l0[0], l1[0]), (l0[1], l1[1]), (l0[2], l1[2])
    move = SCurve.between(q0, q1, vmax, amax, jmax)
    assert move.duration == pytest.approx(move_lower_bound(q0, q1, vmax, amax, jmax), rel=1e-12)
    assert move.duration == max(scurve_time(b - a, *lim) for a, b, lim in zip(q0, q1, (l0, l1)))
    if move.duration == 0.0:
        return
    t, (p, v, a, j) = sample(move)
    tol = 1 + 1e-9
    assert (np.abs(v) <= np.asarray(vmax) * tol).all()
    assert (np.abs(a) <= np.asarray(amax) * tol).all()
    assert (np.abs(j) <= np.asarray(jmax) * tol).all()
    # starts at q0 and ends exactly at q1, at rest
    np.testing.assert_array_equal(p[-1], q1)
    np.testing.assert_array_equal(v[-1], [0.0, 0.0])
    np.testing.assert_array_equal(a[-1], [0.0, 0.0])
    np.testing.assert_allclose(p[0], q0, atol=1e-15)
    np.testing.assert_allclose(v[0], 0.0, atol=1e-15)
    # the profile just before the end already agrees with q1 (no jump onto the end pose)
    np.testing.assert_allclose(move.eval(np.array([move.duration * (1 - 1e-9)]))[0], q1, atol=1e-6)
    # monotone, no overshoot: every joint stays between q0 and q1
    lo, hi = np.minimum(q0, q1), np.maximum(q0, q1)
    assert (p >= lo - 1e-12).all() and (p <= hi + 1e-12).all()
    # derivatives are consistent with each other (trapezoid integration)
    dt = t[1] - t[0]
    np.testing.assert_allclose(np.cumsum((v[1:] + v[:-1]) / 2, axis=0) * dt, p[1:] - p[0], atol=1e-4)
    np.testing.assert_allclose(np.cumsum((a[1:] + a[:-1]) / 2, axis=0) * dt, v[1:] - v[0], atol=2e-3)
    assert (move.eval(t + move.duration) == np.asarray(q1)).all()  # held after the end


def test_scurve_slowest_joint_is_bang_bang() -> None:
    """Time-optimality witness: on the joint that sets the duration, at every instant one limit
    is active (|jerk| = j, or |acc| = a with zero jerk, or |vel| = v during the cruise)."""
    q0, q1 = (-1.0, 0.3), (1.5, -0.2)  # joint 0 moves 2.5 rad: cruise regime
    move = SCurve.between(q0, q1, (3.0, 4.0), (8.0, 12.0), (80.0, 120.0))
    assert move.duration == pytest.approx(2.5 / 3 + 3 / 8 + 8 / 80, rel=1e-12)
    t, (p, v, a, j) = sample(move, 4001)
    t, v, a, j = t[1:-1], v[1:-1, 0], a[1:-1, 0], j[1:-1, 0]
    active = np.isclose(np.abs(j), 80.0) | np.isclose(np.abs(a), 8.0) | np.isclose(np.abs(v), 3.0)
    assert active.all()
    assert np.isclose(np.abs(v), 3.0).any() and np.isclose(np.abs(a), 8.0).any()
    # peaks hit the limits exactly
    assert np.abs(v).max() == pytest.approx(3.0, rel=1e-9)
    assert np.abs(a).max() == pytest.approx(8.0, rel=1e-9)


def test_scurve_faster_joint_is_slowed_to_finish_together() -> None:
    move = SCurve.between((0.0, 0.0), (2.0, 0.2), (3.0, 4.0), (8.0, 12.0), (80.0, 120.0))
    assert move.duration == pytest.approx(scurve_time(2.0, 3.0, 8.0, 80.0), rel=1e-12)
    t, (p, v, a, j) = sample(move)
    moving = np.abs(v) > 1e-9
    # both joints move over the same interval: neither finishes early and waits
    first = [t[moving[:, i]].min() for i in range(2)]
    last = [t[moving[:, i]].max() for i in range(2)]
    assert max(first) < 0.01 and min(last) > move.duration - 0.01
    # joint 1's own optimal time is much shorter: it is slowed, staying well inside its limits
    assert scurve_time(0.2, 4.0, 12.0, 120.0) < 0.6 * move.duration
    assert np.abs(v[:, 1]).max() < 4.0 and np.abs(a[:, 1]).max() < 12.0


def test_scurve_zero_move() -> None:
    move = SCurve.between((0.5, -0.5), (0.5, -0.5), (3.0, 4.0), (8.0, 12.0), (80.0, 120.0))
    assert move.duration == 0.0
    np.testing.assert_array_equal(move.eval(np.array([0.0, 1.0])), [[0.5, -0.5], [0.5, -0.5]])
    assert move_lower_bound((0.5, -0.5), (0.5, -0.5), (3.0, 4.0), (8.0, 12.0), (80.0, 120.0)) == 0.0


@settings(max_examples=40, deadline=None)
@given(q0=POSE, q1=POSE, l0=LIM, l1=LIM)
# found by CI: joint 2's accel and cruise phases were 1e-16 s of round-off, reported as switches
@example(q0=(0.0, 2.8125), q1=(1.0, 1.3125), l0=(1.0, 1.0, 5.0), l1=(2.0, 5.0, 10.0))
# joint 2 moves 5e-324 rad: its slowed jerk underflows to zero, so it has no switches
@example(q0=(0.0, 5e-324), q1=(2.0, 0.0), l0=(1.0, 1.0, 5.0), l1=(1.0, 1.0, 5.0))
def test_jerk_is_constant_between_switch_times(q0, q1, l0, l1) -> None:
    """Between two switch times every joint's jerk is constant (what lets a grid with a knot
    at each switch represent the move exactly), and there is no more than 6 per joint."""
    move = SCurve.between(q0, q1, (l0[0], l1[0]), (l0[1], l1[1]), (l0[2], l1[2]))
    sw = move.switch_times()
    assert sw.size <= 12 and (np.diff(sw) > 0).all()
    if move.duration == 0.0:
        assert sw.size == 0
        return
    assert (sw > 0).all() and (sw < move.duration).all()
    edges = np.r_[0.0, sw, move.duration]
    for a, b in zip(edges[:-1], edges[1:]):
        if b - a < 1e-7:
            continue
        t = a + (b - a) * np.array([1e-3, 0.25, 0.5, 0.75, 1 - 1e-3])
        j = move.derivatives(t)[3]
        np.testing.assert_allclose(j, np.broadcast_to(j[2], j.shape), rtol=1e-9, atol=1e-9)
    # ... and at each switch some joint's jerk changes, or some joint is at its peak velocity
    # (acceleration zero, between its accelerating and decelerating halves)
    eps = 1e-7
    for s in sw:
        if min(s - edges[edges < s].max(), edges[edges > s].min() - s) < 10 * eps:
            continue
        d = move.derivatives(np.array([s - eps, s, s + eps]))
        jump = np.abs(d[3][2] - d[3][0]).max() > 0.0
        peak = (np.abs(d[2][1]) <= 1e-6 * np.array([l0[1], l1[1]])).any() and (np.abs(d[1][1]) > 0).any()
        assert jump or peak
    # the peak-velocity instant of the slowest joint is a switch even without a cruise phase
    slow = int(np.argmax([sum(p[0]) for p in move.profiles]))
    peak_t = float(np.cumsum(move.profiles[slow][0])[2])
    if 1e-9 < peak_t < move.duration - 1e-9:
        assert np.abs(sw - peak_t).min() < 1e-9


@settings(max_examples=200, deadline=None)
@given(st.tuples(st.floats(-3.2, 3.2), st.floats(-3.2, 3.2)), st.tuples(st.floats(-3.2, 3.2), st.floats(-3.2, 3.2)))
def test_sync_duration_is_the_scurve_duration(q0, q1) -> None:
    """The remembered duration the allocation's programmes use is exactly the S-curve's, for
    float joint values and for NumPy arrays of them."""
    lim = ((3.0, 4.0), (10.0, 12.0), (80.0, 120.0))
    want = SCurve.between(q0, q1, *lim).duration
    assert sync_duration(q0, q1, *lim) == want
    assert sync_duration(np.array(q0), np.array(q1), *lim) == want


def test_trajectory_states_are_ruckigs_own_at_time_bit_for_bit():
    """The vectorised sampler of a Ruckig trajectory (used by the row's legs and the live cell's
    approaches) gives exactly Ruckig's ``at_time`` on seeded random moves: from rest and from
    states beyond the limits (a brake pre-trajectory), few samples and many."""
    from coplan.kinematics.timing import ruckig_move, trajectory_states

    rng = np.random.default_rng(7)
    braked = 0
    for it in range(300):
        vmax, amax, jmax = rng.uniform(0.5, 3, 2), rng.uniform(1, 10, 2), rng.uniform(5, 100, 2)
        start = np.array([rng.uniform(-3, 3, 2), rng.uniform(-1.6, 1.6, 2) * vmax * (it % 2), rng.uniform(-1, 1, 2) * amax * (it % 3 == 0)])
        end = np.array([rng.uniform(-3, 3, 2), rng.uniform(-0.8, 0.8, 2) * vmax * (it % 4 == 0), np.zeros(2)])
        traj = ruckig_move(start, end, vmax, amax, jmax)
        braked += any(p.brake.duration > 0 for p in traj.profiles[0])
        for k in (5, 150):
            ts = np.r_[0.0, rng.uniform(0.0, traj.duration, k - 1)]
            want = np.array([traj.at_time(float(x)) for x in ts]).transpose(1, 0, 2)
            assert np.array_equal(trajectory_states(traj, ts), want)
    assert braked > 20


def test_timing_functions_refuse_what_is_not_a_move_expected_and_found():
    """(From a user's trial: scurve_time(nan, 1, 1, 1) gave 4.0 s and scurve_time(1, nan, 1, 1)
    3.17 s, move_lower_bound with a NaN pose 4.0 s, a zero limit a ZeroDivisionError, a negative
    one 'math domain error', SCurve.between of 3 joints against 2 cut them to 2.)"""
    import math

    from coplan.kinematics import SCurve, move_lower_bound, scurve_time

    for args in ((math.nan, 1, 1, 1), (1.0, math.nan, 1, 1), (1.0, 0, 1, 1), (1.0, -1, 1, 1), (math.inf, 1, 1, 1)):
        with pytest.raises(ValueError, match="scurve_time: expected a finite distance and finite limits v, a, j > 0"):
            scurve_time(*args)
    with pytest.raises(ValueError, match="scurve_time"):
        move_lower_bound([0, 0], [math.nan, 1], [1, 1], [1, 1], [1, 1])
    with pytest.raises(ValueError, match="move_lower_bound: expected one value per joint"):
        move_lower_bound([0, 0], [1, 1], [1, 1, 1], [1, 1], [1, 1])
    with pytest.raises(ValueError, match="SCurve.between: expected one value per joint .* found 3, 2, 2, 2, 2"):
        SCurve.between([0, 0, 0], [1, 1], [1, 1], [1, 1], [1, 1])
    assert scurve_time(-1.0, 1, 1, 1) == scurve_time(1.0, 1, 1, 1) > 0 and scurve_time(0.0, 1, 1, 1) == 0.0


def _profile_phase_by_phase(durs, jerks, t):
    """The profile evaluated phase by phase with a mask each (the way ``_profile`` did before it
    sorted the times into phases with one ``searchsorted``): the reference it must equal, bit for bit."""
    t = np.clip(np.asarray(t, float), 0.0, float(sum(durs)))
    out = [np.zeros_like(t) for _ in range(4)]
    p = v = acc = t0 = 0.0
    for k, (d, jk) in enumerate(zip(durs, jerks)):
        m = (t >= t0) & ((t < t0 + d) | (k == len(durs) - 1))
        tau = t[m] - t0
        out[0][m] = p + v * tau + acc * tau**2 / 2 + jk * tau**3 / 6
        out[1][m] = v + acc * tau + jk * tau**2 / 2
        out[2][m] = acc + jk * tau
        out[3][m] = jk
        p, v, acc = p + v * d + acc * d**2 / 2 + jk * d**3 / 6, v + acc * d + jk * d**2 / 2, acc + jk * d
        t0 += d
    return out


def test_the_profile_sorted_into_phases_is_the_phase_by_phase_one_bit_for_bit() -> None:
    """Seeded random S-curves (short moves whose phases vanish, zero moves, times before, at every
    phase boundary and past the end): position, velocity, acceleration and jerk equal the masked
    phase-by-phase evaluation to the bit, signs of zero included."""
    from coplan.kinematics.timing import _profile

    rng = np.random.default_rng(7)
    checked = 0
    for trial in range(1500):
        q0 = rng.uniform(-3, 3, 2)
        q1 = q0 + rng.uniform(-3, 3, 2) * rng.choice([0.0, 1e-3, 0.05, 1.0])
        sc = SCurve.between(q0, q1, (1.5, 2.0), (3.0, 4.0), (20.0, 30.0))
        for durs, jerks in sc.profiles:
            T = float(sum(durs))
            t = np.concatenate([rng.uniform(-0.1, T + 0.1, 40), np.cumsum(durs), [0.0, T]])
            for got, ref in zip(_profile(durs, jerks, t), _profile_phase_by_phase(durs, jerks, t)):
                assert np.array_equal(got, ref) and np.array_equal(np.signbit(got), np.signbit(ref))
            checked += bool(durs)
    assert checked > 1000
