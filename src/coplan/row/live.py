"""A live row on the move: the camera sees only a stretch ahead, the row is planned as fruit come into view.

Entry point: :func:`run_live_row` -> :class:`LiveRow`.

* **The camera** (:func:`row_detections`, seeded): a fruit is reported when it comes within
  ``look_ahead`` m ahead of the carriage's front arm base, at its true position plus Gaussian
  noise (``sigma`` per coordinate); a share ``false_rate`` of extra reports are false (no fruit
  there, anywhere in the fruit's band of the row), a share ``duplicate_rate`` of fruit are
  reported twice (a second, independently noisy report a moment later).
* **Planning as fruit come into view**: the carriage cruises at a constant ``speed`` (a live
  planner cannot shape its speed to fruit it has not seen). Each decision -- an arm free, at
  rest, choosing its next fruit (:func:`coplan.row.booking.run_policy`) -- sees only the reports
  made by then (reports within ``merge`` of an earlier one may be taken for the same fruit;
  off by default: a second report of a picked fruit costs a probe instead); as the arm approaches, its close-range sensor measures the fruit
  (``close_sigma``), and the cycle is planned on that measurement. A false report costs a
  probe: the arm goes there, finds nothing at close range, and returns without dwelling (its
  cycle carries no events); so does a second report of a fruit already taken.
* **Verified against the truth**: the executed motion is one ordinary row plan whose events
  name the true fruit, verified by :func:`coplan.verify.verify` against the true problem.
* **Reference**: the offline plan at the same speed with full knowledge (every true fruit at its
  true position from t = 0); the live row's harvest and row time are reported against it.
* **Real time**: the wall time of every decision, against the time the arm spends on the
  motion committed before it (its previous cycle): a decision made while the arm is still busy
  is never late.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from ..kinds import AssignRule, SpeedProfile
from ..plan import DEFAULT_RATE, Event, EventKind, finalize_plan
from ..problem.model import Fruit, Problem
from .booking import Booker, run_policy
from .continuous import MovingOptions, assemble_moving, plan_continuous
from .cruise import Cruise, pick_windows
from .reach import row_reach

#: After an arm stops, the carriage runs at this share of the working arms' share of its speed.
STOP_SLOWDOWN = 0.5

__all__ = ["LiveRowOptions", "RowFaults", "RowDetection", "LiveRow", "row_detections", "run_live_row"]


@dataclass(frozen=True)
class RowFaults:
    """Things that go wrong during a live row, each at a time drawn from the run's seed (between
    20 % and 80 % of the carriage's run), so that a run can be replayed.

    arm_stop : one arm (drawn) reports a controller fault: it finishes the motion in progress and
        stays where it then rests, an obstacle; its fruit go to the neighbours that reach them
    camera_dark : s the camera reports nothing; what it would have seen is reported when it is back
    false_burst : false reports at one instant, all within the camera's view
    late_replan : s one decision (the first at or after its time) runs late; the arm waits
    """

    arm_stop: bool = False
    camera_dark: float = 0.0
    false_burst: int = 0
    late_replan: float = 0.0

    @property
    def any(self) -> bool:
        return self.arm_stop or self.camera_dark > 0 or self.false_burst > 0 or self.late_replan > 0


@dataclass(frozen=True)
class LiveRowOptions:
    """The camera and the live planner (separate from the problem)."""

    speed: float = 0.1  # m/s, the carriage's cruising speed
    look_ahead: float = 1.5  # m ahead of the front arm's base the camera sees
    sigma: float = 0.01  # m, detection noise per coordinate
    false_rate: float = 0.05  # false reports, as a share of the fruit
    duplicate_rate: float = 0.02  # fruit reported twice
    close_sigma: float = 0.001  # m, the close-range measurement's noise per coordinate
    merge: float = 0.0  # m: a report this close to an earlier one is the same fruit (0: none merged; a
    # second report of a picked fruit then costs a probe -- in trusses, distinct fruit lie closer than
    # two noisy reports of one)
    seed: int = 0
    margin: float = 0.02  # m beyond the clearance, as for the offline plan
    faults: RowFaults = field(default_factory=RowFaults)


@dataclass(frozen=True)
class RowDetection:
    """One camera report: ``id``, where it says, when, and the true fruit (None: false)."""

    id: str
    position: tuple[float, float]
    t: float
    truth: str | None


@dataclass
class LiveRow:
    plan: object
    verification: object
    offline: object  # the offline plan's RowResult
    detections: list[RowDetection]
    outcome: dict[str, str]  # true fruit id -> harvested | missed (why)
    metrics: dict = field(default_factory=dict)


def row_detections(problem: Problem, cruise: Cruise, opts: LiveRowOptions) -> list[RowDetection]:
    """The camera's reports over the whole row (module docstring), in time order."""
    rng = np.random.default_rng(opts.seed)
    front = max(a.base[0] for a in problem.arms)

    def seen_at(x: float) -> float:
        return float(cruise.time_at(np.array([x - front - opts.look_ahead]))[0])

    raw = []
    for f in problem.fruits:
        x, y = f.position
        raw.append(((x + rng.normal(0, opts.sigma), y + rng.normal(0, opts.sigma)), seen_at(x), f.id))
        if rng.random() < opts.duplicate_rate:
            raw.append(((x + rng.normal(0, opts.sigma), y + rng.normal(0, opts.sigma)), seen_at(x) + 0.5, f.id))
    if problem.fruits:
        ys = np.array([f.position[1] for f in problem.fruits])
        g = problem.gantry
        for _ in range(int(round(opts.false_rate * len(problem.fruits)))):
            x, y = rng.uniform(g.start, g.end), rng.uniform(ys.min(), ys.max())
            raw.append(((x, y), seen_at(x), None))
    raw.sort(key=lambda r: (r[1], r[0][0]))
    width = max(4, len(str(len(raw))))
    return [RowDetection(f"d{k + 1:0{width}d}", (round(float(p[0]), 6), round(float(p[1]), 6)), max(0.0, t), truth)
            for k, (p, t, truth) in enumerate(raw)]


