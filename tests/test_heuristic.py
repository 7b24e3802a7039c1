"""The heuristic baseline planner reproduces the lesson, made time-aware."""

from __future__ import annotations

import math

import numpy as np
import pytest

from coplan import kinematics as kin
from coplan.allocate.allocation import AllocationMethod, allocate
from coplan.generate import row_problem, to_yaml
from coplan.planners.heuristic import plan_heuristic
from coplan.plan import EventKind, Plan, PlannerKind, PlanStatus
from coplan.problem import Problem, parse_problem
from coplan.kinematics import cubic_min_time


# --------------------------------------------------------------------------- the lesson, re-implemented
class LessonRobot2R:
    """The course's ``Robot2R`` (only what allocation needs), transcribed from the lesson."""

    def __init__(self, L1=1.0, L2=0.8, base=(0.0, 0.0), joint_limits=((-np.pi, np.pi), (-np.pi + 0.1, np.pi - 0.1))):
        self.L1, self.L2 = L1, L2
        self.base = np.array(base)
        self.joint_limits = joint_limits
        self.r_outer = L1 + L2
        self.r_inner = abs(L1 - L2)

    def inverse_kinematics(self, target, elbow_up=True):
        px = target[0] - self.base[0]
        py = target[1] - self.base[1]
        r_sq = px**2 + py**2
        r = np.sqrt(r_sq)
        if r > self.r_outer - 0.01 or r < self.r_inner + 0.01:
            return None
        cos_t2 = (r_sq - self.L1**2 - self.L2**2) / (2 * self.L1 * self.L2)
        cos_t2 = np.clip(cos_t2, -1.0, 1.0)
        sin_t2 = np.sqrt(1 - cos_t2**2)
        if not elbow_up:
            sin_t2 = -sin_t2
        t2 = np.arctan2(sin_t2, cos_t2)
        t1 = np.arctan2(py, px) - np.arctan2(self.L2 * sin_t2, self.L1 + self.L2 * cos_t2)
        q_sol = np.array([t1, t2])
        for i, (lo, hi) in enumerate(self.joint_limits):
            if q_sol[i] < lo or q_sol[i] > hi:
                return None
        return q_sol

    def jacobian(self, q):
        t1, t2 = q
        s1, c1, s12, c12 = np.sin(t1), np.cos(t1), np.sin(t1 + t2), np.cos(t1 + t2)
        return np.array([[-self.L1 * s1 - self.L2 * s12, -self.L2 * s12], [self.L1 * c1 + self.L2 * c12, self.L2 * c12]])

    def manipulability(self, q):
        return abs(np.linalg.det(self.jacobian(q)))

    def is_in_workspace(self, target):
        r = np.hypot(target[0] - self.base[0], target[1] - self.base[1])
        return self.r_inner < r < self.r_outer


def lesson_allocate_fruit(robots, fruit_positions):
    """``HarvestingCell.allocate_fruit`` from the lesson: best manipulability / (distance + 0.1)."""
    assignments = {i: [] for i in range(len(robots))}
    for k, fruit in enumerate(fruit_positions):
        best_robot, best_score = None, -1
        for i, robot in enumerate(robots):
            if not robot.is_in_workspace(fruit):
                continue
            q_sol = robot.inverse_kinematics(fruit)
            if q_sol is None:
                continue
            score = robot.manipulability(q_sol) / (np.linalg.norm(fruit - robot.base) + 0.1)
            if score > best_score:
                best_score, best_robot = score, i
        if best_robot is not None:
            assignments[best_robot].append(k)
    return assignments


def lesson_cell_fruit() -> list[np.ndarray]:
    np.random.seed(42)
    fx = np.random.uniform(-3.5, 3.5, 12)
    fy = np.random.uniform(0.5, 1.8, 12)
    return [np.array([x, y]) for x, y in zip(fx, fy)]


# --------------------------------------------------------------------------- allocation
LESSON_ALLOCATION = {
    "left": ("f05", "f06", "f07", "f11"),
    "center": ("f04", "f09"),
    "right": ("f02", "f03", "f08", "f10", "f12"),
}


def test_lesson_allocation_on_greenhouse_row(greenhouse: Problem) -> None:
    alloc = allocate(greenhouse, AllocationMethod.HEURISTIC)
    assert alloc.assignment == LESSON_ALLOCATION
    assert alloc.unreachable == ("f01",)
    assert {a: len(v) for a, v in alloc.assignment.items()} == {"left": 4, "center": 2, "right": 5}


