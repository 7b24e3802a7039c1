"""Pick on the move: the carriage never stops for a pick; each arm picks within its time windows.

Entry points: :func:`plan_continuous` (one cruising speed) and :func:`plan_moving` (the speed
chosen by :func:`speed_search`) -> :class:`coplan.row.plan.RowResult` (no stops).

1. **Screen the row** (:func:`coplan.row.reach.row_reach`, as for stop-and-go).
2. **The carriage** (:class:`coplan.row.cruise.Cruise`): one jerk-limited move from
   ``gantry.start`` at the cruising speed, to rest at the end half the front arm's reach past
   where the last fruit first comes within reach (:func:`coplan.row.cruise.cruise_end`; at the
   level the speed search chooses, resting where it first comes within reach is tried too).
3. **Windows** (:func:`coplan.row.cruise.pick_windows`): when each arm can start each pick.
4. **Assignment and order**: the interval-scheduling greedy (earliest deadline first, the
   baseline) and, with ``assign=cpsat``, OR-Tools CP-SAT over optional intervals per fruit and
   arm (:mod:`coplan.row.assign`), seeded by the greedy; the better verified plan is kept.
5. **Motion** (:mod:`coplan.row.booking`): cycles booked in time order, each the earliest that
   keeps the clearance (plus ``margin``) from the neighbours; the tip held over the fruit in row
   coordinates for the dwell.
6. **Verify** in the row frame (:func:`coplan.verify.verify`), as every plan.

A fruit no window allows is left out with the reason ("passed arm2's reach at t = 41.2 s while
arm2 was placing f0117").
"""

from __future__ import annotations

import dataclasses
import enum
import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..errors import Issue, OptionsError, check_fields
from ..kinds import AssignRule, PlannerKind, PlanStatus, SpeedProfile
from ..plan import DEFAULT_RATE, MAX_PLAN_BYTES, EventKind, Plan, compute_metrics
from ..problem.model import Problem
from ..problem.plausible import cruise_speed_issue, plan_seconds_limit
from ..progress import speaker
from ..workers import process_pool, settle_workers
from .booking import Booker, branch_table, run_policy, screen_branches
from .cruise import STRETCH, Cruise, cruise_end, demand_stretches, last_place_bound, pick_windows
from .plan import RowResult, finalize_row
from .reach import DEFAULT_RESOLUTION, RowReach, row_reach
from .starthold import start_hold

__all__ = ["MovingOptions", "assemble_moving", "plan_continuous", "plan_moving", "speed_search", "SpeedPoint", "make_cruise"]

#: A refinement round raises a missed fruit's stretches' demand by this factor ...
REFINE_BUMP = 1.25
#: ... and pushes the level of a complete plan up by this one.
REFINE_PUSH = 1.06
#: The slowest a shaped cruise goes, m/s (a stretch whose fruit ask for more waits a little there).
MIN_SPEED = 0.01


def make_cruise(problem: Problem, reach: RowReach, profile: SpeedProfile, level: float, demand=None,
                hold: float = 0.0, early: bool = False) -> Cruise:
    """The carriage's motion at ``level``: a constant cruise at ``level`` m/s, or a density
    profile whose speed on each metre of rail is ``level * n_arms / demand`` (within
    [MIN_SPEED, the gantry's limit]; ``demand``: :func:`coplan.row.cruise.demand_stretches`);
    first at rest where it starts for ``hold`` s (:func:`start_hold`); at rest at the end
    where :func:`coplan.row.cruise.cruise_end` says (``early``: its early rest)."""
    x1 = cruise_end(problem, reach, early)
    if SpeedProfile(profile) == SpeedProfile.CONSTANT:
        return Cruise.of(problem, level, x1, hold)
    demand = demand if demand is not None else demand_stretches(problem, reach, x1)
    vmax = problem.gantry.max_velocity
    n = len(problem.arms)
    return Cruise.shaped(problem, [(x, float(min(vmax, max(MIN_SPEED, level * n / d)) if d > 0 else vmax)) for x, d in demand], x1,
                         hold)


