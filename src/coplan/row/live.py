"""A live row: the camera sees only a stretch ahead, the row is planned as fruit come into view.

Entry point: :func:`run_live_row` -> :class:`LiveRow`, in either gantry mode.

* **The camera** (:func:`row_reports`, seeded): a fruit is reported when the carriage brings it
  within ``look_ahead`` m ahead of the front arm's base, at its true position plus Gaussian
  noise (``sigma`` per coordinate); a share ``false_rate`` of extra reports are false (no fruit
  there, anywhere in the fruit's band of the row), a share ``duplicate_rate`` of fruit are
  reported twice (a second, independently noisy report half a second later). When each report
  is made follows from the carriage's motion as it is decided (:func:`report_times`).
* **Planning as fruit come into view** -- each decision (an arm free, at rest, choosing its next
  fruit: :func:`coplan.row.policy.run_policy`) sees only the reports made by then (reports
  within ``merge`` of an earlier one may be taken for the same fruit; off by default: a second
  report of a picked fruit costs a probe instead); as the arm approaches, its close-range sensor
  measures the fruit (``close_sigma``) and the cycle is planned on that measurement. A false
  report costs a probe: the arm goes there, finds nothing at close range, and returns without
  dwelling (its cycle carries no events; stop and go, it goes on from there: below); so does a
  second report of a fruit already taken. A
  grasp aimed farther than the pick tolerance from the true fruit (a close-range error of
  several sigma) closes on nothing: the cycle is executed, the fruit stays and is reported missed.
* **On the move** (``mode=continuous``): the carriage cruises at a constant ``speed`` (a live
  planner cannot shape its speed to fruit it has not seen), and holds rather than pass a
  reported fruit no working arm can still book (``hold_for_fruit``: every ``CHECK`` s, an
  earliest-deadline-first schedule of the fruit whose windows close soon, at estimated cycles).
* **Stop and go** (``mode=stop-and-go``): the carriage stops (the first stop and every next one
  as far as it can go: no farther than the first place where a fruit reported and not taken
  would leave every arm's reach, nor than puts the rear arm's base under the edge of what the
  camera has seen, so it passes no fruit unseen); the arms pick, with the carriage at rest, the
  fruit the next stop could not serve and those it shares with the next stop where they
  lengthen the two stops least (:func:`coplan.row.livestops.stop_share`), each arm's balanced;
  once the last pick is over the carriage hops -- a time-optimal jerk-limited move -- while the
  arms place. Once the next stop may be the rail's end, seen from a stop that has not seen that
  far, the next stop is the one, of those from which the camera sees to the rail's end, that
  with this stop serves what is known in the least estimated time, the stretch not seen yet
  priced as the one before it (:func:`coplan.row.livestops.next_to_last`). Once the camera has
  seen to the row's end (``gantry.end``), the hop goes to the one stop that serves the rest in
  the least estimated time (:func:`coplan.row.livestops.last_stop`), not the farthest, where
  the arms beyond the last fruit would idle, and that stop takes it all; the carriage goes on
  to the rail's end to look further only if the camera has reported fruit past it. A
  probe (a false report, or a second report of a fruit taken) ends where the arm finds nothing:
  its gripper is empty, so it goes on to its next fruit from there, not by its bin. An arm
  that stops during a hop changes it: from the carriage's state then, it brakes to the nearest
  stop the working arms need (:func:`coplan.row.cruise.stop_from`), never back along the rail.
* **Verified against the truth**: the executed motion is one ordinary row plan whose events
  name the true fruit, verified by :func:`coplan.verify.verify` against the true problem.
* **Reference**: the offline plan with full knowledge (every true fruit at its true position
  from t = 0) in the same mode -- on the move at the same speed, or the stop-and-go row
  planner (:func:`coplan.row.plan.plan_row`, optimised stops); the live row's harvest and row
  time are reported against it.
* **Real time**: the wall time of every decision, against the time the arm spends on the
  motion committed before it (its previous cycle): a decision made while the arm is still busy
  is never late.
"""

