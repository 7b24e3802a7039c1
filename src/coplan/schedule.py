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

:func:`remove_conflicts` is the older name of step 4 (same guarantee, same arguments).
"""

from __future__ import annotations

import bisect
import time as _time
from dataclasses import dataclass, field, replace
from enum import Enum

import numpy as np

from .allocate import Allocation
from .plan import Event, EventKind
from .problem import Arm, Problem
from .timing import SCurve

__all__ = [
    "StepKind",
    "Step",
    "ArmSchedule",
    "ConflictError",
    "decoupled_schedules",
    "choose_branches",
    "route_moves",
    "coordinate",
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


def _arm_points(arm: Arm, q) -> tuple[np.ndarray, ...]:
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


def _ps2(px, py, ax, ay, ux, uy, uu):
    """Squared distance from points p to segments a + s u, s in [0, 1] (uu = |u|^2)."""
    t = np.clip(((px - ax) * ux + (py - ay) * uy) / uu, 0.0, 1.0)
    dx = px - ax - t * ux
    dy = py - ay - t * uy
    return dx * dx + dy * dy


def _seg_dist(ax, ay, bx, by, cx, cy, dx, dy):
    """Exact distance between segments a-b and c-d, component arrays (broadcast); the same
    rule as :func:`coplan.geometry.segment_distance` (zero when they cross, else the least
    endpoint-to-segment distance), written out on components for speed."""
    ux, uy = bx - ax, by - ay
    vx, vy = dx - cx, dy - cy
    uu = np.maximum(ux * ux + uy * uy, 1e-300)
    vv = np.maximum(vx * vx + vy * vy, 1e-300)
    d = np.minimum(np.minimum(_ps2(ax, ay, cx, cy, vx, vy, vv), _ps2(bx, by, cx, cy, vx, vy, vv)),
                   np.minimum(_ps2(cx, cy, ax, ay, ux, uy, uu), _ps2(dx, dy, ax, ay, ux, uy, uu)))
    d1 = ux * (cy - ay) - uy * (cx - ax)
    d2 = ux * (dy - ay) - uy * (dx - ax)
    d3 = vx * (ay - cy) - vy * (ax - cx)
    d4 = vx * (by - cy) - vy * (bx - cx)
    return np.where((d1 * d2 < 0) & (d3 * d4 < 0), 0.0, np.sqrt(d))


def _points_clearance(pa: tuple, pb: tuple, radii: float) -> np.ndarray:
    """Least capsule clearance between two arms given by :func:`_arm_points` (broadcast)."""
    d = None
    for s in range(2):
        for u in range(2):
            x = _seg_dist(pa[2 * s], pa[2 * s + 1], pa[2 * s + 2], pa[2 * s + 3],
                          pb[2 * u], pb[2 * u + 1], pb[2 * u + 2], pb[2 * u + 3])
            d = x if d is None else np.minimum(d, x)
    return d - radii


def _points_too_close(pa: tuple, pb: tuple, radii: float, need: float) -> np.ndarray:
    """Whether two arms given by :func:`_arm_points` are closer than ``need`` (broadcast).

    The same exact test as ``_points_clearance(...) < need``, with a cheap screen first: two
    links whose midpoints are further apart than their half lengths plus ``radii + need``
    cannot be too close, so the exact distance is computed only for the others.
    """
    pa = np.broadcast_arrays(*pa, *pb)
    pa, pb = pa[:6], pa[6:]
    shape = pa[0].shape
    pa = [x.ravel() for x in pa]
    pb = [x.ravel() for x in pb]
    out = np.zeros(pa[0].size, bool)
    for s in range(2):
        ax, ay, bx, by = pa[2 * s], pa[2 * s + 1], pa[2 * s + 2], pa[2 * s + 3]
        mx, my = (ax + bx) / 2, (ay + by) / 2
        ha = np.hypot(bx - ax, by - ay) / 2
        for u in range(2):
            cx, cy, dx, dy = pb[2 * u], pb[2 * u + 1], pb[2 * u + 2], pb[2 * u + 3]
            hb = np.hypot(dx - cx, dy - cy) / 2
            near = np.hypot(mx - (cx + dx) / 2, my - (cy + dy) / 2) - ha - hb < need + radii
            near &= ~out
            idx = np.flatnonzero(near)
            if idx.size:
                d = _seg_dist(ax[idx], ay[idx], bx[idx], by[idx], cx[idx], cy[idx], dx[idx], dy[idx])
                out[idx[d - radii < need]] = True
    return out.reshape(shape)


def pair_distances(problem: Problem, qa: np.ndarray, qb: np.ndarray, ia: int, ib: int) -> np.ndarray:
    """Least capsule distance between arms ia and ib for joint samples (K, 2) each -> (K,)."""
    a, b = problem.arms[ia], problem.arms[ib]
    return _points_clearance(_arm_points(a, qa), _arm_points(b, qb), a.link_radius + b.link_radius)


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


class ConflictError(RuntimeError):
    """No conflict-free coordination was found (arms that keep blocking each other, or out of time)."""


# ----------------------------------------------------------------------------- coordination
def _same(p, q, tol: float = 1e-9) -> bool:
    return abs(p[0] - q[0]) <= tol and abs(p[1] - q[1]) <= tol


def _stow_poses(arm: Arm, n_shoulder: int = 12) -> np.ndarray:
    """Candidate rest poses of an arm: home, over its bin (both branches), folded-elbow poses
    around the shoulder (and straight ones)."""
    lim = arm.limits
    cands = [np.asarray(arm.home, float)]
    q, valid = arm.ik(np.asarray(arm.bin, float))
    cands += [q[b] for b in range(2) if valid[b]]
    # the elbow folded as far as its limits allow (either side), or straight
    folds = sorted({float(np.clip(f, lim[1, 0] + 0.05, lim[1, 1] - 0.05)) for f in (np.pi - 0.25, -(np.pi - 0.25), 0.0)})
    for s in np.linspace(-np.pi, np.pi, n_shoulder, endpoint=False):
        s = float(np.clip(s, lim[0, 0], lim[0, 1]))
        cands += [np.array([s, f]) for f in folds]
    out = []
    for c in cands:
        if not any(np.allclose(c, o) for o in out):
            out.append(c)
    return np.array(out)


class _Geometry:
    """Static (time-free) clearance tests between neighbouring arms, and move routing."""

    def __init__(self, problem: Problem, need: float):
        self.problem = problem
        self.need = need
        self.nbrs: list[list[int]] = [[] for _ in problem.arms]
        for i, j in problem.neighbour_pairs():
            self.nbrs[i].append(j)
            self.nbrs[j].append(i)
        self._stows: dict[int, np.ndarray] = {}
        self._routes: dict[tuple, list[tuple[float, float]]] = {}

    def close(self, i: int, qi: np.ndarray, j: int, qj: np.ndarray) -> np.ndarray:
        """Whether arm i at poses qi and arm j at poses qj (broadcast) are closer than ``need``."""
        a, b = self.problem.arms[i], self.problem.arms[j]
        return _points_too_close(_arm_points(a, qi), _arm_points(b, qj), a.link_radius + b.link_radius, self.need)

    def static_hits(self, i: int, poses: np.ndarray, j: int, samples: np.ndarray) -> np.ndarray:
        """For each of arm i's poses (C, 2): how many of arm j's samples (M, 2) come too close."""
        poses, samples = np.atleast_2d(np.asarray(poses, float)), np.atleast_2d(np.asarray(samples, float))
        if samples.size == 0 or poses.size == 0:
            return np.zeros(len(poses), int)
        return self.close(i, poses[:, None, :], j, samples[None, :, :]).sum(axis=1)

    @staticmethod
    def path(q0, q1, step: float = 0.04) -> np.ndarray:
        """Straight joint-space samples from q0 to q1, at most ``step`` rad apart."""
        q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
        n = max(2, int(np.ceil(np.abs(q1 - q0).max() / step)) + 1)
        return q0 + np.linspace(0.0, 1.0, n)[:, None] * (q1 - q0)

    def move_path(self, i: int, q0, q1, dt: float = 0.01) -> np.ndarray:
        """Arm i's poses along its time-optimal S-curve move from q0 to q1, every ``dt`` s (the
        joints' profiles differ in shape, so the path is not quite straight in joint space)."""
        mv = _move(self.problem.arms[i], 0.0, q0, q1)
        if mv.duration <= 0:
            return np.atleast_2d(np.asarray(q1, float))
        t = np.append(np.arange(0.0, mv.duration, dt), mv.duration)
        return _CurveTable(mv.curve).eval(t)

    def vias_path(self, i: int, q0, vias, dt: float = 0.01) -> np.ndarray:
        """Arm i's poses along S-curve moves from q0 through ``vias`` (every ``dt`` s)."""
        pts, q = [], q0
        for v in vias:
            pts.append(self.move_path(i, q, v, dt))
            q = v
        return np.vstack(pts) if pts else np.atleast_2d(np.asarray(q0, float))

    def stows(self, i: int) -> np.ndarray:
        if i not in self._stows:
            self._stows[i] = _stow_poses(self.problem.arms[i])
        return self._stows[i]

    def boxed_in(self, i: int, samples: np.ndarray) -> int:
        """How many neighbours of arm i have no candidate rest pose clear of arm i's ``samples``."""
        n = 0
        for j in self.nbrs[i]:
            cand = self.stows(j)
            # home and over the bin first: usually one of them is clear
            if (self.static_hits(j, cand[:3], i, samples) > 0).all() and (self.static_hits(j, cand[3:], i, samples) > 0).all():
                n += 1
        return n

    def route(self, i: int, q0, q1) -> list[tuple[float, float]]:
        """Via poses (ending at q1) for a move of arm i from q0.

        Straight in joint space, unless the straight move sweeps where some neighbour cannot
        be out of the way at any of its candidate rest poses (typically across the
        neighbour's base: no waiting or yielding can let it run). Then a tucked transit:
        fold the elbow (as far as its limits allow, on either side), swing the shoulder,
        unfold -- folding where the move starts and unfolding where it ends, or else swinging
        first (elbow as it is) to a shoulder angle from which the fold sweeps clear, or
        unfolding at such an angle and swinging last. Variants are tried from the fastest;
        the first that boxes no neighbour in is used, else the one boxing in the fewest if
        that is fewer than the straight move.
        """
        key = (i, tuple(np.round(q0, 9)), tuple(np.round(q1, 9)))
        if key in self._routes:
            return self._routes[key]
        q0t, q1t = tuple(map(float, q0)), tuple(map(float, q1))
        out = [q1t]
        if self.nbrs[i] and not _same(q0t, q1t):
            worst = self.boxed_in(i, self.move_path(i, q0t, q1t))
            if worst:
                out = self._tucked(i, q0t, q1t, worst) or out
        self._routes[key] = out
        return out

    def _tucked(self, i: int, q0: tuple, q1: tuple, worst: int) -> list[tuple[float, float]] | None:
        arm = self.problem.arms[i]
        lim = arm.limits
        grid = [float(x) for x in np.linspace(lim[0, 0], lim[0, 1], 13)]
        variants = []
        for side in (1.0, -1.0):
            f = float(np.clip(side * (np.pi - 0.15), lim[1, 0] + 0.05, lim[1, 1] - 0.05))
            shapes = [[(q0[0], f), (q1[0], f), q1]]
            shapes += [[(s, q0[1]), (s, f), (q1[0], f), q1] for s in grid]  # swing first, fold at s
            shapes += [[(q0[0], f), (s, f), (s, q1[1]), q1] for s in grid]  # unfold at s, swing last
            for vias in shapes:
                clean, q = [], q0
                for v in vias:
                    if not _same(v, q):
                        clean.append(v)
                        q = v
                dur, q = 0.0, q0
                for v in clean:
                    dur += _move(arm, 0.0, q, v).duration
                    q = v
                variants.append((dur, clean))
        variants.sort(key=lambda v: v[0])
        best = None
        for dur, vias in variants:
            n = self.boxed_in(i, self.vias_path(i, q0, vias))
            if n == 0:
                return vias
            if best is None or n < best[0]:
                best = (n, vias)
        return best[1] if best is not None and best[0] < worst else None