def least_pace(level: float, cruise: Cruise, limit: float, hold: float = 0.0) -> float:
    """The least pace whose cruise (``cruise``, at ``level``) fits a plan of ``limit`` s: the
    cruise's time scales with 1 / pace, its rests and ramps do not (a little more for those);
    three figures, rounded up."""
    cruising = cruise.duration - hold
    need = level * cruising / max(limit - hold, 1e-9) * 1.001
    step = 10.0 ** (math.floor(math.log10(need)) - 2)
    return math.ceil(need / step) * step


def start_served(problem: Problem, reach: RowReach) -> set[str]:
    """Fruit only the carriage's first positions serve: those the carriage, ramping up from
    rest at its limits, leaves behind before an arm could have reached and picked them -- the
    way out and the pick of the fruit's cheapest cycle (:func:`coplan.allocate.row_bound.cycle_bounds`)
    from the start (the start alone, or a few centimetres beyond: a fruit served from 0-0.10 m
    slowed a whole row sixfold). No speed worth cruising at gives them a window; a carriage
    resting there first does. (It depends on the row only: computed once per search.)"""
    first = [f for f in reach.harvestable() if reach.span(f)[0] == 0]
    if not first:
        return set()
    from ..allocate.row_bound import cycle_bounds

    g = problem.gantry
    ramp = Cruise.of(problem, g.max_velocity, g.end)
    ts = np.arange(0.0, ramp.duration, 0.01)
    xs = ramp.x(ts)
    cost = cycle_bounds(problem)[0]
    dwell = problem.task.pick_dwell + problem.task.place_dwell
    col = {f.id: k for k, f in enumerate(problem.fruits)}
    out = set()
    for f in first:
        hi = float(reach.grid[reach.span(f)[1]])
        arms = np.flatnonzero(reach.cover[f][:, 0])
        cheapest = float(np.min(cost[arms, col[f]])) if arms.size else math.inf
        passed = float(ts[min(int(np.searchsorted(xs, hi, side="right")), ts.size - 1)]) if ts.size else 0.0
        # the cheapest cycle's way out and pick (its ways out and back take as long): not done
        # before the carriage at its fastest leaves the fruit behind
        if reach.span(f)[1] == 0 or passed < 0.5 * (cheapest - dwell) + problem.task.pick_dwell:
            out.add(f)
    return out


def _left_at_start(reach: RowReach, res: RowResult) -> list[str]:
    """Fruit a moving plan left out that the carriage's start position serves (in file order):
    the candidates of :func:`start_served`."""
    left = res.info.get("left_out") or {}
    return [f for f in reach.harvestable() if f in left and reach.span(f)[0] == 0]


def level_cap(problem: Problem, reach: RowReach, profile: SpeedProfile, demand=None) -> float:
    """The level past which nothing changes: the gantry's limit (constant), or the pace at which
    every stretch runs at it (density)."""
    vmax = problem.gantry.max_velocity
    if SpeedProfile(profile) == SpeedProfile.CONSTANT:
        return vmax
    demand = demand if demand is not None else demand_stretches(problem, reach, cruise_end(problem, reach))
    return vmax * max((d for _, d in demand), default=1.0) / len(problem.arms)


MIN_RATE, MAX_RATE = 100.0, 10_000.0  # Hz: a plan's samples (the verifier wants 100 Hz or finer)


