"""A live row on the move: the carriage's motion changed as the row runs.

Entry point: :func:`run_on_the_move`, which :func:`coplan.row.live.run_live_row` calls on the
move. The row is booked in phases of ``CHECK`` s (:meth:`LiveRun.policy`), and the carriage's
motion (its :class:`~coplan.row.cruise.Cruise`) is changed at each fault that changes it -- an arm
stop: slower; the camera dark: a hold -- and, with ``hold_for_fruit``, held wherever a reported
fruit would otherwise pass every working arm unbooked (:meth:`OnTheMove.at_risk`): always once
every pick booked before is over, so that every booked cycle stays exact.
"""

from __future__ import annotations

import math

import numpy as np

from ..kinds import Choice
from .cruise import Cruise, ramp_time
from .liverun import LiveRun
from .sensing import FaultDraws

__all__ = ["run_on_the_move", "OnTheMove", "Change", "STOP_SLOWDOWN"]

#: After an arm stops, the carriage runs at this share of the working arms' share of its speed ...
STOP_SLOWDOWN = 0.5
#: ... and the check for fruit about to pass (``at_risk``) estimates each cycle's moves (out to
#: the fruit, back to the bin) this many times longer and lets a report hold the carriage this
#: many times as often: the neighbours now take the stopped arm's fruit, round it as an obstacle
#: and round each other. Over the fault benchmark's 50 rows on the move, 6 fruit a working arm
#: could still reach were missed without it and none with it; slowing the whole carriage to 0.2
#: instead also missed none, at 1.5 x the row time (median 2.97 x the fault-free offline plan's,
#: against 1.98-2.09 x).
STOPPED_CAUTION = 2
#: On the move, holding for fruit: the planner looks every CHECK s at the fruit whose windows close
#: within LOOK s; one no working arm is free to reach (REACH_TIME s) before its window closes holds the
#: carriage HOLD_PER_FRUIT s per such fruit, shared by the working arms, or SLACK longer than the
#: check found the latest of them late, or twice its last hold for the same fruit, if that is
#: longer (at least HOLD_MIN s, at most HOLD_MAX s; see REFUSED_SLACK below); a
#: report holds the carriage HOLDS_PER_REPORT times at most (a burst of false reports
#: costs some holds, not one per report and per look). Looking 30 s ahead with up to 6 holds a
#: report (was 8 s and 2): at the speed the offline search chooses, a 50-report false burst on
#: sparse_row (seeds 0-9) and course_row (0-6) and six_arm_row (0-1) left 62 fruit a working arm
#: could still reach, none now (the arms, busy to the limit at that speed, each left a fruit to
#: the next until the last one's window closed, the check seeing it only 8 s before); without
#: faults, course_row, six_arm_row and sparse_row (seeds 0-2) harvest 100 % of the offline
#: plan's fruit (99.0-100 % before), row time 0.95-1.01 x the offline plan's (0.95-0.99 x). 30 holds
#: (was 6): with an arm stopped at 0.25-0.3 m/s (8 m rows, 6-10 fruit/m, seeds 0-7; course_row) the
#: working arms' backlog outlasted six and passed 5 fruit they could reach; none now but one no clear cycle serves.
#: A hold is decided once the one before it is over (``held_until``), so HOLD_MAX bounds each
#: rest: 20 s (was 6 s, when every check until a hold began queued another behind it -- 40 at one
#: instant with a 200-report burst on six_arm_row at 0.164 m/s, seed 4, the carriage stopping 64
#: more times after the last fruit was placed: 746 s row, 3 fruit a working arm could reach passed;
#: one at a time with 6 s holds: 418 s, 8 passed; with 20 s: 647 s, none passed; 60 s: 632 s, none).
CHECK, LOOK, REACH_TIME, HOLD_PER_FRUIT, HOLD_MIN, HOLD_MAX, HOLDS_PER_REPORT = 0.5, 30.0, 1.5, 3.0, 1.5, 20.0, 30
#: ... and a fruit whose estimated pick would start less than SLACK s before its window closes is
#: at risk too: the estimate is no bound, and by the time it proves wrong the carriage can no
#: longer brake in time (course_row at 0.114 m/s, seed 2, with moves at 95 % of the joint limits:
#: f0170 fitted arm1 by 0.12 s from t = 252 s on; arm1, free at 256.1 s, could not make it, and
#: the carriage, braking, would have come to rest after its window closed -- missed, no hold).
SLACK = 0.5
#: Where the arms stand close, a neighbour's booked motion may leave no clear cycle for a fruit the
#: estimate fits: a fruit some arm's try has found so (``LiveRun.refused``) counts as at risk unless
#: it fits SLACK x REFUSED_SLACK s before its window closes; and a hold lasts SLACK longer than the
#: check found the fruit late, and twice as long as the last one for the same fruit (1.5, 3, 6 s,
#: ...). Twelve live runs (10 m rows, three arms 1.2 m apart, 6 fruit/m, row seeds 0-5 x camera
#: seeds 0-1, ``--speed auto``): 4 fruit a working arm could reach passed in 4 runs before, none
#: now; 716 -> 720 fruit; row time 0.993-1.212 x (median 1.071) -> 1.000-1.177 x (median 1.080) the
#: offline plan's (a hold just long enough left the fruit at risk again, seconds before its window
#: closed, when the only arm left to take it found its way blocked: too late to hold).
REFUSED_SLACK = 2.0


