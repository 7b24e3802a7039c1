"""The online planner of a live cell: detections and the current time in, committed motion out.

:class:`LiveCell` keeps one plan for every arm (a list of schedule steps: rest-to-rest S-curve
moves, dwells, waits, and re-planned approaches) and the believed fruit (:class:`Track`: the
detections merged within a gating distance). The same object runs against a real camera and
controller (:meth:`LiveCell.observe`, :meth:`LiveCell.refine`, :meth:`LiveCell.sample`) or in
the simulation (:mod:`coplan.live.sim`).

Re-planning (the design): every coordinated move is rest-to-rest, so at the end of every step
each arm is at rest. At time ``now`` each arm keeps its motion up to the first rest instant at
or after ``now + horizon`` (the commit horizon, at least the re-planning latency): the move or
dwell under way runs to its end (a move into a pick or place keeps its dwell), an arm waiting
stops waiting at the horizon. The committed motions are checked against each other (each arm
resting after its own); where one would rest in a neighbour's committed path, its commitment
is extended by its next planned leg (the old plan was clear, so this ends). The rest of the
work -- the fruit an arm holds goes to its bin first, then every other believed fruit -- is
coordinated leg by leg after the committed motion (:func:`coplan.planners.coordinated.coordinate.coordinate` with
``committed``). Candidates, in order: the current plan's own (its order, poses and priority;
each new fruit given to the arm that would finish it first), then the min-makespan MILP's and
the lower bound's allocations; the first gives a plan at once, the others are tried while the
re-plan's ``budget`` lasts and the fastest is kept. The new plan starts from rest where the
committed motion ends, so position, velocity and acceleration continue exactly. If nothing
can be coordinated the old plan stays (it is still clear); fruit left out wait for the next
re-plan.

Close range: when a tip comes within ``close_distance`` of its target the gripper camera
measures again (:meth:`LiveCell.refine`). Nothing there (a false or duplicate detection): the
pick and its place become waits -- the same motion, so safe at once -- and the arm moves on at
the next re-plan. A refined position: the approach under way is replaced, from the arm's exact
state ``correction_delay`` s later, by a time-optimal jerk-limited move (Ruckig) to the refined
pick pose on the same elbow branch; the rest is re-planned after its dwell. If the refined pose
is out of this arm's reach, far from the planned one (across a joint limit), or the corrected
approach cannot be made clear of the neighbours' committed motion, the pick becomes a wait
instead and the fruit -- now known exactly -- is planned again, never risked.
"""

from __future__ import annotations

import time as _time
from dataclasses import replace

import numpy as np

from ..kinds import ReplanCause, TrackState
from ..problem.model import Fruit, Problem
from ..planners.coordinated.schedule import ArmSchedule, ConflictError, Step, StepKind, pair_distances
from ..errors import Issue, finite_number, found
from .gating import TrackIndex
from .records import CloseRange, LiveOptions, Replan, Track
from .feed import Detection, FeedError, cell_only, detection_issues, now_issues, refinement_issues
from .motion import Approach, ApproachError, as_wait, move_step, split_at, truncate_move

__all__ = ["LiveOptions", "Track", "Replan", "CloseRange", "LiveCell"]


