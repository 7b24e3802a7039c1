"""Pick on the move, the speed chosen: :func:`plan_moving` (the row's entry point on the move)
plans at a given level, or searches for the level (:func:`speed_search`: each candidate a full,
verified plan of :func:`coplan.row.continuous.plan_continuous`, side by side in worker
processes) that maximises fruit per hour while harvesting every harvestable fruit.
"""

from __future__ import annotations

import dataclasses
import enum
import math
import time as _time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ..errors import Issue, OptionsError
from ..kinds import AssignRule, PlanStatus, SpeedProfile
from ..plan import EventKind
from ..problem.model import Problem
from ..progress import speaker
from ..workers import process_pool
from .branches import branch_table, screen_branches
from .continuous import (MovingOptions, SpeedPoint, certify, cruise_issue, left_at_start, level_cap, make_cruise, plan_continuous,
                         planned_line, reorder_continuous, start_served)
from .cruise import STRETCH, EndRest, cruise_end, demand_stretches, last_place_bound
from .plan import RowResult, check_row_call
from .reach import RowReach, row_reach
from .starthold import start_hold

__all__ = ["plan_moving", "live_speed", "speed_search", "next_levels", "SEARCH_WIDTH"]

#: A refinement round raises a missed fruit's stretches' demand by this factor ...
REFINE_BUMP = 1.25
#: ... and pushes the level of a complete plan up by this one.
REFINE_PUSH = 1.06

class _Variant(enum.Enum):
    """The plans the speed search makes beside its levels, keyed ``(level, variant)`` among the
    levels it tried (a refinement round's key is ``(level, round)``)."""

    CPSAT = enum.auto()  # CP-SAT's order at the slowest level where the greedy missed fruit
    EARLY = enum.auto()  # the carriage's early rest at the end, at the best complete level
    RAIL = enum.auto()  # ... and its rest at the rail's end there


def _point(res: RowResult, seconds: float) -> SpeedPoint:
    m = res.plan.metrics
    span = float(m.get("makespan") or 0.0)
    got = int(m.get("harvested") or 0)
    return SpeedPoint(float(res.info["level"]), float(res.info["mean_speed"]), got, len(res.reach.cover), span, got * 3600.0 / span if span > 0 else 0.0,
                      bool(res.verification.passed), seconds, end_rest=str(res.info.get("end_rest", EndRest.REACH.value)))