def route_moves(problem: Problem, schedules: dict[str, ArmSchedule], need: float) -> tuple[dict[str, ArmSchedule], int]:
    """Replace every move that boxes a neighbour in by a tucked transit (see :meth:`_Geometry.route`).

    Returns the schedules (retimed) and the number of moves rerouted.
    """
    geo = _Geometry(problem, need)
    out, count = {}, 0
    for i, arm in enumerate(problem.arms):
        sch = schedules[arm.name]
        steps: list[Step] = []
        changed = False
        for st in sch.steps:
            vias = geo.route(i, st.q0, st.q1) if st.kind == StepKind.MOVE else [st.q1]
            if st.kind == StepKind.MOVE and len(vias) > 1:
                q = st.q0
                for v in vias:
                    steps.append(Step(StepKind.MOVE, 0.0, 0.0, tuple(q), tuple(v)))
                    q = v
                changed = True
                count += 1
            else:
                steps.append(st)
        out[arm.name] = ArmSchedule(arm, _retime(arm, steps)) if changed else sch
    return out, count


def choose_branches(problem: Problem, alloc: Allocation, need: float, weight: float = 0.5, passes: int = 2) -> Allocation:
    """Elbow branches at every pick and place chosen to keep out of the neighbours' way.

    The allocation picks each pose's elbow branch for speed alone. But every arm returns to
    its bin after each fruit, so a move that sweeps through a neighbour's place pose (or
    its home), or a pick/place pose that overlaps one, makes the pair queue: a wait per
    cycle. Here each arm's branches come from the same dynamic programme over its sequence
    (home -> fruit -> bin -> ... -> home), with each move costing its time-optimal duration
    plus ``weight`` s per neighbour pose it would hit (the neighbours' current place poses
    and homes; a tucked transit is not assumed). Arms in order, ``passes`` times, so each
    sees its neighbours' updated place poses. Assignment and sequence are unchanged.
    """
    geo = _Geometry(problem, need)
    arms = problem.arms
    margin = problem.task.reach_margin
    fruit_pos = {f.id: np.asarray(f.position, float) for f in problem.fruits}
    fruit_q = {a: dict(v) for a, v in alloc.fruit_q.items()}
    place_q = {a: dict(v) for a, v in alloc.place_q.items()}
    dw = problem.task.pick_dwell + problem.task.place_dwell
    for _ in range(passes):
        for i, arm in enumerate(arms):
            seq = alloc.assignment[arm.name]
            if not seq or not geo.nbrs[i]:
                continue
            avoid = {}
            for j in geo.nbrs[i]:
                poses = [np.asarray(arms[j].home, float)] + [np.asarray(q, float) for q in place_q[arms[j].name].values()]
                uniq: list[np.ndarray] = []
                for q in poses:
                    if not any(_same(q, u, 1e-6) for u in uniq):
                        uniq.append(q)
                avoid[j] = np.asarray(uniq)
            cache: dict = {}

            def cost(q0, q1):
                key = (tuple(np.round(q0, 9)), tuple(np.round(q1, 9)))
                if key not in cache:
                    path = geo.path(q0, q1, step=0.08)
                    hits = sum(int((geo.static_hits(j, avoid[j], i, path) > 0).sum()) for j in avoid)
                    cache[key] = _move(arm, 0.0, q0, q1).duration + weight * hits
                return cache[key]

            qb, vb = arm.ik(np.asarray(arm.bin, float))
            bins = [qb[b] for b in range(2) if vb[b]]
            home = np.asarray(arm.home, float)
            states: dict = {None: (0.0, [], [])}
            for fid in seq:
                qf, vf = arm.ik(fruit_pos[fid], margin)
                fbr = [qf[b] for b in range(2) if vf[b]] or [np.asarray(fruit_q[arm.name][fid], float)]
                new: dict = {}
                for prev, (c0, fs, ps) in states.items():
                    start = home if prev is None else bins[prev]
                    for f in fbr:
                        c1 = c0 + cost(start, f)
                        for b, qbin in enumerate(bins):
                            c2 = c1 + cost(f, qbin) + dw
                            if b not in new or c2 < new[b][0]:
                                new[b] = (c2, fs + [f], ps + [qbin])
                states = new
            best = min(states.items(), key=lambda kv: kv[1][0] + cost(bins[kv[0]], home))[1]
            fruit_q[arm.name] = {f: q.copy() for f, q in zip(seq, best[1])}
            place_q[arm.name] = {f: q.copy() for f, q in zip(seq, best[2])}
    return replace(alloc, fruit_q=fruit_q, place_q=place_q)


