"""One arm's state while :func:`coplan.planners.coordinated.coordinate.coordinate` books its legs."""

from __future__ import annotations

import bisect

import numpy as np

from ...problem.model import Arm
from .legs import Leg
from .schedule import Step, StepKind, curve_eval

__all__ = ["ArmTrack"]


class ArmTrack:
    """One arm in :func:`coordinate`: its committed steps, its pose after them, its remaining legs."""

    def __init__(self, arm: Arm, index: int, rank: int, legs: list[Leg], tables: dict):
        self.arm, self.index, self.rank = arm, index, rank
        self.tables = tables  # the run's curve tables
        self.home = tuple(map(float, arm.home))
        self.steps: list[Step] = []
        self.t0s: list[float] = []
        self.end = 0.0  # committed until here; rests at ``pose`` afterwards until its next commitment
        self.pose = self.home
        self.todo = legs
        self.ready = 0.0  # when it next tries to start its next leg
        self.stuck: int | None = None  # the arm whose rest pose blocks its next leg (cleared when that one moves)
        self.blocker: tuple | None = None  # (arm, its pose) that first rest-blocked the next leg
        self.deferred = False  # finished, waiting for home to be out of the neighbours' way
        self.parked = False

    @property
    def working(self) -> bool:
        return any(not leg.home for leg in self.todo)

    def positions(self, T: np.ndarray) -> np.ndarray:
        """Joint positions (K, 2) at sorted times ``T``; resting at ``pose`` after ``end``."""
        out = np.empty((T.size, 2))
        out[:] = self.pose
        i = max(0, bisect.bisect_right(self.t0s, float(T[0])) - 1)
        for s in self.steps[i:]:
            if s.t0 > T[-1]:
                break
            lo, hi = np.searchsorted(T, [s.t0, s.t1])
            if hi <= lo:
                continue
            out[lo:hi] = curve_eval(s.curve, T[lo:hi] - s.t0, self.tables) if s.kind == StepKind.MOVE and s.curve is not None else s.q1
        return out

    def commit(self, t: float, steps: list[Step]) -> None:
        new = steps
        if t > self.end + 1e-9:
            new = [Step(StepKind.WAIT, self.end, t - self.end, self.pose, self.pose)] + steps
        for s in new:
            self.steps.append(s)
            self.t0s.append(s.t0)
        if steps:
            self.end = steps[-1].t1
            self.pose = tuple(map(float, steps[-1].q1))