@dataclass(frozen=True)
class MovingOptions:
    """How to plan a row on the move (separate from the problem).

    profile : ``density`` (a speed per metre of rail, slower where fruit are dense) or ``constant``
    level : the cruising speed (m/s) of a constant profile, the pace of a density profile (the
        arms' share of time the carriage gives each stretch's fruit, :func:`make_cruise`);
        None: chosen by :func:`speed_search`
    assign : ``greedy`` (earliest deadline first) or ``cpsat`` (CP-SAT, seeded by the greedy)
    margin : kept beyond the problem's clearance when booking cycles, m
    resolution : spacing of the candidate carriage positions of the row's screen, m
    search_rounds : levels the speed search plans (each a full, verified plan), rounded up to whole
        rounds of :data:`SEARCH_WIDTH`; the plans of its best level with the early rest at the end
        and, on the density profile, CP-SAT's order and the refinement come on top
    refine_rounds : full plans that then slow the carriage only where fruit were missed (density;
        default none: with the search's bracketing, they won on no benchmark row and cost the search
        a plan at its end)
    workers : processes the speed search plans in (its levels side by side; the same plan for any); 1: all here
    rate : the plan's samples per second, 100 to 10,000 Hz
    """

    profile: SpeedProfile = SpeedProfile.DENSITY
    level: float | None = None
    assign: AssignRule = AssignRule.CPSAT
    margin: float = 0.02
    resolution: float = DEFAULT_RESOLUTION
    search_rounds: int = 7
    refine_rounds: int = 0  # (2 before the search's top was left unplanned; since, no round won on any of the 10 benchmark rows)
    workers: int = 1
    rate: float = DEFAULT_RATE

    def __post_init__(self) -> None:
        settle_workers(self)  # (auto: this machine's cores, at most 8)
        check_fields(self, {'level', 'rate', 'workers', 'resolution', 'search_rounds'})  # built in Python: every value checked (OptionsError: what was expected, found)
        if not MIN_RATE <= self.rate <= MAX_RATE:  # (a coarser grid is one no verifier passes; a finer one, gigabytes)
            raise OptionsError([Issue("rate", f"expected a plan sample rate from {MIN_RATE:g} to {MAX_RATE:g} Hz, "
                                              f"found {self.rate:g}")], "MovingOptions")


@dataclass(frozen=True)
class SpeedPoint:
    """One full plan of the speed search: its speed and figures (each plan verified)."""

    level: float
    mean_speed: float
    harvested: int
    harvestable: int
    row_time: float
    fruit_per_hour: float
    verified: bool
    seconds: float
    refined: bool = False  # a density profile slowed where fruit were missed (:func:`_refine`)
    assign: str = AssignRule.GREEDY.value  # whose order the arms followed
    start_hold: float = 0.0  # s the carriage first rested where it starts (:func:`start_hold`)
    early_rest: bool = False  # at rest at the end where the last fruit first comes into reach (:func:`coplan.row.cruise.cruise_end`)

    @property
    def complete(self) -> bool:
        return self.verified and self.harvested >= self.harvestable

    def to_dict(self) -> dict:
        return {"level": self.level, "mean_speed": self.mean_speed, "harvested": self.harvested, "harvestable": self.harvestable,
                "share_harvested": self.harvested / self.harvestable if self.harvestable else None,
                "row_time": self.row_time, "fruit_per_hour": self.fruit_per_hour, "verified": self.verified,
                "seconds": self.seconds, "refined": self.refined,
                "assign": self.assign, "start_hold": self.start_hold, "early_rest": self.early_rest}


def _book(problem: Problem, reach: RowReach, cruise: Cruise, opts: MovingOptions, order=None,
          windows=None) -> tuple[Booker, dict]:
    if windows is None:
        windows = pick_windows(problem, reach, cruise, problem.task.pick_dwell)
    booker = Booker(problem, cruise, windows, opts.rate, opts.margin, reach.resolution,
                    branch_table(problem, reach.resolution))
    left = run_policy(booker, order)
    booker.home_parked()
    return booker, left


def assemble_moving(problem: Problem, booker: Booker, cruise: Cruise) -> Plan:
    """One row plan of every arm's booked motion and the carriage's, on the 100 Hz grid."""
    rate = booker.rate
    n = max(max(st.k_free for st in booker.arms), booker.up(cruise.duration)) + 1
    time = np.arange(n) / rate
    q = {a.name: booker.pose_at(i, 0, n) for i, a in enumerate(problem.arms)}
    events = sorted(booker.events, key=lambda e: (e.t_start, e.arm))
    allocation = {a.name: list(booker.arms[i].fruit) for i, a in enumerate(problem.arms)}
    plan = Plan(problem=problem.name, planner=PlannerKind.COORDINATED, status=PlanStatus.UNVERIFIED, time=time, q=q,
                events=events, allocation=allocation, unreachable=[], gantry_x=np.asarray(cruise.x(time), float))
    plan.metrics = compute_metrics(plan, sum(len(v) for v in allocation.values()))
    return plan


