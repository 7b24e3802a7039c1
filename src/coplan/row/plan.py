"""Plan a whole row: where the carriage stops, each stop's cell, one verified row plan.

Entry point: :func:`plan_row` -> :class:`RowResult`.

1. **Screen the row** (:func:`coplan.row.reach.row_reach`): from which carriage positions each
   arm can harvest each fruit; a fruit no position serves is left out with the reason.
2. **Stops** (:mod:`coplan.row.stops`): ``optimised`` (receding segments, a search over strides priced by the arms' round trips), ``fixed``
   (a stop every carriage span) or ``fewest``; each stop's fruit.
3. **Cells**: each stop is a stationary cell (:func:`coplan.problem.gantry.cell_at`) planned by
   the cell planner (``coordinated``, or ``optimal`` with a per-stop budget): every arm from
   home back to home, verified as a cell. A coordinated cell is then retimed by CP-SAT (the
   optimal planner's retime stage: the same moves, every start chosen together; ``retime``),
   kept where it verifies and makes no stop later. Stops are planned as the stop rule commits them
   (receding horizon), so the carriage's first move can start before the rest is planned.
   With ``workers`` > 1 the cells are planned in that many processes while the stop rule goes
   on (each cell's plan is deterministic in its inputs: the same plans as in one process).
4. **Assembly**: one time grid. The carriage moves between stops with time-optimal
   jerk-limited moves; it leaves a stop once that stop's last pick is over (the arms place and
   go home while it moves: the bins ride with it, and arms on one carriage keep their distances
   whatever it does), and the next stop's cell starts early enough that its first pick comes
   just after the carriage has arrived and settled. No pick ever happens while the carriage moves.
5. **Verify** the row plan independently in the row frame (:func:`coplan.verify.verify`).
"""

from __future__ import annotations

import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import Issue, OptionsError, check_fields, known_fields, plain_scalars
from ..output import signals_deferred
from ..workers import cores, process_pool, settle_workers
from ..kinds import GantryMode, PlannerKind, PlanStatus, StopRule
from ..kinematics.timing import Move1D
from ..plan import DEFAULT_RATE, Event, EventKind, Plan, compute_metrics, finalize_plan
from ..problem.gantry import cell_at
from ..problem.model import Problem, require_problem
from ..problem.plausible import check_as_file
from ..progress import Tick, check_progress, speaker, ticker
from .reach import DEFAULT_RESOLUTION, RowReach, resolution_issues, row_reach, screened_out
from .stops import Stop, StopWindow, arrival_time, fewest_stops, fixed_stops, optimised_stops

__all__ = ["RowOptions", "RowResult", "StopPlan", "plan_row", "assemble", "finalize_row"]


