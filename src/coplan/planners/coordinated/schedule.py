"""The optimiser's warm start: decoupled time-optimal schedules, coordinated conflict-free.

An :class:`ArmSchedule` is a list of :class:`Step` s (rest-to-rest S-curve moves and holds).
The warm start is built in four steps, each a rule that can be stated and checked:

1. :func:`decoupled_schedules` -- each arm's fastest schedule for an allocation: every move
   a per-joint time-optimal S-curve, so each arm alone meets the lower bound's move times.
2. :func:`choose_branches` -- the elbow branch at every pick and place, chosen by the same
   dynamic programme as the allocation's but with each move also charged for the
   neighbours' places and homes it sweeps through (those are where the neighbours keep
   coming back to, so such a move would queue behind them every cycle).
3. :func:`route_moves` -- a move that sweeps where a neighbour cannot be out of the way at
   any of its candidate rest poses (no waiting or yielding could let it run) becomes a
   tucked transit: fold the elbow, swing the shoulder, unfold.
4. :func:`coordinate` -- all arms together, leg by leg (a leg is a move and its pick or
   place): each leg is booked at the earliest time at which it, and resting at its target
   afterwards, keeps every neighbour ``clearance + margin`` away from everything the
   neighbours have booked and from where they rest after it (sampled at ``rate``). Bookings
   are never revised and every later booking is checked against them, so the result is
   conflict-free at ``rate`` by construction. Deadlocks (arms resting in each other's way)
   are broken by rule: the other elbow branch, else a yield move to a clear rest pose.
   Finished arms go home once home is out of the neighbours' remaining work.

Steps 2 and 3 live in :mod:`coplan.planners.coordinated.routing`, step 4 in :mod:`coplan.planners.coordinated.coordinate`.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from ...allocate.allocation import Allocation
from ...plan import Event, EventKind
from ...problem.model import Arm, Problem
from ...kinematics.geometry import segment_distance_rows, segment_distance_xy
from ...kinematics.timing import SCurve, phase_starts

__all__ = [
    "StepKind",
    "Step",
    "ArmSchedule",
    "ConflictError",
    "decoupled_schedules",
    "pair_distances",
    # the building blocks routing, coordinate and serial share
    "CurveTable",
    "LinkPoints",
    "arm_points",
    "curve_eval",
    "links_too_close",
    "links_too_close_pairs",
    "merge_waits",
    "points_clearance",
    "points_too_close",
    "retime",
    "scurve_move",
    "steps_positions",
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
        """Joint position, velocity, acceleration at times ``t`` (K,) -> (3, K, 2).

        At each time the last step started by then holds (its pose after it ends, at rest);
        home before the first. For sorted times (every caller's case) each step is evaluated
        only over its own stretch of ``t``: linear in steps plus samples."""
        t = np.asarray(t, float)
        out = np.zeros((3, t.size, 2))
        out[0] = np.asarray(self.arm.home, float)
        if not self.steps or t.size == 0:
            return out
        t0s = np.array([s.t0 for s in self.steps])
        if t.ndim != 1 or np.any(np.diff(t0s) < 0) or np.any(np.diff(t) < 0):
            return self._state_each(t, out)
        lo = np.searchsorted(t, t0s, side="left")  # step j holds over t[lo[j]:lo[j + 1]]
        his = np.append(lo[1:], t.size)
        ends = np.searchsorted(t, [s.t1 for s in self.steps], side="right")  # ... and is at rest from there
        for s, a, b, e in zip(self.steps, lo, his, ends):
            if a >= b:
                continue
            e = min(max(e, a), b)
            if e > a:
                if s.kind == StepKind.MOVE and s.curve is not None:
                    out[:, a:e] = s.curve.derivatives(t[a:e] - s.t0)[:3]
                else:
                    out[0, a:e] = s.q1
            out[0, e:b] = s.q1
            out[1:, a:b][:, e - a:] = 0.0
        return out

    def _state_each(self, t: np.ndarray, out: np.ndarray) -> np.ndarray:
        """:meth:`state` step by step over every time (any order of times or steps)."""
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


def merge_waits(steps: list[Step]) -> list[Step]:
    """``steps`` with every run of consecutive waits merged into one wait."""
    out: list[Step] = []
    for s in steps:
        if out and s.kind == StepKind.WAIT and out[-1].kind == StepKind.WAIT:
            out[-1] = replace(out[-1], duration=out[-1].duration + s.duration)
        else:
            out.append(s)
    return out


def scurve_move(arm: Arm, t0: float, q0, q1) -> Step:
    """The rest-to-rest move of ``arm`` from ``q0`` to ``q1`` starting at ``t0``: a per-joint
    time-optimal S-curve within the arm's limits."""
    c = SCurve.between(q0, q1, arm.max_velocity, arm.max_acceleration, arm.max_jerk)
    return Step(StepKind.MOVE, t0, c.duration, tuple(map(float, q0)), tuple(map(float, q1)), curve=c)


def decoupled_schedules(
    problem: Problem, alloc: Allocation, return_home: bool = True
) -> dict[str, ArmSchedule]:
    """Fastest schedule of each arm alone: home -> (fruit, pick, bin, place)* [-> home].

    Without
    ``return_home`` each arm ends resting over its bin (:func:`coordinate` adds the move home).
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
                mv = scurve_move(arm, t, cur, target)
                steps.append(mv)
                t = mv.t1
                steps.append(Step(kind, t, dwell, target, target, fruit=fid))
                t += dwell
                cur = target
        if steps and return_home:
            steps.append(scurve_move(arm, t, cur, arm.home))
        out[arm.name] = ArmSchedule(arm, steps)
    return out


def arm_points(arm: Arm, q) -> tuple[np.ndarray, ...]:
    """Base, elbow and tip coordinates ``(bx, by, ex, ey, tx, ty)`` of joint samples q (..., 2)."""
    q = np.asarray(q, float)
    t1, t12 = q[..., 0], q[..., 0] + q[..., 1]
    l1, l2 = arm.links
    ex = arm.base[0] + l1 * np.cos(t1)
    ey = arm.base[1] + l1 * np.sin(t1)
    tx = ex + l2 * np.cos(t12)
    ty = ey + l2 * np.sin(t12)
    bx = np.full_like(ex, arm.base[0])
    by = np.full_like(ey, arm.base[1])
    return bx, by, ex, ey, tx, ty


def points_clearance(pa: tuple, pb: tuple, radii: float) -> np.ndarray:
    """Least capsule clearance between two arms given by :func:`arm_points` (broadcast)."""
    d = None
    for s in range(2):
        for u in range(2):
            x = segment_distance_xy(pa[2 * s], pa[2 * s + 1], pa[2 * s + 2], pa[2 * s + 3],
                          pb[2 * u], pb[2 * u + 1], pb[2 * u + 2], pb[2 * u + 3])
            d = x if d is None else np.minimum(d, x)
    return d - radii


class LinkPoints:
    """Arm points of :func:`arm_points` (equal-length 1-D arrays) made ready for
    :func:`links_too_close`, for one set of samples compared many times: the coordinates
    ``P`` (6, N) and each link's midpoint ``mx, my`` and half length ``h`` (2, N, link 0 first),
    computed once. ``lp[a:b]`` takes samples a..b-1 without copying."""

    __slots__ = ("P", "mx", "my", "h")

    def __init__(self, P: np.ndarray, mx: np.ndarray | None = None, my: np.ndarray | None = None,
                 h: np.ndarray | None = None):
        self.P = P
        if mx is None:  # rows of P: bx, by, ex, ey, tx, ty; link s runs from row 2s to row 2s + 2
            ax, ay, bx, by = P[0:4:2], P[1:4:2], P[2:6:2], P[3:6:2]
            mx, my, h = (ax + bx) / 2, (ay + by) / 2, np.hypot(bx - ax, by - ay) / 2
        self.mx, self.my, self.h = mx, my, h

    @classmethod
    def of(cls, points: tuple) -> "LinkPoints":
        return cls(np.stack(points))

    @property
    def size(self) -> int:
        return self.P.shape[1]

    def __getitem__(self, sl) -> "LinkPoints":
        """Samples ``sl``: a slice (a view) or an index array (a copy)."""
        return LinkPoints(self.P[:, sl], self.mx[:, sl], self.my[:, sl], self.h[:, sl])


#: From this many sample pairs on, the pairs of links are tested one at a time (below, the
#: four at once cost fewer NumPy calls); the same answers either way.
ONE_LINK_PAIR_AT_A_TIME = 2048


def links_too_close(a: LinkPoints, b: LinkPoints, radii: float, need: float) -> np.ndarray:
    """Whether two arms, sample by sample (N,), are closer than ``need``: two links whose
    midpoints are further apart than their half lengths plus ``radii + need`` cannot be too
    close (a screen); the exact distance (:func:`segment_distance_xy`) decides for the others.
    Element by element, so a sample's answer depends on nothing else in the arrays.

    On many samples one pair of links at a time, forearms first (the links that meet most
    often), and a sample already found too close is not tested again with another pair: the
    answer is whether any pair is too close, so it is the same (in tight layouts half the exact
    tests or fewer)."""
    out = np.zeros(a.size, bool)
    if a.size < ONE_LINK_PAIR_AT_A_TIME:
        gap = np.hypot(a.mx[:, None] - b.mx[None], a.my[:, None] - b.my[None]) - a.h[:, None] - b.h[None]
        s, u, k = np.nonzero(gap < need + radii)  # link s of a and link u of b may be too close at sample k
        out[k[_exact_hits(a, s, k, b, u, k, radii, need)]] = True
        return out
    for s in reversed(range(a.mx.shape[0])):
        for u in reversed(range(b.mx.shape[0])):
            gap = np.hypot(a.mx[s] - b.mx[u], a.my[s] - b.my[u]) - a.h[s] - b.h[u]
            k = np.flatnonzero((gap < need + radii) & ~out)
            out[k[_exact_hits(a, s, k, b, u, k, radii, need)]] = True
    return out


def _exact_hits(a: LinkPoints, s, k, b: LinkPoints, u, m, radii: float, need: float) -> np.ndarray:
    """For each screened candidate, link ``s`` of ``a`` at its sample ``k`` against link ``u`` of
    ``b`` at its sample ``m`` (index arrays; ``s`` and ``u`` may be one link for all): whether
    they are too close, by the exact distance."""
    if k.size == 0:
        return np.zeros(0, bool)
    rows = np.arange(4)[:, None]  # the link's two ends, x and y: rows 2 s .. 2 s + 3 of the points
    C = np.concatenate([a.P[2 * np.asarray(s) + rows, k], b.P[2 * np.asarray(u) + rows, m]])
    return segment_distance_rows(C) - radii < need


def links_too_close_pairs(a: LinkPoints, b: LinkPoints, radii: float, need: float) -> np.ndarray:
    """:func:`links_too_close` for every sample of ``a`` (N) against every sample of ``b`` (M):
    (N, M), the same answer pair by pair as comparing the two broadcast against each other (on
    many pairs one pair of links at a time, as there)."""
    out = np.zeros((a.size, b.size), bool)
    if a.size * b.size < ONE_LINK_PAIR_AT_A_TIME:
        gap = (np.hypot(a.mx[:, None, :, None] - b.mx[None, :, None, :], a.my[:, None, :, None] - b.my[None, :, None, :])
               - a.h[:, None, :, None] - b.h[None, :, None, :])
        s, u, k, m = np.nonzero(gap < need + radii)  # link s of a at its sample k, link u of b at its sample m
        hit = _exact_hits(a, s, k, b, u, m, radii, need)
        out[k[hit], m[hit]] = True
        return out
    for s in reversed(range(a.mx.shape[0])):
        for u in reversed(range(b.mx.shape[0])):
            gap = (np.hypot(a.mx[s, :, None] - b.mx[u, None, :], a.my[s, :, None] - b.my[u, None, :])
                   - a.h[s, :, None] - b.h[u, None, :])
            k, m = np.nonzero((gap < need + radii) & ~out)
            hit = _exact_hits(a, s, k, b, u, m, radii, need)
            out[k[hit], m[hit]] = True
    return out


def points_too_close(pa: tuple, pb: tuple, radii: float, need: float) -> np.ndarray:
    """Whether two arms given by :func:`arm_points` are closer than ``need`` (broadcast).

    The same exact test as ``points_clearance(...) < need``, with a cheap screen first
    (:func:`links_too_close`, which this is on broadcast arrays).
    """
    if all(isinstance(x, np.ndarray) and x.ndim == 1 for x in (*pa, *pb)) and len({x.size for x in (*pa, *pb)}) == 1:
        shape = pa[0].shape  # the coordinator's case: samples side by side, nothing to broadcast
        A, B = np.stack(pa), np.stack(pb)
    else:
        xs = np.broadcast_arrays(*pa, *pb)
        shape = xs[0].shape
        A, B = np.stack([x.ravel() for x in xs[:6]]), np.stack([x.ravel() for x in xs[6:]])
    return links_too_close(LinkPoints(A), LinkPoints(B), radii, need).reshape(shape)


def pair_distances(problem: Problem, qa: np.ndarray, qb: np.ndarray, ia: int, ib: int) -> np.ndarray:
    """Least capsule distance between arms ia and ib for joint samples (K, 2) each -> (K,)."""
    a, b = problem.arms[ia], problem.arms[ib]
    return points_clearance(arm_points(a, qa), arm_points(b, qb), a.link_radius + b.link_radius)


def retime(arm: Arm, steps: list[Step]) -> list[Step]:
    """Recompute start times so steps follow each other (move curves recomputed)."""
    out, t = [], 0.0
    for st in steps:
        if st.kind == StepKind.MOVE:
            st = scurve_move(arm, t, st.q0, st.q1)
        else:
            st = replace(st, t0=t)
        out.append(st)
        t = st.t1
    return out


class ConflictError(RuntimeError):
    """No conflict-free coordination was found (arms that keep blocking each other, or out of time).

    ``arm`` and ``fruit``, when known, name the work that could not be scheduled (so a caller
    can leave that fruit out, with this error as the reason, and plan the rest)."""

    def __init__(self, message: str, arm: str | None = None, fruit: str | None = None):
        super().__init__(message)
        self.arm, self.fruit = arm, fruit


class CurveTable:
    """Exact, vectorised evaluation of an :class:`~coplan.kinematics.timing.SCurve`'s positions.

    The same piecewise-cubic formulas as :meth:`SCurve.derivatives` (per joint: each phase's
    start state accumulated in the same order), tabulated once per move, so evaluating a
    move at many times is one ``searchsorted`` and one cubic instead of a loop over phases.
    """

    def __init__(self, curve: SCurve):
        self.q0 = np.asarray(curve.q0, float)
        self.q1 = np.asarray(curve.q1, float)
        self.duration = curve.duration
        self.joints = []
        for i, (durs, jerks) in enumerate(curve.profiles):
            if not durs or curve.duration <= 0:
                self.joints.append(None)
                continue
            Ti = float(sum(durs))
            self.joints.append((*phase_starts(durs, jerks), np.asarray(jerks, float),
                                Ti, Ti / curve.duration, float(np.sign(self.q1[i] - self.q0[i]))))

    def eval(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float)
        out = np.empty((t.size, 2))
        for i, jt in enumerate(self.joints):
            if jt is None:
                out[:, i] = self.q0[i]
                continue
            starts, P, V, A, J, Ti, k, sg = jt
            # np.minimum/np.maximum: the same values as np.clip, without its overhead on short arrays
            tau = np.minimum(np.maximum(np.minimum(np.maximum(t, 0.0), self.duration) * k, 0.0), Ti)
            idx = np.minimum(np.maximum(np.searchsorted(starts, tau, side="right") - 1, 0), len(starts) - 1)
            dt = tau - starts[idx]
            out[:, i] = self.q0[i] + sg * (P[idx] + V[idx] * dt + A[idx] * dt**2 / 2 + J[idx] * dt**3 / 6)
        out[t >= self.duration] = self.q1
        return out


def curve_eval(curve: SCurve, t: np.ndarray, tables: dict) -> np.ndarray:
    """Positions of ``curve`` at times ``t`` from its start, tabulated in ``tables`` (a
    per-run cache keyed by the curve's id; the curve is kept with its table). Any other curve
    object (e.g. :class:`coplan.live.motion.Approach`, a re-planned approach from a moving state)
    evaluates itself with its ``eval(t)``."""
    if not isinstance(curve, SCurve):
        return curve.eval(t)
    hit = tables.get(id(curve))
    if hit is None or hit[0] is not curve:
        hit = (curve, CurveTable(curve))
        tables[id(curve)] = hit
    return hit[1].eval(t)


def steps_positions(steps: list[Step], T: np.ndarray, tables: dict) -> np.ndarray:
    """Positions of consecutive ``steps`` at sorted times ``T`` (at rest after the last)."""
    out = np.empty((T.size, 2))
    out[:] = steps[-1].q1
    out[T < steps[0].t0] = steps[0].q0
    for s in steps:
        lo, hi = np.searchsorted(T, [s.t0, s.t1])
        if hi > lo:
            out[lo:hi] = curve_eval(s.curve, T[lo:hi] - s.t0, tables) if s.kind == StepKind.MOVE else s.q1
    return out
