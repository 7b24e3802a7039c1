"""Coordination for the warm start: all arms together, leg by leg (see :mod:`coplan.planners.coordinated.schedule`).

:func:`coordinate` books each leg (a move and its pick or place) at the earliest time at which it
and resting at its target afterwards keep every neighbour ``clearance + margin`` away from
everything already booked; deadlocks are broken by rule.
"""

from __future__ import annotations

import time as _time
from dataclasses import replace

import numpy as np

from ...problem.model import Problem
from ...ties import TIE, first_min_index, quantised
from .boxes import SweepBoxes, apart
from .routing import ArmGeometry, same_pose
from .schedule import (ArmSchedule, ConflictError, LinkPoints, Step, StepKind, merge_waits, scurve_move,
                       steps_positions)
from .legs import Leg, legs_of
from .trace import Trace, Turn, resume_point
from .tracks import ArmTrack

__all__ = ["coordinate"]


class _Window:
    """Arm points for one :meth:`_Coordinator.earliest` search on the grid ``t0 + k / rate``: the
    leg's (relative to its start: the same at every trial start) and each neighbour's
    (absolute), each computed once and grown as needed."""

    def __init__(self, c: _Coordinator, tr: ArmTrack, leg: Leg, t0: float):
        self.c, self.tr, self.t0 = c, tr, t0
        self.key = (tr.index, tr.pose, leg.target, leg.kind, leg.dwell)  # what the leg's points depend on
        self.leg = leg
        self._own: LinkPoints | None = None
        self._nb: dict[int, LinkPoints] = {}
        self._box: tuple | None | bool = False  # not yet computed

    def own_box(self) -> tuple | None:
        """A box holding the arm wherever the leg takes it (None: unbounded)."""
        if self._box is False:
            self._box = self.c.boxes.steps(self.tr.index, self.c.leg_steps(self.tr, self.leg, 0.0), self.leg.target)
        return self._box

    def own(self, n: int) -> LinkPoints:
        if self._own is None or self._own.size < n:
            hit = self.c.own_points.get(self.key)  # shared by the runs on one problem
            if hit is None or hit.size < n:
                m = max(n, 2 * (0 if hit is None else hit.size))
                T = np.arange(m) / self.c.rate
                steps0 = self.c.leg_steps(self.tr, self.leg, 0.0)
                hit = self.c.links(self.tr.index, steps_positions(steps0, T, self.c.tables))
                self.c.own_points[self.key] = hit
            self._own = hit
        return self._own[:n]

    def neighbour(self, o: ArmTrack, t: float, n: int) -> LinkPoints:
        k0 = int(round((t - self.t0) * self.c.rate))
        have = self._nb.get(o.index)
        if have is None or have.size < k0 + n:
            m = max(k0 + n, 2 * (0 if have is None else have.size))
            have = self.c.links(o.index, o.positions(self.t0 + np.arange(m) / self.c.rate))
            self._nb[o.index] = have
        return have[k0:k0 + n]


