"""The anytime optimal planner: the coordinated plan, improved by search and joint optimisation.

Entry point: :func:`plan_optimal`. It keeps an **incumbent**: a verified plan. Every later
candidate replaces it only if the independent verifier passes it, it harvests at least as
much, and it is faster. So the optimal planner never returns a plan slower than the
coordinated one, and whenever it stops -- at its work budget, at an explicit
``time_limit``, on Ctrl-C, or because the incumbent meets the lower bound (then it is
*proven optimal*) -- it has a verified plan to return.

1. **coordinated** (:func:`coplan.planners.coordinated.planner.plan_coordinated`): allocation, time-optimal
   S-curve moves, conflict-free coordination; verified, it is the first incumbent. The course's
   heuristic baseline (always returned beside the plan) is made right after that first plan.
2. **search** (:func:`coplan.planners.optimal.search.improve`): large-neighbourhood search over allocation,
   order, elbow branches and priorities with the coordinator as evaluator; each new best is
   verified and offered to the incumbent.
   Before the search, the coordinated plan's moves are **retimed**
   (:func:`coplan.planners.optimal.retime.retime`): the same moves, picks and places, every
   start chosen together by CP-SAT instead of leg by leg; a retimed plan is verified and
   offered like any other.
3. **refine** (:func:`coplan.planners.optimal.refine.refine`): the search's neighbourhood
   again from its best (and its other local bests), each neighbour retimed and ranked by its
   retimed makespan; each new best verified and offered. Without it (``refine_retimes: 0``,
   or more than ``refine_fruit`` fruit) the search's best alone is retimed.
4. **polish** (:func:`coplan.planners.optimal.windows.solve_windows`, with ``polish: true``):
   one CasADi/IPOPT program over all arms from the incumbent's schedules, where it still waits
   (receding windows on long rows); its plan is verified and offered like any other. When no
   coordinated plan could be verified at all, this is the planner's last resort (whatever
   ``polish`` says) and its status is reported honestly (best iterate kept, baseline beside it).
5. **widen** (:func:`coplan.planners.optimal.widen.widen`, ``widen: true`` by default): when the
   incumbent keeps less than ``widen_goal`` beyond the clearance, one CasADi/IPOPT program over
   all arms at its makespan and order of events widens the least room between neighbours and
   smooths the jerk; kept when verified, as fast and with a certified margin no smaller.

Every default budget is work (coordinator checks, evaluations, IPOPT iterations), so the
same input gives the same plan on any machine and under any load.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from time import time as _epoch  # the wall clock, for callers outside (not a budget)
from dataclasses import dataclass, replace

import numpy as np

from ...allocate.allocation import Allocation, AllocationMethod
from ..coordinated.planner import Coordinated, CoordinatedOptions, make_plan, plan_coordinated, schedules_plan
from ..heuristic import plan_heuristic
from .nlp_data import Grid, SolverStatus, build_grid, knot_events
from ...plan import Event, EventKind, Plan, PlannerKind, PlanStatus, finalize_plan
from ...problem.model import Problem
from ...progress import Tick, speaker, ticker
from ..coordinated.schedule import ArmSchedule, StepKind, decoupled_schedules
from ...allocate.screen import screened
from .search import Neighbourhood, SearchOptions, StopReason, improve
from .options import OptimalOptions
from .windows import LADDER, solve_windows, window_count

__all__ = ["OptimalOptions", "OptimalResult", "plan_optimal", "nlp_plan"]  # OptimalOptions: from .options


@dataclass
class OptimalResult:
    plan: Plan
    verification: object
    baseline: Plan
    baseline_verification: object
    allocation: Allocation
    timings: dict[str, float]
    solver_status: SolverStatus
    coordinated: Plan | None = None
    error: str | None = None  # an internal error that stopped the planner (what it had is kept)
    error_trace: str | None = None


# ----------------------------------------------------------------------------- the NLP
_FAIL_STATUS = {
    SolverStatus.INTERRUPTED: PlanStatus.INTERRUPTED,
    SolverStatus.INFEASIBLE: PlanStatus.FAILED,
    SolverStatus.LIMIT_REACHED: PlanStatus.FAILED,
    SolverStatus.NUMERICAL_ERROR: PlanStatus.FAILED,
}


def nlp_plan(problem: Problem, alloc: Allocation, sched: dict[str, ArmSchedule], opts: OptimalOptions | None = None,
             deadline: float | None = None, say: Callable[[str], None] | None = None, iterations: int | None = None,
             grid: Grid | None = None):
    """The joint NLP over all arms from ``sched`` (receding windows); returns ``(plan, info)``.

    ``iterations``: a budget of IPOPT iterations over every solve (None: none). ``grid``: the
    knot grid of ``sched`` when the caller has built it already.

    The plan is unverified (or failed/interrupted with the best iterate kept)."""
    opts = opts or OptimalOptions()
    say = say or (lambda m: None)
    grid = grid if grid is not None else build_grid(sched, opts.h_target)
    # a window solved near the start's timing after free-timing windows before it starts from a
    # state those left; when any window could not be solved cleanly, the whole schedule is
    # solved again with every window near the start from the first
    discarded = 0.0
    spent = 0
    for level in range(len(LADDER) - 1):
        left = None if iterations is None else iterations - spent
        if level and left is not None and left <= 0:
            break
        stitched, info = solve_windows(problem, sched, grid, opts, deadline, say, level, left)
        spent += info["iterations"]
        info["level"] = level
        if info.get("clean") or info["status"] == SolverStatus.INTERRUPTED or info.get("budget_spent") or (
                deadline is not None and _time.perf_counter() > deadline):
            break
        if level + 2 < len(LADDER):
            say(f"a window could not be solved cleanly: solving every window again with {LADDER[level + 1][0]}")
            discarded += info["build"] + info["solve"]
    status: SolverStatus = info["status"]
    nlp_info = dict(
        status=status.value,
        ipopt_status=info.get("ipopt_status"),
        iterations=info.get("iterations"),
        windows=info.get("windows"),
        rounds=info.get("rounds"),
        window_timing=info.get("window_stages"),
        restarted=bool(info.get("level", 0)),
        separation_points=info.get("points"),
        n_vars=info.get("n_vars"),
        n_cons=info.get("n_cons"),
        max_constraint_violation=info.get("max_violation"),
        seconds=info.get("build", 0.0) + info.get("solve", 0.0) + discarded,
    )
    events = knot_events(sched, grid, stitched.t, stitched.t.size - 1)
    plan_status = PlanStatus.UNVERIFIED if status.converged else _FAIL_STATUS[status]
    msg = (f"IPOPT {info.get('ipopt_status')}" if status.converged else
           f"IPOPT stopped ({info.get('ipopt_status')}); the best iterate of window {info.get('complete_windows', 0) + 1} is kept")
    plan = make_plan(problem, alloc, stitched.sample, float(stitched.t[-1]), events, plan_status,
                     {"nlp": nlp_info, "message": msg}, PlannerKind.OPTIMAL)
    return plan, nlp_info, status


# ----------------------------------------------------------------------------- the incumbent
class _Incumbent:
    """The best verified plan so far (see the module docstring for the acceptance rule)."""

    def __init__(self, problem: Problem, t_start: float, say):
        self.problem, self.t_start, self.say = problem, t_start, say
        self.n_reach = len(problem.reachable_ids())
        self.plan: Plan | None = None
        self.verification = None
        self.candidate: Coordinated | None = None
        self.source = None
        self.first_at = None
        self.first_wall = None  # the wall clock (s since the epoch) at the first verified plan
        self.improved_at = None
        self.history: list[dict] = []

    @property
    def makespan(self) -> float:
        return self.plan.metrics["makespan"] if self.plan is not None else np.inf

    def offer(self, plan: Plan, verification, source: str, candidate: Coordinated | None = None,
              ties: bool = False) -> bool:
        """Keep ``plan`` if verified, harvesting as much and faster (with ``ties``: or as fast,
        so that a parallel search's winner replaces an equal best that happened to arrive first)."""
        plan = finalize_plan(plan, verification, self.n_reach)
        if plan.status not in (PlanStatus.SUCCESS, PlanStatus.PARTIAL):
            return False
        equal = False  # as much, as fast: kept only with ``ties``, and quietly (not an improvement)
        if self.plan is not None:
            got, have = plan.metrics["harvested"], self.plan.metrics["harvested"]
            mk = plan.metrics["makespan"]
            equal = got == have and mk >= self.makespan - 1e-9
            if got < have or (equal and not (ties and mk <= self.makespan + 1e-9)):
                return False
        self.plan, self.verification, self.source = plan, verification, source
        self.candidate = candidate if candidate is not None else self.candidate
        if equal:
            return True
        now = _time.perf_counter() - self.t_start
        if self.first_at is None:
            self.first_at, self.first_wall = now, _epoch()
        self.improved_at = now
        self.history.append({"t": now, "makespan": self.makespan, "source": source})
        lb = plan.metrics.get("lower_bound") or 0.0
        gap = f", {max(self.makespan / lb - 1, 0.0):.2%} over the lower bound {lb:.3f} s" if lb else ""
        self.say(f"incumbent {self.makespan:.3f} s ({source}){gap}")
        return True


def plan_optimal(
    problem: Problem,
    allocation: AllocationMethod | str = AllocationMethod.MAKESPAN,
    options: OptimalOptions | None = None,
    progress: Callable[[str], None] | None = None,
) -> OptimalResult:
    """Plan all arms, anytime: coordinated plan, retime, search, refine (then the joint NLP
    with ``polish``, or as the last resort); every incumbent verified."""
    from ...verify.verifier import verify

    opts = options or OptimalOptions()
    say = speaker(progress)
    tick = ticker(progress)
    t_start = _time.perf_counter()
    deadline = None if opts.time_limit is None else t_start + opts.time_limit
    timings: dict[str, float] = {}
    n_reach = len(problem.reachable_ids())
    base: list = []  # the course's baseline and its verification, always beside the plan

    def make_baseline() -> None:
        """The baseline, made once the first verified plan is in hand (so that the first plan
        does not wait for it: 0.4-2.6 s on rows of 100-600 fruit), else at the end."""
        tb = _time.perf_counter()
        b = plan_heuristic(problem)
        v = verify(problem, b)
        base.extend([finalize_plan(b, v, n_reach), v])
        timings["baseline"] = _time.perf_counter() - tb

    t0 = _time.perf_counter()
    inc = _Incumbent(problem, t0, say)
    n_harvestable = int(screened(problem).reach.any(axis=0).sum())

    def everything_harvestable(p: Plan | None) -> bool:
        """A verified plan that harvests every fruit the screen allows: the bound is about
        exactly those, so meeting it proves the plan optimal (a partial plan too, whose other
        fruit no plan can harvest)."""
        return p is not None and p.status in (PlanStatus.SUCCESS, PlanStatus.PARTIAL) \
            and p.metrics.get("harvested", 0) >= n_harvestable
    cache: dict = {}  # routes and moves shared by every coordinator run
    # under a clock limit the coordinated stage's later candidates get at most a third of it
    # (its first always completes: there must be a plan); the rest is the search's and retiming's
    copts = CoordinatedOptions(margin=opts.margin, budget_checks=opts.coordination_checks,
                               time_limit=None if opts.time_limit is None else opts.time_limit / 3)
    interrupted = False
    stop = StopReason.BUDGET
    search_info = nlp_info = refine_info = widen_info = None
    retime_info: list[dict] = []
    coord_plan = None
    error = error_trace = None
    bound = 0.0

    def stage(name: str, unit: str = "") -> Callable[[float], None]:
        """A tick for stage ``name`` now, and a callable that ticks its share later."""
        def at(share: float | None) -> None:
            tick(Tick(name, share or 0.0, None if share is None else 1.0, unit, inc.makespan if inc.plan else None,
                      bound or None))
        at(None if not unit else 0.0)
        return at

    def first_feasible(c: Coordinated) -> None:
        """The coordinator's first conflict-free candidate, verified and offered at once: a
        verified plan long before every candidate is tried (the best one is offered after)."""
        if inc.plan is None and not c.fallback:
            p = schedules_plan(problem, c.alloc, c.schedules, PlannerKind.OPTIMAL, {})
            inc.offer(p, verify(problem, p), "coordinated", c)
            if not base:
                make_baseline()

    try:
        stage("coordinated")
        coord = plan_coordinated(problem, allocation, copts, say, cache, on_feasible=first_feasible)
        timings["coordinated"] = _time.perf_counter() - t0 - timings.get("baseline", 0.0)  # (the baseline is made inside it)
        coord_plan = coord.plan
        cand = coord.candidate
        if cand is not None:
            inc.offer(schedules_plan(problem, cand.alloc, cand.schedules, PlannerKind.OPTIMAL, {}), coord.verification,
                      "coordinated", cand)
        bound = coord.plan.metrics.get("lower_bound") or 0.0

        def proven() -> bool:
            return everything_harvestable(inc.plan) and inc.makespan <= bound + opts.tolerance

        def checked(c: Coordinated) -> tuple[Plan, object]:
            """A candidate's plan and its verification."""
            p = schedules_plan(problem, c.alloc, c.schedules, PlannerKind.OPTIMAL, {})
            return p, verify(problem, p)

        def offer(c: Coordinated, source: str) -> bool:
            """A candidate's plan, verified, offered to the incumbent; whether it was kept."""
            return inc.offer(*checked(c), source, c)

        def retimed(c: Coordinated, of: str) -> None:
            """The retimed ``c`` offered to the incumbent (when retiming is on and can still gain)."""
            if not opts.retime or c is None or c.fallback or proven() or (deadline is not None and _time.perf_counter() > deadline):
                return
            from .retime import retime, retimed_candidate

            stage("retime")
            tr = _time.perf_counter()
            r = retime(problem, c.schedules, opts.margin, work=opts.retime_work, tables=cache.setdefault("curve_tables", {}),
                       memo=cache.setdefault("meetings", {}),
                       deadline=None if deadline is None else tr + (deadline - tr) / 2)  # (under a clock limit: half what is left)
            entry = {"of": of, "status": r.status, "makespan_before": c.makespan, "makespan": r.makespan,
                     "constraints": r.constraints, "wall_seconds": _time.perf_counter() - tr, "accepted": False}
            if r.schedules is not None and r.makespan < min(c.makespan, inc.makespan) - 1e-9:
                entry["accepted"] = offer(retimed_candidate(c, r), "retime")
            retime_info.append(entry)
            timings["retime"] = timings.get("retime", 0.0) + entry["wall_seconds"]

        start = inc.candidate
        retimed(start, "coordinated")

        # search: allocation, order, branches, priorities with the coordinator as evaluator
        if start is not None and not proven() and opts.search_work > 0 and opts.search_evaluations > 0 \
                and not start.fallback:
            ts = _time.perf_counter()

            def on_improve(c: Coordinated) -> None:
                offer(c, "search")

            sopts = SearchOptions(evaluations=opts.search_evaluations, work=opts.search_work, patience=opts.search_patience, starts=opts.search_starts,
                                  seed=opts.seed,
                                  temperature=opts.search_temperature,
                                  tolerance=opts.tolerance,
                                  fixed_assignment=AllocationMethod(allocation) != AllocationMethod.MAKESPAN)
            anchor = coord.bound.assignment if coord.bound is not None else None
            hood = Neighbourhood(problem, start, opts.margin, sopts, cache)
            if opts.workers > 1:  # a portfolio of seeded searches in parallel processes
                from .portfolio import search_portfolio

                port = search_portfolio(problem, start, bound, opts.margin, sopts, opts.workers, on_improve, deadline,
                                        anchor, stage("search", f"of its work budget (slowest of {opts.workers} workers)"))
                found, stats = port.best, port.stats
                if found is not start:  # the winner, whichever worker's best arrived first at an equal makespan
                    inc.offer(*checked(found), "search", found, ties=True)
            else:
                found, stats = improve(problem, start, bound, opts.margin, sopts, on_improve, deadline, cache, anchor, hood,
                                       stage("search", "of its work budget"))
            search_info = stats.summary()
            if opts.workers > 1:
                search_info["workers"] = port.workers
            timings["search"] = _time.perf_counter() - ts
            stop = stats.stop
            interrupted = stats.stop == StopReason.INTERRUPTED
            n_fruit = sum(len(seq) for seq in found.alloc.assignment.values())
            refining = opts.retime and opts.refine_retimes > 0 and n_fruit <= opts.refine_fruit
            if not interrupted and refining and not proven() and stats.best_state is not None and (
                    deadline is None or _time.perf_counter() < deadline):
                from .refine import RefineOptions, refine

                tr = _time.perf_counter()

                def offer_refined(c: Coordinated) -> bool:
                    """Offered like any other; the refinement drops what the verifier refuses
                    (and keeps its own best, which may trail the incumbent)."""
                    p, ver = checked(c)
                    inc.offer(p, ver, "refine", c)
                    return bool(ver.passed)

                ropts = RefineOptions(retimes=opts.refine_retimes, work=opts.retime_work, tolerance=opts.tolerance)
                _, rstats = refine(problem, hood, stats.best_state, found, bound, opts.margin, ropts, offer_refined,
                                   deadline, cache.setdefault("curve_tables", {}), cache.setdefault("meetings", {}),
                                   stats.local_bests, stage("refine", "of its retimings"))
                refine_info = rstats.summary()
                timings["refine"] = _time.perf_counter() - tr
                stop = rstats.stop
                interrupted = rstats.stop == StopReason.INTERRUPTED
            elif not interrupted and found is not start:
                retimed(found, "search")
        # polish: the joint NLP from the incumbent's schedules, where it still waits; or, when
        # nothing could be verified, the last resort from whatever schedules there are
        within = deadline is None or _time.perf_counter() < deadline
        src = inc.candidate or cand
        if src is None and n_reach:  # nothing coordinated: the NLP starts from the decoupled plan
            from ...allocate.allocation import allocate

            a0 = allocate(problem, allocation)
            src = Coordinated(a0, decoupled_schedules(problem, a0), a0.estimated_makespan)
            say("no conflict-free coordination found; the joint NLP starts from the decoupled (colliding) plan")
        slack = src is not None and retimable(src.schedules)
        grid = None
        if src is not None and inc.plan is not None and opts.polish and not proven():
            if not slack:
                say("joint NLP skipped: the arm that places last never waits and moves straight between its poses, "
                    "so no retiming of the same poses and order can finish it sooner")
            else:
                grid = build_grid(src.schedules, opts.h_target)
                n_win = window_count(grid, opts.window, src.schedules)
                if n_win > opts.polish_windows:
                    slack = False
                    say(f"joint NLP skipped: the schedule needs {n_win} receding windows (polish_windows is {opts.polish_windows})")
        if not interrupted and within and src is not None and n_reach and not proven() and (
                inc.plan is None or (opts.polish and slack)):
            stage("joint NLP")
            tp = _time.perf_counter()
            popts = replace(opts, ipopt={"ipopt.max_iter": 200} | dict(opts.ipopt),
                            max_rounds=min(opts.max_rounds, opts.polish_rounds)) if inc.plan else opts
            plan, nlp_info, nlp_status = nlp_plan(problem, src.alloc, src.schedules, popts, deadline, say,
                                                  opts.polish_iterations if inc.plan else None, grid)
            timings["polish"] = _time.perf_counter() - tp
            interrupted = nlp_status == SolverStatus.INTERRUPTED
            if plan.status != PlanStatus.UNVERIFIED and inc.plan is not None:
                say(f"joint NLP: {plan.solver.get('message', 'no solution')}; kept the incumbent")
            if plan.status == PlanStatus.UNVERIFIED:
                ver = verify(problem, plan)
                accepted = inc.offer(plan, ver, "joint NLP")
                nlp_info["accepted"] = accepted
                nlp_info["verified"] = bool(ver.passed)
                if not accepted and inc.plan is not None:
                    why = "not better than the incumbent" if ver.passed else \
                        f"refused by the verifier ({len(ver.violations)} violation{'s' * (len(ver.violations) != 1)})"
                    say(f"joint NLP: {plan.metrics['makespan']:.3f} s, {why}; kept the incumbent")
            if inc.plan is None:  # nothing verified at all: report the NLP's plan honestly
                ver = verify(problem, plan)
                plan = finalize_plan(plan, ver, n_reach)
                inc.plan, inc.verification, inc.source = plan, ver, "joint NLP (unverified)"
        if opts.widen and not interrupted and inc.plan is not None and inc.candidate is not None \
                and inc.source != "joint NLP" and (
                deadline is None or _time.perf_counter() < deadline):
            stage("widen")
            tw = _time.perf_counter()
            widen_info = widened(problem, inc, opts, deadline, say)
            timings["widen"] = _time.perf_counter() - tw
        if proven():
            stop = StopReason.PROVEN_OPTIMAL
        elif deadline is not None and _time.perf_counter() >= deadline:
            stop = StopReason.TIME_LIMIT
    except KeyboardInterrupt:
        interrupted = True
    except Exception as e:  # noqa: BLE001 -- a bug in a stage: keep what was computed before it, report it
        import traceback

        error, error_trace = f"{type(e).__name__}: {e}", traceback.format_exc()
        say(f"internal error ({error}); keeping what was computed before it")
    if interrupted:
        stop = StopReason.INTERRUPTED
    if not base:
        make_baseline()
    baseline, base_ver = base
    if inc.plan is None:  # interrupted before anything, or nothing could be planned
        if coord_plan is not None:
            inc.plan, inc.verification = coord_plan, None
        else:
            from ...allocate.allocation import allocate

            alloc0 = allocate(problem, allocation)
            inc.plan = make_plan(problem, alloc0, lambda t: {a.name: np.tile(a.home, (t.size, 1)) for a in problem.arms},
                                 0.0, [], PlanStatus.FAILED if error else PlanStatus.INTERRUPTED,
                                 {"message": "stopped before the first plan"}, PlannerKind.OPTIMAL)
        inc.verification = inc.verification or verify(problem, inc.plan)
    plan = inc.plan
    plan.planner = PlannerKind.OPTIMAL
    if interrupted:
        plan.status = PlanStatus.INTERRUPTED
    plan = finalize_plan(plan, inc.verification, n_reach)
    coord_mk = coord_plan.metrics.get("makespan") if coord_plan is not None and coord_plan.status == PlanStatus.SUCCESS else None
    lb = plan.metrics.get("lower_bound")
    mk = plan.metrics.get("makespan") or 0.0
    verified = plan.verification is not None and plan.verification.get("passed")
    plan.metrics.update(
        coordinated_makespan=coord_mk,
        improvement_over_coordinated=(1.0 - mk / coord_mk) if coord_mk else None,
        optimality="proven" if (verified and lb and mk <= lb + opts.tolerance and everything_harvestable(plan)) else "not proven",
        baseline_makespan=baseline.metrics.get("makespan"),
        baseline_status=baseline.status.value,
        time_to_first_verified=inc.first_at,
        time_of_last_improvement=inc.improved_at,
        time_to_ratio=time_to_ratio(inc.history, lb),
    )
    timings["total"] = _time.perf_counter() - t_start - timings["baseline"]
    plan.solver = {
        "status": plan.status.value,
        "message": _message(inc, stop),
        "stopped_by": stop.value,
        "incumbent_from": inc.source,
        "incumbents": inc.history,
        "first_verified_wall_time": inc.first_wall,  # s since the epoch: when a caller outside could have had a plan
        # fruit the incumbent's coordination could not fit in, each with the reason
        "left_out": dict(inc.candidate.left_out) if inc.candidate is not None else {},
        "allocation": AllocationMethod(allocation).value,
        "screen": screened(problem).summary(),
        "lower_bound": coord_plan.solver.get("lower_bound") if coord_plan is not None else None,
        "coordinated": coord_plan.solver if coord_plan is not None else None,
        "search": search_info,
        "refine": refine_info,
        "retime": retime_info,
        "nlp": nlp_info,
        "widen": widen_info,
        "options": {k: v for k, v in opts.__dict__.items() if k != "ipopt"} | {"ipopt": dict(opts.ipopt)},
        "timings": dict(timings),
    }
    if error:
        kept = f"the verified incumbent from the {inc.source} stage ({mk:.3f} s)" if verified and inc.source \
            else "no verified plan (the arms stay at home)"
        plan.solver.update(internal_error=error, stopped_by="internal_error",
                           message=f"internal error ({error}); kept {kept} and the baseline")
    alloc_out = inc.candidate.alloc if inc.candidate is not None else None
    status = SolverStatus.INTERRUPTED if interrupted else SolverStatus.OPTIMAL if verified else SolverStatus.NUMERICAL_ERROR
    return OptimalResult(plan, inc.verification, baseline, base_ver, alloc_out, timings, status, coord_plan, error, error_trace)


def widened(problem: Problem, inc: _Incumbent, opts: OptimalOptions, deadline: float | None, say) -> dict:
    """The widening stage on the incumbent's schedules; the widened plan replaces the incumbent
    when it is verified, harvests as much, is no slower and its certified margin is no smaller.
    Returns the stage's report (plan.json ``solver.widen``)."""
    from ...verify.verifier import verify
    from .widen import WidenOptions, widen

    wopts = WidenOptions(cap=opts.widen_cap, iterations=opts.widen_iterations, max_knots=opts.widen_knots,
                         h_target=opts.h_target)
    before = inc.plan
    margin0 = before.verification["certified_clearance"] - problem.task.clearance
    if margin0 >= opts.widen_goal:
        info = {"status": "skipped", "accepted": False, "margin_before": margin0, "makespan_before": inc.makespan,
                "reason": f"the plan keeps {1000 * margin0:.1f} mm beyond the clearance already "
                          f"(widen_goal is {1000 * opts.widen_goal:.0f} mm)"}
        return info
    res = widen(problem, inc.candidate.alloc, inc.candidate.schedules, inc.makespan, wopts, deadline, say)
    info = dict(res.info)
    info.update(accepted=False, margin_before=margin0, makespan_before=inc.makespan)
    if res.plan is None:
        say(f"widen: {info.get('reason', info['status'])}; kept the incumbent")
        return info
    ver = verify(problem, res.plan)
    plan = finalize_plan(res.plan, ver, inc.n_reach)
    for k in ("lower_bound",):
        if k in before.metrics:
            plan.metrics[k] = before.metrics[k]
    margin = ver.certified_clearance - problem.task.clearance if ver.passed else None
    info.update(verified=bool(ver.passed), margin=margin, makespan=plan.metrics["makespan"])
    why = None
    if not ver.passed:
        why = f"refused by the verifier ({len(ver.violations)} violation{'s' * (len(ver.violations) != 1)})"
    elif plan.metrics["harvested"] < before.metrics["harvested"]:
        why = "it harvests less"
    elif plan.metrics["makespan"] > inc.makespan + 1e-9:
        why = f"slower ({plan.metrics['makespan']:.4f} s against {inc.makespan:.4f} s)"
    elif margin < margin0:
        why = f"its certified margin {1000 * margin:.1f} mm is smaller than {1000 * margin0:.1f} mm"
    if why is not None:
        say(f"widen: {why}; kept the incumbent")
        info["reason"] = why
        return info
    inc.plan, inc.verification = plan, ver
    info["accepted"] = True
    say(f"widen: certified margin {1000 * margin0:.1f} -> {1000 * margin:.1f} mm at {plan.metrics['makespan']:.4f} s")
    return info


def time_to_ratio(history: list[dict], bound: float | None, ratios=(1.05, 1.02, 1.01)) -> dict[str, float | None]:
    """When (s after the planner started) the incumbent first came within each ratio of the
    lower bound (from the incumbent history); None where it never did."""
    out: dict[str, float | None] = {}
    for r in ratios:
        hit = next((h["t"] for h in history if bound and h["makespan"] <= r * bound + 1e-9), None)
        out[f"{r:.2f}"] = hit
    return out


def retimable(schedules: dict[str, ArmSchedule], tol: float = 1e-6) -> bool:
    """Whether the joint NLP could finish these schedules sooner.

    The NLP keeps every pick and place pose and each arm's order, and every arm comes to
    rest at them; between two rest poses no motion is faster than the per-joint S-curve the
    schedules already use. So an arm that places last, never waits and moves straight from
    pose to pose (no tucked transit through via poses) is already as fast as these poses
    allow: only a wait or a via on some last-placing arm leaves the NLP anything to gain."""
    end = max((s.last_place for s in schedules.values()), default=0.0)
    for s in schedules.values():
        if s.last_place < end - tol:
            continue
        steps = [st for st in s.steps if st.t1 <= s.last_place + tol]
        if any(st.kind == StepKind.WAIT for st in steps):
            return True
        if any(a.kind == b.kind == StepKind.MOVE for a, b in zip(steps, steps[1:])):
            return True
    return False


def _message(inc: _Incumbent, stop: StopReason) -> str:
    if inc.source is None or inc.source.endswith("(unverified)"):
        return "no verified plan was found; the best the solver had is kept"
    words = {
        StopReason.PROVEN_OPTIMAL: "the plan meets the lower bound: proven optimal",
        StopReason.BUDGET: "the work budget is spent",
        StopReason.STALLED: "the search stopped improving",
        StopReason.EXHAUSTED: "every allocation, order and elbow branch was tried",
        StopReason.TIME_LIMIT: "the time limit was reached; the verified incumbent is returned",
        StopReason.INTERRUPTED: "interrupted; the verified incumbent is saved",
    }
    source = {"coordinated": "the coordinated plan", "search": "the search", "refine": "the refinement",
              "joint NLP": "the joint NLP"}.get(inc.source, inc.source)
    return f"{words[stop]} (incumbent from {source})"