from __future__ import annotations

import math
import re
import time as _time
from collections import OrderedDict
from dataclasses import dataclass, field

import numpy as np

from ..kinds import Choice, GantryMode, PlanStatus, SpeedProfile
from ..plan import Event, EventKind, finalize_plan
from ..errors import Issue, OptionsError
from ..problem.model import Problem
from ..problem.plausible import live_rail_issue, live_speed_issue
from ..allocate.row_bound import row_bounds
from .continuous import MovingOptions, assemble_moving
from .moving import plan_moving
from .cruise import Cruise, ramp_time
from .liverun import LiveRun
from .livestops import dark_hold
from .reach import row_reach
from .starthold import reports_start_hold
from .stopgo import stop_and_go
from .sensing import (FaultDraws, LiveRowOptions, RowDetection, RowFaults, RowReport, check_fault_room, report_times,
                      row_detections, row_reports)
from .stranded import still_reachable

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

# the camera and the faults live in .sensing; re-exported here, where a live row is run
__all__ = ["LiveRowOptions", "RowFaults", "RowDetection", "LiveRow", "row_reports", "report_times", "row_detections",
           "run_live_row"]


@dataclass
class LiveRow:
    """What :func:`run_live_row` returns: the executed plan, its verification against the truth,
    the offline plan it is measured against, the camera's reports, each fruit's outcome, the metrics."""

    plan: object
    verification: object
    offline: object  # the offline plan's RowResult
    detections: list[RowDetection]
    outcome: dict[str, str]  # true fruit id -> harvested | missed (why)
    metrics: dict = field(default_factory=dict)


def run_live_row(problem: Problem | str, options: LiveRowOptions | None = None, progress=None) -> LiveRow:
    """Run the row live and verify what was executed against the truth (the module docstring says
    how: the camera's reports, the decisions, the faults).

    ``problem``: a row (a :class:`Problem` with a gantry), its file's path or a shipped row's name,
    or a row as a mapping (``coplan.generate.gantry_row(...)``), as :func:`coplan.solve` takes it.
    ``options``: :class:`LiveRowOptions` (the mode, the speed on the move, the camera, the faults).
    Returns a :class:`LiveRow`: ``plan`` (the executed plan on the true fruit), ``verification``
    (against the truth), ``offline`` (the plan with every fruit known, in the same mode, that the
    run is measured against), ``detections`` (the camera's reports as made), ``outcome`` (what
    became of each fruit and report) and ``metrics`` (harvest, row time and its ratio to the
    offline plan's, decisions, faults; ``plan.solver['live']`` holds the same)."""
    from ..problem.given import as_problem

    # (a path gave "'str' object has no attribute 'gantry'"; a mapping, a TypeError)
    problem = as_problem(problem, lambda p: f"problem: expected a row Problem, the path of its file or a row as a "
                                            f"mapping, found {type(p).__name__}")
    if problem.gantry is None:
        raise ValueError(f"{problem.name!r} has no gantry: a live row needs a row")
    if options is not None and not isinstance(options, LiveRowOptions):
        raise TypeError(f"options: a live row takes LiveRowOptions(...), found {type(options).__name__} {options!r}")
    opts = options or LiveRowOptions()
    mode = GantryMode(opts.mode)  # (LiveRowOptions refuses auto when built)
    g = problem.gantry
    too_long = live_rail_issue(problem, mode == GantryMode.STOP_AND_GO, opts.look_ahead)
    if too_long:  # (before any work)
        raise ValueError(f"{problem.name!r}: {too_long}")
    reports = row_reports(problem, opts)
    if mode == GantryMode.CONTINUOUS:
        bad = live_speed_issue(problem, opts.speed)
        if bad:  # (before any work)
            raise OptionsError([Issue("speed", bad)], "LiveRowOptions")
        # (the offline plan at this speed rests where it starts first if fruit only the start serves
        # need it; it is `coplan solve ROW --gantry continuous --speed V`'s plan: CP-SAT's order where
        # the greedy's leaves fruit -- the live booking's own greedy, every fruit known, is not the
        # best offline plan at this speed: on sparse_row at 0.361 m/s it harvests 92 of 93)
        offline = offline_reference(problem, MovingOptions(profile=SpeedProfile.CONSTANT, level=opts.speed,
                                                           margin=opts.margin), progress)
        # the carriage does not know where the last fruit is: it cruises to the end of the rail --
        # after a rest where it starts, as long as the reports then in view that only the start serves need
        if offline.plan.status == PlanStatus.INTERRUPTED:
            raise KeyboardInterrupt
        cruise = Cruise.of(problem, opts.speed, g.end)
        cruise = Cruise.of(problem, opts.speed, g.end, reports_start_hold(problem, reports, cruise))
        check_fault_room(problem, opts, max(cruise.duration, float(offline.plan.time[-1])), STOP_SLOWDOWN)
        faults = FaultDraws(problem, opts, cruise.duration, cruise, offline.reach.locked)
        run = LiveRun(problem, opts, reports + faults.burst, cruise, faults.dark)
        t0 = _time.perf_counter()
        left, cruise, stops = _on_the_move(run, faults, cruise), run.booker.cruise, None
    else:
        from .plan import RowOptions

        offline = offline_reference(problem, RowOptions(), progress)
        if offline.plan.status == PlanStatus.INTERRUPTED:  # (Ctrl-C while the reference was planned)
            raise KeyboardInterrupt
        check_fault_room(problem, opts, float(offline.plan.time[-1]), STOP_SLOWDOWN)
        faults = FaultDraws(problem, opts, float(offline.plan.metrics.get("makespan") or 0.0), None, offline.reach.locked)
        run = LiveRun(problem, opts, reports, Cruise.hops(problem, []), faults.dark)
        t0 = _time.perf_counter()
        left, stops = stop_and_go(run, faults)
        cruise = run.booker.cruise
    planning = _time.perf_counter() - t0
    return _finish(problem, opts, run, faults, left, cruise, offline, planning, stops)


