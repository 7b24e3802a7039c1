"""Decoupled time-optimal schedules and conflict removal by waiting (the optimiser's warm start).

An :class:`ArmSchedule` is a list of :class:`Step` s (rest-to-rest S-curve moves and holds).
:func:`decoupled_schedules` gives each arm its fastest schedule for an allocation: every move
is a per-joint time-optimal S-curve, so each arm alone meets the makespan lower bound's move
times. :func:`remove_conflicts` then delays moves (prioritised planning: the arm with more
slack waits) until no two neighbouring arms come closer than the clearance plus a margin.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from . import kinematics as kin
from .allocate import Allocation
from .geometry import segment_distance
from .plan import Event, EventKind
from .problem import Arm, Problem
from .timing import SCurve

__all__ = [
    "StepKind",
    "Step",
    "ArmSchedule",
    "ConflictError",
    "decoupled_schedules",
    "add_return_home",
    "tuck_moves",
    "remove_conflicts",
    "pair_distances",
]


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


def decoupled_schedules(
    problem: Problem, alloc: Allocation, derate: float = 1.0, return_home: bool = True
) -> dict[str, ArmSchedule]:
    """Fastest schedule of each arm alone: home -> (fruit, pick, bin, place)* [-> home].

    ``derate`` < 1 scales every velocity, acceleration and jerk limit down (a warm start
    strictly inside the limits, which an optimiser can then tighten). Without
    ``return_home`` each arm ends resting over its bin (see :func:`add_return_home`).
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
        if steps and return_home:
            steps.append(_move(arm, t, cur, arm.home, derate))
        out[arm.name] = ArmSchedule(arm, steps)
    return out


def add_return_home(problem: Problem, schedules: dict[str, ArmSchedule]) -> dict[str, ArmSchedule]:
    """Park every arm over its bin until the cell's last place, then move it home.

    An arm that finishes early and waits at home can stand in a neighbour's way (home poses
    reach up into the shared space); over the bin it is out of the way. The return moves
    then start together and :func:`remove_conflicts` staggers them where needed.
    """
    t_all = max((s.last_place for s in schedules.values()), default=0.0)
    out = {}
    for name, sch in schedules.items():
        steps = list(sch.steps)
        if steps:
            q = steps[-1].q1
            if t_all > sch.end + 1e-9:
                steps.append(Step(StepKind.WAIT, sch.end, t_all - sch.end, q, q))
            steps.append(_move(sch.arm, max(t_all, sch.end), q, sch.arm.home))
        out[name] = ArmSchedule(sch.arm, steps)
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


def _retime(arm: Arm, steps: list[Step]) -> list[Step]:
    """Recompute start times so steps follow each other (move curves recomputed)."""
    out, t = [], 0.0
    for st in steps:
        if st.kind == StepKind.MOVE:
            st = _move(arm, t, st.q0, st.q1)
        else:
            st = replace(st, t0=t)
        out.append(st)
        t = st.t1
    return out


def tuck_moves(problem: Problem, schedules: dict[str, ArmSchedule], need: float, samples: int = 60) -> tuple[dict[str, ArmSchedule], int]:
    """Reroute moves whose straight joint path would hit a neighbour resting at home.

    Such a conflict cannot be removed by waiting (the neighbour may be parked there for the
    whole plan), so the move becomes a tucked transit: fold the elbow (close to its limit, on
    the side the move starts from), swing the shoulder, unfold. A tucked route that still
    conflicts is kept only if it is better than the straight one. Returns the schedules and
    the number of moves rerouted.
    """
    names = [a.name for a in problem.arms]
    index = {n: i for i, n in enumerate(names)}
    pairs = problem.neighbour_pairs()
    out = dict(schedules)
    count = 0
    for n in names:
        arm = problem.arms[index[n]]
        homes = []
        for ia, ib in pairs:
            if n in (names[ia], names[ib]):
                m = names[ib] if names[ia] == n else names[ia]
                homes.append((index[m], np.asarray(problem.arms[index[m]].home, float)))
        if not homes:
            continue

        def worst(path: np.ndarray) -> float:
            d = np.inf
            for j, qh in homes:
                other = np.tile(qh, (path.shape[0], 1))
                ia, ib = sorted((index[n], j))
                qa, qb = (path, other) if ia == index[n] else (other, path)
                d = min(d, float(pair_distances(problem, qa, qb, ia, ib).min()))
            return d

        steps: list[Step] = []
        changed = False
        for st in out[n].steps:
            if st.kind != StepKind.MOVE:
                steps.append(st)
                continue
            straight = st.curve.eval(np.linspace(0, st.duration, samples))
            d_straight = worst(straight)
            if d_straight >= need:
                steps.append(st)
                continue
            lim = arm.limits
            side = np.sign(st.q0[1]) or np.sign(st.q1[1]) or 1.0
            fold = float(np.clip(side * (np.pi - 0.15), lim[1, 0] + 0.05, lim[1, 1] - 0.05))
            vias = [st.q0, (st.q0[0], fold), (st.q1[0], fold), st.q1]
            path = np.vstack([np.linspace(a, b, samples) for a, b in zip(vias[:-1], vias[1:])])
            if worst(path) > d_straight:
                steps += [Step(StepKind.MOVE, 0.0, 0.0, tuple(a), tuple(b)) for a, b in zip(vias[:-1], vias[1:])]
                changed = True
                count += 1
            else:
                steps.append(st)
        if changed:
            out[n] = ArmSchedule(arm, _retime(arm, steps))
    return out, count