class LiveCell:
    """The live planner. ``problem`` gives the arms and the task (its fruit are ignored: the
    fruit are what the camera reports)."""

    def __init__(self, problem: Problem, options: LiveOptions | None = None):
        cell_only(problem, "LiveCell")  # (a row was taken, and its first observe failed inside, a track filed)
        self.problem = replace(problem, fruits=())
        self.options = options or LiveOptions()
        self.steps: dict[str, list[Step]] = {a.name: [] for a in problem.arms}
        self.tracks: dict[str, Track] = {}
        self.replans: list[Replan] = []
        self.merges: list[dict] = []
        self.order: list[str] = []  # the priority order of the current plan's coordination
        self._geometry: tuple = ({}, {}, {})  # the coordinator's rest poses, routes and moves (arms only)
        self.commit: dict[str, float] = {a.name: 0.0 for a in problem.arms}  # each arm's motion is fixed up to here

    def warm_up(self) -> float:
        """Plan once on a throw-away copy (one fruit at the first arm's home tip), so the first
        real re-plan does not pay for imports and solver start-up. Returns the seconds spent."""
        from ..kinematics.arm import fk

        t0 = _time.perf_counter()
        arm = self.problem.arms[0]
        tip = fk(np.asarray(arm.home, float), arm.links, arm.base)[1]
        LiveCell(self.problem, self.options).observe(0.0, [Detection(0.0, "warm-up", (float(tip[0]), float(tip[1])), 0.01)])
        return _time.perf_counter() - t0

    # ------------------------------------------------------------------ queries
    def schedules(self) -> dict[str, ArmSchedule]:
        return {a.name: ArmSchedule(a, list(self.steps[a.name])) for a in self.problem.arms}

    @property
    def end(self) -> float:
        return max((s[-1].t1 for s in self.steps.values() if s), default=0.0)

    def makespan(self) -> float:
        return max((s.t1 for st in self.steps.values() for s in st if s.kind == StepKind.PLACE), default=0.0)

    def sample(self, t) -> dict[str, np.ndarray]:
        """Each arm's (q, qd, qdd) (3, K, 2) at times ``t`` (a number or K of them, finite): what
        the controller executes."""
        try:
            ts = np.atleast_1d(np.asarray(t, float))
        except (TypeError, ValueError):
            ts = None
        if ts is None or ts.ndim != 1 or not np.all(np.isfinite(ts)):  # (NaN gave NaN poses; 'a' a bare ValueError)
            raise FeedError([Issue("t", f"expected a time or a list of finite times (s), found {found(t, list_length=True)}")],
                            "LiveCell.sample")
        return {n: sch.state(ts) for n, sch in self.schedules().items()}

    def committed_motion(self, now: float = 0.0) -> dict[str, list[Step]]:
        """Each arm's steps from ``now`` up to where its motion is fixed (``commit``): what a
        controller may execute without waiting for the next re-plan (the rest of ``steps`` is the
        current plan, which a later re-plan may change)."""
        return {n: [s for s in st if s.t1 > now and s.t0 < self.commit[n] - 1e-12] for n, st in self.steps.items()}

    def open_tracks(self) -> list[Track]:
        return [tr for tr in self.tracks.values() if tr.state == TrackState.PENDING]

    # ------------------------------------------------------------------ detections
    def merge(self, d: Detection, index: TrackIndex | None = None) -> tuple[Track, bool]:
        """File one detection: merged into the nearest track within the gate, else a new track.
        Returns ``(track, merged)``. ``index``: the tracks' gating arrays, when a batch is filed
        (:meth:`observe` builds one and keeps it current); built here when not given."""
        index = TrackIndex(self.tracks.values(), self.options.gate) if index is None else index
        p = np.asarray(d.position, float)
        i, best_d = index.nearest(p, d.sigma, d.t)
        if i < 0:
            tr = Track(d.id, p, float(d.sigma), d.t, [d.id])
            self.tracks[tr.id] = tr
            index.add(tr)
            return tr, False
        best = index.tracks[i]
        best.detections.append(d.id)
        if not best.refined and best.state in (TrackState.PENDING, TrackState.PLANNED, TrackState.UNREACHABLE):
            w1, w2 = 1.0 / best.sigma**2, 1.0 / d.sigma**2
            best.position = (w1 * best.position + w2 * p) / (w1 + w2)
            best.sigma = float(1.0 / np.sqrt(w1 + w2))
            index.update(i)
        self.merges.append({"t": d.t, "detection": d.id, "track": best.id, "distance": best_d, "track_state": best.state.value})
        return best, True

    def observe(self, now: float, detections: list[Detection]) -> Replan:
        """New detections at ``now``: merge them and re-plan from the committed motion. Each is
        checked first as a feed file's rows are (:func:`coplan.live.feed.detection_issues`: a time
        from 0 to ``now``, a new id, a plausible position, a noise in (0, 1] m; ``now`` no earlier
        than the last re-plan's); any bad one raises :class:`~coplan.live.feed.FeedError` listing them
        all and leaves the cell as it was (a NaN position was kept, and every later call failed)."""
        seen = {i for tr in self.tracks.values() for i in tr.detections}
        issues = now_issues(now, self._last_call())
        if isinstance(detections, (str, bytes, dict)) or not hasattr(detections, "__iter__"):  # (5: "'int' object is not iterable")
            issues.append(Issue("detections", f"expected a list of Detection(t, id, position, sigma), found {found(detections)}"))
        else:
            issues += detection_issues(list(detections), seen, now if finite_number(now) else None)
        if issues:
            raise FeedError(issues, "LiveCell.observe")
        index = TrackIndex(self.tracks.values(), self.options.gate)
        for d in detections:
            self.merge(d, index)
        return self._replan(now, ReplanCause.DETECTIONS)

    def retry(self, now: float) -> Replan:
        """Re-plan with nothing new (e.g. the plan ended with detected fruit left over); ``now``
        checked as :meth:`observe` checks it (an earlier time was taken, a NaN was a bare ValueError)."""
        issues = now_issues(now, self._last_call())
        if issues:
            raise FeedError(issues, "LiveCell.retry")
        return self._replan(now, ReplanCause.IDLE)

    def _last_call(self) -> float:
        return self.replans[-1].t if self.replans else 0.0

    # ------------------------------------------------------------------ close range
    def next_close_range(self, after: float) -> CloseRange | None:
        """The first time after ``after`` at which a tip comes within ``close_distance`` of the
        estimate of a fruit it approaches (not yet refined)."""
        from ..kinematics.arm import fk

        if not finite_number(after):  # (NaN was taken as 'no time', 'a' a bare TypeError)
            raise FeedError([Issue("after", f"expected a time (a finite number, s), found {found(after)}")],
                            "LiveCell.next_close_range")

        best = None
        for arm in self.problem.arms:
            steps = self.steps[arm.name]
            for i, s in enumerate(steps[:-1]):
                nxt = steps[i + 1]
                if s.kind != StepKind.MOVE or nxt.kind != StepKind.PICK or s.t1 <= after:
                    continue
                tr = self.tracks.get(nxt.fruit)
                if tr is None or tr.refined:
                    continue
                lo = max(s.t0, after)
                T = np.append(np.arange(lo, s.t1, 0.005), s.t1)
                q = ArmSchedule(arm, [s]).state(T)[0]
                tip = fk(q, arm.links, arm.base)[1]
                near = np.flatnonzero(np.hypot(*(tip - tr.position).T) <= self.options.close_distance)
                t = float(T[near[0]]) if near.size else float(s.t1)
                if best is None or t < best.t:
                    best = CloseRange(t, arm.name, tr.id)
                break
        return best

    def refine(self, now: float, track_id: str, position, sigma: float) -> Replan:
        """The close-range measurement of a track (``position`` None: nothing there)."""
        t_start = _time.perf_counter()
        issues = refinement_issues(now, track_id, sorted(self.tracks), position, sigma, self._last_call())
        if issues:  # (an unknown track raised a bare KeyError)
            raise FeedError(issues, "LiveCell.refine")
        tr = self.tracks[track_id]
        tr.refined = True
        arm = self.problem.arm(tr.arm) if tr.arm else None
        steps = self.steps[tr.arm] if arm else []
        i = next((k for k in range(len(steps) - 1) if steps[k].kind == StepKind.MOVE and steps[k + 1].kind == StepKind.PICK
                  and steps[k + 1].fruit == track_id and steps[k + 1].t0 >= now - 1e-9), None)
        if position is None:
            tr.state, tr.note = TrackState.DROPPED, f"nothing found at close range (t = {now:.2f} s)"
            self._unpick(track_id)
            return self._replan(now, ReplanCause.CLOSE_RANGE, note=f"{track_id} dropped: nothing there", dropped=[track_id],
                                t_start=t_start)
        tr.position, tr.sigma = np.asarray(position, float), float(sigma)
        if arm is None or i is None:
            return self._replan(now, ReplanCause.CLOSE_RANGE, note=f"{track_id} refined (not being approached)")
        move = steps[i]
        qs, valid = arm.ik(tr.position, self.problem.task.reach_margin)
        ok = [b for b in range(2) if valid[b]]
        if not ok:  # another arm may reach it
            return self._defer(now, tr, f"refined out of {arm.name}'s reach (with the reach margin)")
        b = min(ok, key=lambda k: float(np.abs(np.asarray(qs[k]) - np.asarray(move.q1)).sum()))
        target = tuple(float(x) for x in qs[b])
        if float(np.abs(np.subtract(target, move.q1)).max()) > self.options.max_correction:
            return self._defer(now, tr, f"the refined pose is {float(np.abs(np.subtract(target, move.q1)).max()):.2f} rad "
                                        f"from the planned one (a joint limit or the other elbow branch)")
        ts = max(now + self.options.correction_delay, move.t0)
        try:
            if ts < move.t1:
                st = move.curve.derivatives(np.array([ts - move.t0]))
                approach = Approach(arm, st[0, 0], st[1, 0], st[2, 0], target)
                head = [truncate_move(move, ts)]
            else:
                approach = Approach(arm, move.q1, (0.0, 0.0), (0.0, 0.0), target)
                head = [move] + ([Step(StepKind.WAIT, move.t1, ts - move.t1, move.q1, move.q1)] if ts > move.t1 else [])
                ts = max(ts, move.t1)
        except ApproachError as e:
            return self._defer(now, tr, f"no corrected approach: {e}")
        corr = Step(StepKind.MOVE, ts, approach.duration, approach.q0, approach.q1, curve=approach)
        pick = Step(StepKind.PICK, corr.t1, self.problem.task.pick_dwell, target, target, fruit=track_id)
        k = 0
        while k < len(steps) and steps[k].t1 <= now + 1e-12:
            k += 1
        forced = (steps[:k], steps[k:i] + head + [corr, pick], [])
        rep = self._replan(now, ReplanCause.CLOSE_RANGE, forced={arm.name: forced}, t_start=t_start,
                           note=f"{track_id} refined by {1000 * float(np.hypot(*(np.asarray(move.q1) - target))):.1f} mrad")
        if not rep.ok:
            self.replans.pop()
            return self._defer(now, tr, f"the corrected approach is not clear of the neighbours ({rep.note})")
        rep.corrected = arm.name
        return rep

    def _defer(self, now: float, tr: Track, why: str) -> Replan:
        """The approach under way cannot take the refined fruit: its pick (and place) become
        waits -- the same motion -- and the fruit, now known exactly, is planned again."""
        tr.state, tr.arm, tr.note, tr.pick_end = TrackState.PENDING, None, why, None
        self._unpick(tr.id)
        return self._replan(now, ReplanCause.CLOSE_RANGE, note=f"{tr.id} planned again: {why}")

    def _unpick(self, track_id: str) -> None:
        """Turn a planned pick of ``track_id`` (and its place) into waits: the same motion."""
        for name, steps in self.steps.items():
            self.steps[name] = [as_wait(s) if s.fruit == track_id and s.kind in (StepKind.PICK, StepKind.PLACE) else s
                                for s in steps]

    # ------------------------------------------------------------------ re-planning
    def _settle(self, cuts: dict, now: float) -> bool:
        """Extend commitments until every arm's committed motion, each resting after its own,
        is clear of its neighbours' (``clearance + margin / 3``); False if that cannot be done."""
        prob = self.problem
        need = prob.task.clearance + self.options.margin / 3.0
        names = [a.name for a in prob.arms]
        for _ in range(8 * len(names) + 8):
            end = max(cuts[n][1][-1].t1 for n in names)
            T = np.append(np.arange(now, end, 0.005), end)
            q = {a.name: ArmSchedule(a, cuts[a.name][1]).state(T)[0] for a in prob.arms}
            bad = None
            for i, j in prob.neighbour_pairs():
                d = pair_distances(prob, q[names[i]], q[names[j]], i, j)
                hit = np.flatnonzero(d < need)
                if hit.size and (bad is None or T[hit[0]] < bad[0]):
                    bad = (float(T[hit[0]]), names[i], names[j])
            if bad is None:
                return True
            tb, grew = bad[0], False
            for n in bad[1:]:
                hist, kept, rest = cuts[n]
                if kept[-1].t1 <= tb and rest:
                    take = 2 if rest[0].kind == StepKind.MOVE and len(rest) > 1 and rest[1].kind in (StepKind.PICK, StepKind.PLACE) else 1
                    cuts[n] = (hist, kept + rest[:take], rest[take:])
                    grew = True
            if not grew:
                return False
        return False

    def _replan(self, now: float, cause: ReplanCause, forced: dict | None = None, note: str = "",
                dropped: list[str] | None = None, t_start: float | None = None) -> Replan:
        from ..allocate.allocation import screened_reach
        from ..planners.coordinated.coordinate import coordinate
        from ..planners.coordinated.planner import priority_orders

        t_start = _time.perf_counter() if t_start is None else t_start  # latency: from the measurement's arrival
        prob, opts = self.problem, self.options
        t_c = now + opts.horizon
        before = self.makespan()
        cuts = {a.name: (forced or {}).get(a.name) or split_at(self.steps[a.name], now, max(t_c, self.commit[a.name]), a.home)
                for a in prob.arms}
        rep = Replan(now, cause, {}, dropped=list(dropped or []), makespan_before=before, note=note)
        if not self._settle(cuts, now):
            rep.ok, rep.note = False, (note + "; " if note else "") + "committed motions are not clear of each other"
            return self._done(rep, t_start)
        # what the committed motion does: picks made, fruit held at its end
        held: dict[str, str | None] = {}
        picks: dict[str, tuple[str, float]] = {}  # fruit -> (arm, pick end) of the picks in committed motion
        for name, (hist, kept, _) in cuts.items():
            h = None
            for s in hist + kept:
                if s.kind == StepKind.PICK:
                    h = s.fruit
                    picks[s.fruit] = (name, s.t1)
                elif s.kind == StepKind.PLACE:
                    h = None
            held[name] = h
        # (a committed pick no longer in the motion kept -- a close-range correction cuts its arm's
        # commitment at the corrected pick, and a long horizon had committed the next one too --
        # is planned again: before, it was neither kept nor planned, and the fruit was lost)
        todo = [tr for tr in self.tracks.values() if tr.id not in picks
                and tr.state in (TrackState.PENDING, TrackState.PLANNED, TrackState.UNREACHABLE, TrackState.COMMITTED)]
        if len(todo) > opts.max_open:  # what the plan holds first, then the tracks seen first; the rest wait
            # (tracks found out of reach come after every pending one: 40 detections out of reach took
            # every place, re-plan after re-plan, and no fruit seen after them was ever planned)
            held_now = [tr for tr in todo if tr.state in (TrackState.PLANNED, TrackState.COMMITTED)]
            waiting = sorted((tr for tr in todo if tr.state not in (TrackState.PLANNED, TrackState.COMMITTED)),
                             key=lambda tr: (tr.state == TrackState.UNREACHABLE, tr.first_seen, tr.id))
            todo = held_now + waiting[:max(0, opts.max_open - len(held_now))]
        believed = replace(prob, fruits=tuple(Fruit(tr.id, self._plan_position(tr)) for tr in todo))
        reach = screened_reach(believed)
        unreachable = {f.id for j, f in enumerate(believed.fruits) if not reach[:, j].any()}
        committed = {n: c[1] for n, c in cuts.items()}
        best, reasons = None, []
        cache = {(id(believed), believed.task.clearance + opts.margin): self._geometry}  # routes do not depend on fruit

        def attempts():  # (label, work, schedules, priority): each allocation with its first order, then the others
            later = []
            for label, work in self._candidates(believed, reach, cuts):
                base = self._schedules(work, cuts, held)
                orders = [o for o in [self.order] + priority_orders(base) if o]
                yield label, work, base, orders[0] if orders else None
                later += [(label, work, base, o) for o in orders[1:2] if label == "keep"]
            yield from later

        used: dict = {"checks": 0}  # (the conflict checks of every candidate coordinated: the work budget)
        for label, work, base, order in attempts():
            if best is not None and (opts.work is not None and used["checks"] > opts.work
                                     or opts.budget is not None and _time.perf_counter() - t_start > opts.budget
                                     or cause != ReplanCause.DETECTIONS and best[4] == "keep" and best[0] <= before + 0.05):
                break  # a plan at once; better ones while the budgets last (a drop or correction: as good as before)
            checks = used["checks"]
            try:
                out, _, _ = coordinate(believed, base, opts.margin, priority=order, max_checks=opts.max_checks,
                                       committed=committed, cache=cache, work=used)
            except ConflictError as e:
                reasons.append(f"{label}: {e}")
                rep.tried.append({"candidate": label, "priority": list(order or []), "makespan": None,
                                  "checks": used["checks"] - checks})
                continue
            span = max((s.last_place for s in out.values()), default=0.0)
            rep.tried.append({"candidate": label, "priority": list(order or []), "makespan": span,
                              "checks": used["checks"] - checks})
            if best is None or span < best[0] - 1e-9:
                best = (span, out, work, order or [], label)
        if best is None:
            rep.ok, rep.note = False, (note + "; " if note else "") + "no coordination: " + "; ".join(reasons)
            return self._done(rep, t_start)
        self.order = list(best[3])
        for fid, (name, t1) in picks.items():  # the plan is taken: what it commits to is committed
            if fid in self.tracks:
                tr = self.tracks[fid]
                tr.state, tr.arm, tr.pick_end = TrackState.COMMITTED, name, t1
        rep.note = (note + "; " if note else "") + f"{best[4]} allocation"
        assigned = {fid: a for a, fs in best[2].items() for fid, _, _ in fs}
        for tr in todo:  # what changed
            arm_new = assigned.get(tr.id)
            if tr.id in unreachable:
                if tr.state != TrackState.UNREACHABLE:
                    rep.unreachable.append(tr.id)
                tr.state, tr.arm, tr.note = TrackState.UNREACHABLE, None, "no arm can harvest it where it was measured"
                continue
            if tr.state == TrackState.PENDING or tr.state == TrackState.UNREACHABLE:
                rep.added.append(tr.id)
            elif tr.arm != arm_new:
                rep.reassigned[tr.id] = [tr.arm, arm_new]
            tr.state, tr.arm = (TrackState.PLANNED, arm_new) if arm_new else (TrackState.PENDING, None)
            tr.pick_end = None
        for name, sch in best[1].items():
            self.steps[name] = list(cuts[name][0]) + list(sch.steps)
            rep.commit_until[name] = self.commit[name] = float(cuts[name][1][-1].t1)
        rep.makespan_after = self.makespan()
        return self._done(rep, t_start)

    def _plan_position(self, tr: Track) -> tuple[float, float]:
        """Where to plan a track's pick: its estimate; or, when no arm can reach the estimate but
        an arm's reach lies within 3 sigma of it, the nearest point it can reach (the
        close-range look then settles it)."""
        p = np.asarray(tr.position, float)
        margin = self.problem.task.reach_margin
        if tr.refined or any(a.can_reach(p, margin) for a in self.problem.arms):
            return float(p[0]), float(p[1])
        best, best_d = p, 3.0 * tr.sigma
        for a in self.problem.arms:
            d = p - np.asarray(a.base, float)
            r = float(np.hypot(*d))
            if r < 1e-9:
                continue
            q = np.asarray(a.base, float) + d / r * float(np.clip(r, a.inner_radius + margin + 1e-4, a.reach - margin - 1e-4))
            dist = float(np.hypot(*(q - p)))
            if dist <= best_d and a.can_reach(q, margin):
                best, best_d = q, dist
        return float(best[0]), float(best[1])

    def _candidates(self, believed: Problem, reach: np.ndarray, cuts: dict):
        """Work lists to coordinate, ``(label, {arm: [(fruit, pick pose, place pose)]})``, made
        when asked for: the current plan's own (its order and poses; each new fruit appended to
        the arm that would finish it first), then the min-makespan MILP's and the lower bound's."""
        from ..allocate.allocation import AllocationMethod, allocate, arm_configs, bound_allocation

        ids = [f.id for f in believed.fruits]
        keep: dict[str, list] = {a.name: [] for a in self.problem.arms}
        have = set()
        for name, (_, _, rest) in cuts.items():
            for i, st in enumerate(rest):
                if st.kind == StepKind.PICK and st.fruit in ids and st.fruit not in have:
                    place = next((x.q1 for x in rest[i + 1:] if x.kind == StepKind.PLACE and x.fruit == st.fruit), None)
                    if place is not None:
                        keep[name].append((st.fruit, st.q1, place))
                        have.add(st.fruit)
        new = [f for j, f in enumerate(ids) if f not in have and reach[:, j].any()]
        if have:
            if new:  # each new fruit to the arm that would finish it first (a round trip from its bin)
                dwell = self.problem.task.pick_dwell + self.problem.task.place_dwell
                arms = {a.name: a for a in self.problem.arms}
                cfg = {n: arm_configs(believed, a) for n, a in arms.items()}

                def trip(n, qf):  # quickest bin -> fruit -> bin over the usable bin poses: (time, bin pose)
                    return min((move_step(arms[n], 0.0, qb, qf).duration * 2.0 + dwell, tuple(map(float, qb))) for qb in cfg[n][0])

                # when each arm finishes its current work: its last place in the current plan
                finish = {n: max([cuts[n][1][-1].t1] + [st.t1 for st in cuts[n][2] if st.kind == StepKind.PLACE])
                          for n in arms if cfg[n][0]}
                pos = {f.id: f.position[0] for f in believed.fruits}
                options = {f: [(trip(n, tuple(map(float, qf))), n, tuple(map(float, qf))) for n in finish
                               for qf in cfg[n][1].get(f, [])] for f in new}
                for f in sorted(new, key=lambda f: min((o[0][0] for o in options[f]), default=np.inf)):
                    if options[f]:
                        (cost, qb), n, qf = min(options[f], key=lambda o: finish[o[1]] + o[0][0])
                        xs = [pos[g] for g, _, _ in keep[n]]  # into the arm's sweep (its order by x), else last
                        up = len(xs) < 2 or xs[-1] >= xs[0]
                        at = next((i for i, x in enumerate(xs) if (x > pos[f]) == up), len(xs))
                        keep[n].insert(at, (f, qf, qb))
                        finish[n] += cost
            yield "keep", keep
        if believed.fruits:
            alloc = allocate(believed, AllocationMethod.MAKESPAN, bound=0.0)
            yield "milp", {a: [(f, alloc.fruit_q[a][f], alloc.place_q[a][f]) for f in fs] for a, fs in alloc.assignment.items()}
            b = bound_allocation(believed)
            yield "bound", {a: [(f, b.fruit_q[a][f], b.place_q[a][f]) for f in fs] for a, fs in b.assignment.items()}
        else:  # no fruit left to plan: place what is held, go home
            yield "finish", keep

    def _schedules(self, work: dict, cuts: dict, held: dict) -> dict[str, ArmSchedule]:
        """Each arm's remaining work as a schedule from where its committed motion ends: the
        fruit it holds to the bin, then (fruit, bin)* in ``work``'s order, then home."""
        prob = self.problem
        base: dict[str, ArmSchedule] = {}
        for arm in prob.arms:
            kept = cuts[arm.name][1]
            t, q = kept[-1].t1, kept[-1].q1
            steps: list[Step] = []

            def leg(target, kind, dwell, fid):
                nonlocal t, q
                mv = move_step(arm, t, q, tuple(map(float, target)))
                steps.extend([mv, Step(kind, mv.t1, dwell, mv.q1, mv.q1, fruit=fid)])
                t, q = mv.t1 + dwell, mv.q1

            if held[arm.name] is not None:  # where the current plan places it, else the quickest bin pose
                f = held[arm.name]
                qb = next((s.q1 for s in cuts[arm.name][2] if s.kind == StepKind.PLACE and s.fruit == f), None)
                if qb is None:
                    qs, ok = arm.ik(np.asarray(arm.bin, float), 0.0)
                    cand = [qs[k] for k in range(2) if ok[k]] or [arm.home]
                    qb = min(cand, key=lambda c: move_step(arm, 0.0, q, tuple(map(float, c))).duration)
                leg(qb, StepKind.PLACE, prob.task.place_dwell, f)
            for fid, qf, qb in work[arm.name]:
                leg(qf, StepKind.PICK, prob.task.pick_dwell, fid)
                leg(qb, StepKind.PLACE, prob.task.place_dwell, fid)
            if steps or not np.allclose(q, arm.home, atol=1e-9):
                steps.append(move_step(arm, t, q, arm.home))
            base[arm.name] = ArmSchedule(arm, steps)
        return base

    def _done(self, rep: Replan, t_start: float) -> Replan:
        rep.latency = _time.perf_counter() - t_start
        self.replans.append(rep)
        return rep