#: The offline references planned last in this process (:func:`offline_reference`), newest last.
_REFERENCES: "OrderedDict[tuple[Problem, object], object]" = OrderedDict()
REFERENCES_KEPT = 4


def offline_reference(problem: Problem, options, progress=None):
    """The offline plan a live row is measured against: ``plan_row(problem, options)`` for a
    :class:`~coplan.row.plan.RowOptions`, ``plan_moving(problem, options)`` for a
    :class:`~coplan.row.continuous.MovingOptions`. It depends on the row and the options alone,
    not on the live run's seed, noise or faults: runs on one row in one process (seeds, fault
    draws, a notebook's loop) plan it once. The last ``REFERENCES_KEPT`` are kept, keyed by the
    problem and options themselves, as :func:`coplan.allocate.row_bound.row_bounds` remembers a
    row's bounds (a problem changed in any field but its file's digest is another row); each
    caller gets its own copy. An interrupted reference is not kept."""
    import copy

    from .plan import RowOptions, plan_row

    key = (problem, options)
    try:
        hash(key)
    except TypeError:  # (something in it that cannot be hashed: planned each time)
        key = None
    if key is not None and key in _REFERENCES:
        _REFERENCES.move_to_end(key)
        if progress is not None:
            progress("offline reference: the plan made for this row and options earlier in this process")
        return copy.deepcopy(_REFERENCES[key])
    ref = plan_row(problem, options, progress) if isinstance(options, RowOptions) else plan_moving(problem, options, progress)
    if key is not None and ref.plan.status != PlanStatus.INTERRUPTED:
        _REFERENCES[key] = copy.deepcopy(ref)
        while len(_REFERENCES) > REFERENCES_KEPT:
            _REFERENCES.popitem(last=False)
    return ref


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


