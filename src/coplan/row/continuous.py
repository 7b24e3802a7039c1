"""Pick on the move: the carriage never stops for a pick; each arm picks within its time windows.

Entry point: :func:`plan_continuous` (one cruising speed) -> :class:`coplan.row.plan.RowResult`
(no stops); :func:`coplan.row.moving.plan_moving` chooses the speed (:mod:`coplan.row.moving`).

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

import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from ..errors import Issue, OptionsError, check_fields, known_fields, plain_scalars
from ..kinds import AssignRule, GantryMode, PlannerKind, PlanStatus, SpeedProfile
from ..plan import DEFAULT_RATE, MAX_PLAN_BYTES, EventKind, Plan, compute_metrics
from ..problem.gantry import top_speed_issues
from ..problem.model import Problem
from ..problem.plausible import plan_seconds_limit
from ..progress import speaker
from ..workers import settle_workers
from .booking import Booker
from .policy import run_policy
from .branches import branch_table
from .cruise import Cruise, EndRest, cruise_end, demand_stretches, pick_windows
from .plan import RowResult, finalize_row
from .reach import DEFAULT_RESOLUTION, RowReach, resolution_issues, row_reach

__all__ = ["MovingOptions", "assemble_moving", "plan_continuous", "reorder_continuous", "SpeedPoint", "make_cruise", "least_pace",
           "level_cap", "start_served", "left_at_start", "planned_line", "MIN_SPEED", "cruise_issue"]

#: The slowest a shaped cruise goes, m/s (a stretch whose fruit ask for more waits a little there).
MIN_SPEED = 0.01


def make_cruise(problem: Problem, reach: RowReach, profile: SpeedProfile, level: float, demand=None,
                hold: float = 0.0, rest: EndRest = EndRest.REACH) -> Cruise:
    """The carriage's motion at ``level``: a constant cruise at ``level`` m/s, or a density
    profile whose speed on each metre of rail is ``level * n_arms / demand`` (within
    [MIN_SPEED, the gantry's limit]; ``demand``: :func:`coplan.row.cruise.demand_stretches`);
    first at rest where it starts for ``hold`` s (:func:`start_hold`); at rest at the end
    where :func:`coplan.row.cruise.cruise_end` says for ``rest``)."""
    x1 = cruise_end(problem, reach, rest)
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


def cruise_issue(problem: Problem, speed: float, reach: RowReach | None = None) -> str | None:
    """What is wrong with ``speed`` (m/s) as the row's constant cruising speed, or None: above
    ``gantry.max_velocity``, or below the least speed whose plan fits the longest coplan writes
    -- that least speed as the planner reckons it (the carriage's cruise to its rest, by the
    row's screen, ``reach``), not :func:`coplan.problem.plausible.cruise_speed_issue`'s quick
    estimate, which may lie a little below it (``coplan solve --speed`` and :func:`plan_moving`
    quoted two ranges for one row)."""
    from ..problem.plausible import cruise_speed_issue, slowest_speed

    g = problem.gantry
    bad = cruise_speed_issue(problem, speed)
    if not bad:
        return None
    ref = speed if 0.0 < speed <= g.max_velocity else slowest_speed(problem)
    if not ref > 0:
        return bad
    limit = plan_seconds_limit(problem)
    reach = reach if reach is not None else row_reach(problem)
    need = least_pace(ref, make_cruise(problem, reach, SpeedProfile.CONSTANT, ref), limit)
    arms = f"{len(problem.arms)} arm{'s' if len(problem.arms) != 1 else ''}"
    return (f"expected a cruising speed in [{need:.3g}, {g.max_velocity:g}] m/s (gantry.max_velocity at most; at least "
            f"what keeps the plan within {limit:.0f} s, the longest coplan makes with {arms} on a row: its file under "
            f"{MAX_PLAN_BYTES >> 20} MiB), found {speed:g}")


def start_served(problem: Problem, reach: RowReach) -> set[str]:
    """Fruit only the carriage's first positions serve: those the carriage, ramping up from
    rest at its limits, leaves behind before an arm could have reached and picked them -- the
    way out and the pick of the fruit's cheapest cycle (:func:`coplan.allocate.row_cycles.cycle_bounds`)
    from the start (the start alone, or a few centimetres beyond: a fruit served from 0-0.10 m
    slowed a whole row sixfold). No speed worth cruising at gives them a window; a carriage
    resting there first does. (It depends on the row only: computed once per search.)"""
    first = [f for f in reach.harvestable() if reach.span(f)[0] == 0]
    if not first:
        return set()
    from ..allocate.row_cycles import cycle_bounds

    g = problem.gantry
    ramp = Cruise.of(problem, g.max_velocity, g.end)
    ts = np.arange(0.0, ramp.duration, 0.01)
    xs = ramp.x(ts)
    cost = cycle_bounds(problem, limits=False)[0]  # (limits=False: the estimates the speed search was tuned on; the bounds take the limits)
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


def left_at_start(reach: RowReach, res: RowResult) -> list[str]:
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


@known_fields
@dataclass(frozen=True)
class MovingOptions:
    """How to plan a row on the move (separate from the problem).

    profile : ``density`` (a speed per metre of rail, slower where fruit are dense), ``constant``, or
        ``auto`` (the speed searched on both, each plan verified, the better kept as the search ranks
        its plans; twice the planning: :func:`coplan.row.moving.plan_moving`)
    level : the cruising speed (m/s) of a constant profile, the pace of a density profile (the
        arms' share of time the carriage gives each stretch's fruit, :func:`make_cruise`);
        None: chosen by :func:`coplan.row.moving.speed_search`
    assign : ``greedy`` (earliest deadline first) or ``cpsat`` (CP-SAT, seeded by the greedy)
    margin : kept beyond the problem's clearance when booking cycles, m
    resolution : spacing of the candidate carriage positions of the row's screen, m
    search_rounds : levels the speed search plans (each a full, verified plan), rounded up to whole
        rounds of :data:`coplan.row.moving.SEARCH_WIDTH`; the plans of its best level with the early rest and the rest at the rail's end (where that leaves fruit, the next complete level down too)
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
        plain_scalars(self)
        bad = settle_workers(self, collect=True) + resolution_issues(self.resolution)  # (auto: this machine's cores, at most 8)
        check_fields(self, {'level', 'rate', 'workers', 'resolution', 'search_rounds'}, found=bad)  # built in Python: every value checked (OptionsError: what was expected, found)
        if not MIN_RATE <= self.rate <= MAX_RATE:  # (a coarser grid is one no verifier passes; a finer one, gigabytes)
            raise OptionsError([Issue("rate", f"expected a plan sample rate from {MIN_RATE:g} to {MAX_RATE:g} Hz, "
                                              f"found {self.rate:g}")], "MovingOptions")
        if SpeedProfile(self.profile) == SpeedProfile.CONSTANT and (fast := top_speed_issues("level", self.level, "planned")):
            raise OptionsError(fast, "MovingOptions")
        if SpeedProfile(self.profile) == SpeedProfile.AUTO and self.level is not None:  # (a level means a speed or a pace)
            raise OptionsError([Issue("level", f"expected null with profile auto (both profiles searched: a level is a "
                                               f"speed on one, a pace on the other), found {self.level!r}")], "MovingOptions")


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
    refined: bool = False  # a density profile slowed where fruit were missed (the speed search's refinement)
    assign: str = AssignRule.GREEDY.value  # whose order the arms followed
    start_hold: float = 0.0  # s the carriage first rested where it starts (:func:`coplan.row.starthold.start_hold`)
    end_rest: str = EndRest.REACH.value  # where it rests at the end (:class:`coplan.row.cruise.EndRest`)

    @property
    def early_rest(self) -> bool:
        """At rest at the end where the last fruit first comes into reach (plan files say it too)."""
        return self.end_rest == EndRest.EARLY.value

    @property
    def complete(self) -> bool:
        return self.verified and self.harvested >= self.harvestable

    def to_dict(self) -> dict:
        return {"level": self.level, "mean_speed": self.mean_speed, "harvested": self.harvested, "harvestable": self.harvestable,
                "share_harvested": self.harvested / self.harvestable if self.harvestable else None,
                "row_time": self.row_time, "fruit_per_hour": self.fruit_per_hour, "verified": self.verified,
                "seconds": self.seconds, "refined": self.refined,
                "assign": self.assign, "start_hold": self.start_hold, "early_rest": self.early_rest, "end_rest": self.end_rest}


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
                    rest: EndRest = EndRest.REACH, screen: bool = False) -> RowResult:
    """Plan ``problem`` (a row) with the carriage at ``level`` (:func:`make_cruise`; first at
    rest where it starts for ``hold`` s; at rest at the end as ``rest`` says) and verify it
    (``screen``: the verdict, its margins coarse: :func:`certify`)."""
    if problem.gantry is None:
        raise ValueError(f"{problem.name!r} has no gantry: plan it as a cell")
    opts = options or MovingOptions()
    say = speaker(progress)
    t0 = _time.perf_counter()
    timings: dict[str, float] = {}
    reach = reach if reach is not None else row_reach(problem, opts.resolution)
    timings["reach"] = _time.perf_counter() - t0
    cruise = make_cruise(problem, reach, opts.profile, level, demand, hold, rest)
    limit = plan_seconds_limit(problem)
    if cruise.duration > limit:  # (a pace so slow that the plan would outgrow its grid and file)
        need = least_pace(level, cruise, limit, hold)
        raise OptionsError([Issue("level", f"expected a pace of at least {need:.3g}, whose plan fits in {limit:.0f} s (the longest "
                                           f"coplan makes with {len(problem.arms)} arms on a row: its file under "
                                           f"{MAX_PLAN_BYTES >> 20} MiB), found "
                                           f"{level:g}: the carriage alone takes {cruise.duration:.0f} s")], "MovingOptions")
    ts = _time.perf_counter()
    booker, left = _book(problem, reach, cruise, opts)
    info: dict = {"mode": GantryMode.CONTINUOUS.value, "profile": SpeedProfile(opts.profile).value, "level": level,
                  "mean_speed": cruise.mean_speed, "top_speed": cruise.speed, "assign": AssignRule.GREEDY.value,
                  "carriage_rest_at": cruise.x1, "carriage_seconds": cruise.duration, "start_hold": hold,
                  "early_rest": EndRest(rest) == EndRest.EARLY, "end_rest": EndRest(rest).value}
    if AssignRule(opts.assign) == AssignRule.CPSAT and left:
        from .assign import cpsat_order

        order, info["cpsat"] = cpsat_order(problem, booker, reach, cruise)
        if order is not None:
            b2, left2 = _book(problem, reach, cruise, opts, order, booker.windows)
            if (len(left2), _end(b2)) < (len(left), _end(booker)):
                booker, left, info["assign"] = b2, left2, AssignRule.CPSAT.value
    timings["schedule"] = _time.perf_counter() - ts
    res = _verified(problem, booker, cruise, reach, left, info, timings, t0, screen)
    say(planned_line(res))
    return res


def planned_line(res: RowResult) -> str:
    """The progress line of one plan on the move (here, or sent on by the parent of a worker)."""
    how = ", CP-SAT's order" if res.info.get("assign") == AssignRule.CPSAT.value else ""
    rest = res.info.get("end_rest", EndRest.REACH.value)
    if rest == EndRest.RAIL.value:  # (the speed search plans a level with each end: say which this is)
        how += ", resting at the rail's end"
    elif rest == EndRest.EARLY.value:
        how += ", resting where the last fruit comes into reach"
    return (f"row on the move ({res.info['profile']}, {res.info['mean_speed']:.3f} m/s on average{how}): "
            f"{res.plan.metrics.get('harvested')} fruit, row time {res.plan.metrics.get('makespan', 0.0):.2f} s, "
            f"planned in {res.timings['planning']:.2f} s")


def _verified(problem: Problem, booker: Booker, cruise: Cruise, reach: RowReach, left: dict, info: dict, timings: dict,
              t0: float, screen: bool = False) -> RowResult:
    """The booked row as a plan, verified (``timings`` gains planning, counted from ``t0``, and
    verify; ``info`` the fruit left out; ``screen``: see :func:`certify`)."""
    plan = assemble_moving(problem, booker, cruise)
    timings["planning"] = _time.perf_counter() - t0
    info["left_out"] = dict(reach.reasons) | left
    info["first_stop_seconds"] = None
    info["tucked"] = list(booker.tucked)  # (fruit whose ways were tucked: the last tries with the carriage at rest)
    return certify(problem, RowResult(plan, None, [], reach, timings, info), screen)


#: how a speed search's candidate is verified (:func:`certify`): the verdict exact, each clear
#: pair's certified least distance refined only to half its margin
SCREEN_MARGIN = 1.0


def certify(problem: Problem, res: RowResult, screen: bool = False) -> RowResult:
    """``res`` with its plan verified (again) and finalised from that verdict (``timings['verify']``
    its time). ``screen``: each clear pair's certified least distance only to within half its
    margin (:data:`SCREEN_MARGIN`; the verdict is the same, at a fraction of the time where a
    pair's distance stays near its least while an arm moves fast): the speed search verifies
    its candidates so, and the plan it keeps again in full, whose report is the one written."""
    from ..verify.verifier import verify

    tv = _time.perf_counter()
    ver = verify(problem, res.plan, margin_rel=SCREEN_MARGIN if screen else 0.0)
    res.timings["verify"] = _time.perf_counter() - tv
    plan = finalize_row(problem, res.plan, ver, res.reach)
    plan.solver = {"status": plan.status.value, "row": res.info, "timings": dict(res.timings)}
    return replace(res, plan=plan, verification=ver)


def reorder_continuous(problem: Problem, level: float, options: MovingOptions, reach: RowReach, demand,
                       events, hold: float = 0.0, screen: bool = False) -> tuple[RowResult | None, dict]:
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
    info: dict = {"mode": GantryMode.CONTINUOUS.value, "profile": SpeedProfile(options.profile).value, "level": level,
                  "mean_speed": cruise.mean_speed, "top_speed": cruise.speed, "assign": AssignRule.CPSAT.value,
                  "carriage_rest_at": cruise.x1, "carriage_seconds": cruise.duration, "cpsat": report,
                  "start_hold": hold, "early_rest": False, "end_rest": EndRest.REACH.value}
    return _verified(problem, booker, cruise, reach, left, info, {"reach": 0.0, "schedule": _time.perf_counter() - t0}, t0,
                     screen), report


def _end(b: Booker) -> float:
    return max((e.t_end for e in b.events), default=0.0)