def test_allocation_matches_the_lessons_own_code(greenhouse: Problem) -> None:
    """The lesson's HarvestingCell on the lesson's exact (unrounded) fruit gives the same split."""
    robots = [LessonRobot2R(base=(x, 0.0)) for x in (-2.0, 0.0, 2.0)]
    lesson = lesson_allocate_fruit(robots, lesson_cell_fruit())
    ids = [f.id for f in greenhouse.fruits]
    got = {name: [ids[k] for k in lesson[i]] for i, name in enumerate(("left", "center", "right"))}
    assert got == {k: list(v) for k, v in LESSON_ALLOCATION.items()}
    assigned = {k for v in lesson.values() for k in v}
    assert [ids[k] for k in range(12) if k not in assigned] == ["f01"]


def test_allocation_matches_the_lessons_code_on_random_rows() -> None:
    """Same rule on 8 random rows (fruit above the bases, as in the lesson's cell)."""
    checked = 0
    for seed in range(8):
        prob = parse_problem(to_yaml(row_problem(3 + seed % 3, 15, spacing=1.6 + 0.1 * seed, seed=seed)))
        robots = [
            LessonRobot2R(a.links[0], a.links[1], a.base, a.joint_limits) for a in prob.arms
        ]
        lesson = lesson_allocate_fruit(robots, list(prob.fruit_positions))
        alloc = allocate(prob, AllocationMethod.HEURISTIC)
        for i, arm in enumerate(prob.arms):
            assert list(alloc.assignment[arm.name]) == [prob.fruits[k].id for k in lesson[i]]
            checked += len(lesson[i])
    assert checked > 60


def test_allocation_uses_the_elbow_up_branch(greenhouse: Problem) -> None:
    alloc = allocate(greenhouse, AllocationMethod.HEURISTIC)
    for arm in greenhouse.arms:
        for fid, q in alloc.fruit_q[arm.name].items():
            assert q[1] >= 0  # branch 0, as the lesson's IK(elbow_up=True)
            lesson_q = LessonRobot2R(base=arm.base).inverse_kinematics(np.array(greenhouse.fruit(fid).position))
            np.testing.assert_allclose(q, lesson_q, atol=1e-12)


# --------------------------------------------------------------------------- the plan
@pytest.fixture(scope="module")
def plan(greenhouse: Problem) -> Plan:
    return plan_heuristic(greenhouse)


def _segments(problem: Problem, plan: Plan, arm_name: str):
    """(t_start, t_end, q_from, q_to) of every move of an arm, rebuilt from its events:
    home -> fruit -> bin -> home for each fruit in order."""
    arm = problem.arm(arm_name)
    home = np.asarray(arm.home)
    evs = plan.events_of(arm_name)
    moves = []
    t, q = 0.0, home
    for pick, place in zip(evs[::2], evs[1::2]):
        q_f = _q_at(plan, arm_name, (pick.t_start + pick.t_end) / 2)
        q_b = _q_at(plan, arm_name, (place.t_start + place.t_end) / 2)
        moves.append((t, pick.t_start, q, q_f))
        moves.append((pick.t_end, place.t_start, q_f, q_b))
        t_home = place.t_end + cubic_min_time(home - q_b, arm.max_velocity, arm.max_acceleration)
        moves.append((place.t_end, t_home, q_b, home))
        t, q = t_home, home
    return moves


def _q_at(plan: Plan, arm: str, t: float) -> np.ndarray:
    i = int(np.argmin(np.abs(plan.time - t)))
    return plan.q[arm][i]


def test_plan_basics(greenhouse: Problem, plan: Plan) -> None:
    assert plan.planner == PlannerKind.HEURISTIC and plan.status == PlanStatus.UNVERIFIED
    assert plan.allocation == {k: list(v) for k, v in LESSON_ALLOCATION.items()}
    assert plan.unreachable == ["f01"]
    assert plan.metrics["harvested"] == 11 and plan.metrics["reachable"] == 11
    # uniform 100 Hz grid from 0
    assert plan.time[0] == 0.0
    np.testing.assert_allclose(np.diff(plan.time), 0.01, atol=1e-12)
    for arm in greenhouse.arms:
        assert plan.q[arm.name].shape == (plan.time.size, 2)
        np.testing.assert_array_equal(plan.q[arm.name][0], arm.home)  # all start at home at t = 0
        np.testing.assert_allclose(plan.q[arm.name][-1], arm.home)  # and end there
    assert plan.metrics["makespan"] == max(e.t_end for e in plan.events if e.kind == EventKind.PLACE)