def plan_continuous(problem: Problem, level: float, options: MovingOptions | None = None, reach: RowReach | None = None,
                    progress: Callable[[str], None] | None = None, demand=None, hold: float = 0.0,
                    early: bool = False) -> RowResult:
    """Plan ``problem`` (a row) with the carriage at ``level`` (:func:`make_cruise`; first at
    rest where it starts for ``hold`` s; ``early``: its early rest at the end) and verify it."""
    if problem.gantry is None:
        raise ValueError(f"{problem.name!r} has no gantry: plan it as a cell")
    opts = options or MovingOptions()
    say = speaker(progress)
    t0 = _time.perf_counter()
    timings: dict[str, float] = {}
    reach = reach if reach is not None else row_reach(problem, opts.resolution)
    timings["reach"] = _time.perf_counter() - t0
    cruise = make_cruise(problem, reach, opts.profile, level, demand, hold, early)
    limit = plan_seconds_limit(problem)
    if cruise.duration > limit:  # (a pace so slow that the plan would outgrow its grid and file)
        need = least_pace(level, cruise, limit, hold)
        raise OptionsError([Issue("level", f"expected a pace of at least {need:.3g}, whose plan fits in {limit:.0f} s (the longest "
                                           f"coplan makes with {len(problem.arms)} arms on a row: its file under "
                                           f"{MAX_PLAN_BYTES >> 20} MiB), found "
                                           f"{level:g}: the carriage alone takes {cruise.duration:.0f} s")], "MovingOptions")
    ts = _time.perf_counter()
    booker, left = _book(problem, reach, cruise, opts)
    info: dict = {"mode": "continuous", "profile": SpeedProfile(opts.profile).value, "level": level,
                  "mean_speed": cruise.mean_speed, "top_speed": cruise.speed, "assign": AssignRule.GREEDY.value,
                  "carriage_rest_at": cruise.x1, "carriage_seconds": cruise.duration, "start_hold": hold,
                  "early_rest": early}
    if AssignRule(opts.assign) == AssignRule.CPSAT and left:
        from .assign import cpsat_order

        order, info["cpsat"] = cpsat_order(problem, booker, reach, cruise)
        if order is not None:
            b2, left2 = _book(problem, reach, cruise, opts, order, booker.windows)
            if (len(left2), _end(b2)) < (len(left), _end(booker)):
                booker, left, info["assign"] = b2, left2, AssignRule.CPSAT.value
    timings["schedule"] = _time.perf_counter() - ts
    res = _verified(problem, booker, cruise, reach, left, info, timings, t0)
    say(_planned_line(res))
    return res


def _planned_line(res: RowResult) -> str:
    """The progress line of one plan on the move (here, or sent on by the parent of a worker)."""
    return (f"row on the move ({res.info['profile']}, {res.info['mean_speed']:.3f} m/s on average): "
            f"{res.plan.metrics.get('harvested')} fruit, makespan {res.plan.metrics.get('makespan', 0.0):.2f} s, "
            f"planned in {res.timings['planning']:.2f} s")


def _verified(problem: Problem, booker: Booker, cruise: Cruise, reach: RowReach, left: dict, info: dict, timings: dict,
              t0: float) -> RowResult:
    """The booked row as a plan, verified (``timings`` gains planning, counted from ``t0``, and
    verify; ``info`` the fruit left out)."""
    from ..verify.verifier import verify

    plan = assemble_moving(problem, booker, cruise)
    timings["planning"] = _time.perf_counter() - t0
    tv = _time.perf_counter()
    ver = verify(problem, plan)
    timings["verify"] = _time.perf_counter() - tv
    plan = finalize_row(problem, plan, ver, reach)
    info["left_out"] = dict(reach.reasons) | left
    info["first_stop_seconds"] = None
    plan.solver = {"status": plan.status.value, "row": info, "timings": dict(timings)}
    return RowResult(plan, ver, [], reach, timings, info)


