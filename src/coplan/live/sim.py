"""The simulated live cell (``coplan run PROBLEM --feed FEED``).

PROBLEM holds the true fruit, FEED what the camera reports. The arms execute the
:class:`~coplan.live.cell.LiveCell`'s plan; events are processed in time order: detection
batches (re-plan), close-range measurements (from the true position with the feed's
close-range sigma; nothing when the detection was false or its fruit is already taken),
and fruit hidden behind another revealed after that one's pick. The executed trajectory is
an ordinary plan (``plan.json``) verified against the true problem by
:func:`coplan.verify.verify`; ``run.json`` holds every detection, every re-plan, each true
fruit's outcome and the metrics, with the omniscient reference (the coordinated planner with
every fruit known).
"""

from __future__ import annotations

import math
import os
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from ..kinds import LIVE_PLANNER, EventKind, PlanStatus, TrackState
from ..plan import DEFAULT_RATE, Event, Plan, compute_metrics, finalize_plan
from ..problem.model import Problem
from ..planners.coordinated.schedule import ArmSchedule, StepKind
from ..progress import Tick, ticker
from .cell import LiveCell, LiveOptions
from .feed import Detection, Feed

__all__ = ["LIVE_PLANNER", "LiveRun", "simulate", "RUN_FORMAT"]

RUN_FORMAT = "coplan.run/1"
BATCH = 0.05  # s: detections this close in time are handled in one re-plan


@dataclass
class LiveRun:
    plan: Plan
    verification: object
    run: dict
    cell: LiveCell
    paths: list = field(default_factory=list)  # (time, {arm: planned tip path (K, 2)}) after each re-plan


def _percentile(x: list[float], p: float) -> float | None:
    return float(np.percentile(x, p)) if x else None