def _on_the_move(run: LiveRun, faults: FaultDraws, cruise: Cruise) -> dict[str, str]:
    """The row on the move: booked in phases of ``CHECK`` s, the carriage's motion changed at each
    fault that changes it (an arm stop: slower; the camera dark: a hold) and, with
    ``hold_for_fruit``, held wherever a reported fruit would otherwise pass every working arm
    unbooked -- always once every pick booked before is over, so that every booked cycle stays
    exact."""
    problem, opts, g = run.problem, run.opts, run.problem.gantry
    halt, delay = faults.halt, faults.delay
    changes = sorted([(t, Change.ARM_STOP) for t in halt.values()] + ([(faults.dark[0], Change.CAMERA_DARK)] if faults.dark else []))
    stretches: list[tuple] = [(math.inf, opts.speed)]
    n = len(problem.arms)
    holds: list[dict] = []
    held_for: dict[str, int] = {}  # report -> holds the carriage made for it
    short: dict[str, float] = {}  # report at risk -> how late its estimated pick is for its window, s
    first = cruise.leaves_start if math.isfinite(cruise.leaves_start) else 0.0  # (a rest where it starts, kept by every change)
    # the end of the last hold for fruit decided: no other is decided before it (each check until
    # then saw the same fruit at risk and queued one more hold behind it -- 40 holds decided at
    # one instant on six_arm_row with a 200-report burst, the carriage still holding 300 s after
    # the last fruit was placed); after it the check looks again, on the windows the hold opened
    held_until = -math.inf

    def _slow_at_once(t_s: float) -> bool:
        """After an arm stop, the carriage at rest at ``t_s`` (where it starts, or in a hold) or on
        its way down to it leaves at the slower speed (it went up to its cruising speed first, then
        slowed: ``--arm-stop --camera-dark 3``, sparse_row at 0.3 m/s, seed 4, an arm stopped 9 s
        into a 20 s hold and the carriage reached 0.3 m/s before it slowed to 0.1): the motion up to
        ``t_s`` is kept exactly, only what follows the rest changes. False where that would change
        the motion before ``t_s`` (the carriage cruising or on its way up: the change then begins
        at cruising speed, as any other)."""
        nonlocal cruise, stretches
        slow = opts.speed * STOP_SLOWDOWN * (n - len(halt)) / n
        if slow <= 0 or t_s >= cruise.duration:
            return False
        wanted = stretches[:-1] + [(math.inf, slow)]
        new = Cruise.shaped(problem, wanted, g.end, first)
        ts = np.append(np.linspace(0.0, t_s, 2001), t_s)
        if any(float(np.max(np.abs(a - b))) > 1e-9 for a, b in zip(new.state(ts), cruise.state(ts))):
            return False
        stretches, cruise = wanted, new
        faults.log["arm_stop"].update({"carriage_at_rest_at": round(t_s, 3), "to_speed": round(slow, 6)})
        run.set_cruise(cruise, since=t_s)
        return True

    def change(kind: Change, t_c: float, risk: list[tuple[str, float]] | None = None) -> None:
        nonlocal cruise, stretches, held_until
        if kind == Change.ARM_STOP and (back := _take_back_unstarted(run, halt, t_c)):
            faults.log["arm_stop"]["decided_again"] = back
        t_s = max([t_c] + run.pick_ends())
        v = stretches[-1][1]
        if kind == Change.ARM_STOP and _slow_at_once(t_s):
            return
        # a change begins at cruising speed: past any ramp or hold under way (or the carriage is stopping anyway)
        while t_s < cruise.duration and abs(float(cruise.state(np.array([t_s]))[1][0]) - v) > 1e-9:
            t_s += run.booker.dt
        x_s = float(cruise.x(np.array([t_s]))[0])
        if x_s >= cruise.x1 - 1e-6 or t_s >= cruise.duration:
            return
        stop = ramp_time(v, 0.0, g.max_acceleration, g.max_jerk)
        if kind == Change.ARM_STOP:
            slow = opts.speed * STOP_SLOWDOWN * (n - len(halt)) / n
            if slow <= 0:
                return
            stretches = stretches[:-1] + [(x_s, v), (math.inf, slow)]
            faults.log["arm_stop"].update({"carriage_slows_at": round(t_s, 3), "to_speed": round(slow, 6)})
        elif kind == Change.CAMERA_DARK:
            hold = faults.dark[0] + faults.dark[1] - (t_s + stop)
            if hold <= 0:
                faults.log["camera_dark"].update(carriage="kept moving: the camera was back before it could come to rest",
                                                 hold_seconds=0.0)  # (the outage's cost, as stop and go says it: none)
                return
            stretches = stretches[:-1] + [(x_s, v, hold), (math.inf, v)]
            faults.log["camera_dark"].update({"carriage_holds_from": round(t_s, 3), "hold_seconds": round(hold, 3)})
        else:  # fruit about to pass every working arm unbooked
            if t_s + stop >= max(hi for _, hi in risk):
                return  # too late to help any of them
            working = n - sum(1 for t in halt.values() if t <= t_c)
            # (at least as long as the check found the latest of them late: with an arm stopped, 1.5-3 s
            # holds for a backlog of several seconds left the fruit at risk each time until a hold came too late)
            hold = min(HOLD_MAX, max(HOLD_MIN, HOLD_PER_FRUIT * len(risk) / max(working, 1),
                                     max(short.get(f, 0.0) + SLACK for f, _ in risk),
                                     max(HOLD_MIN * 2.0 ** held_for.get(f, 0) for f, _ in risk)))
            for f, _ in risk:
                held_for[f] = held_for.get(f, 0) + 1
            stretches = stretches[:-1] + [(x_s, v, hold), (math.inf, v)]
            held_until = t_s + stop + hold
            holds.append({"t": round(t_s, 3), "x": round(x_s, 4), "seconds": round(hold, 3), "for": [f for f, _ in risk]})
        new = Cruise.shaped(problem, stretches, g.end, first)
        ts = np.linspace(0.0, t_s, 2001)
        if float(np.max(np.abs(new.x(ts) - cruise.x(ts)))) > 1e-9:  # never: the change begins after t_s
            raise RuntimeError(f"the carriage's motion changed before t = {t_s:.2f} s")
        cruise = new
        run.set_cruise(cruise, since=t_s)

    def open_windows(f: str, t: float) -> list:
        """Report ``f``'s pick windows still open at ``t``; a window at rest whose twin has a
        deadline (:meth:`LiveRun.rail_end`) left out: the deadline counts."""
        return [w for w in run.booker.windows.get(f, []) if w.hi >= t and not (math.isinf(w.hi) and (f, w.arm) in run.deadlined)]

    def at_risk(t_c: float) -> list[tuple[str, float]]:
        """Reported fruit not taken whose working arms' windows all close within ``LOOK`` s and
        that an earliest-deadline-first schedule of them over those arms, from when each is
        free, with every cycle estimated at ``REACH_TIME`` out and ``REACH_TIME`` plus both
        dwells back (the moves ``STOPPED_CAUTION`` times longer once an arm has stopped), cannot fit
        ``SLACK`` s before their windows close."""
        working = {a for a in range(n) if a not in halt or halt[a] > t_c}
        avail = {a: max(t_c, run.booker.free_time(a)) for a in working}
        caution = STOPPED_CAUTION if len(working) < n else 1  # an arm stopped: its neighbours round an obstacle
        reach_time = REACH_TIME * caution
        back = reach_time + problem.task.pick_dwell + problem.task.place_dwell
        soon = []
        for f in run.booker.windows:
            if f in run.taken or run.seen[f] > t_c:
                continue
            wk = [w for w in open_windows(f, t_c) if w.arm in working]
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
            elif held_for.get(f, 0) < HOLDS_PER_REPORT * caution:
                out.append((f, hi))
                short[f] = min((t_p - (w.hi - slack) for t_p, w in est), default=0.0)
        return out

    def wait_on(i: int, f: str, now: float) -> float:
        """Seconds arm ``i`` waits for the next check, rather than book another fruit, where its
        try on ``f`` found no clear cycle and no other working arm may still take ``f``: a cycle
        booked on another fruit would put the hold that could save ``f`` off until its pick is
        over, past ``f``'s window (a 10 m row, arms 1.2 m apart, seed 0: two fruit passed so) --
        once per arm, fruit and carriage motion, while ``f`` may still hold the carriage."""
        caution = STOPPED_CAUTION if any(t <= now for t in halt.values()) else 1
        if (f, i) in run.waited or held_for.get(f, 0) >= HOLDS_PER_REPORT * caution:
            return 0.0
        ws = open_windows(f, now)
        if any(math.isinf(w.hi) for w in ws if w.arm == i) or any(
                w.arm != i and (w.arm not in halt or halt[w.arm] > now) and (f, w.arm) not in run.refused for w in ws):
            return 0.0  # (open at the rail's end, where the carriage comes to rest; or another arm may take it)
        run.waited.add((f, i))
        return CHECK

    t_c = 0.0
    while True:
        t_next = min([t_c + CHECK if opts.hold_for_fruit else math.inf] + [t for t, _ in changes[:1]])
        if t_next >= cruise.duration:
            break  # coming to rest for good: nothing more to change
        run.policy(halt=halt, delay=delay, until=t_next, explain=False, wait_on=wait_on if opts.hold_for_fruit else None)
        t_c = t_next
        while changes and changes[0][0] <= t_c:
            change(changes.pop(0)[1], t_c)
        if opts.hold_for_fruit and t_c >= held_until:
            risk = at_risk(t_c)
            if risk:
                change(Change.FRUIT, t_c, risk)
    run.holds = holds
    return run.policy(halt=halt, delay=delay)


