"""One arm's motion while the carriage moves: holding the tip over a fruit, and the moves between.

* **Tracking** (:func:`track`): during a pick the tip holds still over the fruit in row
  coordinates, so in the carriage frame it follows ``(x_f - c(t), y_f)``; the joints are that
  point's inverse kinematics on one elbow branch. Its velocity and acceleration at the ends
  come from the carriage's exact state (chain rule through the arm's Jacobian), so the moves
  into and out of a pick join it with continuous position, velocity and acceleration.
* **Moves** (:class:`Leg`): time-optimal jerk-limited per-joint trajectories (Ruckig, joints
  synchronised) from a state to a state -- rest at the bin to the moving pick state, the moving
  state at the pick's end to rest over the bin -- within the arm's velocity, acceleration and
  jerk limits.

Everything is sampled on the plan's grid (``k / rate``); shapes are ``(K, 2)``.
"""

from __future__ import annotations

import numpy as np

from ..kinematics.arm import ik_one, jacobian_entries, jacobian_rate_entries
from ..kinematics.timing import MoveError, ruckig_move, trajectory_states
from ..planners.coordinated.routing import elbow_fold
from ..problem.model import Arm
from .cruise import Cruise

__all__ = ["Leg", "LegError", "Route", "tucked_route", "way", "track", "track_state", "LIMIT_SHARE", "AT_REST_SHARE",
           "AT_REST_CYCLE_SHARE"]


#: Share of each joint limit the moves use (the rest is room for the pick's tracking at the seams).
#: 0.95 since the session of 2026-12-05 (0.9 before): on the move, rows 0.1-6.4 % faster on 9 of
#: the head-to-head's 10 rows (course_row 404.2 -> 378.4 s, dense_row 713.9 -> 687.7 s), sparse_row
#: 0.5 % slower, every plan verified; 0.97 was faster on some and slower on others, and 0.99 (above
#: the whole cycle's check, ``booking._CYCLE_SHARES``) found almost no cycle it could keep.
LIMIT_SHARE = 0.95
#: ... and when every pick is made with the carriage at rest (stop and go: no tracking motion to join;
#: a whole cycle's finite differences then within AT_REST_CYCLE_SHARE of the limits, the room left
#: for the grid's rounding). 0.97 before: live stop and go then took about 1 % longer.
AT_REST_SHARE = 0.99
AT_REST_CYCLE_SHARE = 0.995


#: Ruckig could not compute a move.
LegError = MoveError


def _ik(arm: Arm, pts: np.ndarray, branch: int) -> np.ndarray:
    q, valid = arm.ik(pts)
    out = q[..., branch, :]
    return np.where(valid[..., branch, None], out, np.nan)


def track(arm: Arm, fruit: tuple[float, float], cruise: Cruise, t: np.ndarray, branch: int) -> np.ndarray:
    """(K, 2) joint poses holding the tip over row point ``fruit`` at times ``t`` (NaN where
    the branch has no solution)."""
    c = cruise.x(np.asarray(t, float))
    pts = np.stack([fruit[0] - c, np.full(c.shape, fruit[1])], axis=-1)
    return _ik(arm, pts, branch)


def track_state(arm: Arm, fruit: tuple[float, float], cruise: Cruise, t: float, branch: int) -> np.ndarray:
    """(3, 2): joint position, velocity and acceleration of :func:`track` at time ``t``.

    With the tip's carriage-frame point ``p(t) = (x_f - c(t), y_f)``: ``J qd = pd`` and
    ``J qdd = pdd - Jd qd``, where ``pd = (-c', 0)``, ``pdd = (-c'', 0)``."""
    c, cv, ca = cruise.state_one(t)
    q = np.array(ik_one(fruit[0] - c, fruit[1], arm.links, arm.base, arm.joint_limits, branch))
    if not np.all(np.isfinite(q)):
        return np.array([q, q, q])
    # J qd = pd by Cramer's rule (2 x 2), then J qdd = pdd - J' qd
    ja, jb, jd, je = jacobian_entries(float(q[0]), float(q[1]), arm.links)
    det = ja * je - jb * jd
    if abs(det) < 1e-12:  # at a singular pose no joint rates hold the tip
        return np.full((3, 2), np.nan)

    def solve(r0: float, r1: float) -> np.ndarray:
        return np.array([(r0 * je - jb * r1) / det, (ja * r1 - jd * r0) / det])

    qd = solve(-cv, 0.0)
    jad, jbd, jdd, jed = jacobian_rate_entries(float(q[0]), float(q[1]), float(qd[0]), float(qd[1]), arm.links)
    qdd = solve(-ca - (jad * qd[0] + jbd * qd[1]), -(jdd * qd[0] + jed * qd[1]))
    return np.array([q, qd, qdd])


