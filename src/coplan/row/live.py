"""A live row: the camera sees only a stretch ahead, the row is planned as fruit come into view.

Entry point: :func:`run_live_row` -> :class:`LiveRow`, in either gantry mode.

* **The camera** (:func:`row_reports`, seeded): a fruit is reported when the carriage brings it
  within ``look_ahead`` m ahead of the front arm's base, at its true position plus Gaussian
  noise (``sigma`` per coordinate); a share ``false_rate`` of extra reports are false (no fruit
  there, anywhere in the fruit's band of the row), a share ``duplicate_rate`` of fruit are
  reported twice (a second, independently noisy report half a second later). When each report
  is made follows from the carriage's motion as it is decided (:func:`report_times`).
* **Planning as fruit come into view** -- each decision (an arm free, at rest, choosing its next
  fruit: :func:`coplan.row.booking.run_policy`) sees only the reports made by then (reports
  within ``merge`` of an earlier one may be taken for the same fruit; off by default: a second
  report of a picked fruit costs a probe instead); as the arm approaches, its close-range sensor
  measures the fruit (``close_sigma``) and the cycle is planned on that measurement. A false
  report costs a probe: the arm goes there, finds nothing at close range, and returns without
  dwelling (its cycle carries no events); so does a second report of a fruit already taken. A
  grasp aimed farther than the pick tolerance from the true fruit (a close-range error of
  several sigma) closes on nothing: the cycle is executed, the fruit stays and is reported missed.
* **On the move** (``mode=continuous``): the carriage cruises at a constant ``speed`` (a live
  planner cannot shape its speed to fruit it has not seen).
* **Stop and go** (``mode=stop-and-go``): the carriage stops, the arms pick every fruit seen
  that they can reach from there (picks only with the carriage at rest), and once the last pick
  is over it hops -- a time-optimal jerk-limited move -- to the next stop: the fewest-stops
  rule over the fruit seen and not yet taken (the first place where one of them is about to
  leave every arm's reach), never beyond what the camera has seen (it passes no fruit unseen).
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
import time as _time
from dataclasses import dataclass, field, replace

import numpy as np

from ..allocate.screen import TIP_TOLERANCE
from ..kinds import AssignRule, GantryMode, SpeedProfile
from ..kinematics.timing import Move1D
from ..plan import DEFAULT_RATE, Event, EventKind, finalize_plan
from ..problem.model import Fruit, Problem
from .booking import Booker, run_policy, why_left
from .continuous import MovingOptions, assemble_moving, plan_continuous
from .cruise import Cruise, ramp_time, pick_windows
from .reach import row_reach

#: After an arm stops, the carriage runs at this share of the working arms' share of its speed.
STOP_SLOWDOWN = 0.5
#: Stop and go: a stop's picks may start up to this long per fruit in reach (and one more) after it arrives, s.
STOP_PATIENCE = 10.0

__all__ = ["LiveRowOptions", "RowFaults", "RowDetection", "LiveRow", "row_reports", "report_times", "row_detections",
           "run_live_row"]


@dataclass(frozen=True)
class RowFaults:
    """Things that go wrong during a live row, each at a time drawn from the run's seed (between
    20 % and 80 % of the carriage's run; stop and go: of the offline plan's row time), so that a
    run can be replayed.

    arm_stop : one arm (drawn) reports a controller fault: it finishes the motion in progress and
        stays where it then rests, an obstacle; its fruit go to the neighbours that reach them
    camera_dark : s the camera reports nothing; what it would have seen is reported when it is
        back. The carriage does not pass what it has not seen: on the move it comes to rest (once
        the picks booked before are over) and holds until the camera is back; stop and go, it
        hops no further than the camera saw before it went dark
    false_burst : false reports at one instant, all within the camera's view (stop and go: at the
        first stop reached at or after that instant)
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

    speed: float = 0.1  # m/s, the carriage's cruising speed (on the move)
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
    mode: GantryMode = GantryMode.CONTINUOUS  # continuous or stop-and-go


@dataclass(frozen=True)
class RowDetection:
    """One camera report: ``id``, where it says, when, and the true fruit (None: false)."""

    id: str
    position: tuple[float, float]
    t: float
    truth: str | None