class Change(Choice):
    """What changes the carriage's motion on the move, live: an arm that stops (the carriage
    slows), the camera going dark (it holds), a fruit about to pass every working arm (it holds)."""

    ARM_STOP = "arm_stop"
    CAMERA_DARK = "camera_dark"
    FRUIT = "fruit"


def _take_back_unstarted(run: LiveRun, halt: dict[int, float], t: float) -> list[str]:
    """The working arms' cycles decided before ``t`` and not yet under way, taken back
    (:meth:`~coplan.row.booking.Booker.unbook_unstarted`) to be decided again: at an arm stop the
    carriage then slows at once, not after their picks, and they decide on the slower motion (a
    fruit the stopped arm was to pick, whose window for a neighbour was closing, passed it: a
    12 m row at 0.186 m/s, seed 6, lost two). Returns their fruit (reports), sorted."""
    back = [f for i in range(len(run.problem.arms)) if i not in halt or halt[i] > t
            for f in [run.booker.unbook_unstarted(i, t)] if f is not None]
    run.taken.difference_update(back)
    return sorted(back)


def run_on_the_move(run: LiveRun, faults: FaultDraws, cruise: Cruise) -> dict[str, str]:
    """Run ``run`` on the move from the carriage's motion ``cruise`` (see the module docstring);
    returns the reports left unharvested, each with why (the booking's last word)."""
    return OnTheMove(run, faults, cruise).run()