def reorder_continuous(problem: Problem, level: float, options: MovingOptions, reach: RowReach, demand,
                       events, hold: float = 0.0) -> tuple[RowResult | None, dict]:
    """CP-SAT's order at ``level``, started from ``events`` (the greedy's booking at this level
    with these options, as :func:`plan_continuous` made it): the plan that order books, verified,
    if it leaves fewer fruit out (then ends sooner) than the greedy, else None (the greedy's plan
    stands); and CP-SAT's report. :func:`plan_continuous` with ``assign=cpsat``, without booking
    the greedy again: the speed search's last step, beside its refinement."""
    from .assign import cpsat_order

    t0 = _time.perf_counter()
    cruise = make_cruise(problem, reach, options.profile, level, demand, hold)
    windows = pick_windows(problem, reach, cruise, problem.task.pick_dwell)
    geometry = Booker(problem, cruise, windows, options.rate, options.margin, reach.resolution,
                      branch_table(problem, reach.resolution))  # nothing booked
    order, report = cpsat_order(problem, geometry, reach, cruise, events=events)
    report = {"level": level, **report, "kept": False}
    if order is None:
        return None, report
    booker, left = _book(problem, reach, cruise, options, order, windows)
    got = {e.fruit for e in events if e.kind == EventKind.PLACE}
    greedy_left = sum(1 for f in windows if f not in got)  # as run_policy counts the greedy's
    if (len(left), _end(booker)) >= (greedy_left, max((e.t_end for e in events), default=0.0)):
        return None, report
    report["kept"] = True
    info: dict = {"mode": "continuous", "profile": SpeedProfile(options.profile).value, "level": level,
                  "mean_speed": cruise.mean_speed, "top_speed": cruise.speed, "assign": AssignRule.CPSAT.value,
                  "carriage_rest_at": cruise.x1, "carriage_seconds": cruise.duration, "cpsat": report,
                  "start_hold": hold, "early_rest": False}
    return _verified(problem, booker, cruise, reach, left, info, {"reach": 0.0, "schedule": _time.perf_counter() - t0}, t0), report


def _end(b: Booker) -> float:
    return max((e.t_end for e in b.events), default=0.0)


def _point(res: RowResult, seconds: float) -> SpeedPoint:
    m = res.plan.metrics
    span = float(m.get("makespan") or 0.0)
    got = int(m.get("harvested") or 0)
    return SpeedPoint(float(res.info["level"]), float(res.info["mean_speed"]), got, len(res.reach.cover), span, got * 3600.0 / span if span > 0 else 0.0,
                      bool(res.verification.passed), seconds, early_rest=bool(res.info.get("early_rest")))


