"""Serial fallback for the warm start: arms take turns where they would get in each other's way.

:func:`coplan.planners.coordinated.coordinate.coordinate` can deadlock on dense layouts. :func:`serial_schedules`
keeps every pick and place of its input (same fruit, pose, dwell and order) and succeeds when
each arm's work can be done while its neighbours wait at candidate rest poses clear of it
(:meth:`coplan.planners.coordinated.routing.ArmGeometry.stows`, or their own pick, place and home poses).

* **Booking.** Arms book their legs (a move and its pick or place) one at a time in time order,
  the longest idle first, each at the earliest start (every ``quantum`` s while neighbours are
  booked) at which the leg, and resting at its target after it, keeps ``clearance + margin``
  from every neighbour's bookings and where it rests after them. Bookings are never revised
  and each is checked against all earlier ones: the result is conflict-free. A move leaving a
  neighbour no clear rest pose (typically across its base) becomes a tucked transit
  (:meth:`ArmGeometry.route`).
* **Turns.** An arm that cannot book while a neighbour that cannot book either rests in its way
  takes a turn: each neighbour in the way of the turn's work parks (after a neighbour of its
  own has moved aside, or the arm itself has backed off, if need be) at a candidate pose clear
  of all of it, by one or two moves clear of where the others rest; until the turn's last leg
  is booked its neighbours book only legs clear of the work. A turn is the arm's whole
  remaining work if possible (one arm works while the other waits folded), else its fruit
  cycle, else its next leg. Turn work is checked statically (every pose against every pose),
  so the arm can book its next leg after the parks: every turn adds a leg, and the loop ends.
* **Sampling.** Timed tests sample both arms so that together they move at most ``s = margin /
  2`` between samples (after screening all starts at ``rate``); static tests sample moves so
  that an arm moves at most ``s / 4`` (S-curve joint speeds are at most twice the mean), keep
  half the gaps more and test exactly only where balls bounding blocks of samples come near.
  Clearance stays above ``clearance + margin / 2`` between samples.

Three turn policies (whole work, fruit cycle or leg first) are run if any turn was needed;
the schedule placing its last fruit first is kept.
"""

from __future__ import annotations

import bisect
import itertools
import time as _time
from dataclasses import dataclass, replace

import numpy as np

from .legs import Leg, legs_of
from ...problem.model import Problem
from .routing import ArmGeometry, same_pose
from .schedule import (ArmSchedule, ConflictError, Step, StepKind, arm_points, CurveTable, merge_waits, scurve_move,
                       points_clearance, points_too_close, steps_positions)
from ...ties import quantised

__all__ = ["BudgetSpent", "serial_schedules"]

_POLICIES = (("work", "cycle", "leg"), ("cycle", "leg"), ("leg",))