class Leg:
    """A move from state ``start`` (3, 2) to state ``end`` (3, 2), time-optimal under the arm's
    per-joint limits (:func:`coplan.kinematics.timing.ruckig_move`). ``duration`` in s;
    :meth:`sample` gives the poses."""

    def __init__(self, arm: Arm, start: np.ndarray, end: np.ndarray, share: float = LIMIT_SHARE):
        # a little below the limits (``share``): a move joins a pick's tracking motion, whose own
        # (small) acceleration and jerk add to the move's at the seam
        lim = [[share * x for x in v] for v in (arm.max_velocity, arm.max_acceleration, arm.max_jerk)]
        self.trajectory = ruckig_move(start, end, *lim)
        self.end = np.asarray(end, float)
        self.duration = float(self.trajectory.duration)

    def sample(self, t: np.ndarray) -> np.ndarray:
        """(K, 2) poses at times ``t`` from the leg's start (at its end state's pose after)."""
        t = np.asarray(t, float).ravel()
        out = np.empty((t.size, 2))
        past = t >= self.duration
        if past.any():  # past the end: extrapolate the end state (only used within one sample of it)
            dtk = (t[past] - self.duration)[:, None]
            out[past] = self.end[0] + self.end[1] * dtk + 0.5 * self.end[2] * dtk * dtk
        if not past.all():
            out[~past] = trajectory_states(self.trajectory, np.maximum(t[~past], 0.0))[0]
        return out


def way(arm: Arm, start: np.ndarray, end: np.ndarray, tuck: int = 0, share: float = LIMIT_SHARE):
    """The move from state ``start`` to state ``end``: direct (:class:`Leg`), or tucked to side
    ``tuck`` (+1 or -1: :func:`tucked_route`)."""
    return tucked_route(arm, start, end, tuck, share) if tuck else Leg(arm, start, end, share)


class Route:
    """:class:`Leg` s one after another, each ending at rest where the next begins: ``duration``
    their sum, :meth:`sample` the poses (as a :class:`Leg`'s), ``end`` the last one's end state."""

    def __init__(self, legs: list[Leg]):
        self.legs = legs
        self.end = legs[-1].end
        self.starts = np.cumsum([0.0] + [leg.duration for leg in legs[:-1]])
        self.duration = float(self.starts[-1] + legs[-1].duration)

    def sample(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float).ravel()
        out = np.empty((t.size, 2))
        k = np.clip(np.searchsorted(self.starts, t, side="right") - 1, 0, len(self.legs) - 1)
        for n, leg in enumerate(self.legs):
            on = k == n
            if on.any():
                out[on] = leg.sample(t[on] - self.starts[n])
        return out


def tucked_route(arm: Arm, start: np.ndarray, end: np.ndarray, side: int, share: float = LIMIT_SHARE) -> Route:
    """From state ``start`` to state ``end`` (each (3, 2)) with the elbow folded on the way:
    first the elbow bends to ``side`` (+1 or -1) as the stow poses fold it
    (:func:`coplan.planners.coordinated.routing.elbow_fold`), then the shoulder turns to ``end``'s angle, then the elbow opens to
    ``end``'s; each move time-optimal (:class:`Leg`), at rest between. While the shoulder turns
    the arm reaches no farther than its elbow, the forearm folded back over the upper arm, where
    the direct move sweeps its whole reach: the way a cell planner tucks an arm round a neighbour
    (:mod:`coplan.planners.coordinated.routing`)."""
    fold = elbow_fold(arm, side)
    z = np.zeros(2)
    w1 = np.array([start[0][0], fold])
    w2 = np.array([end[0][0], fold])
    rest = [np.array([w, z, z]) for w in (w1, w2)]
    return Route([Leg(arm, start, rest[0], share), Leg(arm, rest[0], rest[1], share), Leg(arm, rest[1], end, share)])