def speed_search(problem: Problem, options: MovingOptions | None = None, reach: RowReach | None = None,
                 levels=None, progress: Callable[[str], None] | None = None) -> tuple[RowResult, list[SpeedPoint]]:
    """The level (speed, or pace) that maximises fruit per hour while harvesting every
    harvestable fruit (each candidate a full plan, verified for its verdict: :func:`certify`,
    its margins coarse), and the curve of the levels tried; the plan kept is verified in full.

    Fruit per hour rises with the level as long as every fruit is still harvested, so the search
    brackets the fastest complete level. Its top is at first the level where the carriage would
    take as long as the busiest arm's work (constant: the row's work bound, no faster plan
    harvests everything) or gives each stretch exactly its fruit's cheapest cycles (density: pace
    1), not planned: the first plans go from half of it up (:data:`SEARCH_WIDTH` levels a round,
    side by side with as many workers, one after the other with one: the same levels and plan for
    any number of workers), halving further
    until a plan is complete; then it bisects between the fastest complete and the slowest
    incomplete level (that top while no plan was incomplete), to 5 %; where every plan up to the
    top is complete, the top is planned too and the level grows by half while complete. With ``levels`` it plans exactly those
    (the curve) and returns the best. The winner: complete and verified first, then the most
    fruit per hour."""
    from ..allocate.row_bound import busiest_cycles

    opts = options or MovingOptions()
    reach = reach if reach is not None else row_reach(problem, opts.resolution)
    g = problem.gantry
    x1 = cruise_end(problem, reach)
    profile = SpeedProfile(opts.profile)
    demand = demand_stretches(problem, reach, x1) if profile == SpeedProfile.DENSITY else None
    cap = level_cap(problem, reach, profile, demand)
    # every candidate books the same arms on the same fruit: screen their elbow branches once, here
    # (before the workers fork, so that they inherit it)
    screen_branches(problem, reach.resolution, [(i, f) for f in reach.harvestable() for i in np.flatnonzero(reach.cover[f].any(axis=1)).tolist()],
                    branch_table(problem, reach.resolution))
    greedy = replace(opts, assign=AssignRule.GREEDY)  # the search's plans: CP-SAT only once, at its end
    interrupted = False
    with _Runner(problem, reach, demand, max(1, int(opts.workers)), progress) as runner:
        search = _Levels(runner, cap, greedy)
        tried = search.tried
        try:
            if levels is not None:
                search.run(list(levels))
            elif not reach.harvestable():  # nothing to harvest: one plan (the carriage stays where it starts)
                search.run([min(1.0, cap)])  # (a search tried three, one resting at the rail's end at 0.495 m/s)
            else:
                if profile == SpeedProfile.CONSTANT:
                    v = max(x1 - g.start, 0.05) / max(busiest_cycles(problem), 1e-3)
                else:
                    v = 1.0
                ok_v, bad_v = _bracket(search, min(v, cap), cap, opts.search_rounds)
                _last_tries(search, opts, ok_v, bad_v, x1, demand, progress)
        except KeyboardInterrupt:  # Ctrl-C / SIGTERM: the best verified plan so far is kept
            if not tried:
                raise
            interrupted = True
    pts = [p for _, p in tried.values()]
    best = max(tried, key=lambda v: _rank(tried[v][1]))
    # every candidate was screened (its margins coarse): the plan kept is verified in full, after a
    # Ctrl-C too (an interrupted search wrote its screened margin, 13.8 mm where coplan verify of the
    # file certified 20.2); a second Ctrl-C keeps the screened verdict, said in its report
    try:
        tried[best] = (certify(problem, tried[best][0]), tried[best][1])
    except KeyboardInterrupt:
        interrupted = True
        tried[best][0].info["margins_screened"] = ("interrupted as the kept plan was verified in full: its certified "
                                                   "margins are the speed search's screen, each pair's to within half its margin")
    if search.cpsat_report is not None:
        tried[best][0].info.setdefault("cpsat", search.cpsat_report)  # the search's CP-SAT step, whether kept or not
    if interrupted:
        tried[best][0].mark_interrupted()
        tried[best][0].info["interrupted"] = f"the speed search stopped after {len(tried)} plan{'' if len(tried) == 1 else 's'}: the best verified so far"
    return tried[best][0], pts


class _Levels:
    """The plans a speed search has made (``tried``: a level, or ``(level, variant)``, -> ``(result,
    point)``) and its way of making more (:meth:`run`)."""

    def __init__(self, runner: "_Runner", cap: float, greedy: MovingOptions):
        self.runner, self.cap, self.greedy = runner, cap, greedy
        self.tried: dict = {}
        self.served: set[str] | None = None  # (start_served: once, when a plan first leaves such a fruit out)
        self.cpsat_report: dict | None = None  # (CP-SAT's step, kept where a Ctrl-C comes after it)

    def run(self, vs) -> list[SpeedPoint]:
        """Full plans at levels ``vs`` (within the cap, to 4 decimals; each level planned once): their
        points. Where one leaves fruit only a carriage at rest where it starts can give time to, every
        plan from here rests there first (:func:`start_hold`), these too."""
        runner, reach = self.runner, self.runner.reach
        vs = [round(float(min(self.cap, max(v, 1e-3))), 4) for v in vs]
        todo = [v for v in dict.fromkeys(vs) if v not in self.tried]
        self._plan(todo)
        left = set() if runner.hold else {f for v in todo for f in left_at_start(reach, self.tried[v][0])}
        if left:  # fruit only the start serves, missed: every plan from here rests there first
            if self.served is None:
                self.served = start_served(runner.problem, reach)
            held = sorted(left & self.served)
            if held:
                runner.hold = start_hold(runner.problem, reach, held)
                self._plan(todo)
        return [self.tried[v][1] for v in vs]

    def _plan(self, todo: list[float]) -> None:
        """Plan levels ``todo`` with the runner's start hold as it is now, into ``tried``."""
        for v, (res, secs) in zip(todo, self.runner.map(todo, self.greedy)):
            self.tried[v] = (res, replace(_point(res, secs), start_hold=self.runner.hold))


