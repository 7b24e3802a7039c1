"""Decoupled time-optimal schedules and conflict removal by waiting (the optimiser's warm start).

An :class:`ArmSchedule` is a list of :class:`Step` s (rest-to-rest S-curve moves and holds).
:func:`decoupled_schedules` gives each arm its fastest schedule for an allocation: every move
is a per-joint time-optimal S-curve, so each arm alone meets the makespan lower bound's move
times. :func:`remove_conflicts` then delays moves (prioritised planning: the arm with more
slack waits) until no two neighbouring arms come closer than the clearance plus a margin.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from . import kinematics as kin
from .allocate import Allocation
from .geometry import segment_distance
from .plan import Event, EventKind
from .problem import Arm, Problem
from .timing import SCurve

__all__ = ["StepKind", "Step", "ArmSchedule", "decoupled_schedules", "remove_conflicts", "pair_distances"]


class StepKind(str, Enum):
    MOVE = "move"
    PICK = "pick"
    PLACE = "place"
    WAIT = "wait"


@dataclass(frozen=True)
class Step:
    kind: StepKind
    t0: float
    duration: float
    q0: tuple[float, float]
    q1: tuple[float, float]
    fruit: str | None = None
    curve: SCurve | None = None

    @property
    def t1(self) -> float:
        return self.t0 + self.duration


@dataclass
class ArmSchedule:
    arm: Arm
    steps: list[Step] = field(default_factory=list)

    @property
    def end(self) -> float:
        return self.steps[-1].t1 if self.steps else 0.0

    @property
    def last_place(self) -> float:
        return max((s.t1 for s in self.steps if s.kind == StepKind.PLACE), default=0.0)

    def state(self, t) -> np.ndarray:
        """Joint position, velocity, acceleration at times ``t`` (K,) -> (3, K, 2)."""
        t = np.asarray(t, float)
        out = np.zeros((3, t.size, 2))
        out[0] = np.asarray(self.arm.home, float)
        for s in self.steps:
            m = (t >= s.t0) & (t <= s.t1)
            if s.kind == StepKind.MOVE and s.curve is not None:
                if m.any():
                    out[:, m] = s.curve.derivatives(t[m] - s.t0)[:3]
            elif m.any():
                out[0, m] = s.q1
                out[1:, m] = 0.0
            after = t > s.t1
            out[0, after] = s.q1
            out[1:, after] = 0.0
        return out

    def events(self) -> list[Event]:
        kinds = {StepKind.PICK: EventKind.PICK, StepKind.PLACE: EventKind.PLACE}
        return [Event(self.arm.name, s.fruit, kinds[s.kind], s.t0, s.t1) for s in self.steps if s.kind in kinds]

    def shifted(self, index: int, delay: float) -> "ArmSchedule":
        """Insert a wait of ``delay`` s before step ``index`` (later steps move later)."""
        steps = list(self.steps[:index])
        t0 = self.steps[index].t0
        q = self.steps[index].q0
        steps.append(Step(StepKind.WAIT, t0, delay, q, q))
        for s in self.steps[index:]:
            steps.append(replace(s, t0=s.t0 + delay))
        return ArmSchedule(self.arm, _merge_waits(steps))


def _merge_waits(steps: list[Step]) -> list[Step]:
    out: list[Step] = []
    for s in steps:
        if out and s.kind == StepKind.WAIT and out[-1].kind == StepKind.WAIT:
            out[-1] = replace(out[-1], duration=out[-1].duration + s.duration)
        else:
            out.append(s)
    return out


def _move(arm: Arm, t0: float, q0, q1, derate: float = 1.0) -> Step:
    f = np.array([derate, derate])
    c = SCurve.between(q0, q1, np.asarray(arm.max_velocity) * f, np.asarray(arm.max_acceleration) * f, np.asarray(arm.max_jerk) * f)
    return Step(StepKind.MOVE, t0, c.duration, tuple(map(float, q0)), tuple(map(float, q1)), curve=c)


def decoupled_schedules(problem: Problem, alloc: Allocation, derate: float = 1.0) -> dict[str, ArmSchedule]:
    """Fastest schedule of each arm alone: home -> (fruit, pick, bin, place)* -> home.

    ``derate`` < 1 scales every velocity, acceleration and jerk limit down (a warm start
    strictly inside the limits, which an optimiser can then tighten).
    """
    out = {}
    for arm in problem.arms:
        t = 0.0
        cur = tuple(float(x) for x in arm.home)
        steps: list[Step] = []
        for fid in alloc.assignment[arm.name]:
            qf = tuple(map(float, alloc.fruit_q[arm.name][fid]))
            qb = tuple(map(float, alloc.place_q[arm.name][fid]))
            for target, kind, dwell in ((qf, StepKind.PICK, problem.task.pick_dwell), (qb, StepKind.PLACE, problem.task.place_dwell)):
                mv = _move(arm, t, cur, target, derate)
                steps.append(mv)
                t = mv.t1
                steps.append(Step(kind, t, dwell, target, target, fruit=fid))
                t += dwell
                cur = target
        if steps:
            steps.append(_move(arm, t, cur, arm.home, derate))
        out[arm.name] = ArmSchedule(arm, steps)
    return out


def pair_distances(problem: Problem, qa: np.ndarray, qb: np.ndarray, ia: int, ib: int) -> np.ndarray:
    """Least capsule distance between arms ia and ib for joint samples (K, 2) each -> (K,)."""
    a, b = problem.arms[ia], problem.arms[ib]
    pa = kin.fk_points(qa, a.links, a.base)
    pb = kin.fk_points(qb, b.links, b.base)
    d = np.full(qa.shape[0], np.inf)
    for s in range(2):
        for u in range(2):
            d = np.minimum(d, segment_distance(pa[:, s], pa[:, s + 1], pb[:, u], pb[:, u + 1]))
    return d - a.link_radius - b.link_radius


def remove_conflicts(
    problem: Problem,
    schedules: dict[str, ArmSchedule],
    margin: float,
    rate: float = 200.0,
    delay_step: float = 0.05,
    max_delays: int = 400,
) -> tuple[dict[str, ArmSchedule], int]:
    """Delay moves until every neighbouring pair keeps ``clearance + margin`` (sampled at ``rate``).

    At the first conflict, the arm that will finish earlier (more slack) waits ``delay_step``
    before the move it is in (or, when it is dwelling, the other arm waits). Returns the
    new schedules and the number of delays inserted.
    """
    names = [a.name for a in problem.arms]
    need = problem.task.clearance + margin
    pairs = problem.neighbour_pairs()
    n_delays = 0
    while n_delays < max_delays:
        t_end = max((s.end for s in schedules.values()), default=0.0)
        t = np.arange(0.0, t_end + 1.0 / rate, 1.0 / rate)
        q = {n: schedules[n].state(t)[0] for n in names}
        first = None
        for ia, ib in pairs:
            d = pair_distances(problem, q[names[ia]], q[names[ib]], ia, ib)
            bad = np.flatnonzero(d < need)
            if bad.size and (first is None or t[bad[0]] < first[0]):
                first = (t[bad[0]], ia, ib)
        if first is None:
            return schedules, n_delays
        tc, ia, ib = first
        order = sorted((names[ia], names[ib]), key=lambda n: schedules[n].last_place)
        for n in order:  # prefer delaying the arm with more slack
            sch = schedules[n]
            idx = _step_at(sch, tc)
            if idx is not None and sch.steps[idx].kind == StepKind.MOVE:
                # wait before this move, long enough to let the other arm pass
                schedules = dict(schedules)
                schedules[n] = sch.shifted(idx, delay_step)
                break
        else:
            # both dwelling/waiting or finished: delay the move that brought the later arm here
            n = order[0]
            sch = schedules[n]
            idx = _last_move_before(sch, tc)
            if idx is None:
                return schedules, n_delays
            schedules = dict(schedules)
            schedules[n] = sch.shifted(idx, delay_step)
        n_delays += 1
    return schedules, n_delays


def _step_at(sch: ArmSchedule, t: float) -> int | None:
    for i, s in enumerate(sch.steps):
        if s.t0 <= t <= s.t1:
            return i
    return None


def _last_move_before(sch: ArmSchedule, t: float) -> int | None:
    idx = None
    for i, s in enumerate(sch.steps):
        if s.kind == StepKind.MOVE and s.t0 <= t:
            idx = i
    return idx