@dataclass(frozen=True)
class RowReport:
    """A report before its time is known: the camera makes it ``lag`` s after the carriage first
    reaches ``at_x`` (a false burst: at time ``lag``, ``at_x`` None)."""

    id: str
    position: tuple[float, float]
    at_x: float | None
    lag: float
    truth: str | None


@dataclass
class LiveRow:
    plan: object
    verification: object
    offline: object  # the offline plan's RowResult
    detections: list[RowDetection]
    outcome: dict[str, str]  # true fruit id -> harvested | missed (why)
    metrics: dict = field(default_factory=dict)


def _front(problem: Problem) -> float:
    return max(a.base[0] for a in problem.arms)


def row_reports(problem: Problem, opts: LiveRowOptions) -> list[RowReport]:
    """The camera's reports over the whole row (module docstring), in the order it makes them."""
    rng = np.random.default_rng(opts.seed)
    front = _front(problem)
    raw = []
    for f in problem.fruits:
        x, y = f.position
        at = x - front - opts.look_ahead
        raw.append(((x + rng.normal(0, opts.sigma), y + rng.normal(0, opts.sigma)), at, 0.0, f.id))
        if rng.random() < opts.duplicate_rate:
            raw.append(((x + rng.normal(0, opts.sigma), y + rng.normal(0, opts.sigma)), at, 0.5, f.id))
    if problem.fruits:
        ys = np.array([f.position[1] for f in problem.fruits])
        g = problem.gantry
        for _ in range(int(round(opts.false_rate * len(problem.fruits)))):
            x, y = rng.uniform(g.start, g.end), rng.uniform(ys.min(), ys.max())
            raw.append(((x, y), x - front - opts.look_ahead, 0.0, None))
    raw.sort(key=lambda r: (r[1], r[2], r[0][0]))
    width = max(4, len(str(len(raw))))
    return [RowReport(f"d{k + 1:0{width}d}", (round(float(p[0]), 6), round(float(p[1]), 6)), float(at), lag, truth)
            for k, (p, at, lag, truth) in enumerate(raw)]


def report_times(reports: list[RowReport], cruise: Cruise, dark: tuple[float, float] | None = None) -> dict[str, float]:
    """When the camera makes each report on this carriage motion (inf: not on it); ``dark``
    ``(t, seconds)``: what it would report then is reported when it is back."""
    moving = [r for r in reports if r.at_x is not None]
    ts = cruise.time_at(np.array([r.at_x for r in moving])) if moving else np.zeros(0)
    out = {r.id: float(t) + r.lag for r, t in zip(moving, ts)}
    out |= {r.id: r.lag for r in reports if r.at_x is None}
    if dark is not None:
        t0, t1 = dark[0], dark[0] + dark[1]
        out = {k: (t1 if t0 <= t < t1 else t) for k, t in out.items()}
    return out


def row_detections(problem: Problem, cruise: Cruise, opts: LiveRowOptions) -> list[RowDetection]:
    """The camera's reports with their times on ``cruise``, in time order."""
    times = report_times(row_reports(problem, opts), cruise)
    return sorted((RowDetection(r.id, r.position, max(0.0, times[r.id]), r.truth) for r in row_reports(problem, opts)),
                  key=lambda d: (d.t, d.id))


