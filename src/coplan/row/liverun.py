"""One live row's state (:func:`coplan.row.live.run_live_row`): the camera's reports, what is
seen when, the booker that books every arm's cycles, and the close-range sensor that measures a
fruit as an arm approaches it (a false report, or a second report of a fruit taken, costs a
probe). :meth:`LiveRun.set_cruise` keeps the reports' times and the pick windows in step with
the carriage's motion as it is decided."""

from __future__ import annotations

import math
import time as _time
from dataclasses import replace

import numpy as np

from ..allocate.screen import TIP_TOLERANCE
from ..kinds import GantryMode
from ..plan import DEFAULT_RATE, EventKind
from ..problem.model import Fruit, Problem
from .booking import PATIENCE, Booker
from .policy import run_policy
from .cruise import Cruise, pick_windows
from .reach import robust_end, row_reach
from .sensing import LiveRowOptions, RowReport, report_times

__all__ = ["LiveRun", "RAIL_END_SIGMAS"]

#: On the move, a report near the edge of an arm's reach at the rail's end gets a deadline where
#: the arm stops serving it wherever within this many sigma of the report the fruit truly is.
RAIL_END_SIGMAS = 3.0


class LiveRun:
    """One live run's state: the reports, what is seen, the booker and the close-range sensor."""

    def __init__(self, problem: Problem, opts: LiveRowOptions, reports: list[RowReport], cruise: Cruise,
                 dark: tuple[float, float] | None = None):
        self.problem, self.opts = problem, opts
        self.reports = {r.id: r for r in reports}
        self.truth_xy = {f.id: f.position for f in problem.fruits}
        self.rng = np.random.default_rng(opts.seed + 1)
        self.seen_problem = replace(problem, fruits=tuple(Fruit(r.id, r.position) for r in reports),
                                    name=f"{problem.name} (as seen)", source=None, digest=None)
        self.reach = row_reach(self.seen_problem)
        self.booker = Booker(self.seen_problem, cruise, {}, DEFAULT_RATE, opts.margin, self.reach.resolution)
        self.dark = dark  # (t, seconds) the camera reports nothing, or None
        self.seen: dict[str, float] = {}
        self.known: list[tuple[str, tuple[float, float]]] = []  # reports chosen so far (association)
        self.outcome: dict[str, str] = {}
        self.walls: list[float] = []  # every cycle decision's wall time, s
        self.cells: list[tuple[float, float]] = []  # a live stop's cell plan (stop and go): (wall time, lead), s
        self.misses: dict[str, str] = {}  # report -> why the grasp closed on nothing
        self.unseen: dict[str, str] = {}  # report -> why the close-range camera found nothing there (its fruit too far off)
        self.measured: set[str] = set()
        self.taken: set[str] = set()
        self.holds: list[dict] = []  # on the move: where the carriage held for fruit
        self.ends: dict[tuple[str, int], int | None] = {}  # (report, arm) -> robust_end at the rail's end
        self.deadlined: set[tuple[str, int]] = set()  # (report, arm) whose window at rest has a twin with a deadline
        # (report, arm) -> when a try found no clear cycle in the window (the neighbours' booked
        # motion in the way until it closed), on the carriage's motion as now decided: a hold
        # changes the windows, and these are forgotten (:meth:`set_cruise`)
        self.refused: dict[tuple[str, int], float] = {}
        self.waited: set[tuple[str, int]] = set()  # (report, arm) an arm waited on for a hold (:func:`coplan.row.live`)
        orig = self.booker.plan_cycle

        def timed(i, fid, w, t_from, tuck=False):  # every decision's wall time (a decision is one or more cycle attempts)
            t = _time.perf_counter()
            out = orig(i, fid, w, t_from, tuck)
            self.walls.append(_time.perf_counter() - t)
            if out is None and t_from + PATIENCE >= w.hi:  # (every pick time left in the window tried)
                self.refused[(fid, i)] = t_from
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
        self.refused.clear()
        self.waited.clear()
        times = report_times(list(self.reports.values()), cruise, self.dark)
        self.seen = {k: (self.seen[k] if self.seen.get(k, math.inf) < since else t) for k, t in times.items()}
        self.booker.cruise = cruise
        windows = pick_windows(self.seen_problem, self.reach, cruise, self.problem.task.pick_dwell)
        windows = {f: ws for f, ws in windows.items() if math.isfinite(self.seen[f])}  # reported on it
        if GantryMode(self.opts.mode) == GantryMode.CONTINUOUS:
            windows = {f: self.rail_end(f, ws, cruise) for f, ws in windows.items()}
        self.booker.windows = windows

    def rail_end(self, fid: str, ws: list, cruise: Cruise) -> list:
        """On the move the carriage comes to rest for good at the rail's end; a window open there
        (``hi`` inf) on a report near the edge of the arm's reach gets a twin that closes where the
        arm stops serving the fruit wherever within ``RAIL_END_SIGMAS`` sigma of the report it truly
        is (:func:`coplan.row.reach.robust_end`): the deadline the policy orders it by. The
        at-rest window is kept (the report may be off the other way)."""
        out = []
        grid = self.reach.grid
        for w in ws:
            if math.isinf(w.hi):
                key = (fid, w.arm)
                if key not in self.ends:
                    k_lo, k_hi = (int(np.searchsorted(grid, c - 1e-9)) for c in (w.c_lo, w.c_hi))
                    self.ends[key] = robust_end(self.seen_problem, self.reach, self.reports[fid].position, w.arm,
                                                k_lo, k_hi, RAIL_END_SIGMAS * self.opts.sigma)
                k = self.ends[key]
                x = cruise.x1 if k is None else float(grid[k])  # (robust nowhere: by the carriage's arrival)
                if x < cruise.x1 - 1e-9 or k is None:
                    hi = float(cruise.time_at(np.array([x]))[0]) - self.problem.task.pick_dwell
                    if hi >= w.lo:
                        out.append(replace(w, hi=hi, c_hi=x))
                        self.deadlined.add(key)
            out.append(w)
        return out

    def on_book(self, i: int, did: str, now: float) -> bool:
        d = self.reports[did]
        for other, xy in self.known:
            if other != did and math.dist(xy, d.position) < self.opts.merge:
                self.outcome.setdefault(f"report {did}", f"merged with {other} (within {self.opts.merge * 1000:g} mm)")
                return False
        self.known.append((did, d.position))
        claimed = {self.reports[e.fruit].truth for e in self.booker.events}
        away = math.dist(self.truth_xy[d.truth], d.position) if d.truth is not None else 0.0
        far = d.truth is not None and d.truth not in claimed and away > self.opts.close_distance  # (a fruit taken: nothing anyway)
        if d.truth is None or d.truth in claimed or far:
            # the close-range sensor finds nothing there (a false report, a fruit already taken, or
            # one the report put farther off than the gripper camera sees): the arm comes, looks and
            # goes back -- a probe, no dwells
            self.booker.probes.add(did)
            if far:
                self.unseen[did] = (f"missed: reported {away * 1000:.0f} mm from the "
                                    f"fruit, farther than the close-range camera sees ({self.opts.close_distance * 1000:g} mm): "
                                    f"the arm found nothing there")
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
