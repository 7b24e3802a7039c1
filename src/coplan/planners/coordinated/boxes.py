"""Boxes that hold an arm over a stretch of time: the coordinator's cheap screen.

Before the coordinator compares a leg with a neighbour's commitments sample by sample, it
compares two boxes: one holding the arm wherever the leg takes it, one holding the neighbour
over the whole span. Boxes further apart than the clearance needed mean no sample can be too
close, so the exact test is skipped -- it would have found nothing; no answer changes.

A box is ``(xmin, xmax, ymin, ymax)``, or None when nothing bounds the arm (a move whose curve
is not an S-curve). Boxes come from :func:`coplan.kinematics.arm.sweep_box`.
"""

from __future__ import annotations

import bisect
import itertools

import numpy as np

from ...kinematics.arm import sweep_box
from ...kinematics.timing import SCurve
from ...problem.model import Problem
from .schedule import Step, StepKind, curve_eval

__all__ = ["SweepBoxes", "apart", "union", "SLICES"]

SLICES = 16  # stretches of a move bounded separately (:meth:`SweepBoxes.step`)

Box = tuple[float, float, float, float]


def union(a: Box | None, b: Box | None) -> Box | None:
    """The box holding boxes a and b (None, unbounded, if either is)."""
    if a is None or b is None:
        return None
    return (min(a[0], b[0]), max(a[1], b[1]), min(a[2], b[2]), max(a[3], b[3]))


def apart(a: Box | None, b: Box | None, d: float) -> bool:
    """Whether boxes a and b are more than d apart along x or y (never when one is unbounded)."""
    return a is not None and b is not None and (b[0] - a[1] > d or a[0] - b[1] > d or b[2] - a[3] > d or a[2] - b[3] > d)


class SweepBoxes:
    """Boxes of the arms of ``problem`` over steps (memoised in ``memo``: a rest's by its pose, a
    move's by its curve) and over a track's commitments in a span of time."""

    def __init__(self, problem: Problem, memo: dict, tables: dict):
        self.problem, self.memo, self.tables = problem, memo, tables

    def pose(self, i: int, q: tuple) -> Box:
        """A box holding arm i at rest at pose q."""
        box = self.memo.get((i, q))
        if box is None:
            arm = self.problem.arms[i]
            box = self.memo[(i, q)] = sweep_box(q, q, arm.links, arm.base)
        return box

    def step(self, i: int, st: Step) -> Box | None:
        """A box holding arm i throughout step ``st``; None (unbounded) for a move whose curve is
        not an S-curve. An S-curve keeps each joint between its end values and moves it one way
        (rest to rest), so over each of ``SLICES`` stretches of the move the joints stay between
        their values at its ends: the move's box is the union of those stretches' boxes (tight
        where the joints turn little)."""
        if st.kind != StepKind.MOVE or st.curve is None:
            return self.pose(i, st.q1)  # (a rest, or a move without a curve: evaluated at its end pose)
        if not isinstance(st.curve, SCurve):
            return None
        # a move's box is its whole curve's (a step cut short, e.g. a live re-plan's, holds less):
        # memoised by the curve itself, kept beside its box so that its id is not reused
        hit = self.memo.get((i, id(st.curve)))
        if hit is None or hit[0] is not st.curve:
            arm = self.problem.arms[i]
            q = curve_eval(st.curve, np.linspace(0.0, st.curve.duration, SLICES + 1), self.tables)
            lo, hi = np.minimum(q[:-1], q[1:]), np.maximum(q[:-1], q[1:])
            box = sweep_box(lo[0], hi[0], arm.links, arm.base)
            for k in range(1, SLICES):
                box = union(box, sweep_box(lo[k], hi[k], arm.links, arm.base))
            hit = self.memo[(i, id(st.curve))] = (st.curve, box)
        return hit[1]

    def steps(self, i: int, steps: list[Step], after: tuple) -> Box | None:
        """A box holding arm i through ``steps`` and at rest at ``after``."""
        box = self.pose(i, after)
        for st in steps:
            box = union(box, self.step(i, st))
        return box

    def track(self, i: int, steps: list[Step], t0s: list[float], after: tuple, t0: float, t1: float) -> Box | None:
        """A box holding arm i at every time in [t0, t1] of a track: its committed ``steps``
        (starting at ``t0s``) that can cover those times, and its pose ``after`` them (where
        the track rests outside its steps)."""
        box = self.pose(i, after)
        for st in itertools.islice(steps, max(0, bisect.bisect_right(t0s, t0) - 1), None):  # (no copy of the tail)
            if st.t0 > t1 or box is None:
                break
            box = union(box, self.step(i, st))
        return box