class _Run:
    """One live run's state: the reports, what is seen, the booker and the close-range sensor."""

    def __init__(self, problem: Problem, opts: LiveRowOptions, reports: list[RowReport], cruise: Cruise):
        self.problem, self.opts = problem, opts
        self.reports = {r.id: r for r in reports}
        self.truth_xy = {f.id: f.position for f in problem.fruits}
        self.rng = np.random.default_rng(opts.seed + 1)
        self.seen_problem = replace(problem, fruits=tuple(Fruit(r.id, r.position) for r in reports),
                                    name=f"{problem.name} (as seen)", source=None, digest=None)
        self.reach = row_reach(self.seen_problem)
        self.booker = Booker(self.seen_problem, cruise, {}, DEFAULT_RATE, opts.margin, self.reach.resolution)
        self.dark: tuple[float, float] | None = None
        self.seen: dict[str, float] = {}
        self.known: list[tuple[str, tuple[float, float]]] = []  # reports chosen so far (association)
        self.outcome: dict[str, str] = {}
        self.walls: list[float] = []
        self.misses: dict[str, str] = {}  # report -> why the grasp closed on nothing
        self.measured: set[str] = set()
        self.taken: set[str] = set()
        orig = self.booker.plan_cycle

        def timed(*a, **k):  # every decision's wall time (a decision is one or more cycle attempts)
            t = _time.perf_counter()
            out = orig(*a, **k)
            self.walls.append(_time.perf_counter() - t)
            return out

        self.booker.plan_cycle = timed
        self.set_cruise(cruise)

    def add_reports(self, reports: list[RowReport]) -> None:
        """Reports not known when the run began (a false burst at the carriage's position then)."""
        self.reports |= {r.id: r for r in reports}
        fruits = tuple(Fruit(r.id, r.position) for r in reports)
        self.seen_problem = replace(self.seen_problem, fruits=self.seen_problem.fruits + fruits)
        more = row_reach(replace(self.seen_problem, fruits=fruits), self.reach.resolution)
        self.reach.problem = self.seen_problem
        self.reach.cover |= more.cover
        self.reach.reasons |= more.reasons
        self.booker.problem = self.seen_problem
        self.booker.fruit_xy |= {r.id: r.position for r in reports}

    def set_cruise(self, cruise: Cruise, since: float = -math.inf) -> None:
        """The carriage's motion as now decided; the reports' times follow from it (those seen
        before ``since`` keep theirs), and so do the pick windows."""
        times = report_times(list(self.reports.values()), cruise, self.dark)
        self.seen = {k: (self.seen[k] if self.seen.get(k, math.inf) < since else t) for k, t in times.items()}
        self.booker.cruise = cruise
        windows = pick_windows(self.seen_problem, self.reach, cruise, self.problem.task.pick_dwell)
        self.booker.windows = {f: ws for f, ws in windows.items() if math.isfinite(self.seen[f])}  # reported on it

    def on_book(self, i: int, did: str, now: float) -> bool:
        d = self.reports[did]
        for other, xy in self.known:
            if other != did and math.dist(xy, d.position) < self.opts.merge:
                self.outcome.setdefault(f"report {did}", f"merged with {other} (within {self.opts.merge * 1000:g} mm)")
                return False
        self.known.append((did, d.position))
        claimed = {self.reports[e.fruit].truth for e in self.booker.events}
        if d.truth is None or d.truth in claimed:
            # the close-range sensor finds nothing there (a false report, or a fruit already taken):
            # the arm comes, looks and goes back -- a probe, no dwells
            self.booker.probes.add(did)
        elif did not in self.measured:  # it measures the fruit as the arm comes (once: a later choice
            # of it, after one that found no clear cycle, plans on the same measurement)
            self.measured.add(did)
            tx, ty = self.truth_xy[d.truth]
            xy = (tx + self.rng.normal(0, self.opts.close_sigma), ty + self.rng.normal(0, self.opts.close_sigma))
            self.booker.fruit_xy[did] = xy
            off = math.dist(xy, (tx, ty))
            if off > TIP_TOLERANCE - 1e-4:
                self.misses[did] = (f"missed: the close-range measurement was {off * 1000:.1f} mm off; the grasp "
                                    f"closed on nothing")
        return True

    def policy(self, **kw) -> dict[str, str]:
        return run_policy(self.booker, seen=self.seen, on_book=self.on_book, taken=self.taken, **kw)

    def pick_ends(self) -> list[float]:
        return [e.t_end for e in self.booker.events if e.kind == EventKind.PICK]