class OnTheMove:
    """One live row on the move: the run, its faults, the carriage's motion as decided so far
    (``cruise``, from its ``stretches``) and the holds for fruit made."""

    def __init__(self, run: LiveRun, faults: FaultDraws, cruise: Cruise):
        self.live, self.faults, self.cruise = run, faults, cruise
        self.problem, self.opts, self.g = run.problem, run.opts, run.problem.gantry
        self.halt, self.delay = faults.halt, faults.delay
        self.changes = sorted([(t, Change.ARM_STOP) for t in self.halt.values()]
                              + ([(faults.dark[0], Change.CAMERA_DARK)] if faults.dark else []))
        self.stretches: list[tuple] = [(math.inf, self.opts.speed)]
        self.n = len(self.problem.arms)
        self.holds: list[dict] = []
        self.held_for: dict[str, int] = {}  # report -> holds the carriage made for it
        self.short: dict[str, float] = {}  # report at risk -> how late its estimated pick is for its window, s
        self.first = cruise.leaves_start if math.isfinite(cruise.leaves_start) else 0.0  # (a rest where it starts, kept by every change)
        # the end of the last hold for fruit decided: no other is decided before it (each check until
        # then saw the same fruit at risk and queued one more hold behind it -- 40 holds decided at
        # one instant on six_arm_row with a 200-report burst, the carriage still holding 300 s after
        # the last fruit was placed); after it the check looks again, on the windows the hold opened
        self.held_until = -math.inf

    def run(self) -> dict[str, str]:
        """Book the row phase by phase, changing the carriage's motion where a fault or a fruit at
        risk asks; the reports left, each with why."""
        run, opts = self.live, self.opts
        wait_on = self.wait_on if opts.hold_for_fruit else None
        t_c = 0.0
        while True:
            t_next = min([t_c + CHECK if opts.hold_for_fruit else math.inf] + [t for t, _ in self.changes[:1]])
            if t_next >= self.cruise.duration:
                break  # coming to rest for good: nothing more to change
            run.policy(halt=self.halt, delay=self.delay, until=t_next, explain=False, wait_on=wait_on)
            t_c = t_next
            while self.changes and self.changes[0][0] <= t_c:
                self.change(self.changes.pop(0)[1], t_c)
            if opts.hold_for_fruit and t_c >= self.held_until:
                risk = self.at_risk(t_c)
                if risk:
                    self.change(Change.FRUIT, t_c, risk)
        run.holds = self.holds
        return run.policy(halt=self.halt, delay=self.delay)

    def _slower(self) -> float:
        """The carriage's speed once arms have stopped: ``STOP_SLOWDOWN`` of the working arms' share."""
        return self.opts.speed * STOP_SLOWDOWN * (self.n - len(self.halt)) / self.n

    def slow_at_once(self, t_s: float) -> bool:
        """After an arm stop, the carriage at rest at ``t_s`` (where it starts, or in a hold) or on
        its way down to it leaves at the slower speed (it went up to its cruising speed first, then
        slowed: ``--arm-stop --camera-dark 3``, sparse_row at 0.3 m/s, seed 4, an arm stopped 9 s
        into a 20 s hold and the carriage reached 0.3 m/s before it slowed to 0.1): the motion up to
        ``t_s`` is kept exactly, only what follows the rest changes. False where that would change
        the motion before ``t_s`` (the carriage cruising or on its way up: the change then begins
        at cruising speed, as any other)."""
        slow = self._slower()
        if slow <= 0 or t_s >= self.cruise.duration:
            return False
        wanted = self.stretches[:-1] + [(math.inf, slow)]
        new = Cruise.shaped(self.problem, wanted, self.g.end, self.first)
        ts = np.append(np.linspace(0.0, t_s, 2001), t_s)
        if any(float(np.max(np.abs(a - b))) > 1e-9 for a, b in zip(new.state(ts), self.cruise.state(ts))):
            return False
        self.stretches, self.cruise = wanted, new
        self.faults.log["arm_stop"].update({"carriage_at_rest_at": round(t_s, 3), "to_speed": round(slow, 6)})
        self.live.set_cruise(new, since=t_s)
        return True

    def change(self, kind: Change, t_c: float, risk: list[tuple[str, float]] | None = None) -> None:
        """Change the carriage's motion at ``t_c`` for ``kind`` (``risk``: the fruit at risk, with
        when their windows close), from the first instant it cruises after every booked pick."""
        run, g, halt, log = self.live, self.g, self.halt, self.faults.log
        if kind == Change.ARM_STOP and (back := _take_back_unstarted(run, halt, t_c)):
            log["arm_stop"]["decided_again"] = back
        t_s = max([t_c] + run.pick_ends())
        v = self.stretches[-1][1]
        if kind == Change.ARM_STOP and self.slow_at_once(t_s):
            return
        # a change begins at cruising speed: past any ramp or hold under way (or the carriage is stopping anyway)
        while t_s < self.cruise.duration and abs(float(self.cruise.state(np.array([t_s]))[1][0]) - v) > 1e-9:
            t_s += run.booker.dt
        x_s = float(self.cruise.x(np.array([t_s]))[0])
        if x_s >= self.cruise.x1 - 1e-6 or t_s >= self.cruise.duration:
            return
        stop = ramp_time(v, 0.0, g.max_acceleration, g.max_jerk)
        if kind == Change.ARM_STOP:
            slow = self._slower()
            if slow <= 0:
                return
            self.stretches = self.stretches[:-1] + [(x_s, v), (math.inf, slow)]
            log["arm_stop"].update({"carriage_slows_at": round(t_s, 3), "to_speed": round(slow, 6)})
        elif kind == Change.CAMERA_DARK:
            dark = self.faults.dark
            hold = dark[0] + dark[1] - (t_s + stop)
            if hold <= 0:
                log["camera_dark"].update(carriage="kept moving: the camera was back before it could come to rest",
                                          hold_seconds=0.0)  # (the outage's cost, as stop and go says it: none)
                return
            self.stretches = self.stretches[:-1] + [(x_s, v, hold), (math.inf, v)]
            log["camera_dark"].update({"carriage_holds_from": round(t_s, 3), "hold_seconds": round(hold, 3)})
        else:  # fruit about to pass every working arm unbooked
            if t_s + stop >= max(hi for _, hi in risk):
                return  # too late to help any of them
            working = self.n - sum(1 for t in halt.values() if t <= t_c)
            # (at least as long as the check found the latest of them late: with an arm stopped, 1.5-3 s
            # holds for a backlog of several seconds left the fruit at risk each time until a hold came too late)
            hold = min(HOLD_MAX, max(HOLD_MIN, HOLD_PER_FRUIT * len(risk) / max(working, 1),
                                     max(self.short.get(f, 0.0) + SLACK for f, _ in risk),
                                     max(HOLD_MIN * 2.0 ** self.held_for.get(f, 0) for f, _ in risk)))
            for f, _ in risk:
                self.held_for[f] = self.held_for.get(f, 0) + 1
            self.stretches = self.stretches[:-1] + [(x_s, v, hold), (math.inf, v)]
            self.held_until = t_s + stop + hold
            self.holds.append({"t": round(t_s, 3), "x": round(x_s, 4), "seconds": round(hold, 3), "for": [f for f, _ in risk]})
        new = Cruise.shaped(self.problem, self.stretches, g.end, self.first)
        ts = np.linspace(0.0, t_s, 2001)
        if float(np.max(np.abs(new.x(ts) - self.cruise.x(ts)))) > 1e-9:  # never: the change begins after t_s
            raise RuntimeError(f"the carriage's motion changed before t = {t_s:.2f} s")
        self.cruise = new
        run.set_cruise(new, since=t_s)

    def open_windows(self, f: str, t: float) -> list:
        """Report ``f``'s pick windows still open at ``t``; a window at rest whose twin has a
        deadline (:meth:`LiveRun.rail_end`) left out: the deadline counts."""
        run = self.live
        return [w for w in run.booker.windows.get(f, []) if w.hi >= t and not (math.isinf(w.hi) and (f, w.arm) in run.deadlined)]

    def at_risk(self, t_c: float) -> list[tuple[str, float]]:
        """Reported fruit not taken whose working arms' windows all close within ``LOOK`` s and
        that an earliest-deadline-first schedule of them over those arms, from when each is
        free, with every cycle estimated at ``REACH_TIME`` out and ``REACH_TIME`` plus both
        dwells back (the moves ``STOPPED_CAUTION`` times longer once an arm has stopped), cannot fit
        ``SLACK`` s before their windows close."""
        run, halt, n = self.live, self.halt, self.n
        working = {a for a in range(n) if a not in halt or halt[a] > t_c}
        avail = {a: max(t_c, run.booker.free_time(a)) for a in working}
        caution = STOPPED_CAUTION if len(working) < n else 1  # an arm stopped: its neighbours round an obstacle
        reach_time = REACH_TIME * caution
        back = reach_time + self.problem.task.pick_dwell + self.problem.task.place_dwell
        soon = []
        for f in run.booker.windows:
            if f in run.taken or run.seen[f] > t_c:
                continue
            wk = [w for w in self.open_windows(f, t_c) if w.arm in working]
            if wk and max(w.hi for w in wk) <= t_c + LOOK:
                soon.append((max(w.hi for w in wk), f, wk))
        out = []
        # a report that has held the carriage as often as it may holds it no more, but its arm's
        # time is still its (left out of the schedule, the fruit after it seemed to fit: course_row
        # at 0.3 m/s with an arm stopped lost one a working arm could still reach)
        # (an arm whose try on the fruit found no clear cycle in its window, on the carriage's
        # motion as now decided, is not counted on for it: its neighbours' booked motion is in the way)
        blocked = {ff for ff, _ in run.refused}  # (fruit an arm's try found no clear cycle for: the estimate trusted less)
        for hi, f, wk in sorted(soon, key=lambda s: (s[0], s[1])):
            est = [(max(avail[w.arm], w.lo - reach_time) + reach_time, w) for w in wk if (f, w.arm) not in run.refused]
            slack = SLACK * (REFUSED_SLACK if f in blocked else 1.0)
            starts = [(t_p, w.arm) for t_p, w in est if t_p <= w.hi - slack]
            if starts:
                t_p, a = min(starts)
                avail[a] = t_p + back
            elif self.held_for.get(f, 0) < HOLDS_PER_REPORT * caution:
                out.append((f, hi))
                self.short[f] = min((t_p - (w.hi - slack) for t_p, w in est), default=0.0)
        return out

    def wait_on(self, i: int, f: str, now: float) -> float:
        """Seconds arm ``i`` waits for the next check, rather than book another fruit, where its
        try on ``f`` found no clear cycle and no other working arm may still take ``f``: a cycle
        booked on another fruit would put the hold that could save ``f`` off until its pick is
        over, past ``f``'s window (a 10 m row, arms 1.2 m apart, seed 0: two fruit passed so) --
        once per arm, fruit and carriage motion, while ``f`` may still hold the carriage."""
        run, halt = self.live, self.halt
        caution = STOPPED_CAUTION if any(t <= now for t in halt.values()) else 1
        if (f, i) in run.waited or self.held_for.get(f, 0) >= HOLDS_PER_REPORT * caution:
            return 0.0
        ws = self.open_windows(f, now)
        if any(math.isinf(w.hi) for w in ws if w.arm == i) or any(
                w.arm != i and (w.arm not in halt or halt[w.arm] > now) and (f, w.arm) not in run.refused for w in ws):
            return 0.0  # (open at the rail's end, where the carriage comes to rest; or another arm may take it)
        run.waited.add((f, i))
        return CHECK