@known_fields
@dataclass(frozen=True)
class RowOptions:
    """How to plan a row (separate from the problem).

    stops : the stop rule (:class:`coplan.kinds.StopRule`)
    planner : the cell planner at each stop (``coordinated`` or ``optimal``)
    resolution : spacing of the candidate carriage positions, m
    window : the optimised rule's receding window
    cell_search_work : the optimal cell planner's search budget per stop (work, not seconds)
    workers : processes the stops' cells are planned in, beside the stop rule (1: all here; the
        same plans either way)
    retime : the coordinated cell planner's plan at each stop retimed by CP-SAT (the optimal
        planner's retime stage: the same moves, picks and places, every start chosen together),
        kept where it verifies and makes no stop later
    retime_work : CP-SAT's deterministic time limit per retiming round (its own unit, so the
        same plan on any machine), searched without an LP relaxation: 0.5 solves dense_row's
        91-fruit first stop in 0.8 s (114.1 -> 104.9 s) and a 243-fruit stop of six arms in 3 s
        (182.0 -> 167.0 s; the optimal planner's 5.0 with the LP took 34 s there: a row must
        stay ahead of its carriage)
    """

    stops: StopRule = StopRule.OPTIMISED
    planner: PlannerKind = PlannerKind.COORDINATED
    resolution: float = DEFAULT_RESOLUTION
    window: StopWindow = field(default_factory=StopWindow)
    cell_search_work: int = 3000
    workers: int = 1
    retime: bool = True
    retime_work: float = 0.5

    def __post_init__(self) -> None:
        plain_scalars(self)
        bad = settle_workers(self, collect=True) + resolution_issues(self.resolution)  # (auto: this machine's cores, at most 8)
        check_fields(self, {'resolution', 'workers', 'retime_work'}, found=bad)
        if not isinstance(self.window, StopWindow):
            raise OptionsError([Issue("window", f"expected StopWindow(...), found {type(self.window).__name__} "
                                                f"{self.window!r}")], "RowOptions")
        for name in ("stop_price", "pace_price"):
            if getattr(self.window, name) and StopRule(self.stops) != StopRule.OPTIMISED:  # (it was silently ignored)
                raise OptionsError([Issue(f"window.{name}", f"expected 0 with stops {StopRule(self.stops).value!r} (a price "
                                                            f"per stop is the optimised rule's), found "
                                                            f"{getattr(self.window, name):g}")], "RowOptions")
        if self.planner == PlannerKind.HEURISTIC:
            raise OptionsError([Issue("planner", "expected 'coordinated' or 'optimal' (the cell planner at each stop; the "
                                                 "course's heuristic plans a stationary cell, not a row's stops), found 'heuristic'")],
                               "RowOptions")  # built in Python: every value checked (OptionsError: what was expected, found)


@dataclass
class StopPlan:
    """One stop: where, its fruit, its verified cell plan and when the row plan runs it."""

    stop: Stop
    plan: Plan
    start: float = 0.0  # s: when its cell plan starts in the row plan
    arrive: float = 0.0  # s: when the carriage comes to rest there
    depart: float = 0.0  # s: when the carriage leaves (its last pick is over)
    ready: float = 0.0  # s after the call: when its cell plan was ready (wall clock)
    seconds: float = 0.0  # wall time its cell took to plan


@dataclass
class RowResult:
    """A planned row: the verified row plan, its stops (none on the move), the row's screen,
    timings (s) and the planner's report (``info``, also ``plan.solver['row']``). The figures a
    row is judged by -- fruit per hour, first motion, slack, ratios to the bounds -- are
    :func:`coplan.row.metrics.row_metrics` ``(problem, result, row_bounds(problem))``;
    :func:`coplan.solve` adds them to the plan as ``plan.metrics['row']``."""

    plan: Plan
    verification: object
    stops: list[StopPlan]
    reach: RowReach
    timings: dict[str, float]
    info: dict

    def mark_interrupted(self, why: str | None = None) -> None:
        """Say the row was interrupted (Ctrl-C, SIGTERM): its plan's status and solver status
        (the verdict on what it has stays in ``plan.verification``) and, given ``why``, the
        report's ``interrupted`` (``info``, plan.json's ``solver.row``) unless that already says why."""
        self.plan.status = PlanStatus.INTERRUPTED
        self.plan.solver["status"] = PlanStatus.INTERRUPTED.value
        if why is not None:
            self.info.setdefault("interrupted", why)

    def __repr__(self) -> str:  # (short: the screen's cover arrays made it 128,000 characters in a notebook cell)
        places = [e.t_end for e in self.plan.events if e.kind == EventKind.PLACE]
        passed = getattr(self.verification, "passed", None)
        return (f"RowResult({self.plan.label!r}, status={self.plan.status.value}, stops={len(self.stops)}, "
                f"harvested={len(places)}, row_time={max(places, default=0.0):.2f} s, verified={passed}, "
                f"planning={self.timings.get('planning', float('nan')):.2f} s)")