def run_live_row(problem: Problem, options: LiveRowOptions | None = None, progress=None) -> LiveRow:
    """Run the row live (module docstring) and verify what was executed against the truth."""
    if problem.gantry is None:
        raise ValueError(f"{problem.name!r} has no gantry: a live row needs a row")
    opts = options or LiveRowOptions()
    mode = GantryMode(opts.mode)
    if mode == GantryMode.AUTO:
        raise ValueError("mode: expected continuous or stop-and-go for a live row (a live planner runs one mode), found auto")
    g = problem.gantry
    reports = row_reports(problem, opts)
    t0 = _time.perf_counter()
    if mode == GantryMode.CONTINUOUS:
        if not 0.0 < opts.speed <= g.max_velocity:
            raise ValueError(f"speed: expected a cruising speed in (0, {g.max_velocity:g}] m/s, found {opts.speed:g}")
        offline = plan_continuous(problem, opts.speed, MovingOptions(profile=SpeedProfile.CONSTANT, assign=AssignRule.GREEDY,
                                                                     margin=opts.margin), None, progress)
        # the carriage does not know where the last fruit is: it cruises to the end of the rail
        cruise = Cruise.of(problem, opts.speed, g.end)
        faults = _Faults(problem, opts, cruise.duration, cruise)
        run = _Run(problem, opts, reports + faults.burst, cruise)
        t0 = _time.perf_counter()
        left, cruise, stops = _on_the_move(run, faults, cruise), run.booker.cruise, None
    else:
        from .plan import RowOptions, plan_row

        offline = plan_row(problem, RowOptions(), progress)
        faults = _Faults(problem, opts, float(offline.plan.metrics.get("makespan") or 0.0), None)
        run = _Run(problem, opts, reports, Cruise.hops(problem, []))
        t0 = _time.perf_counter()
        left, stops = _stop_and_go(run, faults)
        cruise = run.booker.cruise
    planning = _time.perf_counter() - t0
    return _finish(problem, opts, run, faults, left, cruise, offline, planning, stops)


class _Faults:
    """The faults' draws (:class:`RowFaults`) and a log of what happened when, and what it cost."""

    def __init__(self, problem: Problem, opts: LiveRowOptions, T: float, cruise: Cruise | None):
        f = opts.faults
        self.halt: dict[int, float] = {}
        self.log: dict = {}
        self.delay = None
        self.burst: list[RowReport] = []
        self.burst_at: float | None = None
        self.dark: tuple[float, float] | None = None
        if not f.any:
            return
        rng = np.random.default_rng(opts.seed + 7919)

        def when() -> float:
            return round(float(rng.uniform(0.2, 0.8) * T), 2)

        if f.arm_stop:
            a, t = int(rng.integers(len(problem.arms))), when()
            self.halt[a] = t
            self.log["arm_stop"] = {"arm": problem.arms[a].name, "t": t}
        if f.camera_dark > 0:
            t = when()
            self.dark = (t, float(f.camera_dark))
            self.log["camera_dark"] = {"t": t, "seconds": f.camera_dark}
        if f.false_burst > 0:
            t = when()
            self.burst_at = t
            self._rng_burst = rng.uniform(0.0, 1.0, (f.false_burst, 2))
            self._width = max(4, len(str(f.false_burst)))
            self.log["false_burst"] = {"t": t, "reports": f.false_burst}
            if cruise is not None:
                self.burst = self.burst_reports(problem, opts, float(cruise.x(np.array([t]))[0]), t)
        if f.late_replan > 0:
            t, fired = when(), []
            log = self.log

            def delay(arm: int, now: float) -> float:
                if fired or now < t:
                    return 0.0
                fired.append((arm, now))
                log["late_replan"]["arm"], log["late_replan"]["decided_at"] = problem.arms[arm].name, now
                return f.late_replan

            self.delay = delay
            self.log["late_replan"] = {"t": t, "seconds": f.late_replan}

    def burst_reports(self, problem: Problem, opts: LiveRowOptions, c: float, t: float) -> list[RowReport]:
        """The burst's false reports, within the camera's view with the carriage at ``c``, at ``t``."""
        front = _front(problem)
        ys = [fr.position[1] for fr in problem.fruits] or [1.0]
        y0, y1 = min(ys), max(ys)
        return [RowReport(f"b{k + 1:0{self._width}d}", (round(c + front + u * opts.look_ahead, 6), round(y0 + v * (y1 - y0), 6)),
                          None, t, None) for k, (u, v) in enumerate(self._rng_burst)]