def _bracket(search: _Levels, v: float, cap: float, rounds: int) -> tuple[float | None, float | None]:
    """:func:`speed_search`'s rounds from the starting level ``v``: ``(the fastest complete level,
    the slowest incomplete one above it)`` (None: none planned). The starting level is the
    bracket's top until a plan says otherwise: a faster carriage than the busiest arm's work (pace
    1) leaves fruit on every benchmark row, so it is planned only when the bracket closes below it
    with no incomplete plan."""
    ok_v, bad_v = None, None
    assumed: float | None = v
    w = SEARCH_WIDTH  # (not the workers: the levels tried, and so the plan, are the same for any)
    for _ in range(int(math.ceil(rounds / w))):
        batch, assumed = next_levels(v, cap, ok_v, bad_v, assumed, w)
        if batch is None:
            break
        for p in search.run(batch):
            if p.complete:
                ok_v = p.level if ok_v is None else max(ok_v, p.level)
            else:
                bad_v = p.level if bad_v is None else min(bad_v, p.level)
        if ok_v is not None and bad_v is not None and bad_v < ok_v:
            bad_v = None  # an incomplete plan below a complete one: not a bracket; go on up
    return ok_v, bad_v


def _last_tries(search: _Levels, opts: MovingOptions, ok_v: float | None, bad_v: float | None, x1: float, demand,
                progress) -> None:
    """After the bracket: CP-SAT's order at the slowest incomplete level, the rests at the row's end
    at the best complete level, and (a density profile) the refinement, all into ``search.tried``
    (CP-SAT's report into ``search.cpsat_report``)."""
    runner, tried, greedy = search.runner, search.tried, search.greedy
    if AssignRule(opts.assign) == AssignRule.CPSAT and bad_v is not None:
        # the slowest level at which the greedy missed fruit, once more with CP-SAT's order
        # started from the greedy's booking there (alongside the refinement when there is
        # a second worker)
        runner.reorder(bad_v, opts, list(tried[bad_v][0].plan.events), key=(bad_v, _Variant.CPSAT))
    # at the best complete level (the most fruit per hour: not always the fastest
    # complete one), the carriage's early rest at the end too (where the last
    # fruit first comes into reach: :func:`coplan.row.cruise.cruise_end`) and its rest at
    # the rail's end (the rear arms share the row's tail), the fastest plan kept; with
    # a second worker, alongside the refinement (one plan at a time)
    if ok_v is not None:
        best_v = max((k for k in tried if tried[k][1].complete), key=lambda k: _rank(tried[k][1]))
        runner.rest(best_v, greedy, EndRest.EARLY, key=(best_v, _Variant.EARLY))
        if x1 < runner.problem.gantry.end - 1e-9:  # (else the rail's end is where it rests already)
            runner.rest(best_v, greedy, EndRest.RAIL, key=(best_v, _Variant.RAIL))
    if demand is not None and bad_v is not None:
        _refine(runner.reach, demand, bad_v, tried, runner, greedy)
    for key, report in _collect(runner, tried, progress):
        if key[1] is _Variant.CPSAT:
            search.cpsat_report = report
    rail = tried.get((best_v, _Variant.RAIL)) if ok_v is not None else None
    if rail is not None and not rail[1].complete:
        # (resting at the rail's end, the tail runs at the row's pace: where that leaves
        # fruit at the best level, the next complete level down may still be faster)
        below = [k for k in tried if not isinstance(k, tuple) and k < best_v and tried[k][1].complete]
        if below:
            runner.rest(max(below), greedy, EndRest.RAIL, key=(max(below), _Variant.RAIL))
            _collect(runner, tried, progress)


def next_levels(start: float, cap: float, ok: float | None, bad: float | None, assumed: float | None,
                width: int) -> tuple[list[float] | None, float | None]:
    """The speed search's next round (:func:`speed_search`): ``width`` levels to plan, or None when
    the bracket is closed; and the assumed top after the round. ``start``: the starting level;
    ``cap``: the highest level; ``ok`` / ``bad``: the fastest complete and the slowest incomplete
    level so far (None: none yet); ``assumed``: the bracket's top while no plan is incomplete (the
    start, never planned unless every plan below it is complete; None once it has been).

    From half the start up to it; down by halves while nothing is complete; up by half again while
    nothing above is incomplete; then ``width`` points inside the bracket until it is within 5 %."""
    top = bad if bad is not None else assumed
    if ok is None and bad is None:
        return [start / 2.0 * (1.0 + k / width) for k in range(width)], assumed
    if ok is None:
        return [bad / 2.0 ** (k + 1) for k in range(width)], assumed
    if top is None:
        if ok >= cap:
            return None, assumed
        return [min(cap, ok * 1.5 ** (k + 1)) for k in range(width)], assumed
    if top - ok <= 0.05 * ok:
        if bad is not None:
            return None, assumed
        return [min(cap, top * 1.5 ** k) for k in range(width)], None  # complete up to the start: it too, and on up
    return [ok + (top - ok) * (k + 1) / (width + 1) for k in range(width)], assumed