def _cell_plan(cell: Problem, opts: RowOptions, drive: float | None = None) -> Plan:
    """One stop's cell (``cell_at``), planned by the row's cell planner. The optimal planner's
    cell is kept where it holds the carriage no longer than the coordinated one (its last pick
    less its first: the optimal planner shortens the last place, and a cell whose last pick came
    later made a 10 m row 0.2 s slower than with coordinated cells); else the coordinated."""
    from ..planners.coordinated import plan_coordinated

    if opts.planner == PlannerKind.OPTIMAL:
        from ..planners.optimal import OptimalOptions, plan_optimal

        # (no regroup and no widening: a stop's cell is judged by how long it holds the carriage, and a
        # second solve per stop is beyond a row's planning time; so is the widening, which keeps the
        # makespan: on a 30 m row of 4 arms at 2 fruit/m it took 163 s of a 165 s stop, the carriage
        # waiting 159 s for its first motion)
        best = plan_optimal(cell, options=OptimalOptions(search_work=opts.cell_search_work, refine_retimes=20,
                                                         regroup=False, widen=False)).plan
        base = plan_coordinated(cell).plan
        if best.status == base.status and _stay(best) > _stay(base) + 1e-9:
            return base
        return best
    res = plan_coordinated(cell)
    # the first stop's cell (``drive``: when it may pick there, s): the row's first motion waits
    # for it, and what it has is the drive less the cell's lead to its first pick; retimed only
    # where that is FIRST_RETIME_PER_FRUIT_ARM s per fruit and arm or more (planning and retiming
    # took 8.6-8.8 ms per fruit and arm on a 2-core machine: dense_row's first stop, 91 fruit and
    # 3 arms, 2.4 s; a 175-fruit stop of six arms, 9 s; 2.3 x that). A rule on the row, not a
    # clock: the same plan on any machine
    if opts.retime and (drive is None or drive - _first_last_pick(res.plan)[0]
                        >= FIRST_RETIME_PER_FRUIT_ARM * len(cell.fruits) * len(cell.arms)):
        better = _retimed(cell, res, opts.retime_work)
        if better is not None:
            return better
    return res.plan


def _retimed(cell: Problem, res, work: float) -> Plan | None:
    """The coordinated cell plan ``res`` (a :class:`CoordinatedResult`) with its moves retimed
    together by CP-SAT, as the optimal planner's retime stage does it (the same moves, picks and
    places; a cell of more than ``refine_fruit`` fruit in bounded rounds, each move at most
    ``retime_shift`` later, while a round gains; ``work``: CP-SAT's deterministic limit per
    round): the last round that verifies and makes no stop
    of the row later (:func:`_no_later`); None where none does. Its report is
    ``solver['retime']``."""
    from ..planners.coordinated.planner import CoordinatedOptions, schedules_plan
    from ..planners.optimal.options import OptimalOptions
    from ..planners.optimal.retime import bounded_rounds, retime_rounds
    from ..verify.verifier import verify

    c, base = res.candidate, res.plan
    if c is None or c.fallback or base.status != PlanStatus.SUCCESS:
        return None
    n, shift = bounded_rounds(len(cell.fruits), OptimalOptions())
    rounds, best, before = [], None, c.makespan
    t0 = _time.perf_counter()
    for r, rc, gained, _ in retime_rounds(cell, c, CoordinatedOptions().margin, rounds=n, shift=shift, work=work,
                                          tables={}, memo={}, linear=False):
        rounds.append({"status": r.status, "makespan_before": before, "makespan": r.makespan})
        if not gained:
            break
        before = rc.makespan
        info = dict(base.solver) | {"retime": {"rounds": rounds, "wall_seconds": _time.perf_counter() - t0}}
        p = schedules_plan(cell, rc.alloc, rc.schedules, PlannerKind.COORDINATED, info)
        v = verify(cell, p)
        if not v.passed:
            break
        p = finalize_plan(p, v, len(cell.reachable_ids()))
        if p.status != base.status or not _no_later(p, best or base):
            break
        best = p
    return best