class _Coordinator(ArmGeometry):
    """State of :func:`coordinate` (see there for the rules).

    Its parts, in the order :meth:`run` uses them: static views of the remaining work
    (:meth:`remaining`, :meth:`leg_samples`); timing (:meth:`leg_steps`, :meth:`conflict`,
    :meth:`earliest`); deadlocks (:meth:`is_stuck`, :meth:`yield_pose`, :meth:`do_yield`,
    :meth:`other_branch`, :meth:`detour`, :meth:`home_blocks`, :meth:`park_pose`); the main
    loop (:meth:`run` and its steps, :meth:`commit`).
    """

    def __init__(self, problem: Problem, schedules: dict[str, ArmSchedule], margin: float, rate: float, quantum: float,
                 priority: list[str] | None, deadline: float | None, max_yields: int | None, horizon: float | None,
                 max_checks: int | None = None, cache: dict | None = None, committed: dict | None = None):
        super().__init__(problem, problem.task.clearance + margin)
        self.tables: dict = {}
        if cache is not None:  # routes, rest poses, moves and their curve tables depend only on the problem and ``need``
            shared = cache.setdefault((id(problem), self.need), ({}, {}, {}))
            self._stows, self._routes, self._moves = shared
            self.tables = cache.setdefault("curve_tables", {})
            self.own_points = cache.setdefault(("own_points", id(problem), self.need, rate), {})
        else:
            self.own_points = {}
            self._moves = {}
        self.boxes = SweepBoxes(problem, {} if cache is None else cache.setdefault(("sweep_boxes", id(problem)), {}),
                                self.tables)
        self.max_checks, self.checks = max_checks, 0
        names = [a.name for a in problem.arms]
        self.rate, self.quantum, self.deadline = rate, quantum, deadline
        order = priority or sorted(names, key=lambda n: -float(quantised(schedules[n].last_place)))
        rank = {n: i for i, n in enumerate(order)}
        self.tracks = [ArmTrack(a, i, rank.get(a.name, len(order) + i), legs_of(problem, schedules[a.name]), self.tables)
                       for i, a in enumerate(problem.arms)]
        for tr in self.tracks:  # motion already committed (live re-planning): booked first, the legs follow it
            pre = (committed or {}).get(tr.arm.name)
            if pre:
                tr.end, tr.pose = pre[0].t0, tuple(map(float, pre[0].q0))
                tr.commit(pre[0].t0, list(pre))
                tr.ready = tr.end
        self.max_yields = 6 * len(self.tracks) + 6 if max_yields is None else max_yields
        work = sum(schedules[n].end for n in names)
        self.horizon = 3.0 * work + 30.0 if horizon is None else horizon
        self.yields = 0
        self.parks = 0
        self.log = None  # debugging: a callable taking a message
        self._remaining: dict[int, tuple] = {}
        self._yielded: set = set()
        self.trace: Trace | None = None
        self.resumed_checks = self.resumed_turns = 0

    # ---- recording and resuming (see :mod:`.trace`)
    def start_trace(self, trace: Trace | None, resume) -> None:
        """Record this run in ``trace``; continue the run of ``resume`` (a trace, or several: the
        one that lets it start latest) where this one's legs first matter (the same result as
        running from scratch)."""
        key = (tuple(tr.rank for tr in self.tracks), self.need, self.rate, self.quantum, self.max_checks, self.max_yields)
        legs = [tuple(tr.todo) for tr in self.tracks]
        if trace is not None:
            trace.key, trace.legs, trace.turns, trace.barrier, trace.steps = key, legs, [], None, []
            self.trace = trace
        e = 0
        for r in ([resume] if isinstance(resume, Trace) else resume or []):
            k = resume_point(r, key, legs, self.horizon)
            if k > e:
                e, resume = k, r
        if e <= 0:
            return
        turn = resume.turns[e]
        for tr, (n, end, pose, done, ready, stuck, blocker), steps in zip(self.tracks, turn.tracks, resume.steps):
            tr.steps = list(steps[:n])
            tr.t0s = [s.t0 for s in tr.steps]
            tr.end, tr.pose, tr.ready, tr.stuck, tr.blocker = end, pose, ready, stuck, blocker
            del tr.todo[:done]
        self.checks = self.resumed_checks = turn.checks
        self.resumed_turns = e
        if trace is not None:
            trace.turns = resume.turns[:e]

    def record_turn(self, tr: ArmTrack, t: float) -> None:
        tc = self.trace
        if tc is None or tc.barrier is not None:
            return
        tc.turns.append(Turn(self.checks, t, tr.index, tuple(
            (len(x.steps), x.end, x.pose, len(tc.legs[x.index]) - len(x.todo), x.ready, x.stuck, x.blocker)
            for x in self.tracks)))

    def barrier(self) -> None:
        """This turn reads neighbours' remaining work: no later run resumes past it."""
        if self.trace is not None and self.trace.barrier is None:
            self.trace.barrier = max(0, len(self.trace.turns) - 1)

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

    def leg_samples(self, tr: ArmTrack, leg: Leg) -> np.ndarray:
        """Arm ``tr``'s poses along ``leg`` from where it rests (at ``rate``), target included."""
        steps = self.leg_steps(tr, leg, 0.0)
        if not steps:
            return np.asarray(tr.pose, float)[None]
        T = np.append(np.arange(0.0, steps[-1].t1, 1.0 / self.rate), steps[-1].t1)
        return steps_positions(steps, T, self.tables)

    # ---- timing
    def leg_steps(self, tr: ArmTrack, leg: Leg, t: float) -> list[Step]:
        """The leg's move(s) from where the arm rests, starting at ``t``, then its dwell."""
        steps: list[Step] = []
        if not same_pose(tr.pose, leg.target):
            key = (tr.index, tr.pose, leg.target)
            moves = self._moves.get(key)
            if moves is None:  # routed from where the arm rests (see ArmGeometry.route), from t = 0
                moves, q, t0 = [], tr.pose, 0.0
                for v in self.route(tr.index, tr.pose, leg.target):
                    moves.append(scurve_move(tr.arm, t0, q, v))
                    t0, q = moves[-1].t1, v
                self._moves[key] = moves
            steps = [replace(m, t0=m.t0 + t) for m in moves]
            t = steps[-1].t1
        if leg.kind is not None:
            steps.append(Step(leg.kind, t, leg.dwell, leg.target, leg.target, fruit=leg.fruit))
        return steps

    def conflict(self, tr: ArmTrack, steps: list[Step], t: float, window: _Window):
        """First conflict of ``steps`` (from ``t``, resting after) with the neighbours' commitments.

        Returns None, or ``(tc, j, late)``: the first time too close, the neighbour, and (when
        that first conflict comes after the arm has arrived) the last time before that
        neighbour's commitments end at which the resting arm is too close -- to jump past a
        neighbour passing through the target. ``window`` (from :meth:`earliest`) holds the
        leg's points (relative to its start ``t``) and the neighbours' on the grid ``t`` lies on.
        """
        nb = [self.tracks[j] for j in self.nbrs[tr.index]]
        if not nb:
            return None
        self.checks += 1
        if self.max_checks is not None and self.checks > self.max_checks:
            raise ConflictError(f"work budget for coordinating the arms is used up ({self.max_checks} checks)")
        t_stop = max([steps[-1].t1] + [o.end for o in nb])
        n = int(np.floor((t_stop - t) * self.rate + 1e-9)) + 2  # the last sample: everyone at rest
        T = t + np.arange(n) / self.rate
        pa = window.own(n)
        arrive = next((s.t1 for s in reversed(steps) if s.kind == StepKind.MOVE), t)
        best = None
        mine = window.own_box()
        for o in nb:
            # arms whose boxes over the whole span are further apart than the clearance need
            # cannot be too close at any sample: the exact test would find nothing
            gap = self.need + self.radii(tr.index, o.index) + 1e-9
            if apart(mine, self.boxes.track(o.index, o.steps, o.t0s, o.pose, t - 1e-6, float(T[-1]) + 1e-6), gap):
                continue
            bad = self.close_links(tr.index, pa, o.index, window.neighbour(o, t, n))
            hit = np.flatnonzero(bad)
            if hit.size and (best is None or T[hit[0]] < best[0]):
                late = T[hit[(T[hit] >= arrive) & (T[hit] < o.end)]]
                best = (float(T[hit[0]]), o.index, float(late.max()) if late.size and T[hit[0]] >= arrive else None)
        return best

    def earliest(self, tr: ArmTrack, leg: Leg, t: float) -> tuple[float | None, int | None]:
        """Earliest start, ``t`` or a whole number of samples at least ``quantum`` later, at which
        ``leg`` is clear of the neighbours' commitments: ``(start, None)``; or ``(None, j)`` when
        neighbour j's rest pose after its commitments is in the way (then no start helps).

        Every trial start lies on the grid ``t + k / rate``, so the leg's points (the same at
        every start) and the neighbours' points are computed once per call and sliced."""
        k, q = 0, max(1, int(np.ceil(self.quantum * self.rate - 1e-9)))
        window = None
        while True:
            s = t + k / self.rate
            steps = self.leg_steps(tr, leg, s)
            if not steps:
                return s, None
            if window is None:
                window = _Window(self, tr, leg, t)
            hit = self.conflict(tr, steps, s, window)
            if hit is None:
                return s, None
            tc, j, late = hit
            if tc >= self.tracks[j].end:
                return None, j
            step = q
            if late is not None:
                arrive = next((st.t1 for st in reversed(steps) if st.kind == StepKind.MOVE), s)
                step = max(step, int(np.ceil((late - arrive) * self.rate - 1e-9)) + 1)
            k += step

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

    def yield_pose(self, y: ArmTrack, x: ArmTrack) -> np.ndarray | None:
        """Where arm y should go so that arm x's next leg is clear of it.

        Hard: clear of x's next leg (sampled at ``rate``, target included), and y's way there
        clear of where its neighbours rest. Soft: fewest conflicts with the neighbours'
        remaining work, then the quickest move.
        """
        cand = self.stows(y.index)
        cand = cand[[not same_pose(c, y.pose) for c in cand]]
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
        time = np.array([scurve_move(y.arm, 0.0, y.pose, c).duration for c in cand])
        return cand[first_min_index(np.where(ok, 10.0 * soft + time, np.inf))]

    def do_yield(self, y: ArmTrack, x: ArmTrack, t: float) -> bool:
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
            y.todo.append(Leg(y.home, home=True))
        y.todo.insert(0, Leg(tuple(map(float, pose))))
        y.stuck, y.deferred = None, False
        y.ready = max(y.end, t)
        self.yields += 1
        return True

    def other_branch(self, tr: ArmTrack, leg: Leg) -> Leg | None:
        """The same pick/place with the other elbow branch, if valid and not into a pose a
        neighbour keeps coming back to (its places, its home); else None."""
        if leg.point is None:
            return None
        margin = self.problem.task.reach_margin if leg.kind == StepKind.PICK else 0.0
        q, valid = tr.arm.ik(np.asarray(leg.point, float), margin)
        for b in range(2):
            if valid[b] and not same_pose(q[b], leg.target, 1e-6):
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
            out += scurve_move(self.problem.arms[i], 0.0, q, v).duration
            q = v
        return out

    def detour(self, tr: ArmTrack, leg: Leg, alt: Leg) -> float:
        """Extra time of doing ``alt`` instead of ``leg`` (into the target and on to the next one)."""
        nxt = tr.todo[1].target if len(tr.todo) > 1 else None

        def via(target):
            t = self.route_time(tr.index, tr.pose, target)
            return t + (self.route_time(tr.index, target, nxt) if nxt is not None else 0.0)

        return via(alt.target) - via(leg.target)

    # ---- finishing
    def home_blocks(self, tr: ArmTrack) -> bool:
        """Whether home is in the way of a neighbour's remaining work."""
        return any(self.static_hits(tr.index, np.asarray(tr.home, float), j, self.remaining(j))[0] > 0
                   for j in self.nbrs[tr.index] if self.tracks[j].working)

    def park_pose(self, tr: ArmTrack) -> np.ndarray | None:
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
        time = np.array([scurve_move(tr.arm, 0.0, tr.pose, c).duration for c in cand])
        best = first_min_index(hits * 10.0 + time)
        return None if best == 0 else cand[best]

    # ---- main loop
    def commit(self, tr: ArmTrack, steps: list[Step], start: float) -> None:
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
        """Book every arm's legs, the arm whose next leg is due first at each turn (the rules:
        :func:`coordinate`); the steps: :meth:`next_track`, :meth:`check_limits`,
        :meth:`park_or_defer` (a finished arm whose way home is blocked), :meth:`earliest`
        and :meth:`commit` (the leg booked), :meth:`wait_or_resolve` (a neighbour rests in the
        way) and :meth:`break_deadlock`."""
        while True:
            tr = self.next_track()
            if tr is None:
                break
            t = tr.ready
            self.record_turn(tr, t)
            self.check_limits(t)
            leg = tr.todo[0]
            if leg.home and not same_pose(tr.pose, tr.home):
                self.barrier()
                if self.home_blocks(tr):
                    self.park_or_defer(tr, t)
                    continue
            tr.deferred = False
            start, j = self.earliest(tr, leg, t)
            if start is not None:
                self.commit(tr, self.leg_steps(tr, leg, start), start)
                continue
            self.wait_or_resolve(tr, leg, t, self.tracks[j])
        if self.trace is not None:
            self.trace.steps = [tr.steps for tr in self.tracks]
        return {tr.arm.name: ArmSchedule(tr.arm, merge_waits(tr.steps)) for tr in self.tracks}

    def next_track(self) -> ArmTrack | None:
        """The arm whose next leg is due first (ties: priority rank); None when all are done."""
        active = [tr for tr in self.tracks if tr.todo]
        if not active:
            return None
        due = min(r.ready for r in active)  # times equal but for the last bits are equal: the rank decides on any CPU
        return min((r for r in active if r.ready <= due + TIE), key=lambda r: r.rank)

    def check_limits(self, t: float) -> None:
        """:class:`ConflictError` past the clock deadline or the plan-time horizon."""
        if self.deadline is not None and _time.perf_counter() > self.deadline:
            raise ConflictError("time budget for coordinating the arms is used up")
        if t > self.horizon:
            raise ConflictError(f"no conflict-free schedule found within {self.horizon:.0f} s of plan time")

    def park_or_defer(self, tr: ArmTrack, t: float) -> None:
        """A finished arm whose home is in the neighbours' remaining work: once, a park leg to
        the clearest candidate pose; else it waits until a working neighbour is due."""
        q = self.quantum
        if not tr.parked:
            tr.parked = True
            park = self.park_pose(tr)
            if park is not None:
                tr.todo.insert(0, Leg(tuple(map(float, park))))
                self.parks += 1
                return
        tr.deferred = True
        nxt = [self.tracks[j].ready for j in self.nbrs[tr.index] if self.tracks[j].working]
        tr.ready = max(t + q, min(nxt, default=t + q))

    def wait_or_resolve(self, tr: ArmTrack, leg: Leg, t: float, o: ArmTrack) -> None:
        """Neighbour ``o`` rests in the way of ``leg`` until it moves again: wait for it if it
        will move by itself (only once for the same neighbour and pose), else break the deadlock."""
        q = self.quantum
        j = o.index
        if self.log:
            self.log(f"{t:7.2f} {tr.arm.name} rest-blocked by {o.arm.name} (its end {o.end:.2f}) leg to {np.round(leg.target, 2)}")
        tr.stuck = j
        # the neighbour will move by itself: wait for it, but only once -- if its next rest
        # pose is in the way again, it is a busy neighbour starving this arm: resolve now
        again = tr.blocker is not None and tr.blocker[0] == j and not same_pose(tr.blocker[1], o.pose)
        tr.blocker = (j, o.pose) if tr.blocker is None or tr.blocker[0] != j else tr.blocker
        if not again and not self.is_stuck(j, tr.index):
            tr.ready = max(t + q, o.ready)
            return
        self.break_deadlock(tr, leg, t, o)

    def break_deadlock(self, tr: ArmTrack, leg: Leg, t: float, o: ArmTrack) -> None:
        """The other branch of this pick/place if it costs little, else someone gets out of the
        way (the neighbour if it is finished or has the lower priority; else this arm, so that
        the neighbour's next leg can go), else the other branch whatever it costs; else
        :class:`ConflictError`."""
        self.barrier()
        q = self.quantum
        alt = self.other_branch(tr, leg)
        alt_start = self.earliest(tr, alt, t)[0] if alt is not None else None
        if alt_start is not None and self.detour(tr, leg, alt) <= 0.5:
            tr.todo[0] = alt
            self.commit(tr, self.leg_steps(tr, alt, alt_start), alt_start)
            return
        first, second = (o, tr) if (not o.working or o.rank > tr.rank) else (tr, o)
        if self.yields < self.max_yields and (self.do_yield(first, second, t)
                                              or (o.working and self.do_yield(second, first, t))):
            if tr.todo and tr.todo[0] is leg:
                tr.ready = max(t + q, o.ready)
            return
        if alt_start is not None:
            tr.todo[0] = alt
            self.commit(tr, self.leg_steps(tr, alt, alt_start), alt_start)
            return
        if self.yields >= self.max_yields:
            raise ConflictError(f"arms {tr.arm.name!r} and {o.arm.name!r} keep blocking each other ({self.yields} yields)")
        raise ConflictError(f"arm {o.arm.name!r} rests in the way of arm {tr.arm.name!r} at t = {t:.2f} s "
                            "and neither can get out of the other's way")


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
    max_checks: int | None = None,
    cache: dict | None = None,
    work: dict | None = None,
    committed: dict | None = None,
    trace: Trace | None = None,
    resume: Trace | list[Trace] | None = None,
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
    Moves from a pose the plan did not foresee are routed by :meth:`ArmGeometry.route`.

    Raises :class:`ConflictError` after ``max_yields`` yields, past ``horizon`` s of plan
    time, after ``max_checks`` conflict checks (a work budget: the same on any machine) or at
    ``deadline`` (``time.perf_counter()``; only for an explicit clock limit). ``cache`` (a
    dict the caller keeps) shares routes, rest poses and moves between runs on one problem;
    ``work`` (a dict), when given, has its ``"checks"`` entry increased by the checks made.
    ``committed`` (arm -> steps, for live re-planning): motion each arm is already committed to
    (ending at rest); its legs are booked after it, against every arm's committed motion, and
    the returned schedules begin with it.
    ``trace`` (a :class:`~.trace.Trace`) records this run; ``resume``, earlier runs' traces on
    the same problem (the best is used), lets it start where its legs first differ -- with the
    result from scratch; ``work["checks"]`` still counts as from scratch (a budget buys the
    same runs, sooner), ``work["checks_made"]`` the checks made, ``work["resumed_turns"]`` the
    turns taken over. Neither with ``committed``. Returns the schedules (each ending at home),
    the number of waits and the number of yield/park moves added.
    """
    c = _Coordinator(problem, schedules, margin, rate, quantum, priority, deadline, max_yields, horizon, max_checks, cache,
                     committed)
    if not committed and (trace is not None or resume is not None):
        c.start_trace(trace, resume)
    try:
        out = c.run()
    finally:
        if work is not None:
            work["checks"] = work.get("checks", 0) + c.checks  # as from scratch: resuming changes no budget
            work["checks_made"] = work.get("checks_made", 0) + c.checks - c.resumed_checks
            work["resumed_turns"] = work.get("resumed_turns", 0) + c.resumed_turns
    waits = sum(1 for s in out.values() for st in s.steps if st.kind == StepKind.WAIT)
    return out, waits, c.yields + c.parks