def _collect(runner: "_Runner", tried: dict, progress) -> list[tuple]:
    """The plans made in the background (:meth:`_Runner.collect`) into ``tried``, each said as it
    is kept (CP-SAT's kept plan was never said); ``(key, report)`` for each."""
    out = []
    for key, ((res, report), secs) in runner.collect():
        if res is not None:
            speaker(progress)(planned_line(res))
            tried[key] = (res, replace(_point(res, secs), assign=res.info["assign"], start_hold=runner.hold))
        out.append((key, report))
    return out


#: levels the speed search plans a round (side by side with two workers or more): fixed, so
#: that ``--workers`` changes how long the search takes, never which plan it finds
SEARCH_WIDTH = 2


def _rank(p: SpeedPoint) -> tuple:
    """How the speed search ranks its plans: complete and verified first, then the most fruit
    harvested, then the most fruit per hour."""
    return p.complete, p.verified, p.harvested, p.fruit_per_hour


def _refine(reach: RowReach, demand, level: float, tried: dict, runner: "_Runner", opts: MovingOptions) -> None:
    """Slow down only where fruit were missed: from the slowest incomplete level, each round
    raises the demand of the stretches from which a missed fruit is served by ``REFINE_BUMP``
    and plans again; a complete plan pushes the level up by ``REFINE_PUSH``. Every round a full,
    verified plan (added to ``tried``, keyed apart from the plain levels). The refinement stops
    where its next cruise cannot place the last fruit sooner than a complete plan already does
    (:func:`coplan.row.cruise.last_place_bound`)."""
    d = list(demand)
    v = level
    res = tried[level][0]  # the plan at that level already says which fruit were missed
    for r in range(opts.refine_rounds + 1):
        if r > 0:
            best = min((p.row_time for _, p in tried.values() if p.complete), default=math.inf)
            cruise = make_cruise(runner.problem, reach, SpeedProfile.DENSITY, v, d, runner.hold)
            if last_place_bound(runner.problem, reach, cruise) >= best:
                break
            [(res, secs)] = runner.map([v], opts, d)
            p = replace(_point(res, secs), refined=True, start_hold=runner.hold)
            tried[(v, r)] = (res, p)
            if p.complete:
                v *= REFINE_PUSH
                continue
            if r == opts.refine_rounds:
                break
        got = {e.fruit for e in res.plan.events if e.kind == EventKind.PLACE}
        for fid in reach.harvestable():
            if fid in got:
                continue
            lo, hi = (float(reach.grid[k]) for k in reach.span(fid))
            d = [(x, dk * REFINE_BUMP if x > lo and x - STRETCH < hi else dk) for x, dk in d]


def _plan_job(problem: Problem, level: float, opts: MovingOptions, reach: RowReach, demand,
              hold: float = 0.0, rest: EndRest = EndRest.REACH) -> tuple[RowResult, float]:
    """One full plan in a worker process (module-level: it is pickled to the worker), screened."""
    t = _time.perf_counter()
    res = plan_continuous(problem, level, opts, reach, None, demand, hold, rest, screen=True)
    return res, _time.perf_counter() - t


def _rest_job(problem: Problem, level: float, opts: MovingOptions, reach: RowReach, demand, hold: float = 0.0,
              rest: EndRest = EndRest.EARLY):
    """:func:`plan_continuous` with the carriage at rest at the end as ``rest`` says, in a worker
    process: ``((result, None), seconds)``."""
    res, secs = _plan_job(problem, level, opts, reach, demand, hold, rest)
    return (res, None), secs


def _reorder_job(problem: Problem, level: float, opts: MovingOptions, reach: RowReach, demand, events, hold: float = 0.0):
    """:func:`reorder_continuous` in a worker process: ``((result or None, report), seconds)``."""
    t = _time.perf_counter()
    out = reorder_continuous(problem, level, opts, reach, demand, events, hold, screen=True)
    return out, _time.perf_counter() - t