def _no_later(p: Plan, base: Plan) -> bool:
    """Whether cell plan ``p`` puts no stop of any row later than ``base`` does, and gains
    somewhere. In :func:`assemble` a cell starts at ``max(free, arrive - first pick)`` and frees
    the carriage at its start + last pick, the arms at its start + end: both no later, whatever
    ``free`` and ``arrive`` are, when its last pick, its stay (last pick less first), its end and
    its end less its first pick are each no later."""
    (fp, lp), (fb, lb) = _first_last_pick(p), _first_last_pick(base)
    ep, eb = float(p.time[-1]), float(base.time[-1])
    here, there = (lp, lp - fp, ep, ep - fp), (lb, lb - fb, eb, eb - fb)
    return all(a <= b + 1e-9 for a, b in zip(here, there)) and any(a < b - 1e-6 for a, b in zip(here, there))


def _stay(p: Plan) -> float:
    """How long a stop's cell holds the carriage (its last pick less its first, s)."""
    first, last = _first_last_pick(p)
    return last - first


FIRST_RETIME_PER_FRUIT_ARM = 0.02  # s per fruit and arm of the first stop's slack before its cell starts, to retime it


def _cell_job(cell: Problem, opts: RowOptions, drive: float | None = None) -> tuple[Plan, float]:
    """One stop's cell in a worker process (module-level: it is pickled): the plan and its seconds."""
    t = _time.perf_counter()
    return _cell_plan(cell, opts, drive), _time.perf_counter() - t


def check_row_call(problem, progress, what: str) -> None:
    """TypeError where a row planner's ``problem`` is not a :class:`Problem` or ``progress`` not
    a callable (a name, path or mapping: :func:`coplan.solve` reads those; here a name raised
    "'str' object has no attribute 'gantry'")."""
    require_problem(problem, what)
    check_progress(progress, what)
    check_as_file(problem)  # (as coplan.solve: a carriage of 1 um/s took 21 GB here)
    check_row_work(problem)


def check_row_work(problem: Problem) -> None:
    """:class:`~coplan.errors.ProblemError` where the row's lower bound for any plan
    (:func:`coplan.allocate.row_bound.row_bounds`) outlasts the longest plan coplan makes
    (:func:`coplan.problem.plausible.max_plan_seconds`): arms limited to 0.001 rad/s on a two-arm
    row of 10 fruit passed the file's checks, and coplan solve planned 42205 s in 99 s and 3 GB
    and called it a success, its 244 MB plan.json refused by coplan verify. The file's own check
    (:func:`~coplan.problem.plausible.row_work_bound`, closed form) catches the plainest cases;
    the bound (about a second on a shipped row) is computed only where that comes within a
    quarter of the limit."""
    from ..allocate.row_bound import row_bounds
    from ..errors import Issue, ProblemError
    from ..problem.plausible import plan_seconds_limit, row_work_bound, too_long_row

    limit = plan_seconds_limit(problem)
    if row_work_bound(problem).seconds <= limit / 4:
        return
    b = row_bounds(problem, priced=False)
    bound = b.any_plan
    # (the bound counts every fruit an arm reaches from some carriage position: only where the screen
    # rules none of them out is it a bound on the plan coplan would make)
    if bound > limit and b.fruit <= len(row_reach(problem).harvestable()):
        raise ProblemError([Issue("arms", too_long_row(problem, bound, "its lower bound for any plan (coplan check "
                                                                       "gives its parts) is"))],
                           str(problem.source) if problem.source else "a problem built in Python")


