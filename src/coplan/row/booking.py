"""Book harvest cycles for arms on a moving carriage, one at a time, never closer than allowed.

A :class:`Booker` holds every arm's motion sampled on the plan's grid up to the time the arm is
free again (at rest over its bin, or home). A **cycle** of arm ``a`` on fruit ``f`` is: wait at
rest, a time-optimal move (:class:`coplan.row.track.Leg`) that arrives on the fruit with the
carriage's motion matched, the pick (the tip held over the fruit in row coordinates:
:func:`coplan.row.track.track`), a move to rest over the bin, the place. :meth:`Booker.book`
finds the earliest pick time inside the fruit's window at which the whole cycle keeps
``clearance + margin`` from every neighbour's booked motion -- and, past a neighbour's booked
end, from its resting pose, which is where it stays until it books its next cycle (checked
then against this one), so every pair of cycles is checked by whichever is booked later.

The **policy** (:func:`coplan.row.policy.run_policy`) decides which arm books what.
"""

from __future__ import annotations

import itertools
import math
import weakref
from dataclasses import dataclass, field

import numpy as np

from ..allocate.screen import usable_picks
from ..plan import Event, EventKind
from ..planners.coordinated.schedule import arm_points, points_too_close
from ..problem.gantry import cell_at
from ..problem.model import Problem
from .branches import screen_branches
from .cruise import Cruise, Window
from .track import LIMIT_SHARE, Leg, LegError, track, track_state, way

__all__ = ["Booker", "Cycle", "PATIENCE", "RETRY"]

RETRY = 0.1  # s: a cycle that would come too close to a neighbour is tried again this much later ...
RETRY_GROWTH = 1.5  # ... and each further try that much later again
#: Shares of the joint limits a pick's tracking may use alone (room for the moves that join it) ...
_TRACK_SHARES = (0.95, 0.9, 0.5)
#: ... and a whole cycle, seams included, by finite differences (a little inside the limits).
_CYCLE_SHARES = (0.98, 0.98, 0.98)
PATIENCE = 5.0  # s: the longest an arm waits for a clear cycle on one fruit
_TRIES = 6  # fixed-point rounds: arrival time <-> where the fruit is then


@dataclass
class Cycle:
    """One booked harvest: indices on the grid and the events."""

    arm: int
    fruit: str
    k0: int  # first sample of the cycle (the arm free, at rest)
    q: np.ndarray  # (K, 2) samples k0 .. k0 + K - 1
    events: list[Event]
    tucked: bool = False  # its ways to the fruit and back tucked (:func:`coplan.row.track.tucked_route`)


@dataclass
class ArmState:
    q: np.ndarray  # (capacity, 2) samples booked so far
    k_free: int = 0  # booked up to and including this sample; at rest there
    done: bool = False
    fruit: list[str] = field(default_factory=list)
    last: Cycle | None = None  # the cycle last committed, while nothing is booked after it
    ends: list[float] = field(default_factory=list)  # s: where each cycle on a fruit or report ends