class _Runner:
    """Full plans of the speed search, here (one worker) or in ``workers`` processes (the same
    plans as here, each deterministic in its inputs: the same input and N give the same plan);
    ``hold``: every plan's start hold (:func:`start_hold`)."""

    def __init__(self, problem: Problem, reach: RowReach, demand, workers: int, progress):
        self.problem, self.reach, self.demand, self.workers, self.progress = problem, reach, demand, workers, progress
        self.hold = 0.0
        self.pool = None
        self.pending: list = []

    def __enter__(self) -> "_Runner":
        self.pool = process_pool(self.workers)
        return self

    def __exit__(self, *exc) -> None:
        if self.pool is not None:
            self.pool.shutdown(wait=True, cancel_futures=True)

    def _demand(self, d):
        return self.demand if d is None else d

    def map(self, levels: list[float], opts: MovingOptions, demand=None) -> list[tuple[RowResult, float]]:
        if self.pool is None:
            out = []
            for v in levels:
                t = _time.perf_counter()
                out.append((plan_continuous(self.problem, v, opts, self.reach, self.progress, self._demand(demand), self.hold,
                                            screen=True), _time.perf_counter() - t))
            return out
        futures = [self.pool.submit(_plan_job, self.problem, v, opts, self.reach, self._demand(demand), self.hold)
                   for v in levels]
        out = [f.result() for f in futures]
        for res, _ in out:  # (a worker cannot reach the caller's progress: its lines come from here)
            speaker(self.progress)(planned_line(res))
        return out

    def _later(self, key, job, *args) -> None:
        """``job(problem, *args, ...)`` to collect later (:meth:`collect`): in the background with
        a second worker, else here and now."""
        args = (self.problem, *args)
        self.pending.append((key, job(*args) if self.pool is None else self.pool.submit(job, *args)))

    def reorder(self, level: float, opts: MovingOptions, events, key=None) -> None:
        """:func:`reorder_continuous` at ``level`` from the greedy's ``events``, to collect later
        (:meth:`collect`): in the background with a second worker."""
        self._later(key, _reorder_job, level, opts, self.reach, self.demand, events, self.hold)

    def rest(self, level: float, opts: MovingOptions, rest: EndRest, key=None) -> None:
        """The plan at ``level`` with the carriage at rest at the end as ``rest`` says, to collect
        later (:meth:`collect`, as ``((result, None), seconds)``): in the background with a second
        worker. A density profile's demand then runs to where it rests (at the rail's end: the
        row's tail at the pace of the rest of the row, as the rear arms share it)."""
        demand = self.demand
        if demand is not None and rest == EndRest.RAIL:
            demand = demand_stretches(self.problem, self.reach, cruise_end(self.problem, self.reach, rest))
        self._later(key, _rest_job, level, opts, self.reach, demand, self.hold, rest)

    def collect(self) -> list:
        out = [(k, f if isinstance(f, tuple) else f.result()) for k, f in self.pending]
        self.pending = []
        return out


def plan_moving(problem: Problem, options: MovingOptions | None = None,
                progress: Callable[[str], None] | None = None) -> RowResult:
    """A row on the move: at ``options.level``, or at the level :func:`speed_search` chooses
    (its curve in ``plan.solver['row']['speed_curve']``); planning time covers the search."""
    check_row_call(problem, progress, "plan_moving")
    if options is not None and not isinstance(options, MovingOptions):
        raise TypeError(f"options: a row on the move takes MovingOptions(...), found {type(options).__name__} {options!r}")
    if getattr(problem, "gantry", None) is None:  # (as plan_row says it: it raised from deep in the screen)
        raise ValueError(f"{getattr(problem, 'name', problem)!r} has no gantry: plan it as a cell")
    opts = options or MovingOptions()
    if SpeedProfile(opts.profile) == SpeedProfile.AUTO:
        return _both_profiles(problem, opts, progress)
    if opts.level is not None and SpeedProfile(opts.profile) == SpeedProfile.CONSTANT:
        bad = cruise_issue(problem, opts.level)
        if bad:  # (before any work: a speed of micrometres per second books for hours and writes gigabytes)
            raise OptionsError([Issue("level", bad)], "MovingOptions")
    t0 = _time.perf_counter()
    reach = row_reach(problem, opts.resolution)
    if opts.level is not None:
        res = plan_continuous(problem, opts.level, opts, reach, progress)
        curve = [_point(res, res.timings["planning"])]
        left = left_at_start(reach, res)
        served = start_served(problem, reach) if left else set()
        held = [f for f in left if f in served]
        if held:  # fruit only a carriage at rest where it starts can give time: once more, resting there first
            again = plan_continuous(problem, opts.level, opts, reach, progress, None, start_hold(problem, reach, held))
            curve.append(replace(_point(again, again.timings["planning"]), start_hold=again.info["start_hold"]))
            if again.verification.passed and (again.plan.metrics.get("harvested") or 0) > (res.plan.metrics.get("harvested") or 0):
                res = again
    else:
        res, curve = speed_search(problem, opts, reach, progress=progress)
    total = _time.perf_counter() - t0
    res.info["speed_curve"] = [p.to_dict() for p in curve]
    # what the plan depends on (the options; not the workers, since SEARCH_WIDTH is fixed)
    res.info["options"] = {f.name: (v.value if isinstance(v, enum.Enum) else v)
                           for f in dataclasses.fields(opts) for v in [getattr(opts, f.name)]}
    res.timings["planning"] = total  # the whole search, verification of every candidate included
    res.plan.solver["timings"] = dict(res.timings)
    res.plan.solver["row"] = res.info
    return res