def plan_row(problem: Problem, options: RowOptions | None = None, progress: Callable[[str], None] | None = None) -> RowResult:
    """Plan ``problem`` (a row: it has a gantry) stop and go, end to end, and verify it: the row
    screened for where each fruit can be harvested from, the stops chosen by ``options.stops``
    (optimised, fixed stride or fewest stops), each stop's cell planned by ``options.planner``
    (coordinated, its moves retimed; or optimal) while the rule goes on, the carriage's moves
    jerk-limited, the whole plan verified in the row frame (the module docstring has the details).
    ``options``: :class:`RowOptions` (workers, resolution, the stop window's prices); ``progress``:
    a callable given one line per step. Returns a :class:`RowResult`; the row's figures (fruit per
    hour, ratios to the bounds, first motion) are :func:`coplan.row.metrics.row_metrics`.
    :func:`coplan.solve` (``gantry="stop-and-go"``) calls this and adds them."""
    from ..verify.verifier import verify

    check_row_call(problem, progress, "plan_row")
    if problem.gantry is None:
        raise ValueError(f"{problem.name!r} has no gantry: plan it as a cell")
    if options is not None and not isinstance(options, RowOptions):
        raise TypeError(f"options: a row stop and go takes RowOptions(...), found {type(options).__name__} {options!r}")
    opts = options or RowOptions()
    say, tick = speaker(progress), ticker(progress)
    t0 = _time.perf_counter()
    timings: dict[str, float] = {}
    rule = StopRule(opts.stops)
    # the optimised rule screens the row stretch by stretch, as its windows advance (the carriage
    # can start before the far end is screened); the other rules need the whole row first
    reach = row_reach(problem, opts.resolution, lazy=rule == StopRule.OPTIMISED)
    timings["reach"] = _time.perf_counter() - t0
    planned: list[StopPlan] = []
    first_stop_at: list[float] = []
    pending: list[tuple] = []  # (stop, future, when it was ready) with workers
    # (more than the cores would only queue: the plan does not depend on it; plan.json records the
    # workers asked for, which is the same on any machine -- it recorded these, 1 on one core)
    pool = process_pool(min(int(opts.workers), cores()))

    def landed(s: Stop, p: Plan, ready: float, seconds: float) -> None:
        if p.status == PlanStatus.INTERRUPTED:  # (the optimal cell planner turns Ctrl-C into its best plan)
            raise KeyboardInterrupt
        planned.append(StopPlan(s, p, ready=ready, seconds=seconds))
        done = sum(len(sp.stop.fruit) for sp in planned)
        tick(Tick("row", s.x - problem.gantry.start, problem.gantry.length, "m of rail", note=f"stop {len(planned)}: {done} fruit planned"))

    def on_stop(s: Stop) -> None:
        drive = None
        if not first_stop_at:
            first_stop_at.append(_time.perf_counter() - t0)
            drive = arrival_time(problem.gantry, problem.gantry.start, s.x)  # (its move there and settle)
        cell = cell_at(problem, s.x, s.fruit)
        if pool is None:
            tc = _time.perf_counter()
            p = _cell_plan(cell, opts, drive)
            landed(s, p, _time.perf_counter() - t0, _time.perf_counter() - tc)
            return
        fut, when = pool.submit(_cell_job, cell, opts, drive), []
        fut.add_done_callback(lambda f, when=when: when.append(_time.perf_counter() - t0))
        pending.append((s, fut, when))

    ts = _time.perf_counter()
    info: dict = {"mode": GantryMode.STOP_AND_GO.value, "rule": rule.value, "cell_planner": PlannerKind(opts.planner).value,
                  "workers": int(opts.workers), "retime": bool(opts.retime) and PlannerKind(opts.planner) == PlannerKind.COORDINATED,
                  "resolution": float(opts.resolution)}  # (it moves the plan: a row made with another was not reproducible from its file)
    kept: list[Stop] = []  # every stop the rule kept, in carriage order
    interrupted = False
    try:
        if rule == StopRule.OPTIMISED:
            info["stop_price"] = float(opts.window.stop_price)
            info["pace_price"] = float(opts.window.pace_price)
            _, info["stops_solver"] = optimised_stops(problem, reach, opts.window, lambda s: (kept.append(s), on_stop(s)))
        else:
            for s in (fixed_stops(reach) if rule == StopRule.FIXED else fewest_stops(reach, exact=True)):
                kept.append(s)
                on_stop(s)
        for s, fut, when in pending:  # the cells planned in the workers, in the order the stops were kept
            p, seconds = fut.result()
            landed(s, p, when[0] if when else _time.perf_counter() - t0, seconds)
    except KeyboardInterrupt:  # Ctrl-C / SIGTERM: the row as far as its stops are planned, verified, is kept
        interrupted = True
        for s, fut, when in pending:
            if fut.done() and not fut.cancelled() and fut.exception() is None and all(sp.stop is not s for sp in planned):
                p, seconds = fut.result()
                if p.status != PlanStatus.INTERRUPTED:
                    landed(s, p, when[0] if when else _time.perf_counter() - t0, seconds)
    finally:
        if pool is not None:
            pool.shutdown(wait=not interrupted, cancel_futures=True)
    late = False  # interrupted during the second chance: every stop planned by then is kept
    dropped: list[tuple[float, dict]] = []  # second-chance stops that picked nothing: (x, left_out)
    if not interrupted:
        try:
            info["second_chance"] = _second_chance(problem, reach, planned, opts, landed, t0, dropped)
        except KeyboardInterrupt:  # (the row as planned so far stands: every cell in it is whole)
            late = True
    if interrupted:  # the stops from the first on whose cells are planned (a worker may have finished a later one)
        planned = _planned_prefix(planned, kept)
        info["interrupted"] = f"after {len(planned)} of the {len(kept)} stops kept so far: the row as far as they go"
        say(f"row: interrupted; keeping the row as far as its stops planned so far ({len(planned)}), verified")
        reach.ensure(math.inf)  # (the whole row screened: what is harvestable, for the figures)
    elif late:
        interrupted = True
        info["interrupted"] = (f"while fruit a stop's cell left out were given a second chance: the row's {len(planned)} "
                               f"stops planned by then")
        say("row: interrupted during the second chance; keeping every stop planned so far, verified")
    # (a Ctrl-C while the planned row was assembled and verified threw it all away: it is held
    # until the row is whole and verified, and the row is kept, said interrupted)
    cut = False
    try:
        with signals_deferred():
            planned.sort(key=lambda sp: sp.stop.k)
            timings["stops_and_cells"] = _time.perf_counter() - ts
            timings["cells"] = sum(sp.seconds for sp in planned)
            ta = _time.perf_counter()
            plan = assemble(problem, planned, PlannerKind(opts.planner))
            timings["assemble"] = _time.perf_counter() - ta
            timings["planning"] = _time.perf_counter() - t0
            tv = _time.perf_counter()
            ver = verify(problem, plan)
            timings["verify"] = _time.perf_counter() - tv
            plan = finalize_row(problem, plan, ver, reach)
            if interrupted:
                plan.status = PlanStatus.INTERRUPTED  # (the verdict on what it has is in plan.verification)
            info["first_stop_seconds"] = first_stop_at[0] if first_stop_at else None
            info["retimed_cells"] = sum(1 for sp in planned if sp.plan.solver.get("retime"))  # (cells whose retiming was kept)
            info["left_out"] = _left_out(reach, planned, dropped, interrupted)
            errors = {f"{sp.stop.x:.3f}": sp.plan.solver["internal_error"] for sp in planned if sp.plan.solver.get("internal_error")}
            if errors:  # (a stop's optimal cell planner stopped on an internal error: its plan from before it is the stop's)
                info["cell_errors"] = errors
            plan.solver = {"status": plan.status.value, "row": info, "timings": dict(timings)}
    except KeyboardInterrupt:
        cut = True
    result = RowResult(plan, ver, planned, reach, timings, info)
    if cut:
        result.mark_interrupted("while the planned row was assembled and verified: the row as planned")
    say(f"row: {len(planned)} stop{'' if len(planned) == 1 else 's'} ({rule.value}), {plan.metrics.get('harvested')} fruit, "
        f"row time {plan.metrics.get('makespan', 0.0):.2f} s, planned in {timings['planning']:.2f} s")
    return result