def test_events_follow_the_allocation_with_the_dwells(greenhouse: Problem, plan: Plan) -> None:
    for arm, fruit in LESSON_ALLOCATION.items():
        evs = plan.events_of(arm)
        assert [(e.fruit, e.kind) for e in evs] == [(f, k) for f in fruit for k in (EventKind.PICK, EventKind.PLACE)]
        for e in evs:
            dwell = greenhouse.task.pick_dwell if e.kind == EventKind.PICK else greenhouse.task.place_dwell
            assert e.t_end - e.t_start == pytest.approx(dwell, abs=1e-12)
        assert all(a.t_end <= b.t_start for a, b in zip(evs, evs[1:]))


def test_segment_durations_are_the_shortest_cubic_times(greenhouse: Problem, plan: Plan) -> None:
    for arm_name in LESSON_ALLOCATION:
        arm = greenhouse.arm(arm_name)
        moves = _segments(greenhouse, plan, arm_name)
        assert len(moves) == 3 * len(LESSON_ALLOCATION[arm_name])
        for t0, t1, qa, qb in moves:
            T = cubic_min_time(np.subtract(qb, qa), arm.max_velocity, arm.max_acceleration)
            assert t1 - t0 == pytest.approx(T, abs=1e-9)
            assert T > 0.3  # real moves, not degenerate


def test_each_move_hits_its_binding_limit_from_the_samples(greenhouse: Problem, plan: Plan) -> None:
    """Peak velocity (1.5 D / T) or acceleration (6 D / T^2) of the binding joint equals its limit,
    measured by finite differences on the 100 Hz samples strictly inside each move."""
    dt = plan.dt
    n_vel = n_acc = 0
    for arm_name in LESSON_ALLOCATION:
        arm = greenhouse.arm(arm_name)
        vmax, amax = np.array(arm.max_velocity), np.array(arm.max_acceleration)
        q = plan.q[arm_name]
        for t0, t1, qa, qb in _segments(greenhouse, plan, arm_name):
            T = t1 - t0
            d = np.abs(np.subtract(qb, qa))
            # which joint and which limit sets T
            tv, ta = 1.5 * d / vmax, np.sqrt(6 * d / amax)
            k = int(np.argmax(np.maximum(tv, ta)))
            inner = np.flatnonzero((plan.time > t0 + dt * (1 + 1e-9)) & (plan.time < t1 - dt * (1 + 1e-9)))
            vel = (q[inner + 1] - q[inner - 1]) / (2 * dt)
            acc = (q[inner + 1] - 2 * q[inner] + q[inner - 1]) / dt**2
            # never above the limits (the cubic's second difference is exact: no slack needed)
            assert (np.abs(vel) <= vmax * (1 + 1e-6)).all()
            assert (np.abs(acc) <= amax * (1 + 1e-6)).all()
            if tv[k] >= ta[k]:  # velocity-bound: peak at mid-move, error O((dt / T)^2)
                assert np.abs(vel[:, k]).max() == pytest.approx(vmax[k], rel=2e-3)
                n_vel += 1
            else:  # acceleration-bound: peak at the ends, first full stencil within 2 dt
                peak = np.abs(acc[:, k]).max()
                assert amax[k] * (1 - 4 * dt / T) - 1e-9 <= peak <= amax[k] * (1 + 1e-9)
                n_acc += 1
    assert n_acc > 0  # the greenhouse moves are mostly acceleration-bound


def test_pick_and_place_tips_are_on_target_and_still(greenhouse: Problem, plan: Plan) -> None:
    for e in plan.events:
        arm = greenhouse.arm(e.arm)
        m = (plan.time >= e.t_start) & (plan.time <= e.t_end)
        assert m.sum() >= int(0.2 / plan.dt) - 1
        q = plan.q[e.arm][m]
        assert np.ptp(q, axis=0).max() == 0.0  # still
        _, tip = kin.fk(q, arm.links, arm.base)
        target = greenhouse.fruit(e.fruit).position if e.kind == EventKind.PICK else arm.bin
        assert np.abs(tip - np.asarray(target)).max() < 1e-9
        # and inside the joint limits
        assert (q >= arm.limits[:, 0]).all() and (q <= arm.limits[:, 1]).all()


