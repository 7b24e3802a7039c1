"""Routing for the warm start: rest poses, tucked transits and elbow branches.

:func:`route_moves` turns a move that sweeps where a neighbour cannot be out of the way into a
tucked transit (fold the elbow, swing the shoulder, unfold); :func:`choose_branches` picks the
elbow branch at every pick and place, charging moves for the neighbours' places and homes they
sweep through. See :mod:`coplan.planners.coordinated.schedule` for the whole warm start.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...allocate.allocation import Allocation
from ...problem.model import Arm, Problem
from ...ties import TIE, first_min, quantised
from .schedule import (
    CurveTable,
    ArmSchedule,
    LinkPoints,
    Step,
    StepKind,
    arm_points,
    links_too_close,
    links_too_close_pairs,
    scurve_move,
    points_too_close,
    retime,
)

__all__ = ["route_moves", "choose_branches", "ArmGeometry", "same_pose"]


# ----------------------------------------------------------------------------- coordination
def same_pose(p, q, tol: float = 1e-9) -> bool:
    """Whether joint poses ``p`` and ``q`` agree to ``tol`` (rad) in both joints."""
    return abs(p[0] - q[0]) <= tol and abs(p[1] - q[1]) <= tol


#: How far a folded elbow bends (rad, either way; within its limits, 0.05 rad in: :func:`elbow_fold`).
FOLD = np.pi - 0.25


def elbow_fold(arm: Arm, side: int) -> float:
    """The elbow angle folded to ``side`` (+1 or -1; 0: straight), as far as :data:`FOLD` and the
    elbow's limits (0.05 rad in) allow: the stow poses below, and the tucked ways of a booking on
    the move (:func:`coplan.row.track.tucked_route`)."""
    lim = arm.limits
    return float(np.clip(side * FOLD, lim[1, 0] + 0.05, lim[1, 1] - 0.05))


def stow_poses(arm: Arm, n_shoulder: int = 12) -> np.ndarray:
    """Candidate rest poses of an arm: home, over its bin (both branches), folded-elbow poses
    around the shoulder (and straight ones)."""
    lim = arm.limits
    cands = [np.asarray(arm.home, float)]
    q, valid = arm.ik(np.asarray(arm.bin, float))
    cands += [q[b] for b in range(2) if valid[b]]
    # the elbow folded as far as its limits allow (either side), or straight
    folds = sorted({elbow_fold(arm, side) for side in (1, -1, 0)})
    for s in np.linspace(-np.pi, np.pi, n_shoulder, endpoint=False):
        s = float(np.clip(s, lim[0, 0], lim[0, 1]))
        cands += [np.array([s, f]) for f in folds]
    out, seen = [], set()
    for c in cands:  # first occurrence of each pose (to 1e-7 rad)
        key = tuple(np.round(c, 7))
        if key not in seen:
            seen.add(key)
            out.append(c)
    return np.array(out)


class ArmGeometry:
    """Static (time-free) clearance tests between neighbouring arms, and move routing."""

    def __init__(self, problem: Problem, need: float):
        self.problem = problem
        self.need = need
        self.nbrs: list[list[int]] = [[] for _ in problem.arms]
        for i, j in problem.neighbour_pairs():
            self.nbrs[i].append(j)
            self.nbrs[j].append(i)
        self._stows: dict[int, np.ndarray] = {}
        self._stow_links: dict[int, LinkPoints] = {}
        self._routes: dict[tuple, list[tuple[float, float]]] = {}

    def radii(self, i: int, j: int) -> float:
        """The two arms' link radii together: links closer than ``radii + need`` are too close."""
        return self.problem.arms[i].link_radius + self.problem.arms[j].link_radius

    def close(self, i: int, qi: np.ndarray, j: int, qj: np.ndarray) -> np.ndarray:
        """Whether arm i at poses qi and arm j at poses qj (broadcast) are closer than ``need``."""
        a, b = self.problem.arms[i], self.problem.arms[j]
        return points_too_close(arm_points(a, qi), arm_points(b, qj), self.radii(i, j), self.need)

    def links(self, i: int, q: np.ndarray) -> LinkPoints:
        """Arm i's points at poses q (N, 2), ready for :meth:`close_links` (computed once,
        compared many times)."""
        return LinkPoints.of(arm_points(self.problem.arms[i], q))

    def close_links(self, i: int, li: LinkPoints, j: int, lj: LinkPoints) -> np.ndarray:
        """:meth:`close` on samples from :meth:`links`, side by side (N,)."""
        return links_too_close(li, lj, self.radii(i, j), self.need)

    def static_hits(self, i: int, poses: np.ndarray, j: int, samples: np.ndarray) -> np.ndarray:
        """For each of arm i's poses (C, 2): how many of arm j's samples (M, 2) come too close."""
        poses, samples = np.atleast_2d(np.asarray(poses, float)), np.atleast_2d(np.asarray(samples, float))
        if samples.size == 0 or poses.size == 0:
            return np.zeros(len(poses), int)
        return self.link_hits(i, self.links(i, poses), j, self.links(j, samples))

    def link_hits(self, i: int, poses: LinkPoints, j: int, samples: LinkPoints) -> np.ndarray:
        """:meth:`static_hits` on points from :meth:`links` (computed once, compared many times)."""
        return links_too_close_pairs(poses, samples, self.radii(i, j), self.need).sum(axis=1)

    @staticmethod
    def path(q0, q1, step: float = 0.04) -> np.ndarray:
        """Straight joint-space samples from q0 to q1, at most ``step`` rad apart."""
        q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
        n = max(2, int(np.ceil(np.abs(q1 - q0).max() / step)) + 1)
        return q0 + np.linspace(0.0, 1.0, n)[:, None] * (q1 - q0)

    def move_path(self, i: int, q0, q1, dt: float = 0.01) -> np.ndarray:
        """Arm i's poses along its time-optimal S-curve move from q0 to q1, every ``dt`` s (the
        joints' profiles differ in shape, so the path is not quite straight in joint space)."""
        mv = scurve_move(self.problem.arms[i], 0.0, q0, q1)
        if mv.duration <= 0:
            return np.atleast_2d(np.asarray(q1, float))
        t = np.append(np.arange(0.0, mv.duration, dt), mv.duration)
        return CurveTable(mv.curve).eval(t)

    def vias_path(self, i: int, q0, vias, dt: float = 0.01) -> np.ndarray:
        """Arm i's poses along S-curve moves from q0 through ``vias`` (every ``dt`` s)."""
        pts, q = [], q0
        for v in vias:
            pts.append(self.move_path(i, q, v, dt))
            q = v
        return np.vstack(pts) if pts else np.atleast_2d(np.asarray(q0, float))

    def stows(self, i: int) -> np.ndarray:
        if i not in self._stows:
            self._stows[i] = stow_poses(self.problem.arms[i])
        return self._stows[i]

    def stow_links(self, i: int) -> LinkPoints:
        """:meth:`links` of arm i's :meth:`stows`, computed once."""
        if i not in self._stow_links:
            self._stow_links[i] = self.links(i, self.stows(i))
        return self._stow_links[i]

    def boxed_in(self, i: int, samples: np.ndarray) -> int:
        """How many neighbours of arm i have no candidate rest pose clear of arm i's ``samples``
        (:meth:`static_hits` of each neighbour's stows, with the samples' points computed once)."""
        samples = np.atleast_2d(np.asarray(samples, float))
        if samples.size == 0:
            return 0
        mine, n = self.links(i, samples), 0
        for j in self.nbrs[i]:
            stow = self.stow_links(j)
            # home and over the bin first: usually one of them is clear
            if (self.link_hits(j, stow[:3], i, mine) > 0).all() and (self.link_hits(j, stow[3:], i, mine) > 0).all():
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
        if self.nbrs[i] and not same_pose(q0t, q1t):
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
                    if not same_pose(v, q):
                        clean.append(v)
                        q = v
                dur, q = 0.0, q0
                for v in clean:
                    dur += scurve_move(arm, 0.0, q, v).duration
                    q = v
                variants.append((dur, clean))
        variants.sort(key=lambda v: float(quantised(v[0])))  # stable: equal durations keep their order on any CPU
        best = None
        for dur, vias in variants:
            n = self.boxed_in(i, self.vias_path(i, q0, vias))
            if n == 0:
                return vias
            if best is None or n < best[0]:
                best = (n, vias)
        return best[1] if best is not None and best[0] < worst else None