def _planned_prefix(planned: list[StopPlan], kept: list[Stop]) -> list[StopPlan]:
    """Of an interrupted row's planned stops, those from its first stop kept (``kept``, in
    carriage order) up to the first whose cell is not planned: the row as far as it goes whole."""
    have = {id(sp.stop) for sp in planned}
    prefix = next((i for i, s in enumerate(kept) if id(s) not in have), len(kept))
    keep = {id(s) for s in kept[:prefix]}
    return [sp for sp in planned if id(sp.stop) in keep]


def _left_out(reach: RowReach, planned: list[StopPlan], dropped: list[tuple[float, dict]], interrupted: bool) -> dict[str, str]:
    """Fruit id -> why the row left it out: screened out (``reach.reasons``); left by a stop's cell
    planner (and no second chance took it; ``dropped``: second-chance stops that picked nothing),
    at every stop tried, in carriage order; not planned, the row interrupted before its stop."""
    out = dict(reach.reasons)
    picked = _picked(planned)
    for x, left in sorted([(sp.stop.x, sp.plan.solver.get("left_out") or {}) for sp in planned] + dropped, key=lambda d: d[0]):
        for f, why in left.items():
            if f not in picked:
                said = out.get(f)
                out[f] = (f"{said}; " if said else "") + f"at the stop at {x:.2f} m: {why}"
    if interrupted:  # the rest of the row: not planned
        done = {f for sp in planned for f in sp.stop.fruit}
        for f in reach.harvestable():
            if f not in done and f not in out:
                out[f] = f"{f}: not planned: the row was interrupted before a stop that serves it"
    return out