def _finish(problem: Problem, opts: LiveRowOptions, run: LiveRun, faults: FaultDraws, left: dict[str, str], cruise: Cruise,
            offline, planning: float, stops: list[dict] | None) -> LiveRow:
    """The executed plan (events on the true fruit), verified against the truth, and the metrics."""
    booker, by_id = run.booker, run.reports
    # the row is busy until the last cycle's end, a probe's or a grasp on nothing's too (the arms
    # cannot know a report false before they look): the live row time
    work_end = booker.work_end
    plan, ver, picked_by = _executed(problem, run, faults, cruise, stops)
    events = booker.events
    got = {e.fruit for e in events if e.kind == EventKind.PLACE}
    ref = {e.fruit for e in offline.plan.events if e.kind == EventKind.PLACE}
    outcome = _outcomes(problem, run, left, got)
    seen = run.seen
    # missed though a working arm could still reach it (:func:`coplan.row.stranded.still_reachable`):
    # the true fruit, from a carriage position not yet passed when it was reported -- before an
    # arm stopped by any arm, after it by a working arm clear of the stopped one
    missed_reachable = sorted({by_id[d].truth for d in booker.windows if by_id[d].truth is not None
                               and by_id[d].truth not in got and d not in run.misses and d not in run.unseen
                               and still_reachable(booker, run.reach.grid, run.truth_xy[by_id[d].truth], seen[d], faults.halt,
                                                   GantryMode(opts.mode) == GantryMode.STOP_AND_GO)})
    for f in missed_reachable:  # (its reason, the planner's view of the report, said only the stopped arm reached it)
        if "stopped" in outcome.get(f, "") and "itself" not in outcome[f]:
            d = min((r for r in by_id.values() if r.truth == f), key=lambda r: math.dist(r.position, run.truth_xy[f]))
            outcome[f] += (f"; a working arm could reach the fruit itself, {1000 * math.dist(d.position, run.truth_xy[f]):.0f} mm "
                           f"from where its report put it")
    span = max(float(plan.metrics.get("makespan") or 0.0), work_end)
    ref_span = float(offline.plan.metrics.get("makespan") or 0.0)
    pick_start = {(e.arm, e.fruit): e.t_start for e in events if e.kind == EventKind.PICK}
    cycles = [e.t_end - pick_start[(e.arm, e.fruit)] for e in events if e.kind == EventKind.PLACE]
    cycle_walls = run.walls
    walls = cycle_walls + [w for w, _ in run.cells]  # (every decision: the cycles' and the stops' cells)
    dets = sorted((RowDetection(r.id, r.position, max(0.0, seen.get(r.id, math.inf)), r.truth) for r in by_id.values()
                   if math.isfinite(seen.get(r.id, math.inf))), key=lambda d: (d.t, d.id))
    mode = GantryMode(opts.mode)
    metrics = {
        "mode": mode.value,
        "harvested": len(got), "offline_harvested": len(ref), "of_offline": len(got & ref) / len(ref) if ref else None,
        "harvested_not_offline": len(got - ref), "row_time": span, "offline_row_time": ref_span,
        # (None when nothing was placed: a run that harvested nothing said "the last fruit placed at 0.0 s")
        "last_place": float(plan.metrics.get("makespan") or 0.0) if got else None, "plan_seconds": float(plan.time[-1]),
        "row_time_ratio": span / ref_span if ref_span > 0 else None,
        # what a grower judges, as a planned row's metrics.row (the README says a live run gives its own)
        "fruit_per_hour": 3600.0 * len(got) / span if span > 0 else None,
        "fruit_per_hour_per_arm": {a.name: 3600.0 * sum(1 for e in events if e.kind == EventKind.PLACE and e.arm == a.name) / span
                                   for a in problem.arms} if span > 0 else None,
        "reports": len(dets), "false_reports": sum(d.truth is None for d in dets), "probes": len(booker.probes),
        "merged": sum(1 for k in outcome if k.startswith("report ")), "grasps_on_nothing": len(run.misses),
        "found_nothing_at_close_range": len(run.unseen),  # (reports farther from their fruit than the gripper camera sees)
        "decisions": len(walls), "decision_max_seconds": max(walls, default=0.0),
        "decision_mean_seconds": float(np.mean(walls)) if walls else 0.0,
        "shortest_cycle_seconds": min(cycles, default=None), "planning_seconds": planning,
        # each decision faster than the motion it plans for: a cycle's than the shortest cycle (the
        # arm's cycle under way while it is made), a stop's cell plan than its lead (the stop's
        # booked motion, which runs until the cell's first motion)
        "kept_ahead": (not cycle_walls or not cycles or max(cycle_walls) < min(cycles))
        and all(w < lead for w, lead in run.cells),
        "cell_decisions": [{"seconds": w, "lead_seconds": lead} for w, lead in run.cells],
        "faults": faults.log, "missed_reachable_by_a_working_arm": missed_reachable,
        "holds_for_fruit": len(run.holds), "hold_seconds": round(sum(h["seconds"] for h in run.holds), 3),
        "verified": ver.passed, "speed": opts.speed if mode == GantryMode.CONTINUOUS else None,
        "stops": len(stops) if stops is not None else None,
        "stops_without_picks": sum(not st["picks"] for st in stops) if stops is not None else None,
        "look_ahead": opts.look_ahead, "sigma": opts.sigma,
        "false_rate": opts.false_rate, "seed": opts.seed,
    }
    row = {"mode": f"{mode.value}-live", "left_out": {k: v for k, v in outcome.items() if v != "harvested"},
           # the true fruit a tucked cycle harvested (the last tries with the carriage at rest)
           "tucked": [by_id[d].truth for d in booker.tucked if picked_by.get(by_id[d].truth) == d]}
    if mode == GantryMode.CONTINUOUS:
        row["speed"] = opts.speed
        row["holds"] = run.holds
    else:
        row["stops"] = stops
    plan.solver = {"status": plan.status.value, "row": row, "live": metrics}
    return LiveRow(plan, ver, offline, dets, outcome, metrics)


