"""Motion pieces of live re-planning: re-planned approaches and cutting a plan at a rest instant.

Every coordinated move is rest-to-rest, so each arm is at rest at the end of every step. A
re-plan keeps each arm's motion up to the first rest instant at or after the commit horizon
(:func:`split_at`): the end of the move or dwell under way, or the horizon itself while the
arm waits. What follows starts from rest at that pose, so position, velocity and acceleration
continue exactly.

A close-range correction re-plans an approach *while it runs*: :class:`Approach` is the
time-optimal jerk-limited trajectory (Ruckig) from the arm's exact moving state to the refined
pick pose at rest, within the arm's velocity, acceleration and jerk limits.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ..problem.model import Arm
from ..planners.coordinated.schedule import Step, StepKind
from ..kinematics.timing import MoveError, SCurve, ruckig_move, trajectory_states

__all__ = ["Approach", "ApproachError", "move_step", "split_at", "truncate_move", "step_state", "as_wait"]


#: Ruckig could not compute the re-planned approach.
ApproachError = MoveError


class Approach:
    """A move from a moving state ``(q0, v0, a0)`` to rest at ``q1``: time-optimal under the
    arm's per-joint velocity, acceleration and jerk limits (Ruckig, joints synchronised:
    :func:`coplan.kinematics.timing.ruckig_move`).

    It has the interface of :class:`coplan.kinematics.timing.SCurve` that schedules use
    (``q0``, ``q1``, ``duration``, ``derivatives(t)``, ``eval(t)``).
    """

    def __init__(self, arm: Arm, q0, v0, a0, q1):
        traj = ruckig_move([q0, v0, a0], [q1, (0.0, 0.0), (0.0, 0.0)], arm.max_velocity, arm.max_acceleration,
                           arm.max_jerk)
        self.trajectory = traj
        self.q0 = tuple(float(x) for x in q0)
        self.q1 = tuple(float(x) for x in q1)
        self.start_state = (np.asarray(v0, float), np.asarray(a0, float))
        self.duration = float(traj.duration)

    def derivatives(self, t) -> np.ndarray:
        """Joint (pos, vel, acc), each (K, 2), at times ``t`` (K,) from the approach's start
        (at rest on ``q1`` from ``duration`` on)."""
        t = np.atleast_1d(np.asarray(t, float))
        out = np.zeros((3, t.size, 2))
        past = t >= self.duration
        out[0, past] = self.q1
        if not past.all():
            out[:, ~past] = trajectory_states(self.trajectory, np.maximum(t[~past], 0.0))
        return out

    def eval(self, t) -> np.ndarray:
        return self.derivatives(t)[0]


def move_step(arm: Arm, t0: float, q0, q1) -> Step:
    """A rest-to-rest time-optimal S-curve move (the coordinated planner's moves)."""
    c = SCurve.between(q0, q1, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
    return Step(StepKind.MOVE, t0, c.duration, tuple(map(float, q0)), tuple(map(float, q1)), curve=c)


def step_state(step: Step, t: float) -> np.ndarray:
    """(q, qd, qdd) (3, 2) of one step at absolute time ``t`` inside it."""
    if step.kind == StepKind.MOVE and step.curve is not None:
        return np.asarray(step.curve.derivatives(np.array([t - step.t0]))[:3, 0], float)
    return np.array([step.q1, (0.0, 0.0), (0.0, 0.0)], float)


def truncate_move(step: Step, t: float) -> Step:
    """The part of a move before ``t`` (its curve kept; it ends at the state at ``t``)."""
    q = step_state(step, t)[0]
    return replace(step, duration=t - step.t0, q1=(float(q[0]), float(q[1])))


def as_wait(step: Step) -> Step:
    """The same motion without its pick/place (a dwell where nothing is picked)."""
    return replace(step, kind=StepKind.WAIT, fruit=None)


def split_at(steps: list[Step], now: float, t_c: float, pose) -> tuple[list[Step], list[Step], list[Step]]:
    """Cut one arm's steps for a re-plan at ``now`` with commit horizon ``t_c`` >= ``now``.

    Returns ``(history, committed, rest)``: the steps finished by ``now``; the steps kept from
    there up to the first rest instant at or after ``t_c`` (ending with a wait up to ``t_c``
    when the arm is resting there); and the steps planned after that (to be re-planned).
    ``pose``: where the arm rests when it has no steps.
    """
    k = 0
    while k < len(steps) and steps[k].t1 <= now + 1e-12:
        k += 1
    history = steps[:k]
    kept: list[Step] = []
    rest: list[Step] = []
    i = k
    while i < len(steps):
        s = steps[i]
        if s.t0 >= t_c - 1e-12:
            break
        if s.kind == StepKind.WAIT and s.t1 > t_c:  # resting: cut the wait at the horizon
            kept.append(replace(s, duration=t_c - s.t0))
            rest = [replace(s, t0=t_c, duration=s.t1 - t_c)] + list(steps[i + 1:])
            return history, kept, rest
        kept.append(s)
        i += 1
        if s.kind == StepKind.MOVE and i < len(steps) and steps[i].kind in (StepKind.PICK, StepKind.PLACE) \
                and s.t1 >= t_c - 1e-12:
            kept.append(steps[i])  # a move into a pick/place: its dwell is part of the same leg
            i += 1
    rest = list(steps[i:])
    # steps are contiguous: when the kept ones end before the horizon, nothing follows them
    end = kept[-1].t1 if kept else (history[-1].t1 if history else now)
    last = kept[-1].q1 if kept else (history[-1].q1 if history else tuple(map(float, pose)))
    if end < t_c - 1e-12:
        kept.append(Step(StepKind.WAIT, end, t_c - end, tuple(last), tuple(last)))
    return history, kept, rest