#: m: a fruit a stop's cell planner left out is tried again at a stop at least this far from
#: where it was tried (then farther), while a stop of the rail serves it
RETRY_AWAY = (0.25, 0.5)


def _picked(planned: list[StopPlan]) -> set[str]:
    return {e.fruit for sp in planned for e in sp.plan.events if e.kind == EventKind.PICK}


def _second_chance(problem: Problem, reach: RowReach, planned: list[StopPlan], opts: RowOptions, landed, t0: float,
                   dropped: list[tuple[float, dict]]) -> dict:
    """Fruit a stop's cell planner left out -- its coordination found no schedule there (arms too
    close for the fruit at that carriage position) -- are tried again, at stops elsewhere on the
    rail that serve them (:func:`coplan.row.stops.retry_stops`), each at least
    :data:`RETRY_AWAY` from where they were tried, in up to that many rounds. The new stops join
    the row in carriage order, planned after the rest (their slack says whether the carriage
    would have had to wait). A new stop whose cell picks nothing is not kept (the carriage would
    drive there and settle for nothing): it goes to ``dropped`` as ``(x, left_out)``, for the
    reasons. Returns what it did."""
    from .stops import retry_stops

    tried: dict[str, list[float]] = {}  # fruit -> where a stop left it out
    offered: set[str] = set()  # fruit a second-chance stop took
    stops = 0
    for away in RETRY_AWAY:
        picked = _picked(planned)
        for x, left in [(sp.stop.x, sp.plan.solver.get("left_out") or {}) for sp in planned] + dropped:
            for f in left:
                if f not in picked and x not in tried.setdefault(f, []):
                    tried[f].append(x)
        failed = {f: xs for f, xs in tried.items() if f not in picked}
        new = retry_stops(reach, failed, {sp.stop.k for sp in planned}, away) if failed else []
        if not new:
            break
        for s in new:
            offered |= set(s.fruit)
            tc = _time.perf_counter()
            p = _cell_plan(cell_at(problem, s.x, s.fruit), opts)
            if p.status == PlanStatus.INTERRUPTED or any(e.kind == EventKind.PICK for e in p.events):
                landed(s, p, _time.perf_counter() - t0, _time.perf_counter() - tc)
                stops += 1
            else:
                dropped.append((s.x, dict(p.solver.get("left_out") or {})))
    picked = _picked(planned)
    return {"stops": stops, "fruit": len(offered), "harvested": sum(1 for f in offered if f in picked),
            "dropped": len(dropped)}