def simulate(problem: Problem, feed: Feed, options: LiveOptions | None = None, seed: int = 0,
             omniscient: bool = True, max_events: int = 5000, progress=None) -> LiveRun:
    """Run the live cell on ``feed`` against the true ``problem``; verify what was executed.
    ``progress``: a :class:`coplan.progress.Reporter` receives a tick per event (detections
    taken in so far)."""
    from ..verify.verifier import verify

    feed.check_against(problem)
    opts = replace(options or LiveOptions(), close_distance=feed.close_distance)
    rng = np.random.default_rng(seed)
    cell = LiveCell(problem, opts)
    warm = cell.warm_up()  # a real cell starts its planner before the arms move
    truth = {f.id: np.asarray(f.position, float) for f in problem.fruits}
    det_fruit = {d.id: d.fruit for d in feed.detections}
    queue = sorted((d for d in feed.detections if d.after is None), key=lambda d: d.t)
    hidden: dict[str, list[Detection]] = {}
    for d in feed.detections:
        if d.after is not None:
            hidden.setdefault(d.after, []).append(d)
    track_truth: dict[str, str | None] = {}  # track -> the true fruit its close-range look found
    claimed: set[str] = set()
    released: set[str] = set()
    log: list[dict] = []
    now, k, idle_tried = 0.0, 0, None
    paths: list = []
    tick = ticker(progress)
    for _ in range(max_events):
        tick(Tick("live run", k, max(1, len(queue)), "detections", note=f"t = {now:.1f} s, {len(cell.replans)} re-plans"))
        if len(cell.replans) > len(paths):  # the plan as it stood after each re-plan (for the animation)
            t = np.linspace(now, now + 4.0, 41)
            paths += [(now, {n: _tips(cell, n, t) for n in cell.steps})] * (len(cell.replans) - len(paths))
        t_det = queue[k].t if k < len(queue) else math.inf
        cr = cell.next_close_range(now)
        t_cr = cr.t if cr is not None else math.inf
        t_rel, rel = math.inf, None
        for steps in cell.steps.values():
            for s in steps:
                f = track_truth.get(s.fruit) if s.kind == StepKind.PICK else None
                if f in hidden and f not in released and s.t1 < t_rel:
                    t_rel, rel = max(s.t1, now), f
        pending = sorted(tr.id for tr in cell.open_tracks())
        t_idle = max(now, cell.end) if pending and pending != idle_tried else math.inf
        t_next = min(t_det, t_cr, t_rel, t_idle)
        if t_next == math.inf:
            break
        if t_cr == t_next:
            now = t_cr
            tr = cell.tracks[cr.track]
            # (sorted: of two fruit as near, the first by id -- a set's order, which the process's hash seed
            # sets, chose which fruit a track merged from both was found to be)
            cands = sorted(f for f in {det_fruit.get(d) for d in tr.detections} if f is not None and f not in claimed)
            # the gripper camera sees what lies within close_distance of where the arm goes (a fruit
            # the detections put farther off is not there: it was found however far off they were)
            near = [f for f in cands if float(np.hypot(*(truth[f] - tr.position))) <= feed.close_distance]
            fid = track_truth.get(tr.id) or min(near, key=lambda f: float(np.hypot(*(truth[f] - tr.position))), default=None)
            extra = []
            if fid is not None:
                claimed.add(fid)
                track_truth[tr.id] = fid
                pos = truth[fid] + rng.normal(0.0, feed.close_sigma, 2)
                # other fruit the camera has seen, right beside it (merged into this track from afar): now told apart
                seen = {det_fruit.get(d) for t in cell.tracks.values() for d in t.detections}
                extra = [g for g in sorted(seen - claimed - {None}) if float(np.hypot(*(truth[g] - truth[fid]))) < feed.close_distance / 2]
            else:
                pos = None
                dup = [f for f in {det_fruit.get(d) for d in tr.detections} if f is not None]
                far = sorted(set(cands) - set(near))
                tr.note = ("false detection" if not dup else
                           f"detections of {', '.join(far)} {min(float(np.hypot(*(truth[f] - tr.position))) for f in far) * 1000:.0f} mm "
                           f"off, farther than the close-range camera sees ({feed.close_distance * 1000:g} mm)" if far else
                           f"duplicate of {', '.join(sorted(dup))} (already taken)")
            log.append({"t": now, "event": "close-range", "arm": cr.arm, "track": tr.id, "found": fid is not None,
                        "error_before": None if fid is None else float(np.hypot(*(truth[fid] - tr.position)))})
            note = tr.note
            cell.refine(now, tr.id, pos, feed.close_sigma)
            if pos is None:
                tr.note = f"{note}: nothing found at close range (t = {now:.2f} s)"
            if extra:
                found = [Detection(now, _new_id(f"{tr.id}+{g}", det_fruit), tuple(truth[g] + rng.normal(0.0, feed.close_sigma, 2)),
                                   feed.close_sigma, g) for g in extra]
                det_fruit |= {d.id: d.fruit for d in found}
                cell.observe(now, found)
                log.append({"t": now, "event": "told apart", "track": tr.id, "detections": [d.id for d in found]})
                for d in found:
                    if d.id in cell.tracks:
                        claimed.add(d.fruit)
                        track_truth[d.id] = d.fruit
        elif t_rel == t_next:
            now = t_rel
            released.add(rel)
            queue = queue[:k] + sorted(queue[k:] + [replace(d, t=now + d.t) for d in hidden[rel]], key=lambda d: d.t)
            log.append({"t": now, "event": "uncovered", "behind": rel, "detections": [d.id for d in hidden[rel]]})
        elif t_det == t_next:
            batch = []
            while k < len(queue) and queue[k].t <= t_det + BATCH:
                batch.append(queue[k])
                k += 1
            now = max(now, batch[-1].t)
            cell.observe(now, batch)
            log.append({"t": now, "event": "detections", "detections": [d.id for d in batch]})
        else:
            now = t_idle
            idle_tried = pending
            cell.retry(now)
            log.append({"t": now, "event": "retry", "pending": pending})
    out = _finish(problem, feed, cell, track_truth, det_fruit, hidden, released, log, omniscient, verify, warm)
    out.paths = paths
    return out


def _tips(cell: LiveCell, name: str, t: np.ndarray) -> np.ndarray:
    from ..kinematics.arm import fk

    arm = cell.problem.arm(name)
    st = cell.steps[name]
    near = [s for s in st if s.t1 >= t[0] - 1e-9 and s.t0 <= t[-1]] or st[-1:]  # resting after its last step
    q = ArmSchedule(arm, near).state(t)[0] if near else np.tile(np.asarray(arm.home, float), (t.size, 1))
    return fk(q, arm.links, arm.base)[1]