def _executed(problem: Problem, run: LiveRun, faults: FaultDraws, cruise: Cruise, stops: list[dict] | None):
    """The executed plan, its events renamed to the true fruit (a probe's cycle has none: the arm
    found nothing there; nor has a grasp that closed on nothing), each arm home or parked at the
    end, verified against the truth: ``(plan, verification, {true fruit: the report picked})``."""
    from ..kinds import LIVE_PLANNER
    from ..verify.row import row_reachable_ids
    from ..verify.verifier import verify

    booker, by_id = run.booker, run.reports
    events, picked_by = [], {}
    for e in sorted(booker.events, key=lambda e: (e.t_start, e.arm)):
        if e.fruit in run.misses:
            continue
        d = by_id[e.fruit]
        if picked_by.setdefault(d.truth, e.fruit) != e.fruit:  # never: a taken fruit's report is a probe
            raise RuntimeError(f"fruit {d.truth} booked twice ({picked_by[d.truth]}, {e.fruit})")
        events.append(Event(e.arm, d.truth, e.kind, e.t_start, e.t_end))
    booker.events = events
    for st in booker.arms:
        st.fruit = [by_id[f].truth for f in st.fruit if f not in booker.probes and f not in run.misses]
    booker.home_parked(set(faults.halt))
    plan = assemble_moving(problem, booker, cruise)
    plan.planner = LIVE_PLANNER  # (the executed plan of a live run, as a live cell's)
    plan.metrics["lower_bound"] = row_bounds(problem, priced=False).any_plan  # (the row's, for any motion: as coplan solve's)
    if stops is not None and faults.dark is not None:  # what the outage cost (on the move: its hold, logged as it came)
        faults.log["camera_dark"]["hold_seconds"] = dark_hold(plan, faults.dark)
    stop = faults.log.get("arm_stop") or {}
    if "arm" in stop:  # an arm's fault, declared where the verifier reads it (solver.live.faults: it ends out)
        plan.solver = {"live": {"faults": {"arm_stop": dict(stop)}}}
    ver = verify(problem, plan)
    return finalize_plan(plan, ver, len(row_reachable_ids(problem))), ver, picked_by