def finalize_row(problem: Problem, plan: Plan, ver, reach: RowReach) -> Plan:
    """A row plan's status and metrics from the verifier's verdict (:func:`coplan.plan.finalize_plan`):
    as for a cell, success when every fruit some carriage position reaches is harvested (the
    verifier's own count: a fruit only a locked arm or a blocked pose reaches makes it partial).
    Its ``unreachable`` lists what the screen left out, and ``metrics.unreachable`` counts, as a
    cell's does, the fruit out of every arm's reach from the whole rail."""
    from ..verify.row import row_reachable_ids

    plan.unreachable = screened_out(problem, reach)
    plan = finalize_plan(plan, ver, len(row_reachable_ids(problem)))
    plan.metrics["unreachable"] = len(problem.fruits) - plan.metrics["reachable"]
    return plan


def _first_last_pick(p: Plan) -> tuple[float, float]:
    picks = [e for e in p.events if e.kind == EventKind.PICK]
    if not picks:
        return 0.0, 0.0
    return min(e.t_start for e in picks), max(e.t_end for e in picks)


def assemble(problem: Problem, stops: list[StopPlan], planner: PlannerKind = PlannerKind.COORDINATED,
             rate: float = DEFAULT_RATE) -> Plan:
    """One row plan of the stops' cell plans (module docstring, step 4); sets each stop's times."""
    g = problem.gantry
    dt = 1.0 / rate

    def up(t: float) -> int:  # the first grid index at or after t
        return int(math.ceil(t * rate - 1e-6))

    x, moves = g.start, []  # (start index, Move1D)
    free, carriage_free = 0, 0  # grid index: arms all home again / the carriage may leave
    for sp in stops:
        mv = Move1D.between(x, sp.stop.x, g.max_velocity, g.max_acceleration, g.max_jerk)
        depart = carriage_free
        arrive = depart * dt + mv.duration
        fp, lp = _first_last_pick(sp.plan)
        start = max(free, up(arrive + g.settle - fp))
        if mv.duration > 0:
            moves.append((depart, mv))
        sp.start, sp.arrive, sp.depart = start * dt, arrive, (start + up(lp)) * dt
        carriage_free = start + up(lp)
        free = start + sp.plan.time.size - 1
        x = sp.stop.x
    n = max([free, carriage_free] + [i + up(mv.duration) for i, mv in moves]) + 1
    time = np.arange(n) / rate
    q = {a.name: np.tile(np.asarray(a.home, float), (n, 1)) for a in problem.arms}
    events: list[Event] = []
    for sp in stops:
        i0 = int(round(sp.start * rate))
        k = sp.plan.time.size
        for a in problem.arms:
            q[a.name][i0:i0 + k] = sp.plan.q[a.name]
        events += [Event(e.arm, e.fruit, e.kind, e.t_start + i0 * dt, e.t_end + i0 * dt) for e in sp.plan.events]
    gx = np.full(n, g.start)
    for i, mv in moves:
        gx[i:] = mv.x1
        seg = np.arange(i, min(n, i + up(mv.duration) + 1))
        gx[seg] = mv.state((seg - i) * dt)[0]
    events.sort(key=lambda e: (e.t_start, e.arm))
    allocation: dict[str, list[str]] = {a.name: [] for a in problem.arms}
    for sp in stops:
        for a, fs in sp.plan.allocation.items():
            allocation[a] += list(fs)
    plan = Plan(problem=problem.name, planner=planner, status=PlanStatus.UNVERIFIED, time=time, q=q, events=events,
                allocation=allocation, unreachable=[], gantry_x=gx)
    plan.metrics = compute_metrics(plan, sum(len(sp.stop.fruit) for sp in stops))
    return plan