def speed_search(problem: Problem, options: MovingOptions | None = None, reach: RowReach | None = None,
                 levels=None, progress: Callable[[str], None] | None = None) -> tuple[RowResult, list[SpeedPoint]]:
    """The level (speed, or pace) that maximises fruit per hour while harvesting every
    harvestable fruit (each candidate a full, verified plan), and the curve of the levels tried.

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
    from ..allocate.row_bound import row_bounds

    opts = options or MovingOptions()
    reach = reach if reach is not None else row_reach(problem, opts.resolution)
    g = problem.gantry
    x1 = cruise_end(problem, reach)
    profile = SpeedProfile(opts.profile)
    demand = demand_stretches(problem, reach, x1) if profile == SpeedProfile.DENSITY else None
    cap = level_cap(problem, reach, profile, demand)
    tried: dict = {}
    cpsat_report = None
    # every candidate books the same arms on the same fruit: screen their elbow branches once, here
    # (before the workers fork, so that they inherit it)
    screen_branches(problem, reach.resolution, [(i, f) for f in reach.harvestable() for i in np.flatnonzero(reach.cover[f].any(axis=1)).tolist()],
                    branch_table(problem, reach.resolution))
    greedy = replace(opts, assign=AssignRule.GREEDY)  # the search's plans: CP-SAT only once, at its end
    interrupted = False
    served: set[str] | None = None  # (start_served: once, when a plan first leaves such a fruit out)
    with _Runner(problem, reach, demand, max(1, int(opts.workers)), progress) as runner:
        try:
            def run_many(vs) -> list[SpeedPoint]:
                nonlocal served
                vs = [round(float(min(cap, max(v, 1e-3))), 4) for v in vs]
                todo = [v for v in dict.fromkeys(vs) if v not in tried]
                for v, (res, secs) in zip(todo, runner.map(todo, greedy)):
                    tried[v] = (res, replace(_point(res, secs), start_hold=runner.hold))
                left = set() if runner.hold else {f for v in todo for f in _left_at_start(reach, tried[v][0])}
                if left:  # fruit only the start serves, missed: every plan from here rests there first
                    if served is None:
                        served = start_served(problem, reach)
                    held = sorted(left & served)
                    if held:
                        runner.hold = start_hold(problem, reach, held)
                        for v, (res, secs) in zip(todo, runner.map(todo, greedy)):
                            tried[v] = (res, replace(_point(res, secs), start_hold=runner.hold))
                return [tried[v][1] for v in vs]

            if levels is not None:
                run_many(list(levels))
            else:
                if profile == SpeedProfile.CONSTANT:
                    v = max(x1 - g.start, 0.05) / max(row_bounds(problem).work, 1e-3)
                else:
                    v = 1.0
                v = min(v, cap)
                ok_v, bad_v = None, None
                # the starting level is the bracket's top until a plan says otherwise: a faster carriage
                # than the busiest arm's work (pace 1) leaves fruit on every benchmark row, so it is
                # planned only when the bracket closes below it with no incomplete plan
                assumed: float | None = v
                w = SEARCH_WIDTH  # (not the workers: the levels tried, and so the plan, are the same for any)
                for _ in range(int(math.ceil(opts.search_rounds / w))):
                    # w levels at once: from half the start up to it / down by halves / up by half again
                    # until bracketed, then w points inside
                    top = bad_v if bad_v is not None else assumed
                    if ok_v is None and bad_v is None:
                        batch = [v / 2.0 * (1.0 + k / w) for k in range(w)]
                    elif ok_v is None:
                        batch = [bad_v / 2.0 ** (k + 1) for k in range(w)]
                    elif top is None:
                        if ok_v >= cap:
                            break
                        batch = [min(cap, ok_v * 1.5 ** (k + 1)) for k in range(w)]
                    elif top - ok_v <= 0.05 * ok_v:
                        if bad_v is not None:
                            break
                        batch = [min(cap, top * 1.5 ** k) for k in range(w)]  # complete up to the start: it too, and on up
                        assumed = None
                    else:
                        batch = [ok_v + (top - ok_v) * (k + 1) / (w + 1) for k in range(w)]
                    for p in run_many(batch):
                        if p.complete:
                            ok_v = p.level if ok_v is None else max(ok_v, p.level)
                        else:
                            bad_v = p.level if bad_v is None else min(bad_v, p.level)
                    if ok_v is not None and bad_v is not None and bad_v < ok_v:
                        bad_v = None  # an incomplete plan below a complete one: not a bracket; go on up
                if AssignRule(opts.assign) == AssignRule.CPSAT and bad_v is not None:
                    # the slowest level at which the greedy missed fruit, once more with CP-SAT's order
                    # started from the greedy's booking there (alongside the refinement when there is
                    # a second worker)
                    runner.reorder(bad_v, opts, list(tried[bad_v][0].plan.events), key=(bad_v, "cpsat"))
                # at the best complete level (the most fruit per hour: not always the fastest
                # complete one), the carriage's early rest at the end too (where the last
                # fruit first comes into reach: :func:`coplan.row.cruise.cruise_end`), the faster plan
                # kept; with a second worker, alongside the refinement (one plan at a time)
                if ok_v is not None:
                    best_v = max((k for k in tried if tried[k][1].complete), key=lambda k: _rank(tried[k][1]))
                    runner.early(best_v, greedy, key=(best_v, "early"))
                if demand is not None and bad_v is not None:
                    _refine(reach, demand, bad_v, tried, runner, greedy)
                for key, ((res, report), secs) in runner.collect():
                    if key[1] == "cpsat":
                        cpsat_report = report
                    elif res is not None:  # (the early rest's plan, made in the background: its line from here)
                        speaker(progress)(_planned_line(res))
                    if res is not None:
                        tried[key] = (res, replace(_point(res, secs), assign=res.info["assign"], start_hold=runner.hold))
        except KeyboardInterrupt:  # Ctrl-C / SIGTERM: the best verified plan so far is kept
            if not tried:
                raise
            interrupted = True
    pts = [p for _, p in tried.values()]
    best = max(tried, key=lambda v: _rank(tried[v][1]))
    if cpsat_report is not None:
        tried[best][0].info.setdefault("cpsat", cpsat_report)  # the search's CP-SAT step, whether kept or not
    if interrupted:
        tried[best][0].plan.status = PlanStatus.INTERRUPTED  # (its verdict is in plan.verification)
        tried[best][0].plan.solver["status"] = PlanStatus.INTERRUPTED.value
        tried[best][0].info["interrupted"] = f"the speed search stopped after {len(tried)} plan{'' if len(tried) == 1 else 's'}: the best verified so far"
    return tried[best][0], pts


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
              hold: float = 0.0, early: bool = False) -> tuple[RowResult, float]:
    """One full plan in a worker process (module-level: it is pickled to the worker)."""
    t = _time.perf_counter()
    res = plan_continuous(problem, level, opts, reach, None, demand, hold, early)
    return res, _time.perf_counter() - t


def _early_job(problem: Problem, level: float, opts: MovingOptions, reach: RowReach, demand, hold: float = 0.0):
    """:func:`plan_continuous` with the early rest at the end, in a worker process: ``((result, None), seconds)``."""
    res, secs = _plan_job(problem, level, opts, reach, demand, hold, True)
    return (res, None), secs


def _reorder_job(problem: Problem, level: float, opts: MovingOptions, reach: RowReach, demand, events, hold: float = 0.0):
    """:func:`reorder_continuous` in a worker process: ``((result or None, report), seconds)``."""
    t = _time.perf_counter()
    out = reorder_continuous(problem, level, opts, reach, demand, events, hold)
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

    def map(self, levels: list[float], opts: MovingOptions, demand=None, early: bool = False) -> list[tuple[RowResult, float]]:
        if self.pool is None:
            out = []
            for v in levels:
                t = _time.perf_counter()
                out.append((plan_continuous(self.problem, v, opts, self.reach, self.progress, self._demand(demand), self.hold,
                                            early), _time.perf_counter() - t))
            return out
        futures = [self.pool.submit(_plan_job, self.problem, v, opts, self.reach, self._demand(demand), self.hold, early)
                   for v in levels]
        out = [f.result() for f in futures]
        for res, _ in out:  # (a worker cannot reach the caller's progress: its lines come from here)
            speaker(self.progress)(_planned_line(res))
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

    def early(self, level: float, opts: MovingOptions, key=None) -> None:
        """The plan at ``level`` with the carriage's early rest at the end, to collect later
        (:meth:`collect`, as ``((result, None), seconds)``): in the background with a second worker."""
        self._later(key, _early_job, level, opts, self.reach, self.demand, self.hold)

    def collect(self) -> list:
        out = [(k, f if isinstance(f, tuple) else f.result()) for k, f in self.pending]
        self.pending = []
        return out


def plan_moving(problem: Problem, options: MovingOptions | None = None,
                progress: Callable[[str], None] | None = None) -> RowResult:
    """A row on the move: at ``options.level``, or at the level :func:`speed_search` chooses
    (its curve in ``plan.solver['row']['speed_curve']``); planning time covers the search."""
    if options is not None and not isinstance(options, MovingOptions):
        raise TypeError(f"options: a row on the move takes MovingOptions(...), found {type(options).__name__} {options!r}")
    if getattr(problem, "gantry", None) is None:  # (as plan_row says it: it raised from deep in the screen)
        raise ValueError(f"{getattr(problem, 'name', problem)!r} has no gantry: plan it as a cell")
    opts = options or MovingOptions()
    if opts.level is not None and SpeedProfile(opts.profile) == SpeedProfile.CONSTANT:
        bad = cruise_speed_issue(problem, opts.level)
        if bad:  # (before any work: a speed of micrometres per second books for hours and writes gigabytes)
            raise OptionsError([Issue("level", bad)], "MovingOptions")
    t0 = _time.perf_counter()
    reach = row_reach(problem, opts.resolution)
    if opts.level is not None:
        res = plan_continuous(problem, opts.level, opts, reach, progress)
        curve = [_point(res, res.timings["planning"])]
        left = _left_at_start(reach, res)
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
