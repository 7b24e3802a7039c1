"""The widening stage's start: each arm's rest spread over its moves (``coplan.planners.optimal.ease``)."""

from __future__ import annotations

import numpy as np
import pytest

from coplan.generate import overlap_problem, to_yaml
from coplan.kinematics.timing import SCurve
from coplan.planners.coordinated import plan_coordinated
from coplan.planners.coordinated.schedule import StepKind
from coplan.planners.optimal.ease import ease, jerk_integral
from coplan.planners.optimal.windows import min_clearance
from coplan.problem import parse_problem


@pytest.mark.parametrize("stretch", [1.0, 1.3, 2.0])
def test_the_jerk_integral_of_a_move_is_its_numerical_integral_and_falls_as_the_fifth_power(stretch):
    """Analytic against numeric: the integral of the squared jerk of both joints over the move,
    and a move slowed uniformly by s has 1/s^5 of it."""
    c = SCurve.between((0.1, -0.4), (1.3, 0.5), (2.0, 3.0), (6.0, 9.0), (40.0, 60.0))
    slow = SCurve(c.q0, c.q1, c.profiles, c.duration * stretch)
    t = np.linspace(0.0, slow.duration, 400_001)
    j = slow.derivatives(t)[3]
    numeric = float(np.sum(j[:-1] ** 2) * (t[1] - t[0]))
    assert jerk_integral(slow) == pytest.approx(numeric, rel=1e-3)
    assert jerk_integral(slow) == pytest.approx(jerk_integral(c) / stretch**5, rel=1e-9)


@pytest.mark.parametrize("seed", [0, 4, 19])
def test_eased_schedules_keep_every_event_order_limit_and_room_and_have_less_jerk(seed):
    """Seeded interference-heavy layouts: the eased schedules keep each pick and place as long,
    in the same order across arms, the last place by the makespan and the plan's end; no move is
    shorter, so every limit holds (checked on the samples); the least room between neighbours
    is no smaller (nor than the room kept); and no arm's jerk integral grows."""
    n = 2 + seed % 2
    prob = parse_problem(to_yaml(overlap_problem(n_arms=n, n_fruits=3 * n, spacing=1.4, seed=100 + seed)), f"s{seed}")
    cand = plan_coordinated(prob).candidate
    sch = cand.schedules
    makespan = max(s.last_place for s in sch.values())
    end = max(s.end for s in sch.values())
    eased, report = ease(prob, sch, makespan, keep=0.10)
    events = lambda ss: sorted((e.t_start, e.arm, e.fruit, e.kind.value) for s in ss.values() for e in s.events())  # noqa: E731
    before, after = events(sch), events(eased)
    assert [x[1:] for x in before] == [x[1:] for x in after]  # the same events, in the same order
    dur = {(e.arm, e.fruit, e.kind): e.t_end - e.t_start for s in sch.values() for e in s.events()}
    for s in eased.values():
        for e in s.events():
            assert e.t_end - e.t_start == pytest.approx(dur[(e.arm, e.fruit, e.kind)], abs=1e-12)
    assert max(s.last_place for s in eased.values()) <= makespan + 1e-9
    assert max(s.end for s in eased.values()) <= end + 1e-9
    t = np.arange(0.0, end, 1e-3)
    for name, s in eased.items():
        arm = s.arm
        q, qd, qdd = s.state(t)
        assert np.all(np.abs(qd) <= np.asarray(arm.max_velocity) * (1 + 1e-9))
        assert np.all(np.abs(qdd) <= np.asarray(arm.max_acceleration) * (1 + 1e-9))
        moves = [st for st in s.steps if st.kind == StepKind.MOVE]
        assert all(st.duration >= o.duration - 1e-12 for st, o in zip(moves, [m for m in sch[name].steps if m.kind == StepKind.MOVE]))
        j0 = sum(jerk_integral(st.curve) for st in sch[name].steps if st.kind == StepKind.MOVE)
        j1 = sum(jerk_integral(st.curve) for st in moves)
        assert j1 <= j0 * (1 + 1e-12)
        if name in report["arms"]:
            assert report["rms_jerk_ratio"][name] == pytest.approx(np.sqrt(j1 / j0))
    room0 = min_clearance(prob, {n_: s.state(t)[0] for n_, s in sch.items()})
    room1 = min_clearance(prob, {n_: s.state(t)[0] for n_, s in eased.items()})
    assert room1 >= min(room0, prob.task.clearance + 0.10) - 1e-9
    assert report["arms"]  # some arm had rest to spread on each of these layouts