def route_moves(problem: Problem, schedules: dict[str, ArmSchedule], need: float) -> tuple[dict[str, ArmSchedule], int]:
    """Replace every move that boxes a neighbour in by a tucked transit (see :meth:`ArmGeometry.route`).

    Returns the schedules (retimed) and the number of moves rerouted.
    """
    geo = ArmGeometry(problem, need)
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
        out[arm.name] = ArmSchedule(arm, retime(arm, steps)) if changed else sch
    return out, count


def choose_branches(problem: Problem, alloc: Allocation, need: float, weight: float = 0.5, passes: int = 2,
                    memo: dict | None = None) -> Allocation:
    """Elbow branches at every pick and place chosen to keep out of the neighbours' way.

    The allocation picks each pose's elbow branch for speed alone. But every arm returns to
    its bin after each fruit, so a move that sweeps through a neighbour's place pose (or
    its home), or a pick/place pose that overlaps one, makes the pair queue: a wait per
    cycle. Here each arm's branches come from the same dynamic programme over its sequence
    (home -> fruit -> bin -> ... -> home), with each move costing its time-optimal duration
    plus ``weight`` s per neighbour pose it would hit (the neighbours' current place poses
    and homes; a tucked transit is not assumed). Arms in order, ``passes`` times, so each
    sees its neighbours' updated place poses. Assignment and sequence are unchanged.

    ``memo`` (a dict the caller keeps, for one problem and one ``need``) remembers which
    move hits which neighbour pose, so repeated calls over similar allocations (the search's
    evaluations) test each move against each pose once.
    """
    geo = ArmGeometry(problem, need)
    memo = {} if memo is None else memo
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
                    if not any(same_pose(q, u, 1e-6) for u in uniq):
                        uniq.append(q)
                avoid[j] = np.asarray(uniq)
            avoid_keys = {j: [_key(q) for q in v] for j, v in avoid.items()}
            # the arm's programme depends only on its sequence, its poses handed in and the
            # neighbours' poses to avoid: a repeated one (the search changes one or two arms
            # at a time) is looked up, not solved again
            dp_key = ("dp", i, weight, dw, tuple(seq), tuple(_key(fruit_q[arm.name][f]) for f in seq),
                      tuple((j, tuple(k)) for j, k in avoid_keys.items()))
            hit = memo.get(dp_key)
            if hit is not None:
                fruit_q[arm.name] = {f: q.copy() for f, q in zip(seq, hit[0])}
                place_q[arm.name] = {f: q.copy() for f, q in zip(seq, hit[1])}
                continue
            cache: dict = {}

            def cost(q0, q1):
                key = (_key(q0), _key(q1))
                if key not in cache:
                    cache[key] = _move_seconds(arm, i, q0, q1, key, memo) + weight * _hits(geo, i, q0, q1, key, avoid,
                                                                                            avoid_keys, memo)
                return cache[key]

            qb, vb = arm.ik(np.asarray(arm.bin, float))
            bins = [qb[b] for b in range(2) if vb[b]]
            home = np.asarray(arm.home, float)
            branches = []
            for fid in seq:
                qf, vf = arm.ik(fruit_pos[fid], margin)
                branches.append([qf[b] for b in range(2) if vf[b]] or [np.asarray(fruit_q[arm.name][fid], float)])
            # every move the programme may price, tested against the neighbours' poses at once
            moves = [(home, f) for f in branches[0]] + [(qbin, home) for qbin in bins]
            moves += [m for fbr in branches for f in fbr for qbin in bins for m in ((qbin, f), (f, qbin))]
            _prefetch_hits(geo, i, moves, avoid, avoid_keys, memo)
            states: dict = {None: (0.0, [], [])}
            for fbr in branches:
                new: dict = {}
                for prev, (c0, fs, ps) in states.items():
                    start = home if prev is None else bins[prev]
                    for f in fbr:
                        c1 = c0 + cost(start, f)
                        for b, qbin in enumerate(bins):
                            c2 = c1 + cost(f, qbin) + dw
                            if b not in new or c2 < new[b][0] - TIE:
                                new[b] = (c2, fs + [f], ps + [qbin])
                states = new
            best = first_min(states.items(), key=lambda kv: kv[1][0] + cost(bins[kv[0]], home))[1]
            memo[dp_key] = (best[1], best[2])
            fruit_q[arm.name] = {f: q.copy() for f, q in zip(seq, best[1])}
            place_q[arm.name] = {f: q.copy() for f, q in zip(seq, best[2])}
    return replace(alloc, fruit_q=fruit_q, place_q=place_q)