class Booker:
    """Every arm's booked motion (module docstring)."""

    def __init__(self, problem: Problem, cruise: Cruise, windows: dict[str, list[Window]], rate: float, margin: float,
                 step: float = 0.05, branch_table: dict | None = None):
        self.problem, self.cruise, self.windows, self.rate = problem, cruise, windows, rate
        self.dt = 1.0 / rate
        self.cell = cell_at(problem, 0.0, ())  # the carriage frame
        self.need = problem.task.clearance + margin
        self.n_pick = int(math.ceil(problem.task.pick_dwell * rate - 1e-9))
        self.n_place = int(math.ceil(problem.task.place_dwell * rate - 1e-9))
        self.probes: set[str] = set()  # fruit whose cycle is a probe: the arm comes, finds nothing, goes back (no dwells)
        self.tucked: list[str] = []  # fruit booked by a tucked cycle (:meth:`plan_cycle` with ``tuck``), in booking order
        self.arms = [ArmState(np.tile(np.asarray(a.home, float), (1024, 1))) for a in problem.arms]
        self.events: list[Event] = []
        self.work_end = 0.0  # s: the end of the last cycle committed on a fruit or a report (a probe's too)
        self.bin_q = [self._bin_pose(i) for i in range(len(problem.arms))]
        pairs = problem.neighbour_pairs()
        self.neighbours = [[j for p in pairs for j in p if i in p and j != i] for i in range(len(problem.arms))]
        self.fruit_xy = {f.id: tuple(map(float, f.position)) for f in problem.fruits}
        self.checks = 0
        # elbow branches screened so far (:meth:`branches`); ``branch_table``: one shared by the
        # bookings of one fixed problem (:func:`coplan.row.branches.branch_table`); none: this booking's own (a live
        # row's booker sees its problem grow)
        self._use = {} if branch_table is None else branch_table
        self.step = step  # m: the row screen's grid, on which a pick's elbow branch is screened
        self.leg_share = LIMIT_SHARE  # of the joint limits a move uses (AT_REST_SHARE: every pick at rest)
        self.probe_rests = False  # a probe with the carriage at rest ends where it found nothing (:meth:`_probe_stays`)
        self.cycle_shares = _CYCLE_SHARES  # of the limits a whole cycle's finite differences may reach
        # where each arm rests when it has nothing to do: home, but an arm the screen locks (it
        # harvests nothing) is parked out of its neighbours' way first (:mod:`coplan.row.park`)
        self.rest_q = [np.asarray(a.home, float) for a in problem.arms]
        self.halted: dict[int, float] = {}  # arm -> the time of its controller fault: no motion starts from then
        for i, pose in _parked(problem, self.need).items():
            if self._go(i, pose, 0.0):
                self.rest_q[i] = pose

    # ------------------------------------------------------------------ poses
    def _bin_pose(self, i: int) -> np.ndarray:
        arm = self.cell.arms[i]
        q, valid = arm.ik(np.asarray(arm.bin, float))
        use = usable_picks(replace_reach_margin(self.cell), np.asarray([arm.bin], float), arms=(i,))[i][0]
        ok = [b for b in (0, 1) if valid[b] and use[b]] or [b for b in (0, 1) if valid[b]]
        if not ok:
            raise ValueError(f"{arm.name} cannot reach its bin")
        home = np.asarray(arm.home, float)
        return min((q[b] for b in ok), key=lambda qb: float(np.max(np.abs(qb - home))))

    def branches(self, i: int, fid: str, c0: float, c1: float) -> list[int]:
        """Elbow branches of arm ``i`` usable on fruit ``fid`` with the carriage anywhere in
        ``[c0, c1]``: the screen's rules on a 5 cm grid of carriage positions covering it
        (computed once per arm and fruit, over the arm's whole reach of the fruit: :func:`coplan.row.branches.screen_branches`)."""
        key = (i, fid)
        if key not in self._use:
            screen_branches(self.problem, self.step, [key], self._use, self.fruit_xy, self.cell)
        lo, use = self._use[key]
        k0 = int(math.floor((c0 - lo) / self.step + 1e-9))
        k1 = int(math.ceil((c1 - lo) / self.step - 1e-9))
        if k0 < 0 or k1 >= use.shape[0]:
            return []
        return [b for b in (0, 1) if use[k0:k1 + 1, b].all()]

    # ------------------------------------------------------------------ time
    def up(self, t: float) -> int:
        """The first grid index at or after ``t``."""
        return int(math.ceil(t * self.rate - 1e-6))

    def free_time(self, i: int) -> float:
        return self.arms[i].k_free * self.dt

    def pose_at(self, i: int, k0: int, k1: int) -> np.ndarray:
        """(k1 - k0, 2) arm ``i``'s booked samples, its resting pose past its booked end."""
        return self.poses_at(i, np.arange(k0, k1))

    def poses_at(self, i: int, idx: np.ndarray) -> np.ndarray:
        """(len(idx), 2) arm ``i`` at grid samples ``idx``: as booked, at its resting pose past its booked end."""
        st = self.arms[i]
        return st.q[np.minimum(idx, st.k_free)]

    def _clear(self, i: int, k0: int, q: np.ndarray, known: tuple[int, int] = (0, 0)) -> bool:
        """Arm ``i``'s motion ``q`` from sample ``k0`` keeps ``need`` from every neighbour -- and so
        does the pose it then rests at, against whatever a neighbour has booked beyond it (that
        motion was checked against this arm's *previous* resting pose: a new one, home after the
        bin or the bin after home, must be checked again). ``known``: samples ``[a, b)`` already
        found clear, not tested again."""
        k1 = k0 + q.shape[0]
        reach = max([k1] + [self.arms[j].k_free + 1 for j in self.neighbours[i]])
        if reach > k1:
            q = np.vstack([q, np.repeat(q[-1:], reach - k1, axis=0)])
        a, b = known
        if b <= a:
            return not self._hits(i, k0, q, first=True).any()
        idx = np.arange(k0, k0 + q.shape[0])
        rest = (idx < a) | (idx >= b)
        return not self._hits_at(i, idx[rest], q[rest], first=True).any()

    def _hits(self, i: int, k0: int, q: np.ndarray, first: bool = False) -> np.ndarray:
        """(len(q),) whether arm ``i`` at sample ``k0 + k`` of ``q`` comes within ``need`` of a
        neighbour's booked motion (its resting pose past its booking); ``first``: only whether
        any does (the array is all False if none, and stops at the first neighbour that does)."""
        return self._hits_at(i, np.arange(k0, k0 + q.shape[0]), q, first)

    def _hits_at(self, i: int, idx: np.ndarray, q: np.ndarray, first: bool = False) -> np.ndarray:
        """:meth:`_hits` for samples anywhere on the grid: arm ``i`` at pose ``q[m]`` at sample
        ``idx[m]``, each neighbour where it is booked then (:meth:`poses_at`)."""
        a = self.problem.arms[i]
        pa = arm_points(a, q)
        out = np.zeros(q.shape[0], bool)
        for j in self.neighbours[i]:
            b = self.problem.arms[j]
            self.checks += q.shape[0]
            out |= points_too_close(pa, arm_points(b, self.poses_at(j, idx)), a.link_radius + b.link_radius, self.need)
            if first and out.any():
                break
        return out

    def _differences_within(self, i: int, q: np.ndarray, shares: tuple[float, float, float], at_rest: bool = False) -> bool:
        """``q``'s finite differences on the grid -- velocity, acceleration, jerk -- within
        ``shares`` of arm ``i``'s limits (``at_rest``: the arm at rest before and after ``q``)."""
        if not np.all(np.isfinite(q)):
            return False
        arm = self.problem.arms[i]
        if at_rest:
            q = np.vstack([q[:1], q[:1], q, q[-1:], q[-1:]])
        for k, (lim, share) in enumerate(zip((arm.max_velocity, arm.max_acceleration, arm.max_jerk), shares), start=1):
            if np.any(np.abs(np.diff(q, n=k, axis=0)) / self.dt ** k > share * np.asarray(lim)):
                return False
        return True

    def _within_limits(self, i: int, q: np.ndarray) -> bool:
        lim = self.problem.arms[i].limits
        return bool(np.all(np.isfinite(q)) and np.all(q >= lim[:, 0] - 1e-9) and np.all(q <= lim[:, 1] + 1e-9))

    # ------------------------------------------------------------------ cycles
    def plan_cycle(self, i: int, fid: str, w: Window, t_from: float, tuck: bool = False) -> Cycle | None:
        """The earliest clear cycle of arm ``i`` on ``fid`` in window ``w`` starting at rest at
        ``t_from`` or later (None when none fits the window).

        The tries come in turn from :meth:`_tries`. Each try's approach (its move to the fruit)
        is checked against the neighbours before the rest of its cycle is built: where a
        neighbour is in the way the approach is nearly always where it meets it, and a hit there
        is a hit of the whole cycle (the same samples of the same motion, each sample's test its
        own), so the answer is the same as building every cycle whole. The approaches of the
        next tries are checked together, more at a time as they fail.

        ``tuck``: the same tries with the way to the fruit and back tucked instead
        (:func:`coplan.row.track.tucked_route`: the elbow folded to one side, then to the other)
        -- slower, but while its shoulder turns the arm reaches no farther than its elbow:
        :func:`coplan.row.policy.run_policy`'s last try on a fruit with the carriage at rest for good."""
        for side in ((1, -1) if tuck else (0,)):
            cyc = self._first_clear(i, fid, w, t_from, side)
            if cyc is not None:
                return cyc
        return None

    def _first_clear(self, i: int, fid: str, w: Window, t_from: float, tuck: int) -> Cycle | None:
        """:meth:`plan_cycle`, each try's ways tucked to side ``tuck`` (0: direct)."""
        st = self.arms[i]
        k0 = st.k_free
        q0 = st.q[k0].copy()
        tries = self._tries(i, fid, w, k0, q0, max(k0, self.up(t_from)), tuck)
        batch = 1
        while True:
            todo = list(itertools.islice(tries, batch))
            if not todo:
                return None
            batch *= 4
            approaches = [self._approach(k0, k_p, leg) for k_p, _, leg in todo]
            hit = self._approaches_hit(i, approaches)
            for (k_p, b, leg), (k_a, approach), h in zip(todo, approaches, hit):
                if h:
                    continue
                cyc = self._assemble(i, fid, k0, q0, k_p, b, leg, self.bin_q[i], approach, tuck)
                if cyc is not None and self._clear(i, k0, cyc.q, known=(k_a, k_a + approach.shape[0])):
                    cyc.tucked = bool(tuck)
                    return cyc

    def _tries(self, i: int, fid: str, w: Window, k0: int, q0: np.ndarray, k_from: int, tuck: int = 0):
        """Arm ``i``'s tries on ``fid`` from rest at ``q0`` (sample ``k0``), in turn: ``(k_p, b,
        leg)``, a pick at sample ``k_p`` on elbow branch ``b`` reached by ``leg``. The earliest
        pick in the window that the arm can reach from ``k_from`` (the arrival time and where the
        fruit is then found by fixed-point rounds), its quicker branch first, then the other if it
        arrives in time (it may go round what is in the way); then later, by steps that grow (a
        neighbour in the way for long is not probed every 0.1 s), up to ``PATIENCE`` of waiting.
        ``tuck`` (+1 or -1): each way to the fruit tucked to that side (:func:`coplan.row.track.tucked_route`)."""
        arm = self.problem.arms[i]
        rest = np.array([q0, np.zeros(2), np.zeros(2)])
        xy = self.fruit_xy[fid]
        t_p = max(w.lo, k_from * self.dt)
        t_last = min(w.hi, k_from * self.dt + PATIENCE)
        retry = RETRY
        while True:
            k_p = self.up(t_p)
            for _ in range(_TRIES):
                t_p = k_p * self.dt
                if t_p > t_last + 1e-9:
                    return
                c0, c1 = self.cruise.state_one(t_p)[0], self.cruise.state_one(t_p + self._dwells(fid)[0] * self.dt)[0]
                brs = self.branches(i, fid, c0, c1)
                if not brs:
                    k_p += max(1, self.up(RETRY))
                    continue
                legs = []
                for b in brs:
                    target = track_state(arm, xy, self.cruise, t_p, b)
                    try:
                        legs.append((b, way(arm, rest, target, tuck, self.leg_share)))
                    except LegError:
                        continue
                if not legs:
                    k_p += max(1, self.up(RETRY))
                    continue
                b, leg1 = min(legs, key=lambda bl: bl[1].duration)
                if t_p - leg1.duration >= k_from * self.dt - 1e-9:
                    break
                k_p = max(k_p + 1, self.up(k_from * self.dt + leg1.duration))
            else:
                return
            yield k_p, b, leg1
            for b2, leg2 in legs:
                if b2 != b and k_p * self.dt - leg2.duration >= k_from * self.dt - 1e-9:
                    yield k_p, b2, leg2
            t_p = k_p * self.dt + retry
            retry *= RETRY_GROWTH

    def _approaches_hit(self, i: int, approaches: list[tuple[int, np.ndarray]]) -> list[bool]:
        """For each ``(first sample, poses)`` of :meth:`_approach`, whether arm ``i`` comes within
        ``need`` of a neighbour on the way (:meth:`_hits_at`, all in one evaluation)."""
        sizes = [q.shape[0] for _, q in approaches]
        if not any(sizes):
            return [False] * len(approaches)
        idx = np.concatenate([np.arange(k, k + m) for (k, _), m in zip(approaches, sizes)])
        hit = self._hits_at(i, idx, np.concatenate([q for _, q in approaches]))
        ends = np.cumsum(sizes)
        return [bool(hit[e - m:e].any()) for e, m in zip(ends, sizes)]

    def _approach(self, k0: int, k_p: int, leg1: Leg) -> tuple[int, np.ndarray]:
        """``(first sample, (m, 2) poses)``: the samples from ``k0`` on at which a cycle that
        picks at sample ``k_p`` is on its way there by ``leg1`` (as :meth:`_assemble` samples them)."""
        t_p = k_p * self.dt
        s1 = t_p - leg1.duration
        ts = np.arange(k0, k_p + 1) * self.dt  # (the first samples of :meth:`_assemble`'s grid)
        mv = (ts < t_p - 1e-9) & ~(ts < s1)
        on = np.flatnonzero(mv)
        if on.size == 0:
            return k_p, np.empty((0, 2))
        return k0 + int(on[0]), leg1.sample(ts[mv] - s1)

    def _dwells(self, fid: str) -> tuple[int, int]:
        """Samples of the pick and the place dwell of a cycle on ``fid`` (none for a probe)."""
        return (0, 0) if fid in self.probes else (self.n_pick, self.n_place)

    def _assemble(self, i: int, fid: str, k0: int, q0: np.ndarray, k_p: int, b: int, leg1: Leg, qb: np.ndarray,
                  approach: np.ndarray | None = None, tuck: int = 0) -> Cycle | None:
        """The cycle of a try (:meth:`plan_cycle`), or None where it leaves the limits; ``tuck``
        (+1 or -1): its way back folds the elbow to that side (:func:`coplan.row.track.tucked_route`;
        its way there, ``leg1``, is :meth:`_tries`')."""
        arm = self.problem.arms[i]
        dt = self.dt
        n_pick, n_place = self._dwells(fid)
        xy = self.fruit_xy[fid]
        t_p = k_p * dt
        t_pe = (k_p + n_pick) * dt
        if fid in self.probes and self.probe_rests and t_p >= self.cruise.duration:  # (the carriage at rest for good)
            return self._probe_stays(i, fid, k0, q0, k_p, leg1)
        end_state = track_state(arm, xy, self.cruise, t_pe, b)
        try:
            leg2 = way(arm, end_state, np.array([qb, np.zeros(2), np.zeros(2)]), tuck, self.leg_share)
        except LegError:
            return None
        k_pl = self.up(t_pe + leg2.duration)
        k_end = k_pl + n_place
        ts = np.arange(k0, k_end + 1) * dt
        q = np.empty((ts.size, 2))
        s1 = t_p - leg1.duration
        pre = ts < t_p - 1e-9
        wait = pre & (ts < s1)
        q[wait] = q0
        mv = pre & ~wait
        if mv.any():
            q[mv] = leg1.sample(ts[mv] - s1) if approach is None else approach
        pk = slice(k_p - k0, k_p + n_pick - k0 + 1)
        qt = track(arm, xy, self.cruise, ts[pk], b)
        # IK gives principal angles: a pick that carries a joint across +-pi is continuous in
        # fact, and then beyond its limits (refused below), never a jump of 2 pi
        q[pk] = np.unwrap(qt, axis=0) if np.all(np.isfinite(qt)) else qt
        if not self._differences_within(i, q[pk], _TRACK_SHARES):
            return None
        back = slice(k_p + n_pick + 1 - k0, k_pl - k0)
        if back.stop > back.start:
            q[back] = leg2.sample(ts[back] - t_pe)
        q[k_pl - k0:] = qb
        if not self._within_limits(i, q) or not self._differences_within(i, q, self.cycle_shares, at_rest=True):
            return None
        ev = [] if fid in self.probes else [Event(arm.name, fid, EventKind.PICK, t_p, t_pe),
                                            Event(arm.name, fid, EventKind.PLACE, k_pl * dt, k_end * dt)]
        return Cycle(i, fid, k0, q, ev)

    def _probe_stays(self, i: int, fid: str, k0: int, q0: np.ndarray, k_p: int, leg1: Leg) -> Cycle | None:
        """A probe with the carriage at rest for good: the arm goes to the report, finds nothing
        and rests there (its gripper is empty: no way back to the bin); its next cycle starts
        from there, or it goes back to its bin if it has none (:func:`run_policy`)."""
        dt = self.dt
        ts = np.arange(k0, k_p + 1) * dt
        s1 = k_p * dt - leg1.duration
        q = np.where((ts < s1)[:, None], q0, leg1.sample(np.clip(ts - s1, 0.0, leg1.duration)))
        if not self._within_limits(i, q) or not self._differences_within(i, q, self.cycle_shares, at_rest=True):
            return None
        return Cycle(i, fid, k0, q, [])

    def moves_after_halt(self, i: int, k0: int, q: np.ndarray) -> bool:
        """Whether motion ``q`` of arm ``i`` (samples from ``k0``) starts at or after the arm's
        fault (:attr:`halted`): a cycle or move decided before the fault but starting after it
        (waiting for the carriage or a neighbour) is never made."""
        t_h = self.halted.get(i)
        if t_h is None:
            return False
        k_m = _leaves_rest(k0, q)
        return k_m is not None and k_m * self.dt >= t_h

    def commit(self, cyc: Cycle) -> None:
        st = self.arms[cyc.arm]
        k1 = cyc.k0 + cyc.q.shape[0]
        if k1 > st.q.shape[0]:
            grow = np.tile(st.q[-1], (max(k1, 2 * st.q.shape[0]) - st.q.shape[0], 1))
            st.q = np.vstack([st.q, grow])
        st.q[cyc.k0:k1] = cyc.q
        st.q[k1:] = cyc.q[-1]
        st.k_free = k1 - 1
        st.last = cyc
        if cyc.fruit:
            st.fruit.append(cyc.fruit)
            st.ends.append((k1 - 1) * self.dt)
            if cyc.tucked:
                self.tucked.append(cyc.fruit)
            self.work_end = max(self.work_end, (k1 - 1) * self.dt)
        self.events += cyc.events

    def unbook_unstarted(self, i: int, t: float) -> str | None:
        """Take back arm ``i``'s last cycle if it is the last thing the arm has booked and its
        motion starts after ``t`` (decided when the arm was last free, it waits at rest for the
        carriage or a neighbour): the arm rests where it is from ``t`` on and decides again. Not
        where that rest would come within ``need`` of a neighbour's booked motion (checked
        against its motion after this cycle began to move, not against this rest). Returns the
        fruit (or report) taken back, or None."""
        st = self.arms[i]
        cyc = st.last
        if cyc is None or not cyc.fruit or cyc.k0 + cyc.q.shape[0] - 1 != st.k_free:
            return None
        k_m = _leaves_rest(cyc.k0, cyc.q)
        k_cut = max(cyc.k0, self.up(t))
        if k_m is None or k_m <= k_cut:
            return None  # under way (or about to be): it is made
        rest = cyc.q[0]
        if not self._clear(i, k_cut, rest[None]):
            return None
        st.q[k_cut:] = rest
        st.k_free = k_cut
        st.last = None
        gone = {id(e) for e in cyc.events}
        self.events = [e for e in self.events if id(e) not in gone]
        st.fruit.remove(cyc.fruit)
        st.ends.pop()
        if cyc.tucked:
            self.tucked.remove(cyc.fruit)
        self.work_end = max((e for a in self.arms for e in a.ends), default=0.0)
        return cyc.fruit

    def wait(self, i: int, seconds: float) -> None:
        """Arm ``i`` rests where it is ``seconds`` longer."""
        st = self.arms[i]
        k1 = st.k_free + max(1, self.up(seconds))
        if k1 >= st.q.shape[0]:
            st.q = np.vstack([st.q, np.tile(st.q[-1], (max(k1 + 1, 2 * st.q.shape[0]) - st.q.shape[0], 1))])
        st.q[st.k_free:] = st.q[st.k_free]
        st.k_free = k1

    def at_home(self, i: int) -> bool:
        """Whether arm ``i`` rests at home (a locked arm: where it is parked) at the end of what it has booked."""
        return bool(np.allclose(self.arms[i].q[self.arms[i].k_free], self.rest_q[i], atol=1e-12))

    def rests_out(self, i: int) -> bool:
        """Whether arm ``i`` rests where a probe left it: neither at its bin nor home."""
        q = self.arms[i].q[self.arms[i].k_free]
        return not (self.at_home(i) or np.allclose(q, self.bin_q[i], atol=1e-12))

    def go_bin(self, i: int) -> bool:
        """Book arm ``i``'s move back to its bin (rest to rest), where a cycle would have ended."""
        return self._go(i, self.bin_q[i], 0.0)

    def go_home(self, i: int, not_before: float = 0.0) -> bool:
        """Book arm ``i``'s move home (rest to rest), the earliest clear start; False if none
        within a minute of waiting."""
        if self.at_home(i):
            self.arms[i].done = True
            return True
        if self.rests_out(i):
            self._go(i, self.bin_q[i], not_before)  # (from a probe's pose: by its bin, the way every cycle ends)
        if self._go(i, self.rest_q[i], not_before):
            self.arms[i].done = True
            return True
        return False

    def home_parked(self, halted=()) -> None:
        """Book each parked arm's way home (the problem's home is where every arm starts and
        ends) once every other arm's booked motion is over: the park move reversed, the others
        resting at home, where the arm left them at t = 0; an arm a fault stopped (``halted``)
        stays where it is."""
        for i, rest in enumerate(self.rest_q):
            home = np.asarray(self.problem.arms[i].home, float)
            if i in halted or np.allclose(rest, home, atol=1e-12):
                continue
            self._go(i, home, max(self.free_time(j) for j in range(len(self.arms))))

    def _go(self, i: int, target: np.ndarray, not_before: float) -> bool:
        """Book arm ``i``'s rest-to-rest move to ``target``, the earliest clear start; False if
        none within a minute of waiting.

        Each try is the wait at the arm's pose, the move, and the rest at ``target`` (as
        :meth:`_clear` checks it). Where the two resting poses come too close to a neighbour is
        found once, sample by sample up to where every neighbour's booking ends (past it they
        rest: the last sample's answer holds); each try then checks only its own move."""
        arm = self.problem.arms[i]
        st = self.arms[i]
        q0 = st.q[st.k_free].copy()
        leg = Leg(arm, np.array([q0, np.zeros(2), np.zeros(2)]), np.array([target, np.zeros(2), np.zeros(2)]), self.leg_share)
        k0 = st.k_free
        k_s = max(k0, self.up(not_before))
        n = self.up(leg.duration)
        reach = max([k0 + 1] + [self.arms[j].k_free + 1 for j in self.neighbours[i]])
        resting = {}  # pose -> (reach - k0 + 1,) its hits from k0 to reach
        step, tries = self.up(RETRY), int(60.0 / RETRY)
        moves: dict[int, tuple[np.ndarray, bool]] = {}  # start -> (the move, whether it comes too close)
        batch = 1
        for m in range(tries):
            if k_s not in moves:  # the next tries' moves, checked together (more at a time as they fail)
                starts = [k_s + b * step for b in range(min(batch, tries - m))]
                moves.update(self._moves_from(i, leg, n, target, starts))
                batch *= 4
            move, hit = moves.pop(k_s)
            if i in self.halted and self.moves_after_halt(i, k0, self._waited(q0, k_s - k0, move)):
                return False  # (its fault came first: it stays where it rests)
            if self._rest_hit(i, q0, k0, reach, resting, k0, k_s):
                return False  # (resting at q0 comes too close before this start: before any later start too)
            if not hit and not self._rest_hit(i, target, k0, reach, resting, k_s + n + 1, reach):
                self.commit(Cycle(i, "", k0, self._waited(q0, k_s - k0, move), []))
                return True
            k_s += step
        return False

    def _moves_from(self, i: int, leg: Leg, n: int, target: np.ndarray, starts: list[int]) -> dict[int, tuple[np.ndarray, bool]]:
        """Arm ``i``'s move ``leg`` sampled from each start sample in ``starts`` (``n + 1`` samples
        each, the last one ``target``), and whether it comes within ``need`` of a neighbour's
        booked motion: start -> (move (n + 1, 2), hit). Each move sampled and checked sample by
        sample as one start at a time would (:meth:`_hits_at`), in one evaluation."""
        t = np.concatenate([np.arange(k, k + n + 1) * self.dt - k * self.dt for k in starts])
        q = leg.sample(t).reshape(len(starts), n + 1, 2)
        q[:, -1] = target
        idx = np.concatenate([np.arange(k, k + n + 1) for k in starts])
        hit = self._hits_at(i, idx, q.reshape(-1, 2)).reshape(len(starts), n + 1).any(axis=1)
        return {k: (q[b], bool(hit[b])) for b, k in enumerate(starts)}

    @staticmethod
    def _waited(q0: np.ndarray, wait: int, move: np.ndarray) -> np.ndarray:
        """``wait`` samples at rest at ``q0``, then ``move``."""
        return np.concatenate([np.repeat(q0[None, :], wait, axis=0), move])

    def _rest_hit(self, i: int, pose: np.ndarray, k0: int, reach: int, memo: dict, a: int, b: int) -> bool:
        """Whether arm ``i`` resting at ``pose`` over samples ``[a, b)`` comes within ``need`` of a
        neighbour (:meth:`_go`: its hits from ``k0`` to ``reach`` found once, in ``memo``)."""
        if b <= a:
            return False
        key = pose.tobytes()
        if key not in memo:
            memo[key] = self._hits(i, k0, np.repeat(pose[None, :], reach - k0 + 1, axis=0))
        h = memo[key]
        lo, hi = a - k0, b - k0
        if lo >= h.size:
            return bool(h[-1])
        return bool(h[lo:hi].any()) or (hi > h.size and bool(h[-1]))


_PARKED: "weakref.WeakKeyDictionary[Problem, dict[float, dict]]" = weakref.WeakKeyDictionary()


def _leaves_rest(k0: int, q: np.ndarray) -> int | None:
    """The grid index of the last sample at rest before motion ``q`` (samples from ``k0``)
    first moves; None if it never moves."""
    moving = np.flatnonzero(np.abs(q - q[0]).max(axis=1) > 1e-12)
    return int(k0 + moving[0] - 1) if moving.size else None


def _parked(problem: Problem, need: float) -> dict:
    """:func:`coplan.row.park.park_poses`, once per problem and clearance (every booking of a
    speed search shares them)."""
    from .park import park_poses

    per = _PARKED.setdefault(problem, {})
    if need not in per:
        per[need] = park_poses(problem, need)
    return per[need]


def replace_reach_margin(problem: Problem) -> Problem:
    """The problem with no reach margin (a bin is not a fruit: only the annulus counts)."""
    from dataclasses import replace

    return replace(problem, task=replace(problem.task, reach_margin=0.0))