@dataclass
class _Leg:
    """One unit of an arm's work: a move to ``target`` (then an optional pick/place dwell)."""

    target: tuple[float, float]
    kind: StepKind | None = None  # PICK / PLACE after the move, or None
    dwell: float = 0.0
    fruit: str | None = None
    point: tuple[float, float] | None = None  # world point of a pick/place (for the other IK branch)
    home: bool = False  # the final move home


def _legs_of(problem: Problem, sch: ArmSchedule) -> list[_Leg]:
    """An arm's schedule as legs (waits dropped); it ends with a move home if it has any."""
    arm = sch.arm
    fruit_pos = {f.id: tuple(map(float, f.position)) for f in problem.fruits}
    legs: list[_Leg] = []
    for st in sch.steps:
        if st.kind == StepKind.MOVE:
            legs.append(_Leg(tuple(map(float, st.q1))))
        elif st.kind in (StepKind.PICK, StepKind.PLACE):
            point = fruit_pos[st.fruit] if st.kind == StepKind.PICK else tuple(map(float, arm.bin))
            leg = _Leg(tuple(map(float, st.q1)), st.kind, st.duration, st.fruit, point)
            if legs and legs[-1].kind is None and _same(legs[-1].target, leg.target):
                legs[-1].kind, legs[-1].dwell, legs[-1].fruit, legs[-1].point = leg.kind, leg.dwell, leg.fruit, leg.point
            else:  # a dwell right where the arm already is
                legs.append(leg)
    home = tuple(map(float, arm.home))
    if legs and legs[-1].kind is None and _same(legs[-1].target, home):
        legs[-1].home = True
    elif legs:
        legs.append(_Leg(home, home=True))
    return legs