def _key(q) -> tuple[float, float]:
    """Pose ``q`` to 1e-9 rad: exactly ``tuple(np.round(q, 9))`` (NumPy rounds q * 1e9 half to
    even and divides by 1e9, as Python's ``round`` does), at a sixth of its cost."""
    try:
        return (round(float(q[0]) * 1e9) / 1e9, round(float(q[1]) * 1e9) / 1e9)
    except (ValueError, OverflowError):  # not finite
        return tuple(np.round(np.asarray(q, float), 9))


def _move_seconds(arm, i: int, q0, q1, key: tuple, memo: dict) -> float:
    k = ("move", i) + key
    if k not in memo:
        memo[k] = scurve_move(arm, 0.0, q0, q1).duration
    return memo[k]


def _hit_key(i: int, move: tuple, j: int, pose: tuple) -> tuple:
    """The memo's key for arm i's move (``(_key(q0), _key(q1))``) against arm j's pose ``pose``
    (a ``_key``): one format for :func:`_prefetch_hits`, which fills it, and :func:`_hits`."""
    return ("hit", i) + move + (j,) + pose


def _prefetch_hits(geo: ArmGeometry, i: int, moves: list, avoid: dict, avoid_keys: dict, memo: dict,
                   chunk: int = 400_000) -> None:
    """Fill ``memo`` as :func:`_hits` would for every move ``(q0, q1)`` in ``moves``, in a few
    vectorised tests (all the moves' path samples against all of a neighbour's poses) instead of
    one small test per move; the same samples and the same exact test, so the same answers."""
    seen: set = set()
    uniq = []
    for q0, q1 in moves:
        key = (_key(q0), _key(q1))
        if key not in seen:
            seen.add(key)
            uniq.append((q0, q1, key))
    for j, poses in avoid.items():
        todo = [(q0, q1, key) for q0, q1, key in uniq
                if any(_hit_key(i, key, j, kp) not in memo for kp in avoid_keys[j])]
        if not todo or len(poses) == 0:
            continue
        paths = [geo.path(q0, q1, step=0.08) for q0, q1, _ in todo]
        pose_links = geo.links(j, poses)
        per = max(1, chunk // len(poses))
        lo = 0
        while lo < len(paths):  # moves in chunks of about ``chunk`` sample-pose pairs
            hi, n = lo, 0
            while hi < len(paths) and (hi == lo or n + len(paths[hi]) <= per):
                n += len(paths[hi])
                hi += 1
            samples = np.vstack(paths[lo:hi])
            starts = np.cumsum([0] + [len(p) for p in paths[lo:hi - 1]])
            close = links_too_close_pairs(pose_links, geo.links(i, samples), geo.radii(j, i), geo.need).T  # (samples, poses)
            hit = np.logical_or.reduceat(close, starts, axis=0)  # (moves, poses)
            for m in range(lo, hi):
                key = todo[m][2]
                for kp, h in zip(avoid_keys[j], hit[m - lo]):
                    memo[_hit_key(i, key, j, kp)] = bool(h)
            lo = hi


def _hits(geo: ArmGeometry, i: int, q0, q1, key: tuple, avoid: dict, avoid_keys: dict, memo: dict) -> int:
    """How many of the neighbours' ``avoid`` poses arm i's straight joint path q0 -> q1 comes too
    close to; each (move, pose) pair is tested once per ``memo``."""
    n, path = 0, None
    for j, poses in avoid.items():
        keys = [_hit_key(i, key, j, kp) for kp in avoid_keys[j]]
        todo = [m for m, k in enumerate(keys) if k not in memo]
        if todo:
            if path is None:
                path = geo.path(q0, q1, step=0.08)
            hit = geo.static_hits(j, poses[todo], i, path) > 0
            for m, h in zip(todo, hit):
                memo[keys[m]] = bool(h)
        n += sum(memo[k] for k in keys)
    return n