def _outcomes(problem: Problem, run: LiveRun, left: dict[str, str], got: set[str]) -> dict[str, str]:
    """Each true fruit's outcome: "harvested", or "missed: <why>" -- the reason its reports were
    left with (their report ids named with the fruit each reports), else out of every arm's reach,
    never reported, or reported where no arm could pick it (the report's error). ``run.outcome``
    (what became of each report) is updated in place and returned."""
    by_id, outcome = run.reports, run.outcome
    for f in problem.fruits:
        outcome[f.id] = "harvested" if f.id in got else "missed"

    def named(text: str) -> str:  # report ids in a reason, with the fruit each reports
        def one(mt):
            r = by_id.get(mt.group(0))
            return mt.group(0) if r is None else f"{r.truth} (report {r.id})" if r.truth else f"a false report ({r.id})"
        return re.sub(r"\b[db]\d{4,}\b", one, text)

    for did, why in (left | run.misses | run.unseen).items():  # (a report the camera never made is not a reason: below)
        if by_id[did].truth is not None and by_id[did].truth not in got and math.isfinite(run.seen.get(did, math.inf)):
            outcome[by_id[did].truth] = named(why if why.startswith("missed") else f"missed: {why}")
    reported: dict[str, list[RowReport]] = {}  # true fruit -> its reports the camera made
    for r in by_id.values():
        if r.truth is not None and math.isfinite(run.seen.get(r.id, math.inf)):
            reported.setdefault(r.truth, []).append(r)
    left_over = [f.id for f in problem.fruits if outcome[f.id] == "missed"]
    anywhere = row_reach(problem, fruit_ids=left_over).cover if left_over else {}  # (the true positions)
    for f in problem.fruits:
        if outcome[f.id] == "missed":  # no report of it was ever booked nor left with a reason
            rs = reported.get(f.id, [])
            outcome[f.id] = ("missed: out of every arm's reach from every carriage position (true position)"
                             if f.id not in anywhere else
                             "missed: never reported (the camera did not see it before the run ended)" if not rs else
                             f"missed: reported at ({rs[0].position[0]:.3f}, {rs[0].position[1]:.3f}) (report {rs[0].id}), "
                             f"where no arm could pick it as the carriage went (the report's error)")
    return outcome
