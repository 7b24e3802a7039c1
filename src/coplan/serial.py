"""Serial fallback for the warm start: arms take turns where they would get in each other's way.

:func:`coplan.coordinate.coordinate` can deadlock on dense layouts. :func:`serial_schedules`
keeps every pick and place of its input (same fruit, pose and dwell) and succeeds whenever each
arm's work can be done while its neighbours wait at candidate rest poses clear of it
(:meth:`coplan.routing._Geometry.stows`: home, over the bin, folded poses). Rules:

* **Booking.** Arms book their legs (a leg: a move and its pick or place) one at a time, in time
  order; the arm idle longest first. A leg is booked at the earliest start (every ``quantum`` s
  while the neighbours are booked) at which it, and resting at its target afterwards, keeps
  ``clearance + margin`` from every neighbour's bookings and from where that neighbour rests
  after them. Bookings are never revised and each is checked against all earlier ones, so the
  result is conflict-free. A move that would leave a neighbour no clear rest pose at all
  (typically across its base) becomes a tucked transit (:meth:`_Geometry.route`).
* **Turns.** When no arm is moving and none can book (arms resting in each other's way), the
  waiting arm with the most picks left takes a turn: each neighbour resting in the way of the
  turn's work goes, one after another, to a candidate rest pose clear of all of it (one or two
  moves, each clear of where every neighbour rests), and the neighbours' later legs must keep
  clear of the turn's work until its last leg is booked. A turn is the arm's whole remaining
  work if possible, else its current fruit cycle, else its next leg -- so with two arms, one
  works while the other waits folded out of its way. Turn work is checked statically (every
  pose against every pose), so the turn's arm can always book its next leg: every turn adds at
  least one leg and the loop ends.
* **Sampling.** Static tests use moves sampled so densely that no point of an arm moves more
  than ``s = margin / 2`` between samples (S-curve joint speeds are at most twice the mean) and
  keep ``clearance + margin + s``; timed tests sample both arms together so finely that they
  move at most ``s`` between samples. Between samples clearance stays above
  ``clearance + margin / 2``. Static tests bound blocks of samples by balls first and test
  exactly only where the balls come near; timed tests screen all starts at ``rate`` first.

Three turn policies are run (whole work first / fruit cycles first / legs only) when any turn
was needed, and the schedule placing its last fruit first is kept.
"""

from __future__ import annotations

import bisect
import itertools
from dataclasses import dataclass, replace

import numpy as np

from .problem import Problem
from .routing import _Geometry, _same
from .schedule import (ArmSchedule, ConflictError, Step, StepKind, _arm_points, _CurveTable, _merge_waits, _move,
                       _points_clearance, _points_too_close, _steps_positions)

__all__ = ["serial_schedules"]

_POLICIES = (("work", "cycle", "leg"), ("cycle", "leg"), ("leg",))


@dataclass
class _Leg:
    target: tuple[float, float]
    kind: StepKind | None = None  # PICK / PLACE after the move, or None
    dwell: float = 0.0
    fruit: str | None = None
    home: bool = False


def _legs(sch: ArmSchedule) -> list[_Leg]:
    """An arm's schedule as legs (waits dropped), always ending with a move home."""
    home = tuple(map(float, sch.arm.home))
    legs: list[_Leg] = []
    for st in sch.steps:
        q = tuple(map(float, st.q1))
        if st.kind == StepKind.MOVE:
            legs.append(_Leg(q))
        elif st.kind in (StepKind.PICK, StepKind.PLACE):
            if legs and legs[-1].kind is None and _same(legs[-1].target, q):
                legs[-1].kind, legs[-1].dwell, legs[-1].fruit = st.kind, st.duration, st.fruit
            else:
                legs.append(_Leg(q, st.kind, st.duration, st.fruit))
    if legs and legs[-1].kind is None and _same(legs[-1].target, home):
        legs[-1].home = True
    else:
        legs.append(_Leg(home, home=True))
    return legs