def _on_the_move(run: _Run, faults: _Faults, cruise: Cruise) -> dict[str, str]:
    """The row on the move: booked in phases, the carriage's motion changed at each fault that
    changes it (an arm stop: slower; the camera dark: a hold), always once every pick booked
    before is over, so that every booked cycle stays exact."""
    problem, opts, g = run.problem, run.opts, run.problem.gantry
    run.dark = faults.dark
    run.set_cruise(cruise)
    halt, delay = faults.halt, faults.delay
    changes = sorted([(t, "arm_stop") for t in halt.values()] + ([(faults.dark[0], "camera_dark")] if faults.dark else []))
    stretches: list[tuple] = [(math.inf, opts.speed)]
    n = len(problem.arms)
    booker_dt = run.booker.dt
    for t_c, kind in changes:
        run.policy(halt=halt, delay=delay, until=t_c)
        t_s = max([t_c] + run.pick_ends())
        v = stretches[-1][1]
        # a change begins at cruising speed: past any ramp under way (or the carriage is stopping anyway)
        while t_s < cruise.duration and abs(float(cruise.state(np.array([t_s]))[1][0]) - v) > 1e-9:
            t_s += booker_dt
        x_s = float(cruise.x(np.array([t_s]))[0])
        if x_s >= cruise.x1 - 1e-6 or t_s >= cruise.duration:
            continue
        if kind == "arm_stop":
            slow = opts.speed * STOP_SLOWDOWN * (n - len(halt)) / n
            if slow <= 0:
                continue
            stretches = stretches[:-1] + [(x_s, v), (math.inf, slow)]
            faults.log["arm_stop"].update({"carriage_slows_at": round(t_s, 3), "to_speed": slow})
        else:
            back = faults.dark[0] + faults.dark[1]
            hold = back - (t_s + ramp_time(v, 0.0, g.max_acceleration, g.max_jerk))
            if hold <= 0:
                faults.log["camera_dark"]["carriage"] = "kept moving: the camera was back before it could come to rest"
                continue
            stretches = stretches[:-1] + [(x_s, v, hold), (math.inf, v)]
            faults.log["camera_dark"].update({"carriage_holds_from": round(t_s, 3), "hold_seconds": round(hold, 3)})
        new = Cruise.shaped(problem, stretches, g.end)
        ts = np.linspace(0.0, t_s, 2001)
        if float(np.max(np.abs(new.x(ts) - cruise.x(ts)))) > 1e-9:  # never: the change begins after t_s
            raise RuntimeError(f"the carriage's motion changed before t = {t_s:.2f} s")
        cruise = new
        run.set_cruise(cruise, since=t_s)
    return run.policy(halt=halt, delay=delay)


