"""What a live row is told and what goes wrong: the simulated camera's reports and the faults.

* :func:`row_reports` -- the camera's reports over the whole row (seeded): each fruit when the
  carriage brings it within ``look_ahead`` m ahead of the front arm's base, with Gaussian noise,
  false and repeated reports; :func:`report_times` -- when each is made, on the carriage's
  motion as it is decided (a camera outage delays what it would have seen until it is back).
* :class:`RowFaults` (the options) and :class:`FaultDraws` (their seeded times, and a log of
  what happened and what it cost).

Used by :mod:`coplan.row.live`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import Issue, OptionsError, check_fields, known_fields
from ..kinds import GantryMode, LiveGantryMode
from ..plan import MAX_PLAN_BYTES
from ..problem.gantry import top_speed_issues
from ..problem.model import Problem
from ..problem.plausible import plan_seconds_limit
from .cruise import Cruise

__all__ = ["MAX_FALSE_BURST", "MAX_FAULT_SECONDS", "MAX_LOOK_AHEAD", "MAX_SIGMA", "RowFaults", "LiveRowOptions", "RowDetection", "RowReport", "FaultDraws", "front_base", "row_reports", "check_fault_room",
           "report_times", "row_detections"]


#: The largest false burst a run takes: 20 x the 50 of the fault benchmark (1000 on sparse_row,
#: stop and go: 6.2 s and 180 MB; 5000: 46 s and 370 MB; 100000 grew to 2.2 GB).
MAX_FALSE_BURST = 1000
#: The longest camera outage or late decision a run takes, s (as ``coplan run`` takes them).
MAX_FAULT_SECONDS = 3600.0
#: The farthest the camera may see ahead of the front arm's base, m, and the largest detection
#: noise, m per coordinate (as ``coplan run`` takes them).
MAX_LOOK_AHEAD = 100.0
MAX_SIGMA = 1.0


@known_fields
@dataclass(frozen=True)
class RowFaults:
    """Things that go wrong during a live row, each at a time drawn from the run's seed (between
    20 % and 80 % of the carriage's run; stop and go: of the offline plan's row time), so that a
    run can be replayed.

    arm_stop : one arm (drawn) reports a controller fault: it finishes the motion in progress and
        stays where it then rests, an obstacle; its fruit go to the neighbours that reach them (on
        the move the carriage slows; stop and go, a hop under way brakes to the nearest stop from
        which they do)
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

    def __post_init__(self) -> None:
        check_fields(self)  # built in Python: every value checked (OptionsError: what was expected, found)
        issues = [Issue(name, f"expected at most {MAX_FAULT_SECONDS:g} s, found {getattr(self, name)!r}")
                  for name in ("camera_dark", "late_replan") if getattr(self, name) > MAX_FAULT_SECONDS]
        if self.false_burst > MAX_FALSE_BURST:
            issues.append(Issue("false_burst", f"expected at most {MAX_FALSE_BURST} false reports at one instant, "
                                               f"found {self.false_burst}"))
        if issues:
            raise OptionsError(issues, type(self).__name__)

    @property
    def any(self) -> bool:
        return self.arm_stop or self.camera_dark > 0 or self.false_burst > 0 or self.late_replan > 0


@known_fields
@dataclass(frozen=True)
class LiveRowOptions:
    """The camera and the live planner (separate from the problem)."""

    speed: float = 0.1  # m/s, the carriage's cruising speed (on the move)
    look_ahead: float = 1.5  # m ahead of the front arm's base the camera sees
    sigma: float = 0.01  # m, detection noise per coordinate
    false_rate: float = 0.05  # false reports, as a share of the fruit
    duplicate_rate: float = 0.02  # fruit reported twice
    close_sigma: float = 0.001  # m, the close-range measurement's noise per coordinate
    close_distance: float = 0.1  # m: the gripper camera sees a fruit this close to where the arm goes (the report)
    merge: float = 0.0  # m: a report this close to an earlier one is the same fruit (0: none merged; a
    # second report of a picked fruit then costs a probe -- in trusses, distinct fruit lie closer than
    # two noisy reports of one)
    seed: int = 0
    margin: float = 0.02  # m beyond the clearance, as for the offline plan
    faults: RowFaults = field(default_factory=RowFaults)
    mode: GantryMode = GantryMode.CONTINUOUS  # continuous or stop-and-go
    hold_for_fruit: bool = True  # on the move: hold rather than pass a reported fruit no working arm can still book

    def __post_init__(self) -> None:
        # a live planner runs one mode: its choices, not the gantry's three ("stop and go" was told
        # "expected one of 'stop-and-go', 'continuous', 'auto'", and auto then refused)
        live = tuple(m.value for m in LiveGantryMode)
        mode = [] if self.mode in live else [Issue("mode", (
            "expected continuous or stop-and-go for a live row (a live planner runs one mode), found auto"
            if self.mode == GantryMode.AUTO.value else
            f"expected one of {', '.join(repr(m) for m in live)} for a live row, found {self.mode!r}"))]
        if isinstance(self.speed, str) and self.speed.strip().lower() == "auto":  # (the CLI's word: said where to find it)
            raise OptionsError(mode + [Issue("speed", "expected a cruising speed in m/s, found 'auto': the speed `coplan "
                                                       "run --speed auto` takes is coplan.row.moving.live_speed(problem)[0]")],
                               "LiveRowOptions")
        check_fields(self, {'look_ahead', 'speed'}, found=mode)  # built in Python: every value checked (OptionsError: what was expected, found)
        issues = [Issue(name, f"expected a share of the fruit from 0 to 1, found {getattr(self, name):g}")
                  for name in ("false_rate", "duplicate_rate") if getattr(self, name) > 1.0]
        issues += [Issue(name, f"expected at most {top:g} m, found {getattr(self, name)!r}")
                   for name, top in (("look_ahead", MAX_LOOK_AHEAD), ("sigma", MAX_SIGMA), ("close_sigma", MAX_SIGMA))
                   if getattr(self, name) > top]
        issues += top_speed_issues("speed", self.speed, "run")
        if not 0.005 <= self.close_distance <= 1.0:  # (a feed file's close_range.distance range)
            issues.append(Issue("close_distance", f"expected a number in [0.005, 1] m, found {self.close_distance!r}"))
        if not isinstance(self.faults, RowFaults):
            issues.append(Issue("faults", f"expected RowFaults(...), found {type(self.faults).__name__} {self.faults!r}"))
        if issues:
            raise OptionsError(issues, "LiveRowOptions")


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