def run_live_row(problem: Problem, options: LiveRowOptions | None = None, progress=None) -> LiveRow:
    """Run the row live (module docstring) and verify what was executed against the truth."""
    from ..verify.row import row_reachable_ids
    from ..verify.verifier import verify

    if problem.gantry is None:
        raise ValueError(f"{problem.name!r} has no gantry: a live row needs a row")
    opts = options or LiveRowOptions()
    g = problem.gantry
    if not 0.0 < opts.speed <= g.max_velocity:
        raise ValueError(f"speed: expected a cruising speed in (0, {g.max_velocity:g}] m/s, found {opts.speed:g}")
    rate = DEFAULT_RATE
    # the carriage does not know where the last fruit is: it cruises to the end of the rail
    cruise = Cruise.of(problem, opts.speed, g.end)
    dets = row_detections(problem, cruise, opts)
    dets, halt, delay, fault_log = _faults(problem, cruise, opts, dets)
    rng = np.random.default_rng(opts.seed + 1)
    truth_xy = {f.id: f.position for f in problem.fruits}
    seen_problem = replace(problem, fruits=tuple(Fruit(d.id, d.position) for d in dets), name=f"{problem.name} (as seen)",
                           source=None, digest=None)
    reach = row_reach(seen_problem)
    windows = pick_windows(seen_problem, reach, cruise, problem.task.pick_dwell)
    booker = Booker(seen_problem, cruise, windows, rate, opts.margin, reach.resolution)
    seen = {d.id: d.t for d in dets}
    by_id = {d.id: d for d in dets}
    known: list[tuple[str, tuple[float, float]]] = []  # reports chosen so far (association)
    outcome: dict[str, str] = {}
    walls: list[float] = []

    def on_book(i: int, did: str, now: float) -> bool:
        d = by_id[did]
        for other, xy in known:
            if other != did and math.dist(xy, d.position) < opts.merge:
                outcome.setdefault(f"report {did}", f"merged with {other} (within {opts.merge * 1000:g} mm)")
                return False
        known.append((did, d.position))
        claimed = {by_id[e.fruit].truth for e in booker.events}
        if d.truth is None or d.truth in claimed:
            # the close-range sensor finds nothing there (a false report, or a fruit already taken):
            # the arm comes, looks and goes back -- a probe, no dwells
            booker.probes.add(did)
        else:  # it measures the fruit as the arm comes
            tx, ty = truth_xy[d.truth]
            booker.fruit_xy[did] = (tx + rng.normal(0, opts.close_sigma), ty + rng.normal(0, opts.close_sigma))
        return True

    t0 = _time.perf_counter()
    orig = booker.plan_cycle

    def timed(*a, **k):  # every decision's wall time (a decision is one or more cycle attempts)
        t = _time.perf_counter()
        out = orig(*a, **k)
        walls.append(_time.perf_counter() - t)
        return out

    booker.plan_cycle = timed
    if halt:
        # an arm stops: from then on the carriage slows to what the working arms can keep up with,
        # its ramp starting once every pick booked before the fault is over (the carriage's motion
        # up to there is unchanged, so every booked cycle stays exact)
        taken: set[str] = set()
        t_f = min(halt.values())
        run_policy(booker, seen=seen, on_book=on_book, halt=halt, delay=delay, until=t_f, taken=taken)
        t_s = max([t_f] + [e.t_end for e in booker.events if e.kind == EventKind.PICK])
        x_s = float(cruise.x(np.array([t_s]))[0])
        n = len(problem.arms)
        slow = opts.speed * STOP_SLOWDOWN * (n - len(halt)) / n
        if slow > 0 and x_s < cruise.x1 - 1e-6:
            cruise = Cruise.shaped(problem, [(x_s, opts.speed), (math.inf, slow)], g.end)
            booker.cruise = cruise
            booker.windows = windows = pick_windows(seen_problem, reach, cruise, problem.task.pick_dwell)
            fault_log["arm_stop"].update({"carriage_slows_at": round(t_s, 3), "to_speed": slow})
        left = run_policy(booker, seen=seen, on_book=on_book, halt=halt, delay=delay, taken=taken)
    else:
        left = run_policy(booker, seen=seen, on_book=on_book, halt=halt, delay=delay)
    planning = _time.perf_counter() - t0
    # the events name the true fruit (a probe's cycle has none: the arm found nothing there)
    events, picked_by = [], {}
    for e in sorted(booker.events, key=lambda e: (e.t_start, e.arm)):
        d = by_id[e.fruit]
        if picked_by.setdefault(d.truth, e.fruit) != e.fruit:  # never: a taken fruit's report is a probe
            raise RuntimeError(f"fruit {d.truth} booked twice ({picked_by[d.truth]}, {e.fruit})")
        events.append(Event(e.arm, d.truth, e.kind, e.t_start, e.t_end))
    booker.events = events
    for st in booker.arms:
        st.fruit = [by_id[f].truth for f in st.fruit if f not in booker.probes]
    plan = assemble_moving(problem, booker, cruise)
    ver = verify(problem, plan)
    plan = finalize_plan(plan, ver, len(row_reachable_ids(problem)))
    offline = plan_continuous(problem, opts.speed, MovingOptions(profile=SpeedProfile.CONSTANT, assign=AssignRule.GREEDY,
                                                                 margin=opts.margin), None, progress)
    got = {e.fruit for e in events if e.kind == EventKind.PLACE}
    ref = {e.fruit for e in offline.plan.events if e.kind == EventKind.PLACE}
    for f in problem.fruits:
        outcome[f.id] = "harvested" if f.id in got else "missed"
    for did, why in left.items():
        if by_id[did].truth is not None and by_id[did].truth not in got:
            outcome[by_id[did].truth] = f"missed: {why}"
    working = [a for a in range(len(problem.arms)) if a not in halt]
    stopped_at = min(halt.values(), default=math.inf)
    # missed though a working arm could still reach it: a window of a working arm open after the
    # stop (and after the report) with a pick pose clear of the stopped arm where it rests
    missed_reachable = sorted({by_id[d].truth for d, ws in windows.items() if by_id[d].truth is not None
                               and by_id[d].truth not in got
                               and any(w.arm in working and w.hi >= seen[d] and (w.hi >= stopped_at or not halt)
                                       and _clear_of_stopped(booker, w, truth_xy[by_id[d].truth], halt) for w in ws)})
    span = float(plan.metrics.get("makespan") or 0.0)
    ref_span = float(offline.plan.metrics.get("makespan") or 0.0)
    pick_start = {(e.arm, e.fruit): e.t_start for e in events if e.kind == EventKind.PICK}
    cycles = [e.t_end - pick_start[(e.arm, e.fruit)] for e in events if e.kind == EventKind.PLACE]
    metrics = {
        "harvested": len(got), "offline_harvested": len(ref), "of_offline": len(got & ref) / len(ref) if ref else None,
        "harvested_not_offline": len(got - ref), "row_time": span, "offline_row_time": ref_span,
        "row_time_ratio": span / ref_span if ref_span > 0 else None,
        "reports": len(dets), "false_reports": sum(d.truth is None for d in dets), "probes": len(booker.probes),
        "merged": sum(1 for k in outcome if k.startswith("report ")),
        "decisions": len(walls), "decision_max_seconds": max(walls, default=0.0),
        "decision_mean_seconds": float(np.mean(walls)) if walls else 0.0,
        "shortest_cycle_seconds": min(cycles, default=None), "planning_seconds": planning,
        "kept_ahead": bool(walls) and (not cycles or max(walls) < min(cycles)),
        "faults": fault_log, "missed_reachable_by_a_working_arm": missed_reachable,
        "verified": ver.passed, "speed": opts.speed, "look_ahead": opts.look_ahead, "sigma": opts.sigma,
        "false_rate": opts.false_rate, "seed": opts.seed,
    }
    plan.solver = {"status": plan.status.value, "row": {"mode": "continuous-live", "speed": opts.speed,
                                                        "left_out": {k: v for k, v in outcome.items() if v != "harvested"}},
                   "live": metrics}
    return LiveRow(plan, ver, offline, dets, outcome, metrics)