class _Sweep:
    """Poses of one arm in path order, in blocks of ``block`` consecutive samples (and coarse
    blocks of 16 of those), each bounded by a ball: its middle pose and the furthest any point
    of the arm gets from it within the block. ``block=1``: separate poses, not a path."""

    def __init__(self, arm, q, block: int = 16):
        self.q, self.block, self.ratio = np.atleast_2d(np.asarray(q, float)), block, 16 if block > 1 else 1
        d = np.abs(np.diff(self.q, axis=0)) @ np.array([arm.links[0] + arm.links[1], arm.links[1]])
        self.gap = float(d.max()) if d.size and block > 1 else 0.0  # most any point moves between samples
        cum = np.concatenate([[0.0], np.cumsum(d)])
        self.levels = []
        for size in (block, block * self.ratio):
            starts = np.arange(0, len(self.q), size)
            ends = np.minimum(starts + size, len(self.q)) - 1
            mid = np.minimum(starts + size // 2, ends)
            self.levels.append((starts, self.q[mid], np.maximum(cum[mid] - cum[starts], cum[ends] - cum[mid])))


@dataclass
class _Track:
    index: int
    legs: list[_Leg]
    pose: tuple[float, float]
    free: float = 0.0  # booked until here, resting at ``pose`` after
    claim: list | None = None  # [sweep of its turn's work, legs of it not yet booked]

    def picks(self) -> int:
        return sum(1 for lg in self.legs if lg.kind == StepKind.PICK)


class _Serial(_Geometry):
    def __init__(self, problem: Problem, margin: float, rate: float, min_wait: float, quantum: float):
        super().__init__(problem, problem.task.clearance + margin)
        self.rate, self.min_wait, self.quantum = rate, min_wait, quantum
        self.step = max(margin, 0.004) / 2.0  # timed tests: the two arms move at most this between samples
        self.fine = self.step / 4.0  # static tests: an arm moves at most this between samples
        self.speed = [(a.links[0] + a.links[1]) * a.max_velocity[0] + a.links[1] * a.max_velocity[1] for a in problem.arms]
        self.tables, self._units, self._paths, self._tests = {}, {}, {}, {}

    # ---- static geometry
    def hits(self, i: int, A: _Sweep, j: int, B: _Sweep, first: bool = False) -> np.ndarray:
        """Per block of A: whether some pose in it comes within ``need`` of some pose of B (plus
        half the sample gaps of both, so that the paths between the samples keep ``need``)."""
        a, b = self.problem.arms[i], self.problem.arms[j]
        radii, need = a.link_radius + b.link_radius, self.need + (A.gap + B.gap) / 2

        def slack(level, ia, ib):  # clearance of the balls' middles less need and both radii
            (_, qa, ra), (_, qb, rb) = A.levels[level], B.levels[level]
            return _points_clearance(_arm_points(a, qa[ia]), _arm_points(b, qb[ib]), radii) - need - ra[ia] - rb[ib]

        ia, ib = (x.ravel() for x in np.meshgrid(np.arange(len(A.levels[1][0])), np.arange(len(B.levels[1][0])), indexing="ij"))
        s = slack(1, ia, ib)
        na, nb = len(A.levels[0][0]), len(B.levels[0][0])
        if first and (s + A.levels[1][2][ia] + B.levels[1][2][ib] < 0).any():  # two middle poses meet
            return np.ones(na, bool)
        keep = s < 0
        ia = (ia[keep, None, None] * A.ratio + np.arange(A.ratio)[None, :, None] + 0 * np.arange(B.ratio)).ravel()
        ib = (ib[keep, None, None] * B.ratio + np.arange(B.ratio)[None, None, :] + 0 * np.arange(A.ratio)[:, None]).ravel()
        ia, ib = ia[(ia < na) & (ib < nb)], ib[(ia < na) & (ib < nb)]
        out = np.zeros(na, bool)
        s = slack(0, ia, ib)
        out[ia[s + A.levels[0][2][ia] + B.levels[0][2][ib] < 0]] = True  # the middle poses themselves
        if first and out.any():
            return out
        ia, ib, s = ia[(s < 0) & ~out[ia]], ib[(s < 0) & ~out[ia]], s[(s < 0) & ~out[ia]]
        o = np.argsort(s, kind="stable")  # likeliest first
        ia, ib, per = ia[o], ib[o], max(1, 20000 // (A.block * B.block))
        for c in range(0, ia.size, per):
            if first and out.any():
                break
            keep = ~out[ia[c:c + per]]
            sa, sb = ia[c:c + per][keep], ib[c:c + per][keep]
            ka = np.minimum(A.levels[0][0][sa, None] + np.arange(A.block), len(A.q) - 1)
            kb = np.minimum(B.levels[0][0][sb, None] + np.arange(B.block), len(B.q) - 1)
            pa, pb = _arm_points(a, A.q[ka][:, :, None]), _arm_points(b, B.q[kb][:, None, :])
            out[sa[_points_too_close(pa, pb, radii, need).any(axis=(1, 2))]] = True
        return out

    def clear(self, i: int, A: _Sweep, j: int, B: _Sweep) -> bool:
        key = (id(A), id(B), i, j)
        if key not in self._tests:  # (the sweeps are kept with the answer, so ids stay unique)
            self._tests[key] = (A, B, not self.hits(i, A, j, B, first=True).any())
        return self._tests[key][2]

    def boxed_in(self, i: int, samples: np.ndarray) -> int:
        """Neighbours of arm i with no candidate rest pose clear of ``samples`` (used by
        :meth:`_Geometry.route`; the same rule with this module's test)."""
        sw = _Sweep(self.problem.arms[i], samples)
        sw.gap = min(sw.gap, self.fine)  # (route's own samples are sparser: as routing.py, no slack for them)
        return sum(1 for j in self.nbrs[i] if self.hits(j, self.stow_sweep(j), i, sw).all())

    def stow_sweep(self, j: int) -> _Sweep:
        if ("stows", j) not in self._paths:
            self._paths[("stows", j)] = _Sweep(self.problem.arms[j], self.stows(j), block=1)
        return self._paths[("stows", j)]

    def move_samples(self, i: int, mv: Step) -> np.ndarray:
        arm = self.problem.arms[i]
        dq = np.abs(np.subtract(mv.q1, mv.q0))
        disp = (arm.links[0] + arm.links[1]) * dq[0] + arm.links[1] * dq[1]
        n = int(max(np.ceil(mv.duration * self.rate), np.ceil(2.0 * disp / self.fine))) + 1
        return _CurveTable(mv.curve).eval(np.linspace(0.0, mv.duration, n))

    def unit(self, i: int, q0: tuple, target: tuple, routed: bool = True) -> tuple[list[Step], np.ndarray]:
        """Moves (from t = 0; none if there already) from q0 to target and their samples: one
        S-curve, or (``routed``) a tucked transit if that one boxes a neighbour in."""
        key = (i, q0, target, routed)
        if key not in self._units:
            arm, moves, pts, q = self.problem.arms[i], [], [np.asarray([q0], float)], q0
            vias = [] if _same(q0, target) else [target]
            if vias and routed and self.boxed_in(i, self.move_samples(i, _move(arm, 0.0, q0, target))):
                vias = self.route(i, q0, target)
            for v in vias:
                moves.append(_move(arm, moves[-1].t1 if moves else 0.0, q, v))
                pts.append(self.move_samples(i, moves[-1]))
                q = v
            self._units[key] = (moves, np.vstack(pts))
        return self._units[key]

    def sweep(self, i: int, q0: tuple, targets: list[tuple], routed: bool = True) -> _Sweep:
        """Arm i from q0 through ``targets`` (just resting at q0 if none)."""
        key = (i, q0, tuple(targets), routed)
        if key not in self._paths:
            pts, q = [np.asarray([q0], float)], q0
            for v in targets:
                pts.append(self.unit(i, q, v, routed)[1])
                q = v
            self._paths[key] = _Sweep(self.problem.arms[i], np.vstack(pts))
        return self._paths[key]

    # ---- booking
    def run(self, schedules: dict[str, ArmSchedule], scopes: tuple[str, ...]) -> dict[str, ArmSchedule]:
        arms = self.problem.arms
        self.tracks = [_Track(i, _legs(schedules[a.name]), tuple(map(float, a.home))) for i, a in enumerate(arms)]
        self.steps: list[list[Step]] = [[] for _ in arms]
        self.t0s: list[list[float]] = [[] for _ in arms]
        t, self.turns, limit = 0.0, 0, 2 * sum(len(tr.legs) for tr in self.tracks) + 10
        while any(tr.legs for tr in self.tracks):
            moved = True
            while moved:
                moved = False
                idle = [tr for tr in self.tracks if tr.legs and tr.free <= t + 1e-9]
                for tr in sorted(idle, key=lambda r: (r.claim is None, r.free, -r.picks(), r.index)):
                    if (t <= tr.free + 1e-9 or t >= tr.free + self.min_wait - 1e-9) and self.book(tr, t):
                        moved = True
            nxt = [tr.free for tr in self.tracks if tr.free > t + 1e-9]
            nxt += [tr.free + self.min_wait for tr in self.tracks if tr.legs and tr.free + self.min_wait > t + 1e-9]
            if nxt:
                t = min(nxt)
            elif any(tr.legs for tr in self.tracks):
                self.turns += 1
                if self.turns > limit:
                    raise ConflictError(f"no serial schedule: more than {limit} turns")
                t = self.turn(t, scopes)
        return {a.name: ArmSchedule(a, _merge_waits(self.steps[i])) for i, a in enumerate(arms)}

    def book(self, tr: _Track, t: float) -> bool:
        """Book tr's next leg at its earliest clear start from t on; False if there is none."""
        leg = tr.legs[0]
        moves, _ = self.unit(tr.index, tr.pose, leg.target)
        if moves or leg.kind is not None:  # (else there already: nothing to do)
            sw = self.sweep(tr.index, tr.pose, [leg.target])
            nb = [self.tracks[j] for j in self.nbrs[tr.index]]
            if any(o.claim is not None and not self.clear(tr.index, sw, o.index, o.claim[0]) for o in nb):
                return False
            steps = self.earliest(tr, t, moves, leg, nb)
            if steps is None:
                return False
            self.commit(tr, steps)
        tr.legs.pop(0)
        if tr.claim is not None:
            tr.claim[1] -= 1
            tr.claim = tr.claim if tr.claim[1] > 0 else None
        return True

    def earliest(self, tr: _Track, t: float, moves: list[Step], leg: _Leg, nb: list[_Track]) -> list[Step] | None:
        """The leg's steps at the earliest clear start, or None: starts ``quantum`` apart up to
        the end of the neighbours' bookings, screened in batches at ``rate``, then checked densely."""
        h = 1.0 / self.rate
        steps0 = self.leg_steps(moves, leg, 0.0)
        last, q = int(np.ceil((max([t] + [o.free for o in nb]) - t) / h - 1e-9)), max(1, round(self.quantum / h))
        ks = [0] + [k for k in list(range(q, last, q)) + [last] if k and t + k * h >= tr.free + self.min_wait]
        M = int(np.ceil(steps0[-1].t1 / h)) + 1
        mine = _steps_positions(steps0, np.arange(M + 1) * h, self.tables)  # at the target from M on
        theirs, tail = {}, {}
        for c0 in range(0, len(ks), 8):
            kc = np.asarray(ks[c0:c0 + 8])
            ok = np.ones(kc.size, bool)
            for o in nb:
                j = o.index
                if j not in theirs:
                    theirs[j] = self.positions(j, t + np.arange(max(ks[-1] + M, int(np.ceil((o.free - t) / h))) + 2) * h)
                    bad = self.close(tr.index, mine[M], j, theirs[j])  # resting at the target meets j
                    tail[j] = np.append(np.logical_or.accumulate(bad[::-1])[::-1], False)
                ok &= ~tail[j][np.minimum(kc + M, len(theirs[j]))]
                c, m = np.repeat(np.flatnonzero(ok), M), np.tile(np.arange(M), int(ok.sum()))
                if c.size:
                    ok[c[self.close(tr.index, mine[m], j, theirs[j][kc[c] + m])]] = False
                if not ok.any():
                    break
            for c in np.flatnonzero(ok):
                steps = self.leg_steps(moves, leg, t + int(kc[c]) * h)
                if all(self.timed_clear(tr.index, steps, o.index) for o in nb):
                    return steps
        return None

    def timed_clear(self, i: int, steps: list[Step], j: int) -> bool:
        """Arm i doing ``steps`` (resting after) keeps clear of arm j's bookings, sampled so
        finely that the two together move at most ``step`` between samples."""
        t, stop = steps[0].t0, max(steps[-1].t1, self.tracks[j].free)
        dt = min(1.0 / self.rate, 2.0 * self.step / (self.speed[i] + self.speed[j]))
        T = np.linspace(t, stop, int(np.ceil((stop - t) / dt)) + 2)
        return not self.close(i, _steps_positions(steps, T, self.tables), j, self.positions(j, T)).any()

    def positions(self, j: int, T: np.ndarray) -> np.ndarray:
        """Arm j's booked positions at sorted times ``T`` (resting after its last step)."""
        if not self.steps[j]:
            return np.tile(np.asarray(self.tracks[j].pose, float), (T.size, 1))
        k = max(0, bisect.bisect_right(self.t0s[j], float(T[0])) - 1)
        return _steps_positions(self.steps[j][k:], T, self.tables)

    @staticmethod
    def leg_steps(moves: list[Step], leg: _Leg, t: float) -> list[Step]:
        out = []
        for mv in moves:
            out.append(replace(mv, t0=t))
            t += mv.duration
        if leg.kind is not None:
            out.append(Step(leg.kind, t, leg.dwell, leg.target, leg.target, fruit=leg.fruit))
        return out

    def commit(self, tr: _Track, steps: list[Step]) -> None:
        if steps[0].t0 > tr.free + 1e-9:
            steps = [Step(StepKind.WAIT, tr.free, steps[0].t0 - tr.free, tr.pose, tr.pose)] + steps
        self.steps[tr.index] += steps
        self.t0s[tr.index] += [st.t0 for st in steps]
        tr.free, tr.pose = steps[-1].t1, tuple(map(float, steps[-1].q1))

    # ---- turns
    @staticmethod
    def scope_legs(tr: _Track, scope: str) -> list[_Leg]:
        legs = []
        for lg in tr.legs:
            if lg.home or (scope == "leg" and legs):
                break
            legs.append(lg)
            if scope == "cycle" and lg.kind == StepKind.PLACE:
                break
        return legs or tr.legs[:1]

    def turn(self, t: float, scopes: tuple[str, ...]) -> float:
        """No arm is moving and none can book: the first waiting arm that can have a turn gets
        one -- its neighbours park out of its way, after it has backed off to a candidate rest
        pose itself if it must. Returns when the parks are done."""
        for tr in self.tracks:
            tr.claim = None
        waiting = sorted((tr for tr in self.tracks if tr.legs), key=lambda r: (-r.picks(), r.index))
        for scope in scopes:
            reason = None  # the finest scope's first failure is reported
            for x in waiting:
                poses = {o.index: o.pose for o in self.tracks}
                cand = [tuple(map(float, c)) for c in self.candidates(x.index)]
                cand.sort(key=lambda c: _move(self.problem.arms[x.index], 0.0, x.pose, c).duration)
                backs = [c for c in cand if not _same(c, x.pose) and self.free(x.index, x.pose, c, poses)][:6]
                for back in [None] + backs:
                    plan, work, why = self.plan_turn(x, scope, back)
                    reason = reason or why
                    if plan is None:
                        continue
                    for j, vias in plan:  # one after another, everyone else resting
                        o, q, moves = self.tracks[j], self.tracks[j].pose, []
                        for v in vias:
                            moves += self.unit(j, q, v, routed=False)[0]
                            q = v
                        start = max(t, o.free + (self.min_wait if t > o.free + 1e-9 else 0.0))
                        self.commit(o, self.leg_steps(moves, _Leg(vias[-1]), start))
                        t = o.free
                        if j != x.index and (not o.legs or not o.legs[-1].home):
                            o.legs.append(_Leg(tuple(map(float, self.problem.arms[j].home)), home=True))
                    x.claim = [work, len(self.scope_legs(x, scope))]
                    return t
        raise ConflictError(f"no serial schedule: {reason or 'the arms block each other'}")

    def plan_turn(self, x: _Track, scope: str, back: tuple | None) -> tuple[list | None, _Sweep, str]:
        """Moves ``[(arm, vias)]`` giving arm x a turn (x backing off to ``back`` first, if
        given), the turn's work, and why not if there are none."""
        legs = self.scope_legs(x, scope)
        poses = {o.index: o.pose for o in self.tracks}
        poses[x.index] = x.pose if back is None else back
        work = self.sweep(x.index, poses[x.index], [lg.target for lg in legs])
        plan = [] if back is None else [(x.index, [back])]
        for j in self.nbrs[x.index]:
            if self.clear(j, self.sweep(j, poses[j], []), x.index, work):
                continue
            done = {x.index, j} | {k for k, _ in plan}
            # j parks; else first another neighbour of j parks out of its way (a few tries each)
            tries = [(None, None)] + [(k, vk) for k in self.nbrs[j] if k not in done
                                      for vk in itertools.islice(self.parks(k, x.index, work, poses), 4)]
            for k, vk in tries:
                trial = dict(poses) if k is None else {**poses, k: vk[-1]}
                vias = next(self.parks(j, x.index, work, trial), None)
                if vias is not None:
                    break
            if vias is None:
                what = f"{legs[0].kind.value} of {legs[0].fruit}" if legs[0].kind else "move"
                return None, work, (f"arm {self.problem.arms[j].name!r} cannot get out of the way of the {what} by arm "
                                    f"{self.problem.arms[x.index].name!r}: no candidate rest pose clear of it is reachable")
            plan += ([] if k is None else [(k, vk)]) + [(j, vias)]
            poses = {**trial, j: vias[-1]}
        return plan, work, ""

    def candidates(self, j: int) -> np.ndarray:
        """Arm j's candidate rest poses: the stows, then its own remaining picks, places and home."""
        own = [lg.target for lg in self.tracks[j].legs]
        return np.vstack([self.stows(j)] + ([np.asarray(own, float)] if own else []))

    def free(self, j: int, q0: tuple, q1: tuple, poses: dict) -> bool:
        """Whether arm j's straight move q0 -> q1 keeps clear of where its neighbours rest."""
        sw = self.sweep(j, q0, [q1], routed=False)
        return all(self.clear(j, sw, k, self.sweep(k, poses[k], [])) for k in self.nbrs[j])

    def parks(self, j: int, x: int, work: _Sweep, poses: dict):
        """Vias taking arm j to a candidate rest pose clear of arm x's ``work`` and of where the
        other arms rest (one or two moves, each clear of where they rest), from which its next
        leg boxes no neighbour in; poses in the way of the fewest neighbours' remaining work
        first, then the quickest."""
        cand, cur = self.candidates(j), poses[j]
        stow = _Sweep(self.problem.arms[j], cand, block=1)
        ok = ~self.hits(j, stow, x, work) if x in self.nbrs[j] else np.ones(len(cand), bool)
        soft = np.zeros(len(cand))
        for k in self.nbrs[j]:
            if k != x:
                ok &= ~self.hits(j, stow, k, self.sweep(k, poses[k], []))
            rem = [lg.target for lg in self.scope_legs(self.tracks[k], "work")] if self.tracks[k].legs else []
            soft += self.hits(j, stow, k, self.sweep(k, poses[k], rem))
        time = np.array([_move(self.problem.arms[j], 0.0, cur, c).duration for c in cand])
        order = [tuple(map(float, cand[c])) for c in np.lexsort((time, soft)) if ok[c]]
        nxt = self.tracks[j].legs[0].target if self.tracks[j].legs else tuple(map(float, self.problem.arms[j].home))

        def fine(q0, q1) -> bool:
            return not _same(q0, q1) and self.free(j, q0, q1, poses) and not self.boxed_in(j, self.unit(j, q1, nxt)[1])

        yield from ([c] for c in order if fine(cur, c))
        mids = [m for m in (tuple(map(float, cand[c])) for c in np.argsort(time)) if not _same(m, cur) and self.free(j, cur, m, poses)]
        yield from ([m, c] for m in mids[:8] for c in order if fine(m, c))


def serial_schedules(
    problem: Problem,
    schedules: dict[str, ArmSchedule],
    margin: float,
    rate: float = 200.0,
    min_wait: float = 0.05,
    quantum: float = 0.05,
) -> dict[str, ArmSchedule]:
    """Conflict-free schedules doing the work of ``schedules`` (e.g. from
    :func:`coplan.schedule.decoupled_schedules`): the same picks and places (fruit, pose, dwell)
    in the same order, each arm's steps contiguous from t = 0 at home, S-curve moves from the
    previous pose, waits (``WAIT`` steps) at least ``min_wait`` s, every arm ending at home.
    Neighbouring arms keep ``clearance + margin`` at the samples, ``clearance + margin / 2``
    everywhere. Arms take turns where they would get in each other's way (module docstring).

    Raises :class:`~coplan.schedule.ConflictError` naming the arms and the reason when some leg
    cannot run with a neighbour at any of its candidate rest poses (or cannot get there).
    """
    geo = _Serial(problem, margin, rate, min_wait, quantum)
    best, err = None, None
    for scopes in _POLICIES:
        try:
            out = geo.run(schedules, scopes)
        except ConflictError as e:
            err = err or e
            continue
        key = (max((s.last_place for s in out.values()), default=0.0), max((s.end for s in out.values()), default=0.0))
        if best is None or key < best[0]:
            best = (key, out)
        if not geo.turns:  # no turn was needed: the policies would not differ
            break
    if best is None:
        raise err
    return best[1]