def front_base(problem: Problem) -> float:
    return max(a.base[0] for a in problem.arms)


def row_reports(problem: Problem, opts: LiveRowOptions) -> list[RowReport]:
    """The camera's reports over the whole row (module docstring), in the order it makes them."""
    rng = np.random.default_rng(opts.seed)
    front = front_base(problem)
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
    reports = row_reports(problem, opts)
    times = report_times(reports, cruise)
    return sorted((RowDetection(r.id, r.position, max(0.0, times[r.id]), r.truth) for r in reports),
                  key=lambda d: (d.t, d.id))


class FaultDraws:
    """The faults' draws (:class:`RowFaults`) and a log of what happened when, and what it cost."""

    def __init__(self, problem: Problem, opts: LiveRowOptions, T: float, cruise: Cruise | None, locked=()):
        """``locked``: names of the arms the screen locks (they never work): the arm that stops
        is drawn among the others (the same draw as before where none is locked)."""
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
            working = [i for i, arm in enumerate(problem.arms) if arm.name not in set(locked)] or list(range(len(problem.arms)))
            a, t = working[int(rng.integers(len(working)))], when()
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
                log["late_replan"].update({"arm": problem.arms[arm].name, "decided_at": round(now, 3),
                                           "waits_until": round(now + f.late_replan, 3)})  # (the first decision at or after t)
                return f.late_replan

            self.delay = delay
            self.log["late_replan"] = {"t": t, "seconds": f.late_replan}

    def burst_reports(self, problem: Problem, opts: LiveRowOptions, c: float, t: float) -> list[RowReport]:
        """The burst's false reports, within the camera's view with the carriage at ``c``, at ``t``."""
        front = front_base(problem)
        ys = [fr.position[1] for fr in problem.fruits] or [1.0]
        y0, y1 = min(ys), max(ys)
        return [RowReport(f"b{k + 1:0{self._width}d}", (round(c + front + u * opts.look_ahead, 6), round(y0 + v * (y1 - y0), 6)),
                          None, t, None) for k, (u, v) in enumerate(self._rng_burst)]


def check_fault_room(problem: Problem, opts: LiveRowOptions, seconds: float, stop_slowdown: float) -> None:
    """Refuse faults that would make the executed plan longer than the longest plan coplan makes
    (:func:`coplan.problem.plausible.plan_seconds_limit`: its file must read back), before any
    work: the fault-free run (``seconds``: the offline plan's, or the live carriage's cruise),
    slowed as after an arm stops from the start (the working arms' carriage speed falls by
    ``stop_slowdown`` per arm share), plus the outage and the late decision in full."""
    f = opts.faults
    if not (f.arm_stop or f.camera_dark or f.late_replan):
        return
    n = len(problem.arms)
    slow = 1.0 / (stop_slowdown * (n - 1) / n) if f.arm_stop and n > 1 else 1.0
    need = 1.05 * seconds * slow + f.camera_dark + f.late_replan  # (5 %: the arms' last cycles, holds)
    limit = plan_seconds_limit(problem)
    if need > limit:
        raise OptionsError([Issue("faults", f"expected faults whose run fits in {limit:.0f} s (the longest plan coplan makes "
                                            f"with {n} arms on a row, its file under {MAX_PLAN_BYTES >> 20} MiB), found "
                                            f"a run that may take {need:.0f} s: {seconds:.0f} s without faults"
                                            f"{f' (x {slow:.1f} after an arm stops)' if slow > 1 else ''}, "
                                            f"{f.camera_dark:g} s of camera outage and a decision {f.late_replan:g} s late")],
                           "LiveRowOptions")