def _faults(problem: Problem, cruise: Cruise, opts: LiveRowOptions, dets: list[RowDetection]):
    """Apply :class:`RowFaults` (module docstring): the reports changed, the arm halts, the late
    decision, and a log of what happened when."""
    f = opts.faults
    halt: dict[int, float] = {}
    log: dict = {}
    if not f.any:
        return dets, halt, None, log
    rng = np.random.default_rng(opts.seed + 7919)
    T = cruise.duration

    def when() -> float:
        return round(float(rng.uniform(0.2, 0.8) * T), 2)

    if f.arm_stop:
        a, t = int(rng.integers(len(problem.arms))), when()
        halt[a] = t
        log["arm_stop"] = {"arm": problem.arms[a].name, "t": t}
    if f.camera_dark > 0:
        t = when()
        dets = [replace(d, t=t + f.camera_dark) if t <= d.t < t + f.camera_dark else d for d in dets]
        log["camera_dark"] = {"t": t, "seconds": f.camera_dark}
    if f.false_burst > 0:
        t = when()
        front = max(a.base[0] for a in problem.arms)
        c = float(cruise.x(np.array([t]))[0])
        ys = [fr.position[1] for fr in problem.fruits] or [1.0]
        width = max(4, len(str(len(dets) + f.false_burst)))
        dets = dets + [RowDetection(f"b{k + 1:0{width}d}", (round(float(rng.uniform(c + front, c + front + opts.look_ahead)), 6),
                                                            round(float(rng.uniform(min(ys), max(ys))), 6)), t, None)
                       for k in range(f.false_burst)]
        log["false_burst"] = {"t": t, "reports": f.false_burst}
    delay = None
    if f.late_replan > 0:
        t, fired = when(), []

        def delay(arm: int, now: float) -> float:
            if fired or now < t:
                return 0.0
            fired.append((arm, now))
            log["late_replan"]["arm"], log["late_replan"]["decided_at"] = problem.arms[arm].name, now
            return f.late_replan

        log["late_replan"] = {"t": t, "seconds": f.late_replan}
    return sorted(dets, key=lambda d: (d.t, d.id)), halt, delay, log


def _clear_of_stopped(booker: Booker, w, xy, halt: dict[int, float]) -> bool:
    """Whether arm ``w.arm`` has a pick pose on the fruit at ``xy`` (row frame), with the carriage
    somewhere in the window's run, that keeps the clearance from every stopped arm where it rests
    (the screen knows nothing of a stopped arm; a pose blocked by one is no longer reachable)."""
    from ..planners.coordinated.schedule import arm_points, points_too_close

    if not halt:
        return True
    problem = booker.problem
    arm = problem.arms[w.arm]
    for c in np.linspace(w.c_lo, w.c_hi, 9):
        q, valid = arm.ik(np.array([xy[0] - c, xy[1]]))
        for b in (0, 1):
            if not valid[b]:
                continue
            pa = arm_points(arm, q[b])
            if all(not points_too_close(pa, arm_points(problem.arms[j], booker.arms[j].q[booker.arms[j].k_free]),
                                        arm.link_radius + problem.arms[j].link_radius, problem.task.clearance).any()
                   for j in halt):
                return True
    return False