class _Sweep:
    """Poses of one arm in path order, in blocks of ``block`` samples (and coarse blocks of 16
    blocks), each bounded by a ball: its middle pose and the furthest any point of the arm gets
    from it in the block. ``block=1``: separate poses, not a path."""

    def __init__(self, arm, q, block: int = 16):
        self.q, self.block, self.ratio = np.atleast_2d(np.asarray(q, float)), block, 16 if block > 1 else 1
        d = np.abs(np.diff(self.q, axis=0)) @ np.array([arm.links[0] + arm.links[1], arm.links[1]])
        self.gap = float(d.max()) if d.size and block > 1 else 0.0  # most any point moves between samples
        cum, n, self.levels = np.concatenate([[0.0], np.cumsum(d)]), len(self.q), []
        for size in (block, block * self.ratio):
            s = np.arange(0, n, size)
            e, m = np.minimum(s + size, n) - 1, np.minimum(s + size // 2, n - 1)
            self.levels.append((s, self.q[m], np.maximum(cum[m] - cum[s], cum[e] - cum[m])))


@dataclass
class _Track:
    index: int
    legs: list[Leg]
    pose: tuple[float, float]
    free: float = 0.0  # booked until here, resting at ``pose`` after
    claim: list | None = None  # [sweep of its turn's work, legs of it not yet booked]

    def picks(self) -> int:
        return sum(1 for lg in self.legs if lg.kind == StepKind.PICK)


class BudgetSpent(ConflictError):
    """Taking turns spent its work budget (``fruit``: the work it was trying to fit in)."""


class _Serial(ArmGeometry):
    def __init__(self, problem: Problem, margin: float, rate: float, min_wait: float, quantum: float):
        super().__init__(problem, problem.task.clearance + margin)
        self.rate, self.min_wait, self.quantum = rate, min_wait, quantum
        self.step = max(margin, 0.004) / 2.0  # timed tests: both arms together move at most this between samples
        self.fine = self.step / 4.0  # static tests: an arm moves at most this between samples
        self.speed = [(a.links[0] + a.links[1]) * a.max_velocity[0] + a.links[1] * a.max_velocity[1] for a in problem.arms]
        self.tables, self._units, self._paths, self._tests, self._hit_memo = {}, {}, {}, {}, {}
        self.pairs, self.max_pairs = 0, None  # work: pose pairs tested (``max_pairs``: the budget)
        self.deadline = None  # a clock limit (perf_counter), only where the caller has one

    def spend(self, n: int) -> None:
        """Count ``n`` pose-pair tests; past the budget, taking turns gives up (a work budget,
        the same on any machine, so one hard layout cannot hold the planner for hours); past
        the caller's clock limit too, where it has one (then the plan depends on the clock)."""
        self.pairs += int(n)
        if self.max_pairs is not None and self.pairs > self.max_pairs:
            raise BudgetSpent(f"taking turns found no schedule within its work budget ({self.max_pairs:,} pose-pair tests)")
        if self.deadline is not None and _time.perf_counter() > self.deadline:
            raise BudgetSpent(f"taking turns found no schedule before the time limit ({self.pairs:,} pose-pair tests)")

    # ---- static tests
    def hits(self, i: int, A: _Sweep, j: int, B: _Sweep, first: bool = False) -> np.ndarray:
        """Per block of A: whether a pose in it comes within ``need`` of a pose of B (plus half
        of both sample gaps, so the paths between samples keep ``need``); ``first``: any.
        Remembered by the sweeps (kept with the answer, so their ids stay unique): taking turns
        asks the same question again and again (a crowded 6 m row of 26 fruit asked 3,878, 2,722
        of them new: 28 of its 38 s), and a repeat spends the work budget as the first asking did,
        so the budget runs out where it did."""
        key = (i, id(A), j, id(B), bool(first))
        got = self._hit_memo.get(key)
        if got is None:
            before = self.pairs
            out = self._hits(i, A, j, B, first)  # (BudgetSpent: nothing remembered)
            got = self._hit_memo[key] = (A, B, out, self.pairs - before)
        else:
            self.spend(got[3])
        return got[2].copy()

    def _hits(self, i: int, A: _Sweep, j: int, B: _Sweep, first: bool) -> np.ndarray:
        a, b = self.problem.arms[i], self.problem.arms[j]
        radii, need = a.link_radius + b.link_radius, self.need + (A.gap + B.gap) / 2
        (sa0, qa0, ra0), (sa1, qa1, ra1), (sb0, qb0, rb0), (sb1, qb1, rb1) = A.levels + B.levels
        out = np.zeros(len(sa0), bool)

        def slack(qa, qb, ra, rb):  # clearance of the middle poses, less need and both radii
            return points_clearance(arm_points(a, qa), arm_points(b, qb), radii) - need - ra - rb

        ia, ib = (x.ravel() for x in np.meshgrid(np.arange(len(sa1)), np.arange(len(sb1)), indexing="ij"))
        self.spend(ia.size)
        s = slack(qa1[ia], qb1[ib], ra1[ia], rb1[ib])
        if first and (s + ra1[ia] + rb1[ib] < 0).any():
            return ~out
        ia = (ia[s < 0, None, None] * A.ratio + np.arange(A.ratio)[:, None] + 0 * np.arange(B.ratio)).ravel()
        ib = (ib[s < 0, None, None] * B.ratio + np.arange(B.ratio) + 0 * np.arange(A.ratio)[:, None]).ravel()
        ia, ib = ia[(ia < len(sa0)) & (ib < len(sb0))], ib[(ia < len(sa0)) & (ib < len(sb0))]
        self.spend(ia.size)
        s = slack(qa0[ia], qb0[ib], ra0[ia], rb0[ib])
        out[ia[s + ra0[ia] + rb0[ib] < 0]] = True  # the middle poses themselves
        o = np.flatnonzero((s < 0) & ~out[ia])
        o = o[np.argsort(s[o], kind="stable")]  # the likeliest first
        ia, ib, per = ia[o], ib[o], max(1, 20000 // (A.block * B.block))
        for c in range(0, ia.size, per):
            if first and out.any():
                break
            keep = ~out[ia[c:c + per]]
            ka = np.minimum(sa0[ia[c:c + per][keep], None] + np.arange(A.block), len(A.q) - 1)
            kb = np.minimum(sb0[ib[c:c + per][keep], None] + np.arange(B.block), len(B.q) - 1)
            self.spend(ka.size * B.block)
            bad = points_too_close(arm_points(a, A.q[ka][:, :, None]), arm_points(b, B.q[kb][:, None, :]), radii, need)
            out[ia[c:c + per][keep][bad.any(axis=(1, 2))]] = True
        return out

    def clear(self, i: int, A: _Sweep, j: int, B: _Sweep) -> bool:
        key = (id(A), id(B), i, j)
        if key not in self._tests:  # (the sweeps are kept with the answer: their ids stay unique)
            self._tests[key] = (A, B, not self.hits(i, A, j, B, first=True).any())
        return self._tests[key][2]

    def boxed_in(self, i: int, samples: np.ndarray) -> int:
        """Neighbours of arm i left no candidate rest pose clear of ``samples`` (also used by
        :meth:`ArmGeometry.route`, whose samples are sparser: no slack for their gaps, as there)."""
        sw = _Sweep(self.problem.arms[i], samples)
        sw.gap = min(sw.gap, self.fine)
        return sum(1 for j in self.nbrs[i] if self.hits(j, self.cands(j, own=False), i, sw).all())

    def cands(self, j: int, own: bool = True) -> _Sweep:
        """Arm j's candidate rest poses: the stows (and its remaining pick, place and home poses)."""
        extra = [lg.target for lg in self.tracks[j].legs] if own else []
        key = ("cands", j, tuple(extra))
        if key not in self._paths:
            self._paths[key] = _Sweep(self.problem.arms[j], np.vstack([self.stows(j)] + [np.asarray(extra, float)] * bool(extra)), 1)
        return self._paths[key]

    def unit(self, i: int, q0: tuple, target: tuple, routed: bool = True) -> tuple[list[Step], np.ndarray]:
        """Moves (from t = 0; none if there already) from q0 to target, and their samples: one
        S-curve, or (``routed``) a tucked transit if that one boxes a neighbour in."""
        key = (i, q0, target, routed)
        if key not in self._units:
            arm, moves, pts, q = self.problem.arms[i], [], [np.asarray([q0], float)], q0
            vias = [] if same_pose(q0, target) else [target]
            if vias and routed and self.boxed_in(i, self.samples(i, scurve_move(arm, 0.0, q0, target))):
                vias = self.route(i, q0, target)
            for v in vias:
                moves.append(scurve_move(arm, moves[-1].t1 if moves else 0.0, q, v))
                pts.append(self.samples(i, moves[-1]))
                q = v
            self._units[key] = (moves, np.vstack(pts))
        return self._units[key]

    def samples(self, i: int, mv: Step) -> np.ndarray:
        (l1, l2), dq = self.problem.arms[i].links, np.abs(np.subtract(mv.q1, mv.q0))
        n = int(max(np.ceil(mv.duration * self.rate), np.ceil(2.0 * ((l1 + l2) * dq[0] + l2 * dq[1]) / self.fine))) + 1
        return CurveTable(mv.curve).eval(np.linspace(0.0, mv.duration, n))

    def sweep(self, i: int, q0: tuple, targets: list[tuple], routed: bool = True) -> _Sweep:
        """Arm i from q0 through ``targets`` (resting at q0 if none)."""
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
        self.tracks = [_Track(i, legs_of(self.problem, schedules[a.name], always_home=True), tuple(map(float, a.home))) for i, a in enumerate(arms)]
        self.steps: list[list[Step]] = [[] for _ in arms]
        self.t0s: list[list[float]] = [[] for _ in arms]
        t, self.turns, limit, self._failed = 0.0, 0, 4 * sum(len(tr.legs) for tr in self.tracks) + 20, set()
        while any(tr.legs for tr in self.tracks):
            moved = True
            while moved:  # everyone idle and due books, the longest idle first
                idle = sorted((tr for tr in self.tracks if tr.legs and self.due(tr, t)), key=lambda r: (r.claim is None, float(quantised(r.free)), -r.picks(), r.index))
                moved = any([self.book(tr, t) for tr in idle])
            if not any(tr.legs for tr in self.tracks):
                break
            nxt = [tr.free for tr in self.tracks if tr.free > t + 1e-9]
            nxt += [tr.free + self.min_wait for tr in self.tracks if tr.legs and tr.free + self.min_wait > t + 1e-9]
            # stuck: cannot book, a neighbour that cannot book either rests in the way, no turn under way near
            stuck = [x for x in self.tracks if x.legs and self.due(x, t) and not any(self.tracks[k].claim for k in self.ball(x.index, 3))
                     and any(o.free <= t + 1e-9 and (not o.legs or self.due(o, t)) and not self.clear(o.index, self.sweep(
                         o.index, o.pose, []), x.index, self.sweep(x.index, x.pose, [x.legs[0].target])) for o in self.nbr_tracks(x))]
            if not nxt:  # nothing will move by itself
                for tr in self.tracks:
                    tr.claim = None
                stuck = [tr for tr in self.tracks if tr.legs]
            if stuck and self.turn(t, scopes, stuck, must=not nxt):
                if self.turns > limit:
                    raise ConflictError(f"no serial schedule: more than {limit} turns")
                continue
            t = min(nxt)
        return {a.name: ArmSchedule(a, merge_waits(self.steps[i])) for i, a in enumerate(arms)}

    def due(self, tr: _Track, t: float) -> bool:
        """Idle at t and not within ``min_wait`` of its last step (no sliver waits)."""
        return tr.free <= t + 1e-9 and (t <= tr.free + 1e-9 or t >= tr.free + self.min_wait - 1e-9)

    def nbr_tracks(self, tr: _Track) -> list[_Track]:
        return [self.tracks[j] for j in self.nbrs[tr.index]]

    def ball(self, i: int, r: int) -> set[int]:
        out = {i}
        for _ in range(r):
            out |= {k for j in out for k in self.nbrs[j]}
        return out

    def book(self, tr: _Track, t: float) -> bool:
        """Book tr's next leg at its earliest clear start from t on; False if there is none."""
        leg = tr.legs[0]
        moves, _ = self.unit(tr.index, tr.pose, leg.target)
        if moves or leg.kind is not None:  # (else there already: nothing to do)
            sw, nb = self.sweep(tr.index, tr.pose, [leg.target]), [self.tracks[j] for j in self.nbrs[tr.index]]
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

    def earliest(self, tr: _Track, t: float, moves: list[Step], leg: Leg, nb: list[_Track]) -> list[Step] | None:
        """The leg's steps at the earliest clear start, or None: starts ``quantum`` apart up to
        the end of the neighbours' bookings, screened in batches at ``rate``, then checked densely."""
        h, steps0 = 1.0 / self.rate, self.leg_steps(moves, leg, 0.0)
        last, q = int(np.ceil((max([t] + [o.free for o in nb]) - t) / h - 1e-9)), max(1, round(self.quantum / h))
        k0 = int(np.ceil((tr.free + self.min_wait - t) / h - 1e-9))  # no sliver waits
        ks = [0] * self.due(tr, t) + [k for k in list(range(q, last, q)) + [max(last, k0, 1)] if k >= k0 and k > 0]
        M = int(np.ceil(steps0[-1].t1 / h)) + 1
        mine, theirs, tail = steps_positions(steps0, np.arange(M + 1) * h, self.tables), {}, {}  # at the target from M on
        for c0 in range(0, len(ks), 8):
            kc = np.asarray(ks[c0:c0 + 8])
            ok = np.ones(kc.size, bool)
            for j in (o.index for o in nb):
                if j not in theirs:
                    theirs[j] = self.positions(j, t + np.arange(max(ks[-1] + M, int(np.ceil((self.tracks[j].free - t) / h))) + 2) * h)
                    bad = self.close(tr.index, mine[M], j, theirs[j])  # resting at the target meets j from here on
                    tail[j] = np.append(np.logical_or.accumulate(bad[::-1])[::-1], False)
                ok &= ~tail[j][np.minimum(kc + M, len(theirs[j]))]
                c, m = np.repeat(np.flatnonzero(ok), M), np.tile(np.arange(M), int(ok.sum()))
                if c.size:
                    ok[c[self.close(tr.index, mine[m], j, theirs[j][kc[c] + m])]] = False
            for c in np.flatnonzero(ok):
                steps = self.leg_steps(moves, leg, t + int(kc[c]) * h)
                if all(self.timed_clear(tr.index, steps, o.index) for o in nb):
                    return steps
        return None

    def timed_clear(self, i: int, steps: list[Step], j: int) -> bool:
        """Arm i doing ``steps`` (resting after) keeps clear of arm j's bookings (dense samples)."""
        t, stop = steps[0].t0, max(steps[-1].t1, self.tracks[j].free)
        dt = min(1.0 / self.rate, 2.0 * self.step / (self.speed[i] + self.speed[j]))
        T = np.linspace(t, stop, int(np.ceil((stop - t) / dt)) + 2)
        return not self.close(i, steps_positions(steps, T, self.tables), j, self.positions(j, T)).any()

    def positions(self, j: int, T: np.ndarray) -> np.ndarray:
        """Arm j's booked positions at sorted times ``T`` (resting after its last step)."""
        if not self.steps[j]:
            return np.tile(np.asarray(self.tracks[j].pose, float), (T.size, 1))
        return steps_positions(self.steps[j][max(0, bisect.bisect_right(self.t0s[j], float(T[0])) - 1):], T, self.tables)

    @staticmethod
    def leg_steps(moves: list[Step], leg: Leg, t: float) -> list[Step]:
        out = []
        for mv in moves:
            out.append(replace(mv, t0=t))
            t += mv.duration
        return out + ([Step(leg.kind, t, leg.dwell, leg.target, leg.target, fruit=leg.fruit)] if leg.kind else [])

    def commit(self, tr: _Track, steps: list[Step]) -> None:
        if steps[0].t0 > tr.free + 1e-9:
            steps = [Step(StepKind.WAIT, tr.free, steps[0].t0 - tr.free, tr.pose, tr.pose)] + steps
        self.steps[tr.index] += steps
        self.t0s[tr.index] += [st.t0 for st in steps]
        tr.free, tr.pose = steps[-1].t1, tuple(map(float, steps[-1].q1))

    # ---- turns
    @staticmethod
    def scope_legs(tr: _Track, scope: str) -> list[Leg]:
        legs = []
        for lg in tr.legs:
            if lg.home or (scope == "leg" and legs):
                break
            legs.append(lg)
            if scope == "cycle" and lg.kind == StepKind.PLACE:
                break
        return legs or tr.legs[:1]

    def turn(self, t: float, scopes: tuple[str, ...], stuck: list[_Track], must: bool) -> bool:
        """The first stuck arm that can have a turn gets one, its parks booked from t in order.
        False if none can (ConflictError if ``must``: nothing else will move)."""
        for scope in scopes:
            reason = blocked = None  # the finest scope's first failure is reported
            for x in sorted(stuck, key=lambda r: (-r.picks(), r.index)):
                key = (scope, x.index) + tuple((self.tracks[k].pose, len(self.tracks[k].legs)) for k in sorted(self.ball(x.index, 3)))
                if key in self._failed and not must:  # (nothing near it has changed since it last could not)
                    continue
                poses = {o.index: o.pose for o in self.tracks}  # (the busy ones: after their bookings)
                order = sorted(map(tuple, self.cands(x.index).q.tolist()), key=lambda c: float(quantised(scurve_move(self.problem.arms[x.index], 0.0, x.pose, c).duration)))
                backs = (c for c in order if not same_pose(c, x.pose) and self.free(x.index, x.pose, c, poses))
                try:
                    for back in itertools.chain([None], itertools.islice(backs, 6)):  # else x first backs off
                        plan, work, why = self.plan_turn(x, scope, back)
                        if reason is None and why:
                            reason, blocked = why, x
                        if plan is not None:
                            break
                except BudgetSpent as e:  # the turn being searched for names the work given up
                    raise BudgetSpent(str(e), arm=self.problem.arms[x.index].name,
                                      fruit=next((lg.fruit for lg in x.legs if lg.fruit), None)) from None
                if plan is None:
                    self._failed.add(key)
                    continue
                self.turns += 1
                for j, vias in plan:  # (each clear, at the latest, once the others rest)
                    o, q, moves = self.tracks[j], self.tracks[j].pose, []
                    for v in vias:
                        moves += self.unit(j, q, v, routed=False)[0]
                        q = v
                    steps = self.earliest(o, t, moves, Leg(vias[-1]), [self.tracks[k] for k in self.nbrs[j]])
                    if steps is None:
                        raise ConflictError(f"no serial schedule: arm {self.problem.arms[j].name!r} cannot park")
                    self.commit(o, steps)
                    if not o.legs or not o.legs[-1].home:
                        o.legs.append(Leg(tuple(map(float, self.problem.arms[j].home)), home=True))
                x.claim = [work, len(self.scope_legs(x, scope))]
                return True
        if must:
            fruit = next((lg.fruit for lg in blocked.legs if lg.fruit), None) if blocked is not None else None
            raise ConflictError(f"no serial schedule: {reason or 'the arms block each other'}",
                                arm=self.problem.arms[blocked.index].name if blocked is not None else None, fruit=fruit)
        return False

    def plan_turn(self, x: _Track, scope: str, back: tuple | None) -> tuple[list | None, _Sweep, str]:
        """Parks ``[(arm, vias)]`` giving arm x a turn (x first backing off to ``back``, if
        given), the turn's work, and why not if there are none."""
        legs, poses = self.scope_legs(x, scope), {o.index: o.pose for o in self.tracks}
        poses[x.index], plan = x.pose if back is None else back, [] if back is None else [(x.index, [back])]
        work = self.sweep(x.index, poses[x.index], [lg.target for lg in legs])
        for j in self.nbrs[x.index]:
            if self.clear(j, self.sweep(j, poses[j], []), x.index, work):
                continue
            done = {x.index, j} | {k for k, _ in plan}  # j parks; else a resting neighbour of j first moves aside
            tries = [(None, None)] + [(k, vk) for k in self.nbrs[j] if k not in done
                                      for vk in itertools.islice(self.parks(k, x.index, work, poses), 4)]
            for k, vk in tries:
                trial = poses if k is None else {**poses, k: vk[-1]}
                vias = next(self.parks(j, x.index, work, trial), None)
                if vias is not None:
                    break
            if vias is None:
                what = f"{legs[0].kind.value} of {legs[0].fruit}" if legs[0].kind else "move"
                why = ("none of its candidate rest poses is clear of it" if self.hits(j, self.cands(j), x.index, work).all()
                       else "it cannot reach a clear rest pose without touching a neighbour")
                return None, work, (f"arm {self.problem.arms[j].name!r} cannot get out of the way of the {what} "
                                    f"by arm {self.problem.arms[x.index].name!r}: {why}")
            plan += ([] if k is None else [(k, vk)]) + [(j, vias)]
            poses = {**trial, j: vias[-1]}
        return plan, work, ""

    def free(self, j: int, q0: tuple, q1: tuple, poses: dict) -> bool:
        """Whether arm j's straight move q0 -> q1 keeps clear of where its neighbours rest."""
        sw = self.sweep(j, q0, [q1], routed=False)
        return all(self.clear(j, sw, k, self.sweep(k, poses[k], [])) for k in self.nbrs[j])

    def parks(self, j: int, x: int, work: _Sweep, poses: dict):
        """Vias taking arm j to a candidate rest pose clear of arm x's ``work`` and of where the
        others rest (one or two moves clear of where they rest), from which its next leg boxes no
        neighbour in; poses in the way of the fewest neighbours' remaining work first, then the
        quickest."""
        cand, cur = self.cands(j), poses[j]
        ok = ~self.hits(j, cand, x, work) if x in self.nbrs[j] else np.ones(len(cand.q), bool)
        soft = np.zeros(len(cand.q))
        for k in self.nbrs[j]:
            ok &= ~self.hits(j, cand, k, self.sweep(k, poses[k], [])) if k != x else True
            rem = [lg.target for lg in self.scope_legs(self.tracks[k], "work")] if self.tracks[k].legs else []
            soft += self.hits(j, cand, k, self.sweep(k, poses[k], rem))
        time = quantised([scurve_move(self.problem.arms[j], 0.0, cur, c).duration for c in cand.q])  # ties: stable, any CPU
        order = [tuple(map(float, cand.q[c])) for c in np.lexsort((time, soft)) if ok[c]]
        nxt = self.tracks[j].legs[0].target if self.tracks[j].legs else tuple(map(float, self.problem.arms[j].home))

        def fine(q0, q1) -> bool:
            return not same_pose(q0, q1) and self.free(j, q0, q1, poses) and not self.boxed_in(j, self.unit(j, q1, nxt)[1])

        yield from ([c] for c in order if fine(cur, c))
        mids = [m for m in (tuple(map(float, cand.q[c])) for c in np.argsort(time, kind="stable")) if not same_pose(m, cur) and self.free(j, cur, m, poses)]
        yield from ([m, c] for m in mids[:8] for c in order if fine(m, c))


def serial_schedules(problem: Problem, schedules: dict[str, ArmSchedule], margin: float, rate: float = 200.0,
                     min_wait: float = 0.05, quantum: float = 0.05, max_pairs: int | None = None,
                     work: dict | None = None, deadline: float | None = None) -> dict[str, ArmSchedule]:
    """Conflict-free schedules doing the work of ``schedules`` (e.g. from
    :func:`coplan.planners.coordinated.schedule.decoupled_schedules`): the same picks and places (fruit, pose, dwell,
    order), each arm's steps contiguous from t = 0 at home, S-curve moves from the previous pose,
    ``WAIT`` steps of at least ``min_wait`` s, every arm ending at home. Neighbours keep
    ``clearance + margin`` at the samples (``clearance + margin / 2`` between them).

    Raises :class:`~coplan.planners.coordinated.schedule.ConflictError`, naming the arms and the reason, when a leg
    cannot run with a neighbour at any candidate rest pose (or the neighbour cannot get there),
    or when more than ``max_pairs`` pose pairs have been tested (the work budget; ``work``, a
    dict, has its ``"pairs"`` entry increased by the pairs tested), or once ``deadline`` (a
    :func:`time.perf_counter` value: a caller's clock limit) has passed.
    """
    geo, best, err = _Serial(problem, margin, rate, min_wait, quantum), None, None
    geo.max_pairs, geo.deadline = max_pairs, deadline  # over all policies
    try:
        for scopes in _POLICIES:
            try:
                out = geo.run(schedules, scopes)
            except BudgetSpent as e:
                err = e  # no other policy gets to run
                break
            except ConflictError as e:
                err = err or e
                continue
            key = tuple(float(quantised(max((getattr(s, k) for s in out.values()), default=0.0))) for k in ("last_place", "end"))
            best = (key, out) if best is None or key < best[0] else best
            if not geo.turns:  # no turn was needed: the policies would not differ
                break
    finally:
        if work is not None:
            work["pairs"] = work.get("pairs", 0) + geo.pairs
    if best is None:
        raise err
    return best[1]