def _stop_and_go(run: _Run, faults: _Faults) -> tuple[dict[str, str], list[dict]]:
    """The row stop by stop (module docstring): book every fruit seen that the arms reach from
    this stop, then hop to the next once the last pick is over."""
    problem, opts, g = run.problem, run.opts, run.problem.gantry
    reach, grid = run.reach, run.reach.grid
    front, rear = _front(problem), min(a.base[0] for a in problem.arms)
    far = g.end + max(a.base[0] + a.reach for a in problem.arms)  # no arm reaches a fruit beyond this
    run.dark = faults.dark
    legs: list[tuple[float, float]] = []
    inset = int(math.ceil(2.0 * opts.sigma / reach.resolution - 1e-9))
    k, t_arr = 0, 0.0
    stops: list[dict] = []
    while True:
        if faults.burst_at is not None and not faults.burst and faults.burst_at <= t_arr:
            faults.burst = faults.burst_reports(problem, opts, float(grid[k]), t_arr)
            faults.log["false_burst"]["at_stop_x"] = round(float(grid[k]), 3)
            run.add_reports(faults.burst)
        run.set_cruise(Cruise.hops(problem, legs))
        # picks only with the carriage at rest here: windows from the arrival on, for as long as
        # the arms could need to harvest everything in reach (a fruit none can book by then waits
        # for the next stop, or is left out)
        here = {f: [w for w in ws if w.hi >= t_arr] for f, ws in run.booker.windows.items()}
        until = t_arr + STOP_PATIENCE * (1 + sum(bool(ws) for ws in here.values()))
        run.booker.windows = {f: [replace(w, lo=max(w.lo, t_arr), hi=min(w.hi, until)) for w in ws] for f, ws in here.items()}
        before = len(run.booker.events)
        run.policy(halt=faults.halt, delay=faults.delay, make_way=True)
        picks = [e for e in run.booker.events[before:] if e.kind == EventKind.PICK]
        t_dep = max([t_arr] + [e.t_end for e in picks])
        stops.append({"x": round(float(grid[k]), 4), "arrive": round(t_arr, 3), "depart": round(t_dep, 3), "picks": len(picks)})
        nxt = None
        while nxt is None:
            # what the camera has seen by the departure: up to its view then (or when it went dark)
            t_view = t_dep if faults.dark is None or not faults.dark[0] <= t_dep < sum(faults.dark) else faults.dark[0]
            edge = float(run.booker.cruise.x(np.array([t_view]))[0]) + front + opts.look_ahead
            # an unseen fruit lies at or beyond the edge: the rear arm serves it at least until the
            # carriage puts that arm's base under it, so a hop up to there passes none
            cap = min(grid.size - 1, int(math.floor((edge - rear - g.start) / reach.resolution + 1e-9)))
            ends = []
            for f, t in run.seen.items():
                if t > t_dep or f in run.taken or f not in reach.cover:
                    continue
                ks = reach.stops_of(f)
                ahead = ks[ks > k]
                if ahead.size:
                    gaps = np.flatnonzero(np.diff(ahead) > 1)
                    run_end = int(ahead[gaps[0]] if gaps.size else ahead[-1])
                    # inside the run's end by two sigma of the camera's noise (the close-range
                    # measurement may move the fruit by that much), if the run is that long
                    ends.append(max(int(ahead[0]), run_end - inset))
            if k >= grid.size - 1 or (not ends and edge >= far):
                nxt = k  # the end of the rail, or nothing left anywhere ahead
            elif min(ends + [cap]) > k:
                todo = [f for f, t in run.seen.items() if t <= t_dep and f not in run.taken and f in reach.cover]
                nxt = _next_stop(run.seen_problem, reach, todo, k, min(ends + [cap]), set(faults.halt))
            elif faults.dark is not None and t_dep < sum(faults.dark):
                faults.log["camera_dark"]["carriage_waits_at"] = round(float(grid[k]), 3)
                t_dep = sum(faults.dark)  # nothing seen ahead: wait for the camera
            else:
                nxt = k + 1
        if nxt == k:
            break
        legs.append((t_dep, float(grid[nxt])))
        k = nxt
        t_arr = Cruise.hops(problem, legs).duration
    for i in range(len(problem.arms)):
        if i not in faults.halt:
            run.booker.go_home(i)
    windows = pick_windows(run.seen_problem, reach, run.booker.cruise, problem.task.pick_dwell)
    run.booker.windows = windows
    left = {f: why_left(run.booker, f, faults.halt) for f in windows if f not in run.taken}
    return left, stops


def _next_stop(problem: Problem, reach, todo: list[str], k: int, k_max: int, stopped: set[int]) -> int:
    """The next stop in ``(k, k_max]`` (grid indices; none beyond ``k_max`` passes a fruit): the
    least estimated time per fruit -- the hop (time-optimal) and the stop's busiest arm, the
    fruit it serves balanced over the working arms (fewest options first, each where it
    lengthens the stop least) at their time-optimal bin -> fruit -> bin round trips
    (:func:`coplan.row.stops.round_trips`). With nothing to harvest on the way, ``k_max``."""
    from .stops import round_trips

    g = problem.gantry
    ks = np.arange(k + 1, k_max + 1)
    trips = round_trips(problem, reach, todo, ks) if todo else {}
    by_k: dict[int, dict[str, list[tuple[float, int]]]] = {}
    for (f, kk, a), c in trips.items():
        if a not in stopped:
            by_k.setdefault(kk, {}).setdefault(f, []).append((c, a))
    x0 = float(reach.grid[k])
    best = (math.inf, k_max)
    for kk, fr in by_k.items():
        load = [0.0] * len(problem.arms)
        for f, opts in sorted(fr.items(), key=lambda it: (len(it[1]), it[0])):
            c, a = min(opts, key=lambda o: (max(load[o[1]] + o[0], max(load)), o[0], o[1]))
            load[a] += c
        hop = Move1D.between(x0, float(reach.grid[kk]), g.max_velocity, g.max_acceleration, g.max_jerk).duration
        best = min(best, ((hop + max(load)) / len(fr), -kk))
    return -best[1] if math.isfinite(best[0]) else k_max