def _executed_plan(problem: Problem, cell: LiveCell, track_truth: dict) -> tuple[Plan, list[str], dict[str, str]]:
    """The executed plan, its events on the true fruit; the tracks whose pick found no fruit (a
    false detection); and, per true fruit, why a grasp aimed at it closed on nothing: the
    close-range measurement put the tip farther from the fruit than the verifier's
    ``position_tolerance`` throughout the pick -- a fruit missed (the cycle ran, nothing was
    harvested), not a plan that breaks a limit or comes too close."""
    from ..kinematics.arm import fk
    from ..planners.heuristic import grid as uniform_grid
    from ..verify.verdict import VerifyOptions

    sch = cell.schedules()
    times = uniform_grid(cell.end, DEFAULT_RATE)
    q = {n: s.state(times)[0] for n, s in sch.items()}
    tol = VerifyOptions().position_tolerance
    arms = {a.name: a for a in problem.arms}
    truth = {f.id: np.asarray(f.position, float) for f in problem.fruits}
    events, unknown, allocation = [], [], {n: [] for n in sch}
    misses: dict[str, str] = {}
    kinds = {StepKind.PICK: EventKind.PICK, StepKind.PLACE: EventKind.PLACE}
    for n, s in sch.items():
        empty: set[str] = set()  # this arm's tracks whose grasp closed on nothing (their place too: nothing to place)
        for st in s.steps:
            if st.kind in kinds:
                fid = track_truth.get(st.fruit)
                if fid is None:
                    unknown.append(st.fruit)
                    continue
                if st.kind == StepKind.PICK:
                    on = (times >= st.t0 - 1e-9) & (times <= st.t1 + 1e-9)
                    tips = fk(q[n][on], arms[n].links, arms[n].base)[1] if on.any() else np.zeros((0, 2))
                    least = float(np.min(np.hypot(*(tips - truth[fid]).T))) if len(tips) else math.inf
                    if least > tol:
                        empty.add(st.fruit)
                        misses[fid] = (f"{n}'s grasp closed on nothing: the close-range measurement put the tip "
                                       f"{least * 1000:.1f} mm from the fruit (more than {tol * 1000:.0f} mm)")
                        continue
                elif st.fruit in empty:
                    continue
                events.append(Event(n, fid, kinds[st.kind], st.t0, st.t1))
                if st.kind == StepKind.PICK:
                    allocation[n].append(fid)
    events.sort(key=lambda e: (e.t_start, e.arm))
    plan = Plan(problem=problem.name, planner=LIVE_PLANNER, status=PlanStatus.UNVERIFIED, time=times, q=q, events=events,
                allocation=allocation, unreachable=problem.unreachable(), solver={})
    return plan, unknown, misses


def _new_id(name: str, taken) -> str:
    """``name``, or ``name#2``, ``#3``, ... where a feed's own detection has it (a feed that named one
    'a+f09' stopped the run with 'expected a unique id' where the gripper told two fruit apart)."""
    out, n = name, 1
    while out in taken:
        n += 1
        out = f"{name}#{n}"
    return out