class _Track:
    """One arm in :func:`coordinate`: its committed steps, its pose after them, its remaining legs."""

    def __init__(self, arm: Arm, index: int, rank: int, legs: list[_Leg], tables: dict):
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
            out[lo:hi] = _curve_eval(s.curve, T[lo:hi] - s.t0, self.tables) if s.kind == StepKind.MOVE and s.curve is not None else s.q1
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


class _CurveTable:
    """Exact, vectorised evaluation of an :class:`~coplan.timing.SCurve`'s positions.

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
            starts, P, V, A = [], [], [], []
            p = v = acc = 0.0
            t0 = 0.0
            for d, jk in zip(durs, jerks):
                starts.append(t0)
                P.append(p)
                V.append(v)
                A.append(acc)
                p, v, acc = p + v * d + acc * d**2 / 2 + jk * d**3 / 6, v + acc * d + jk * d**2 / 2, acc + jk * d
                t0 += d
            Ti = float(sum(durs))
            self.joints.append((np.asarray(starts), np.asarray(P), np.asarray(V), np.asarray(A), np.asarray(jerks, float),
                                Ti, Ti / curve.duration, float(np.sign(self.q1[i] - self.q0[i]))))

    def eval(self, t: np.ndarray) -> np.ndarray:
        t = np.asarray(t, float)
        out = np.empty((t.size, 2))
        for i, jt in enumerate(self.joints):
            if jt is None:
                out[:, i] = self.q0[i]
                continue
            starts, P, V, A, J, Ti, k, sg = jt
            tau = np.clip(np.clip(t, 0.0, self.duration) * k, 0.0, Ti)
            idx = np.clip(np.searchsorted(starts, tau, side="right") - 1, 0, len(starts) - 1)
            dt = tau - starts[idx]
            out[:, i] = self.q0[i] + sg * (P[idx] + V[idx] * dt + A[idx] * dt**2 / 2 + J[idx] * dt**3 / 6)
        out[t >= self.duration] = self.q1
        return out


def _curve_eval(curve: SCurve, t: np.ndarray, tables: dict) -> np.ndarray:
    """Positions of ``curve`` at times ``t`` from its start, tabulated in ``tables`` (a
    per-run cache keyed by the curve's id; the curve is kept with its table)."""
    hit = tables.get(id(curve))
    if hit is None or hit[0] is not curve:
        hit = (curve, _CurveTable(curve))
        tables[id(curve)] = hit
    return hit[1].eval(t)


def _steps_positions(steps: list[Step], T: np.ndarray, tables: dict) -> np.ndarray:
    """Positions of consecutive ``steps`` at sorted times ``T`` (at rest after the last)."""
    out = np.empty((T.size, 2))
    out[:] = steps[-1].q1
    out[T < steps[0].t0] = steps[0].q0
    for s in steps:
        lo, hi = np.searchsorted(T, [s.t0, s.t1])
        if hi > lo:
            out[lo:hi] = _curve_eval(s.curve, T[lo:hi] - s.t0, tables) if s.kind == StepKind.MOVE else s.q1
    return out


class _Coordinator(_Geometry):
    """State of :func:`coordinate` (see there for the rules)."""

    def __init__(self, problem: Problem, schedules: dict[str, ArmSchedule], margin: float, rate: float, quantum: float,
                 priority: list[str] | None, deadline: float | None, max_yields: int | None, horizon: float | None):
        super().__init__(problem, problem.task.clearance + margin)
        names = [a.name for a in problem.arms]
        self.rate, self.quantum, self.deadline = rate, quantum, deadline
        order = priority or sorted(names, key=lambda n: -schedules[n].last_place)
        rank = {n: i for i, n in enumerate(order)}
        self.tables: dict = {}
        self.tracks = [_Track(a, i, rank.get(a.name, len(order) + i), _legs_of(problem, schedules[a.name]), self.tables)
                       for i, a in enumerate(problem.arms)]
        self.max_yields = 6 * len(self.tracks) + 6 if max_yields is None else max_yields
        work = sum(schedules[n].end for n in names)
        self.horizon = 3.0 * work + 30.0 if horizon is None else horizon
        self.yields = 0
        self.parks = 0
        self.log = None  # debugging: a callable taking a message
        self._remaining: dict[int, tuple] = {}
        self._moves: dict[tuple, list[Step]] = {}
        self._yielded: set = set()

    # ---- static views of the remaining work
    def remaining(self, j: int) -> np.ndarray:
        """Joint samples of arm j's remaining work legs (from where it rests; home move excluded)."""
        tr = self.tracks[j]
        key = (len(tr.todo), tr.pose)
        hit = self._remaining.get(j)
        if hit is not None and hit[0] == key:
            return hit[1]
        pts, q = [np.asarray(tr.pose, float)[None]], tr.pose
        for leg in tr.todo:
            if leg.home:
                break
            pts.append(self.vias_path(j, q, self.route(j, q, leg.target), dt=0.03))
            q = leg.target
        out = np.vstack(pts)
        self._remaining[j] = (key, out)
        return out

    def leg_samples(self, tr: _Track, leg: _Leg) -> np.ndarray:
        """Arm ``tr``'s poses along ``leg`` from where it rests (at ``rate``), target included."""
        steps = self.leg_steps(tr, leg, 0.0)
        if not steps:
            return np.asarray(tr.pose, float)[None]
        T = np.append(np.arange(0.0, steps[-1].t1, 1.0 / self.rate), steps[-1].t1)
        return _steps_positions(steps, T, self.tables)

    # ---- timing
    def leg_steps(self, tr: _Track, leg: _Leg, t: float) -> list[Step]:
        """The leg's move(s) from where the arm rests, starting at ``t``, then its dwell."""
        steps: list[Step] = []
        if not _same(tr.pose, leg.target):
            key = (tr.index, tr.pose, leg.target)
            moves = self._moves.get(key)
            if moves is None:  # routed from where the arm rests (see _Geometry.route), from t = 0
                moves, q, t0 = [], tr.pose, 0.0
                for v in self.route(tr.index, tr.pose, leg.target):
                    moves.append(_move(tr.arm, t0, q, v))
                    t0, q = moves[-1].t1, v
                self._moves[key] = moves
            steps = [replace(m, t0=m.t0 + t) for m in moves]
            t = steps[-1].t1
        if leg.kind is not None:
            steps.append(Step(leg.kind, t, leg.dwell, leg.target, leg.target, fruit=leg.fruit))
        return steps

    def conflict(self, tr: _Track, steps: list[Step], t: float):
        """First conflict of ``steps`` (from ``t``, resting after) with the neighbours' commitments.

        Returns None, or ``(tc, j, late)``: the first time too close, the neighbour, and (when
        that first conflict comes after the arm has arrived) the last time before that
        neighbour's commitments end at which the resting arm is too close -- to jump past a
        neighbour passing through the target.
        """
        nb = [self.tracks[j] for j in self.nbrs[tr.index]]
        if not nb:
            return None
        t_stop = max([steps[-1].t1] + [o.end for o in nb])
        n = int(np.floor((t_stop - t) * self.rate + 1e-9)) + 2  # the last sample: everyone at rest
        T = t + np.arange(n) / self.rate
        qa = _steps_positions(steps, T, self.tables)
        arrive = next((s.t1 for s in reversed(steps) if s.kind == StepKind.MOVE), t)
        best = None
        for o in nb:
            bad = self.close(tr.index, qa, o.index, o.positions(T))
            hit = np.flatnonzero(bad)
            if hit.size and (best is None or T[hit[0]] < best[0]):
                late = T[hit[(T[hit] >= arrive) & (T[hit] < o.end)]]
                best = (float(T[hit[0]]), o.index, float(late.max()) if late.size and T[hit[0]] >= arrive else None)
        return best

    def earliest(self, tr: _Track, leg: _Leg, t: float) -> tuple[float | None, int | None]:
        """Earliest start, ``t`` or at least ``quantum`` later, at which ``leg`` is clear of the
        neighbours' commitments: ``(start, None)``; or ``(None, j)`` when neighbour j's rest
        pose after its commitments is in the way (then no start helps)."""
        s = t
        while True:
            steps = self.leg_steps(tr, leg, s)
            if not steps:
                return s, None
            hit = self.conflict(tr, steps, s)
            if hit is None:
                return s, None
            tc, j, late = hit
            if tc >= self.tracks[j].end:
                return None, j
            step = self.quantum
            if late is not None:
                arrive = next((st.t1 for st in reversed(steps) if st.kind == StepKind.MOVE), s)
                step = max(step, late - arrive + 1.0 / self.rate)
            s += step

    # ---- deadlocks
    def is_stuck(self, j: int, waiting: int) -> bool:
        """Whether arm j will not move unless someone yields (finished, deferred or in a blocking cycle)."""
        seen = {waiting}
        x = self.tracks[j]
        while True:
            if not x.todo or x.deferred:
                return True
            if x.stuck is None:
                return False
            if x.index in seen:
                return True
            seen.add(x.index)
            x = self.tracks[x.stuck]

    def yield_pose(self, y: _Track, x: _Track) -> np.ndarray | None:
        """Where arm y should go so that arm x's next leg is clear of it.

        Hard: clear of x's next leg (sampled at ``rate``, target included), and y's way there
        clear of where its neighbours rest. Soft: fewest conflicts with the neighbours'
        remaining work, then the quickest move.
        """
        cand = self.stows(y.index)
        cand = cand[[not _same(c, y.pose) for c in cand]]
        ok = self.static_hits(y.index, cand, x.index, self.leg_samples(x, x.todo[0])) == 0 if x.todo else np.ones(len(cand), bool)
        soft = np.zeros(len(cand))
        frac = np.linspace(0.0, 1.0, 16)[None, :, None]
        ways = np.asarray(y.pose, float) + frac * (cand[:, None, :] - np.asarray(y.pose, float))  # (C, 16, 2)
        for j in self.nbrs[y.index]:
            o = self.tracks[j]
            ok &= ~self.close(y.index, ways, j, np.asarray(o.pose, float)).any(axis=1)
            rem = self.remaining(j)
            soft += self.static_hits(y.index, cand, j, rem) / len(rem)
        if not ok.any():
            return None
        time = np.array([_move(y.arm, 0.0, y.pose, c).duration for c in cand])
        return cand[int(np.argmin(np.where(ok, 10.0 * soft + time, np.inf)))]

    def do_yield(self, y: _Track, x: _Track, t: float) -> bool:
        """Send arm y out of arm x's way (a yield move first in its list); False if it cannot."""
        key = (y.index, x.index, len(x.todo), x.pose, y.pose)
        if key in self._yielded:
            return False
        pose = self.yield_pose(y, x)
        if self.log:
            self.log(f"{t:7.2f} {y.arm.name} yields to {x.arm.name}: {None if pose is None else np.round(pose, 2)} from {np.round(y.pose, 2)}")
        if pose is None:
            return False
        self._yielded.add(key)
        if not y.todo or not y.todo[-1].home:
            y.todo.append(_Leg(y.home, home=True))
        y.todo.insert(0, _Leg(tuple(map(float, pose))))
        y.stuck, y.deferred = None, False
        y.ready = max(y.end, t)
        self.yields += 1
        return True

    def other_branch(self, tr: _Track, leg: _Leg) -> _Leg | None:
        """The same pick/place with the other elbow branch, if valid and not into a pose a
        neighbour keeps coming back to (its places, its home); else None."""
        if leg.point is None:
            return None
        margin = self.problem.task.reach_margin if leg.kind == StepKind.PICK else 0.0
        q, valid = tr.arm.ik(np.asarray(leg.point, float), margin)
        for b in range(2):
            if valid[b] and not _same(q[b], leg.target, 1e-6):
                for j in self.nbrs[tr.index]:
                    o = self.tracks[j]
                    rests = [lg.target for lg in o.todo if lg.kind == StepKind.PLACE or lg.home] + [o.home]
                    if self.static_hits(tr.index, q[b], j, np.asarray(rests, float))[0]:
                        return None
                return replace(leg, target=tuple(map(float, q[b])))
        return None

    def route_time(self, i: int, q0, q1) -> float:
        """Duration of arm i's (routed) move from q0 to q1."""
        out, q = 0.0, q0
        for v in self.route(i, q0, q1):
            out += _move(self.problem.arms[i], 0.0, q, v).duration
            q = v
        return out

    def detour(self, tr: _Track, leg: _Leg, alt: _Leg) -> float:
        """Extra time of doing ``alt`` instead of ``leg`` (into the target and on to the next one)."""
        nxt = tr.todo[1].target if len(tr.todo) > 1 else None

        def via(target):
            t = self.route_time(tr.index, tr.pose, target)
            return t + (self.route_time(tr.index, target, nxt) if nxt is not None else 0.0)

        return via(alt.target) - via(leg.target)

    # ---- finishing
    def home_blocks(self, tr: _Track) -> bool:
        """Whether home is in the way of a neighbour's remaining work."""
        return any(self.static_hits(tr.index, np.asarray(tr.home, float), j, self.remaining(j))[0] > 0
                   for j in self.nbrs[tr.index] if self.tracks[j].working)

    def park_pose(self, tr: _Track) -> np.ndarray | None:
        """Where a finished arm waits until home is out of the way: where it is if that is clear
        of the neighbours' remaining work, else the clearest candidate -- counting the
        neighbours' remaining work, where they rest now and their homes (None: stay)."""
        cand = np.vstack([np.asarray(tr.pose, float)[None], self.stows(tr.index)])
        hits = np.zeros(len(cand))
        for j in self.nbrs[tr.index]:
            o = self.tracks[j]
            hits += self.static_hits(tr.index, cand, j, np.vstack([self.remaining(j), np.asarray(o.home, float)[None]]))
        if hits[0] == 0:
            return None
        time = np.array([_move(tr.arm, 0.0, tr.pose, c).duration for c in cand])
        best = int(np.argmin(hits * 10.0 + time))
        return None if best == 0 else cand[best]

    # ---- main loop
    def commit(self, tr: _Track, steps: list[Step], start: float) -> None:
        if steps:
            tr.commit(start, steps)
        tr.todo.pop(0)
        tr.ready = max(tr.end, start)
        tr.stuck = None
        tr.blocker = None
        for j in self.nbrs[tr.index]:
            if self.tracks[j].stuck == tr.index:
                self.tracks[j].stuck = None

    def run(self) -> dict[str, ArmSchedule]:
        q = self.quantum
        while True:
            active = [tr for tr in self.tracks if tr.todo]
            if not active:
                break
            tr = min(active, key=lambda r: (r.ready, r.rank))
            t = tr.ready
            if self.deadline is not None and _time.perf_counter() > self.deadline:
                raise ConflictError("time budget for coordinating the arms is used up")
            if t > self.horizon:
                raise ConflictError(f"no conflict-free schedule found within {self.horizon:.0f} s of plan time")
            leg = tr.todo[0]
            if leg.home and not _same(tr.pose, tr.home) and self.home_blocks(tr):
                if not tr.parked:
                    tr.parked = True
                    park = self.park_pose(tr)
                    if park is not None:
                        tr.todo.insert(0, _Leg(tuple(map(float, park))))
                        self.parks += 1
                        continue
                tr.deferred = True
                nxt = [self.tracks[j].ready for j in self.nbrs[tr.index] if self.tracks[j].working]
                tr.ready = max(t + q, min(nxt, default=t + q))
                continue
            tr.deferred = False
            start, j = self.earliest(tr, leg, t)
            if start is not None:
                self.commit(tr, self.leg_steps(tr, leg, start), start)
                continue
            # a neighbour rests in the way until it moves again
            o = self.tracks[j]
            if self.log:
                self.log(f"{t:7.2f} {tr.arm.name} rest-blocked by {o.arm.name} (its end {o.end:.2f}) leg to {np.round(leg.target, 2)}")
            tr.stuck = j
            # the neighbour will move by itself: wait for it, but only once -- if its next rest
            # pose is in the way again, it is a busy neighbour starving this arm: resolve now
            again = tr.blocker is not None and tr.blocker[0] == j and not _same(tr.blocker[1], o.pose)
            tr.blocker = (j, o.pose) if tr.blocker is None or tr.blocker[0] != j else tr.blocker
            if not again and not self.is_stuck(j, tr.index):
                tr.ready = max(t + q, o.ready)
                continue
            # deadlock: the other branch of this pick/place if it costs little, else someone
            # gets out of the way (the neighbour if it is finished or has the lower priority;
            # else this arm, so that the neighbour's next leg can go), else the other branch
            # whatever it costs
            alt = self.other_branch(tr, leg)
            alt_start = self.earliest(tr, alt, t)[0] if alt is not None else None
            if alt_start is not None and self.detour(tr, leg, alt) <= 0.5:
                tr.todo[0] = alt
                self.commit(tr, self.leg_steps(tr, alt, alt_start), alt_start)
                continue
            first, second = (o, tr) if (not o.working or o.rank > tr.rank) else (tr, o)
            if self.yields < self.max_yields and (self.do_yield(first, second, t)
                                                  or (o.working and self.do_yield(second, first, t))):
                if tr.todo and tr.todo[0] is leg:
                    tr.ready = max(t + q, o.ready)
                continue
            if alt_start is not None:
                tr.todo[0] = alt
                self.commit(tr, self.leg_steps(tr, alt, alt_start), alt_start)
                continue
            if self.yields >= self.max_yields:
                raise ConflictError(f"arms {tr.arm.name!r} and {o.arm.name!r} keep blocking each other ({self.yields} yields)")
            raise ConflictError(f"arm {o.arm.name!r} rests in the way of arm {tr.arm.name!r} at t = {t:.2f} s "
                                "and neither can get out of the other's way")
        return {tr.arm.name: ArmSchedule(tr.arm, _merge_waits(tr.steps)) for tr in self.tracks}


def coordinate(
    problem: Problem,
    schedules: dict[str, ArmSchedule],
    margin: float,
    rate: float = 200.0,
    quantum: float = 0.05,
    priority: list[str] | None = None,
    deadline: float | None = None,
    max_yields: int | None = None,
    horizon: float | None = None,
) -> tuple[dict[str, ArmSchedule], int, int]:
    """Coordinate all arms leg by leg; every neighbouring pair keeps ``clearance + margin``.

    Each arm's work is a list of legs (a move, then its pick or place). The arm whose next
    leg is due first (ties: ``priority`` order, default the arm that finishes last first)
    books it at the earliest start -- now, or at least ``quantum`` s later -- at which the
    leg, and resting at its target afterwards, is clear (sampled at ``rate``) of every
    neighbour's booked motion and of where that neighbour rests after it. A booking is never
    revised and every later booking is checked against it, so the result is conflict-free at
    ``rate`` by construction; booking ahead (not only "go if clear now") means an arm with a
    long move cannot be starved by a busy neighbour.

    Deadlocks are broken by rule, not by search: an arm blocked by a neighbour that rests in
    its way and will not move by itself (finished, waiting to go home, or blocked in a cycle)
    first tries the other elbow branch of its pick/place (if that costs at most 0.5 s more,
    counting the move on from there); else the neighbour (a finished one, or the
    lower-priority one of a blocking pair) yields to the candidate rest pose -- home, over
    its bin, folded-elbow poses -- that clears the blocked leg, reachable without
    touching an arm at rest, with the fewest conflicts with the neighbours' remaining work.
    A finished arm goes home once home is clear of the neighbours' remaining work; until
    then it waits where it is, or (if that is in the way) at the clearest candidate pose.
    Moves from a pose the plan did not foresee are routed by :meth:`_Geometry.route`.

    Raises :class:`ConflictError` after ``max_yields`` yields, past ``horizon`` s of plan
    time or at ``deadline`` (``time.perf_counter()``). Returns the schedules (each ending at
    home), the number of waits and the number of yield/park moves added.
    """
    c = _Coordinator(problem, schedules, margin, rate, quantum, priority, deadline, max_yields, horizon)
    out = c.run()
    waits = sum(1 for s in out.values() for st in s.steps if st.kind == StepKind.WAIT)
    return out, waits, c.yields + c.parks


def remove_conflicts(
    problem: Problem,
    schedules: dict[str, ArmSchedule],
    margin: float,
    rate: float = 200.0,
    delay_step: float = 0.05,
    priority: list[str] | None = None,
    deadline: float | None = None,
) -> tuple[dict[str, ArmSchedule], int]:
    """The older name of :func:`coordinate` (``delay_step`` is its ``quantum``).

    Returns the conflict-free schedules and the number of waits plus yield/park moves added.
    """
    out, waits, extra = coordinate(problem, schedules, margin, rate=rate, quantum=delay_step, priority=priority, deadline=deadline)
    return out, waits + extra
