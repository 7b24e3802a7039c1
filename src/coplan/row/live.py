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

from ..kinds import GantryMode, PlanStatus, SpeedProfile
from ..plan import Event, EventKind, finalize_plan
from ..errors import Issue, OptionsError
from ..problem.model import Problem
from ..problem.plausible import live_rail_issue, live_speed_issue
from ..allocate.row_bound import row_bounds
from .continuous import MovingOptions, assemble_moving
from .moving import plan_moving
from .cruise import Cruise
from .liverun import LiveRun
from .livemove import STOP_SLOWDOWN, run_on_the_move
from .livestops import dark_hold
from .reach import row_reach
from .starthold import reports_start_hold
from .stopgo import stop_and_go
from .sensing import (FaultDraws, LiveRowOptions, RowDetection, RowFaults, RowReport, check_fault_room, report_times,
                      row_detections, row_reports)
from .stranded import still_reachable


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
    from .plan import check_row_work

    check_row_work(problem)  # (a row no plan of coplan's can hold: refused before the feed is drawn)
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
        left, cruise, stops = run_on_the_move(run, faults, cruise), run.booker.cruise, None
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
    reach = set(row_reachable_ids(problem))
    # (out of every arm's reach from every carriage position: the plan said 230 reachable and 0
    # unreachable of a 233-fruit row, where run.json said three missed, out of reach)
    plan.unreachable = [f.id for f in problem.fruits if f.id not in reach]
    ver = verify(problem, plan)
    return finalize_plan(plan, ver, len(reach)), ver, picked_by


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