def _finish(problem, feed, cell, track_truth, det_fruit, hidden, released, log, omniscient, verify, warm) -> LiveRun:
    from ..planners.coordinated.planner import plan_coordinated
    from ..verify.verdict import ViolationKind

    plan, unknown, grasped_nothing = _executed_plan(problem, cell, track_truth)
    n_reach = len(problem.reachable_ids())
    ver = verify(problem, plan)
    plan.metrics = compute_metrics(plan, n_reach)
    plan = finalize_plan(plan, ver, n_reach)
    missed_picks = {v.fruit: v.message for v in ver.violations
                    if v.kind in (ViolationKind.PICK_MISSED, ViolationKind.PICK_DWELL) and v.fruit}
    picked = {e.fruit for e in plan.events if e.kind == EventKind.PICK}
    placed = {e.fruit for e in plan.events if e.kind == EventKind.PLACE}
    by_truth: dict[str, list[str]] = {}
    for tr in cell.tracks.values():
        for f in {det_fruit.get(d) for d in tr.detections}:
            if f is not None:
                by_truth.setdefault(f, []).append(tr.id)
    detected = {d.fruit for d in feed.detections if d.fruit is not None and (d.after is None or d.after in released)}
    unreach = set(problem.unreachable())
    named = any(d.fruit is not None for d in feed.detections)  # (a camera's own file names none: not "never detected")
    outcomes = {}
    for f in problem.fruits:
        ok = f.id in picked and f.id in placed and f.id not in missed_picks
        if ok:
            why = None
        elif f.id in grasped_nothing and f.id not in picked:
            why = grasped_nothing[f.id]
        elif f.id in missed_picks:
            why = f"pick not within tolerance: {missed_picks[f.id]}"
        elif f.id in unreach:
            why = "out of every arm's reach (true position)"
        elif f.id not in detected:
            hid = [h for h, ds in hidden.items() if any(d.fruit == f.id for d in ds)]
            why = (f"never revealed (hidden behind {', '.join(hid)}, which was not picked)" if hid else "never detected"
                   if named or not feed.detections else
                   "no report names it (the feed's detections carry no 'fruit': none is matched to a "
                   "true fruit, so every one counts as false)")
        else:
            notes = []
            for t in by_truth.get(f.id, []):
                tr = cell.tracks[t]
                others = sorted({det_fruit.get(d) for d in tr.detections} - {f.id, None})
                if others:  # one track for two true fruit: the arm picked one of them
                    notes.append(f"{t}: its reports were merged with those of {', '.join(others)} into one track "
                                 f"(within the gate: LiveOptions.gate, 3 sigma), {tr.state.value} as one fruit")
                else:
                    notes.append(f"{t}: {tr.state.value}" + (f" ({tr.note})" if tr.note else ""))
            why = "; ".join(notes) or "not harvested"
        outcomes[f.id] = {"harvested": ok, "reachable": f.id not in unreach, "tracks": by_truth.get(f.id, []), "why": why}
    false_tracks = [tr for tr in cell.tracks.values() if all(det_fruit.get(d) is None for d in tr.detections)]
    lat = [r.latency for r in cell.replans]
    harvested = sum(o["harvested"] for o in outcomes.values())
    reachable = sum(o["reachable"] for o in outcomes.values())
    makespan = plan.metrics["makespan"]
    metrics = {
        "harvested": harvested, "reachable": reachable,
        "pick_success_rate": harvested / reachable if reachable else None,
        "makespan": makespan, "throughput": harvested / makespan if makespan > 0 else 0.0,
        "grasps_on_nothing": len(grasped_nothing),
        "false_detections": len(false_tracks),  # (tracks of false detections alone: what the arms could be sent to)
        "false_reports": sum(1 for f in det_fruit.values() if f is None),  # (the feed's false detections, each report)
        "false_reports_merged": sum(1 for tr in cell.tracks.values() if tr not in false_tracks
                                    for d in tr.detections if det_fruit.get(d) is None),  # (into a real fruit's track)
        "false_picks_avoided": sum(tr.state == TrackState.DROPPED for tr in false_tracks),
        "false_picks": sum(1 for tr in false_tracks if tr.id in unknown),
        "false_unreachable": sum(tr.state == TrackState.UNREACHABLE for tr in false_tracks),  # (never tried: out of reach)
        "duplicates_merged": sum(len(tr.detections) - 1 for tr in cell.tracks.values()),
        "duplicates_dropped_at_close_range": sum(tr.state == TrackState.DROPPED and tr not in false_tracks for tr in cell.tracks.values()),
        "unreachable_detections": sorted(tr.id for tr in cell.tracks.values() if tr.state == TrackState.UNREACHABLE),
        "replans": len(cell.replans), "replans_failed": sum(not r.ok for r in cell.replans),
        "latency_median": _percentile(lat, 50), "latency_p95": _percentile(lat, 95), "latency_max": max(lat, default=None),
        "late_replans": sum(r.latency > cell.options.horizon for r in cell.replans), "warm_up_seconds": warm,
        "verified": ver.passed, "status": plan.status.value,
        # (the makespan ends at the last place: close-range probes of false tracks after it, and the
        # ways home, are the arms' work the makespan leaves out -- said beside it, not hidden)
        "work_end": cell.end,
        "probes_after_last_place": sum(1 for e in log if e["event"] == "close-range" and not e["found"] and e["t"] > makespan)
        if makespan > 0 else 0,  # (with nothing placed there is no last place to be after)
    }
    if omniscient:
        ref = plan_coordinated(problem)
        om = ref.plan.metrics["makespan"]
        om_thr = ref.plan.metrics["harvested"] / om if om > 0 else 0.0
        metrics |= {"omniscient_makespan": om, "omniscient_harvested": ref.plan.metrics["harvested"],
                    "omniscient_status": ref.plan.status.value, "omniscient_throughput": om_thr,
                    "makespan_loss": makespan / om - 1.0 if om > 0 and makespan > 0 else None,
                    "throughput_loss": 1.0 - metrics["throughput"] / om_thr if om_thr > 0 else None}
    # (the feed's path as run.json's reader can follow it: '../feed.yaml' was relative to where the command ran)
    where = str(Path(feed.source).absolute()) if feed.source and os.path.isfile(feed.source) else feed.source
    plan.solver = {"status": plan.status.value, "live": {"replans": len(cell.replans), "feed": where}}
    run = {
        "format": RUN_FORMAT, "problem": problem.name, "feed": where,
        "feed_sha256": feed.digest,  # (the path alone: an edited feed could not be told from the one run)
        "options": {k: getattr(cell.options, k) for k in cell.options.__dataclass_fields__},
        "close_range": {"distance": feed.close_distance, "sigma": feed.close_sigma},
        "detections": [d.to_dict() | {"track": next((t.id for t in cell.tracks.values() if d.id in t.detections), None)}
                       for d in feed.detections],
        "tracks": [tr.to_dict() | {"truth": track_truth.get(tr.id)} for tr in cell.tracks.values()],
        "merges": cell.merges,
        "replans": [r.to_dict() for r in cell.replans],
        "events": log,
        "fruit": outcomes,
        "metrics": metrics,
        "verification": ver.summary(),
    }
    return LiveRun(plan, ver, run, cell)