def _finish(problem: Problem, opts: LiveRowOptions, run: _Run, faults: _Faults, left: dict[str, str], cruise: Cruise,
            offline, planning: float, stops: list[dict] | None) -> LiveRow:
    """The executed plan (events on the true fruit), verified against the truth, and the metrics."""
    from ..verify.row import row_reachable_ids
    from ..verify.verifier import verify

    booker, by_id, halt = run.booker, run.reports, faults.halt
    # the events name the true fruit (a probe's cycle has none: the arm found nothing there; nor
    # has a grasp that closed on nothing)
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
    plan = assemble_moving(problem, booker, cruise)
    ver = verify(problem, plan)
    plan = finalize_plan(plan, ver, len(row_reachable_ids(problem)))
    got = {e.fruit for e in events if e.kind == EventKind.PLACE}
    ref = {e.fruit for e in offline.plan.events if e.kind == EventKind.PLACE}
    outcome = run.outcome
    for f in problem.fruits:
        outcome[f.id] = "harvested" if f.id in got else "missed"
    for did, why in (left | run.misses).items():
        if by_id[did].truth is not None and by_id[did].truth not in got:
            outcome[by_id[did].truth] = why if why.startswith("missed") else f"missed: {why}"
    windows = booker.windows
    working = [a for a in range(len(problem.arms)) if a not in halt]
    stopped_at = min(halt.values(), default=math.inf)
    seen = run.seen
    # missed though a working arm could still reach it: a window of a working arm open after the
    # stop (and after the report) with a pick pose clear of the stopped arm where it rests
    missed_reachable = sorted({by_id[d].truth for d, ws in windows.items() if by_id[d].truth is not None
                               and by_id[d].truth not in got and d not in run.misses
                               and any(w.arm in working and w.hi >= seen[d] and (w.hi >= stopped_at or not halt)
                                       and _clear_of_stopped(booker, w, run.truth_xy[by_id[d].truth], halt) for w in ws)})
    span = float(plan.metrics.get("makespan") or 0.0)
    ref_span = float(offline.plan.metrics.get("makespan") or 0.0)
    pick_start = {(e.arm, e.fruit): e.t_start for e in events if e.kind == EventKind.PICK}
    cycles = [e.t_end - pick_start[(e.arm, e.fruit)] for e in events if e.kind == EventKind.PLACE]
    walls = run.walls
    dets = sorted((RowDetection(r.id, r.position, max(0.0, seen.get(r.id, math.inf)), r.truth) for r in by_id.values()
                   if math.isfinite(seen.get(r.id, math.inf))), key=lambda d: (d.t, d.id))
    mode = GantryMode(opts.mode)
    metrics = {
        "mode": mode.value,
        "harvested": len(got), "offline_harvested": len(ref), "of_offline": len(got & ref) / len(ref) if ref else None,
        "harvested_not_offline": len(got - ref), "row_time": span, "offline_row_time": ref_span,
        "row_time_ratio": span / ref_span if ref_span > 0 else None,
        "reports": len(dets), "false_reports": sum(d.truth is None for d in dets), "probes": len(booker.probes),
        "merged": sum(1 for k in outcome if k.startswith("report ")), "grasps_on_nothing": len(run.misses),
        "decisions": len(walls), "decision_max_seconds": max(walls, default=0.0),
        "decision_mean_seconds": float(np.mean(walls)) if walls else 0.0,
        "shortest_cycle_seconds": min(cycles, default=None), "planning_seconds": planning,
        "kept_ahead": bool(walls) and (not cycles or max(walls) < min(cycles)),
        "faults": faults.log, "missed_reachable_by_a_working_arm": missed_reachable,
        "verified": ver.passed, "speed": opts.speed if mode == GantryMode.CONTINUOUS else None,
        "stops": len(stops) if stops is not None else None, "look_ahead": opts.look_ahead, "sigma": opts.sigma,
        "false_rate": opts.false_rate, "seed": opts.seed,
    }
    row = {"mode": f"{mode.value}-live", "left_out": {k: v for k, v in outcome.items() if v != "harvested"}}
    if mode == GantryMode.CONTINUOUS:
        row["speed"] = opts.speed
    else:
        row["stops"] = stops
    plan.solver = {"status": plan.status.value, "row": row, "live": metrics}
    return LiveRow(plan, ver, offline, dets, outcome, metrics)


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