def _both_profiles(problem: Problem, opts: MovingOptions, progress) -> RowResult:
    """``profile=auto``: the speed searched over a density profile, then over one constant speed,
    each plan verified; the better kept as the search ranks its plans (:func:`_rank`: complete and
    verified, then most fruit, then most fruit per hour; a tie to density, the default).
    ``info["profiles"]`` has both searches' figures, ``speed_curve`` both curves (each point its
    ``profile``); the planning time counts both. A Ctrl-C in the second search keeps the first's
    plan, said interrupted."""
    t0 = _time.perf_counter()
    done: dict[SpeedProfile, tuple[RowResult, float]] = {}
    interrupted = None
    for prof in (SpeedProfile.DENSITY, SpeedProfile.CONSTANT):
        t = _time.perf_counter()
        try:
            res = plan_moving(problem, replace(opts, profile=prof), progress)
        except KeyboardInterrupt:  # (before that search had a plan)
            if not done:
                raise
            interrupted = f"interrupted in the {prof.value} profile's search, before it had a plan: the {next(iter(done)).value} profile's kept"
            break
        done[prof] = (res, _time.perf_counter() - t)
        if res.plan.status == PlanStatus.INTERRUPTED:
            interrupted = f"interrupted in the {prof.value} profile's search"
            break
    best = max(done, key=lambda k: (_rank(_point(done[k][0], done[k][1])), k == SpeedProfile.DENSITY))
    res = done[best][0]
    res.info["speed_curve"] = [c | {"profile": k.value} for k, (r, _) in done.items() for c in r.info["speed_curve"]]
    res.info["profiles"] = {k.value: {"fruit_per_hour": _point(r, secs).fruit_per_hour, "harvested": _point(r, secs).harvested,
                                      "row_time": _point(r, secs).row_time, "mean_speed": r.info.get("mean_speed"),
                                      "verified": bool(r.verification.passed), "planning": secs}
                            for k, (r, secs) in done.items()} | {"kept": best.value}
    res.info["options"]["profile"] = SpeedProfile.AUTO.value  # (what the plan depends on: both were searched)
    if interrupted:
        res.mark_interrupted()
        res.info["interrupted"] = interrupted
    res.timings["planning"] = _time.perf_counter() - t0  # both searches
    res.plan.solver["timings"] = dict(res.timings)
    res.plan.solver["row"] = res.info
    return res


def live_speed(problem: Problem, workers: int = 1) -> tuple[float, RowResult]:
    """The cruising speed for a live row on the move (``coplan run ROW --speed auto``,
    ``benchmarks/bench_moving.py``'s live rows): the constant speed the offline search over
    constant speeds chooses, every fruit known (each plan verified), rounded down to the mm/s --
    a live planner cannot shape its speed to fruit it has not seen; and the search's result.
    ValueError where the search found no speed (the carriage need not move); KeyboardInterrupt
    where the search was interrupted (Ctrl-C, SIGTERM): a speed from a search cut short is not
    the one it chooses, and a live run is not started on it."""
    best = plan_moving(problem, MovingOptions(profile=SpeedProfile.CONSTANT, workers=workers))
    if best.plan.status == PlanStatus.INTERRUPTED:
        raise KeyboardInterrupt(best.info.get("interrupted", "the speed search was interrupted"))
    top = best.info.get("top_speed")
    if not top:
        raise ValueError(f"the offline speed search found no cruising speed for {problem.name!r}")
    return math.floor(float(top) * 1000 + 1e-9) / 1000, best  # (no faster than the speed found)