def test_heuristic_is_deterministic(greenhouse: Problem, plan: Plan) -> None:
    again = plan_heuristic(greenhouse)
    assert again.events == plan.events
    for a in plan.q:
        np.testing.assert_array_equal(again.q[a], plan.q[a])


# --------------------------------------------------------------------------- the single-arm demo
def test_single_arm_reproduces_the_lesson_demo(single_arm: Problem) -> None:
    """home (pi/4, pi/4) -> pick (1.2, 0.8) -> place (-0.5, 1.0) -> home, each a lesson cubic."""
    plan = plan_heuristic(single_arm)
    arm = single_arm.arms[0]
    robot = LessonRobot2R()
    home = np.array([0.7854, 0.7854])
    q_pick = robot.inverse_kinematics(np.array([1.2, 0.8]))
    q_place = robot.inverse_kinematics(np.array([-0.5, 1.0]))
    pick, place = plan.events
    assert (pick.kind, pick.fruit, place.kind) == (EventKind.PICK, "pick", EventKind.PLACE)
    np.testing.assert_allclose(_q_at(plan, "arm", (pick.t_start + pick.t_end) / 2), q_pick, atol=1e-12)
    np.testing.assert_allclose(_q_at(plan, "arm", (place.t_start + place.t_end) / 2), q_place, atol=1e-12)
    np.testing.assert_array_equal(plan.q["arm"][0], home)
    np.testing.assert_allclose(plan.q["arm"][-1], home, atol=1e-12)
    # segment times: shortest cubics, dwells in between
    T1 = cubic_min_time(q_pick - home, arm.max_velocity, arm.max_acceleration)
    T2 = cubic_min_time(q_place - q_pick, arm.max_velocity, arm.max_acceleration)
    T3 = cubic_min_time(home - q_place, arm.max_velocity, arm.max_acceleration)
    assert pick.t_start == pytest.approx(T1, abs=1e-12)
    assert place.t_start == pytest.approx(T1 + 0.3 + T2, abs=1e-12)
    assert plan.duration == pytest.approx(math.ceil((T1 + 0.3 + T2 + 0.2 + T3) * 100 - 1e-9) / 100, abs=1e-12)
    assert plan.metrics["makespan"] == pytest.approx(T1 + 0.3 + T2 + 0.2, abs=1e-12)
    # the first segment is the lesson's cubic_trajectory s = 3 tau^2 - 2 tau^3 from home to the pick
    m = plan.time <= T1
    tau = plan.time[m] / T1
    lesson = home + (3 * tau**2 - 2 * tau**3)[:, None] * (q_pick - home)
    np.testing.assert_allclose(plan.q["arm"][m], lesson, atol=1e-12)
    # the tip passes through the lesson's targets
    _, tip = kin.fk(plan.q["arm"], arm.links, arm.base)
    assert np.linalg.norm(tip - [1.2, 0.8], axis=1).min() < 1e-9
    assert np.linalg.norm(tip - [-0.5, 1.0], axis=1).min() < 1e-9


@pytest.mark.parametrize("dwell", [0.3001, 0.2103, 0.305])
def test_the_baselines_dwells_hold_on_the_samples_whatever_their_length(dwell: float) -> None:
    """A dwell that is no whole number of samples (0.3001 s) was held 0.290 s on the plan's
    100 Hz grid -- a pick_dwell violation the course's method does not make: each dwell now lasts
    the whole samples that cover it (0.31 s), on the fruit and on the bin, which the verifier
    passes; a dwell on the grid keeps its own length."""
    from coplan.verify import ViolationKind, verify

    d = row_problem(n_arms=2, n_fruits=4, seed=1)
    d["task"]["pick_dwell"] = d["task"]["place_dwell"] = dwell
    prob = parse_problem(to_yaml(d), "dwell")
    plan = plan_heuristic(prob)
    ver = verify(prob, plan)
    assert not [v for v in ver.violations if v.kind in (ViolationKind.PICK_DWELL, ViolationKind.PLACE_DWELL)]
    held = {round(e.t_end - e.t_start, 9) for e in plan.events}
    assert held == {math.ceil(dwell * 100 - 1e-9) / 100}