class ConflictError(RuntimeError):
    """Waiting alone cannot separate two arms (a resting pose blocks another arm's motion)."""


def remove_conflicts(
    problem: Problem,
    schedules: dict[str, ArmSchedule],
    margin: float,
    rate: float = 200.0,
    delay_step: float = 0.05,
    max_delays: int = 400,
    priority: list[str] | None = None,
    deadline: float | None = None,
) -> tuple[dict[str, ArmSchedule], int]:
    """Prioritised planning by waiting: make every neighbouring pair keep ``clearance + margin``.

    Arms are fixed one at a time, in ``priority`` order (default: the arm that finishes last
    first, so the critical arm is never delayed). Each later arm is checked against the arms
    already fixed, sampled at ``rate``; at its first conflict it waits (until the blocking
    arm ends the step it is in, at most 1 s, at least as long as the conflict lasts and
    ``delay_step``) before the last move that starts at or before it (so a conflict while resting
    at a pose delays the move that would bring it there). An arm in the way while still at
    its start pose first clears out to its bin. Raises :class:`ConflictError` when waiting
    cannot help (a parked arm is in the way), after ``max_delays`` waits, or at ``deadline``
    (a ``time.perf_counter()`` value).
    Returns the new schedules and the number of waits inserted.
    """
    names = [a.name for a in problem.arms]
    index = {n: i for i, n in enumerate(names)}
    need = problem.task.clearance + margin
    pairs = set(problem.neighbour_pairs())
    order = priority or sorted(names, key=lambda n: -schedules[n].last_place)
    fixed: list[str] = []
    out = dict(schedules)
    n_delays = 0
    for n in order:
        others = [m for m in fixed if (min(index[n], index[m]), max(index[n], index[m])) in pairs]
        sch = out[n]
        cleared = False
        t_from = 0.0  # everything before the last shifted step is unchanged and already clear
        while others:
            t_end = max([sch.end] + [out[m].end for m in others]) + 1.0 / rate
            t = np.arange(t_from, t_end, 1.0 / rate)
            qn = sch.state(t)[0]
            first = None
            run = 0.0
            blocker = None
            for m in others:
                ia, ib = sorted((index[n], index[m]))
                qa, qb = (qn, out[m].state(t)[0]) if ia == index[n] else (out[m].state(t)[0], qn)
                bad = pair_distances(problem, qa, qb, ia, ib) < need
                hit = np.flatnonzero(bad)
                if hit.size and (first is None or t[hit[0]] < first):
                    first = float(t[hit[0]])
                    blocker = m
                    clear = np.flatnonzero(~bad[hit[0]:])
                    run = (clear[0] if clear.size else bad.size - hit[0]) / rate
            if first is None:
                break
            if deadline is not None and _time.perf_counter() > deadline:
                raise ConflictError("time budget for removing conflicts by waiting is used up")
            if first >= out[blocker].end:
                raise ConflictError(f"arm {n!r} runs into arm {blocker!r} parked at the end of its schedule at t = {first:.2f} s")
            idx = _last_move_before(sch, first)
            if first > sch.end:
                raise ConflictError(f"another arm runs into arm {n!r} parked at the end of its schedule at t = {first:.2f} s")
            if idx is None:
                if cleared or not sch.steps:
                    raise ConflictError(
                        f"arm {n!r} is in the way of another arm at t = {first:.2f} s while resting at its start pose"
                    )
                # blocked at home before its first move: clear out to the bin first
                sch = _clear_out(sch)
                cleared = True
                t_from = 0.0
                n_delays += 1
                continue
            # wait until the blocking arm has finished the step it is in (at most 1 s), at least
            # as long as the conflict lasted and delay_step; then look again
            b_idx = _step_at(out[blocker], first)
            b_rest = out[blocker].steps[b_idx].t1 - first if b_idx is not None else 0.0
            t_from = max(0.0, sch.steps[idx].t0 - 1.0 / rate)
            sch = sch.shifted(idx, max(delay_step, run, min(b_rest, 1.0)))
            n_delays += 1
            if n_delays > max_delays:
                raise ConflictError(f"no conflict-free waiting schedule found within {max_delays} waits")
        out[n] = sch
        fixed.append(n)
    return out, n_delays


def _clear_out(sch: ArmSchedule) -> ArmSchedule:
    """Start with a move from home to the bin (the first place pose), then go on from there."""
    places = [s for s in sch.steps if s.kind == StepKind.PLACE]
    if not places:
        return sch
    qb = places[0].q1
    steps = [Step(StepKind.MOVE, 0.0, 0.0, sch.steps[0].q0, qb)]
    first = sch.steps[0]
    if first.kind == StepKind.MOVE:
        steps.append(Step(StepKind.MOVE, 0.0, 0.0, qb, first.q1))
        steps += sch.steps[1:]
    else:
        steps += sch.steps
    return ArmSchedule(sch.arm, _retime(sch.arm, steps))


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
