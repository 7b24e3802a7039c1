"""The optimal planner's stages, run in turn over one incumbent (:data:`STAGES`).

Each stage is a function of one :class:`Run` (the problem, the options, the incumbent, the
shared caches, the clock and every stage's report) that improves the incumbent or leaves it:

========== ==================================================================================
coordinated the coordinated planner's candidates; the first verified one is the incumbent
retime      the coordinated plan's moves, every start chosen together by CP-SAT
search      large-neighbourhood search over allocation, order, branches, priorities
refine      the search's neighbourhood again, each neighbour retimed (or the search's best retimed)
polish      the joint NLP where the incumbent still waits (``polish``); the last resort when
            nothing could be verified
widen       one joint NLP at the incumbent's makespan: more room between neighbours, less jerk
regroup     where the room is still short of the widening's goal: the stages above again at a
            clearance raised by the shortfall (other events), kept when no slower with more room
========== ==================================================================================

Adding or reordering a stage is one line of :data:`STAGES`. Each stage's report goes to
plan.json (``solver.<stage>``) and its wall time to ``solver.timings``; ``solver.stages``
lists what each stage did.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

from ...allocate.allocation import AllocationMethod
from ...allocate.screen import screened
from ...plan import Plan, PlannerKind, PlanStatus, finalize_plan
from ...problem.model import Problem
from ...progress import Tick
from ..coordinated.planner import (Coordinated, CoordinatedOptions, find_coordinated, make_plan, plan_coordinated,
                                  schedules_plan)
from ..coordinated.schedule import ArmSchedule, StepKind, decoupled_schedules
from ..heuristic import plan_heuristic
from .incumbent import Incumbent, Source
from .judged import widened
from .nlp_data import Grid, SolverStatus, any_interrupted, build_grid, knot_events
from .options import OptimalOptions
from .search import Neighbourhood, SearchOptions, StopReason, improve
from .windows import LADDER, solve_windows, window_count

__all__ = ["Run", "STAGES", "nlp_plan", "retimable", "widened"]


@dataclass
class Run:
    """One optimal-planner run: what every stage reads and writes."""

    problem: Problem
    allocation: AllocationMethod | str
    opts: OptimalOptions
    say: Callable[[str], None]
    tick: Callable[[Tick], None]
    t_start: float
    inc: Incumbent
    deadline: float | None = None
    cache: dict = field(default_factory=dict)  # routes and moves shared by every coordinator run
    timings: dict = field(default_factory=dict)
    base: list = field(default_factory=list)  # the course's baseline and its verification
    reports: dict = field(default_factory=lambda: {"search": None, "refine": None, "retime": [], "nlp": None,
                                                   "widen": None, "regroup": None})
    log: list = field(default_factory=list)  # per stage: name, seconds, what it did
    coord: object = None  # the coordinated planner's result
    coord_plan: Plan | None = None
    cand: Coordinated | None = None  # the coordinated planner's best candidate
    start: Coordinated | None = None  # where the search starts
    retimed_first: Coordinated | None = None  # the first candidate, retimed alongside the coordinated planner
    found: Coordinated | None = None  # the search's best
    stats: object = None
    hood: Neighbourhood | None = None
    bound: float = 0.0
    interrupted: bool = False
    stop: StopReason = StopReason.BUDGET
    # the whole planner (problem, allocation, options, progress) -> OptimalResult, for a stage that
    # plans again (regroup): given by plan_optimal, which imports this module, not imported here
    again: Callable | None = None

    def __post_init__(self):
        self.n_reach = len(self.problem.reachable_ids())
        self.n_harvestable = int(screened(self.problem).reach.any(axis=0).sum())

    # ---------------------------------------------------------------- helpers for the stages
    def in_time(self) -> bool:
        return self.deadline is None or _time.perf_counter() < self.deadline

    def everything_harvestable(self, p: Plan | None) -> bool:
        """A verified plan that harvests every fruit the screen allows: the bound is about
        exactly those, so meeting it proves the plan optimal (a partial plan too, whose other
        fruit no plan can harvest)."""
        return p is not None and p.status in (PlanStatus.SUCCESS, PlanStatus.PARTIAL) \
            and p.metrics.get("harvested", 0) >= self.n_harvestable

    def proven(self) -> bool:
        return self.everything_harvestable(self.inc.plan) and self.inc.makespan <= self.bound + self.opts.tolerance

    def make_baseline(self) -> None:
        """The baseline, made once the first verified plan is in hand (so that the first plan
        does not wait for it: 0.4-2.6 s on rows of 100-600 fruit) -- with the coordinated stage
        alongside, once that plan is retimed, while the other process works -- else at the end."""
        from ...verify.verifier import verify

        tb = _time.perf_counter()
        b = plan_heuristic(self.problem)
        v = verify(self.problem, b)
        self.base.extend([finalize_plan(b, v, self.n_reach), v])
        self.timings["baseline"] = _time.perf_counter() - tb

    def stage(self, name: str, unit: str = "") -> Callable[[float], None]:
        """A tick for stage ``name`` now, and a callable that ticks its share later."""
        def at(share: float | None) -> None:
            self.tick(Tick(name, share or 0.0, None if share is None else 1.0, unit,
                           self.inc.makespan if self.inc.plan else None, self.bound or None))
        at(None if not unit else 0.0)
        return at

    def checked(self, c: Coordinated) -> tuple[Plan, object]:
        """A candidate's plan and its verification."""
        from ...verify.verifier import verify

        p = schedules_plan(self.problem, c.alloc, c.schedules, PlannerKind.OPTIMAL, {})
        return p, verify(self.problem, p)

    def offer(self, c: Coordinated, source: str) -> bool:
        """A candidate's plan, verified, offered to the incumbent; whether it was kept."""
        return self.inc.offer(*self.checked(c), source, c)

    def retimed(self, c: Coordinated | None, of: str) -> bool:
        """The retimed ``c`` offered to the incumbent (when retiming is on and can still gain);
        whether a retiming ran."""
        if not self.opts.retime or c is None or c.fallback or self.proven() or not self.in_time():
            return False
        from .retime import bounded_rounds, retime_rounds

        self.stage("retime")
        # bounded, a move comes forward at most by the waits before it and goes back at most by
        # the shift: from its own result, another round can gain again
        n, shift = bounded_rounds(_fruit_of(c), self.opts)
        rounds = retime_rounds(self.problem, c, self.opts.margin, rounds=n, shift=shift, work=self.opts.retime_work, tables=self.cache.setdefault("curve_tables", {}),
                               memo=self.cache.setdefault("meetings", {}), deadline=self.deadline)  # (under a limit: half what is left)
        for k, (r, rc, gained, seconds) in enumerate(rounds):
            entry = {"of": of if k == 0 else f"{of}, round {k + 1}", "status": r.status, "shift": shift,
                     "makespan_before": c.makespan, "makespan": r.makespan,
                     "constraints": r.constraints, "wall_seconds": seconds, "accepted": False}
            if rc is not None and r.makespan < min(c.makespan, self.inc.makespan) - 1e-9:
                entry["accepted"] = self.offer(rc, Source.RETIME)
            self.reports["retime"].append(entry)
            self.timings["retime"] = self.timings.get("retime", 0.0) + seconds
            if not (gained and entry["accepted"]) or not self.in_time():
                break
            c = rc
        return True


def _fruit_of(c: Coordinated) -> int:
    """How many fruit candidate ``c`` plans: beyond ``refine_fruit`` a plan is long (its retiming
    bounded, not refined)."""
    return sum(len(seq) for seq in c.alloc.assignment.values())


# ----------------------------------------------------------------------------- the stages
def coordinated(run: Run) -> str:
    """The coordinated planner; its first conflict-free candidate is verified and offered at
    once (a verified plan long before every candidate is tried), its best one after."""
    from ...verify.verifier import verify

    problem, opts, inc = run.problem, run.opts, run.inc

    def first_feasible(c: Coordinated, baseline: bool = True) -> None:
        if inc.plan is None and not c.fallback:
            p = schedules_plan(problem, c.alloc, c.schedules, PlannerKind.OPTIMAL, {})
            inc.offer(p, verify(problem, p), Source.COORDINATED, c)
            if baseline and not run.base:
                run.make_baseline()

    # under a clock limit the coordinated stage's later candidates get at most a third of it on
    # a long problem (more than ``refine_fruit`` fruit; its first always completes: there must be
    # a plan), the rest being the search's and retiming's, which gain more there; on a cell, the
    # whole limit, as the coordinated planner alone would have it -- so that the optimal planner
    # is never slower than the coordinated one under the same limit (crossing_paths at 0.3 s: its
    # first candidate, 8.05 s, where the coordinated planner's later ones find 6.50 s in 0.26 s)
    share = 1.0 if run.n_harvestable <= opts.refine_fruit else 1 / 3
    copts = CoordinatedOptions(margin=opts.margin, budget_checks=opts.coordination_checks,
                               time_limit=None if opts.time_limit is None else opts.time_limit * share)
    run.stage("coordinated")
    t0 = _time.perf_counter()
    first = None
    if opts.workers > 1 and opts.retime and run.n_harvestable > opts.refine_fruit:  # (the retiming will be bounded)
        coord, first = _alongside(run, copts, first_feasible)
    else:
        coord = plan_coordinated(problem, run.allocation, copts, run.say, run.cache, on_feasible=first_feasible)
    run.coord = coord
    # (the baseline is made inside it; a retiming alongside is the retime stage's)
    run.timings["coordinated"] = (_time.perf_counter() - t0 - run.timings.get("baseline", 0.0)
                                  - run.timings.get("retime", 0.0))
    run.coord_plan = coord.plan
    run.cand = cand = coord.candidate
    if cand is not None:
        inc.offer(schedules_plan(problem, cand.alloc, cand.schedules, PlannerKind.OPTIMAL, {}), coord.verification,
                  Source.COORDINATED, cand)
    run.bound = coord.plan.metrics.get("lower_bound") or 0.0
    run.start = inc.candidate
    if first is not None:  # where one worker would start: the better of the first and the best candidate
        run.start = cand if cand is not None and cand.makespan < first.makespan - 1e-9 else first
    return "planned" if cand is not None else "no conflict-free candidate"


def _alongside(run: Run, copts: CoordinatedOptions, first_feasible: Callable[[Coordinated], None]):
    """Two workers or more on a long problem (more than ``refine_fruit`` fruit): the coordinated
    planner's candidates in another process while this one takes the first candidate and
    retimes it (bounded) at once -- on a long row that retiming, not the later candidates, is
    what comes near the bound. Then the flow goes on exactly as with one worker, from the other
    process's result (its best candidate is where the retime stage and the search start), so
    the same input and workers give the same plan."""
    from .portfolio import Alongside, AlongsideFailed

    other = Alongside(run.problem, run.allocation, copts)
    try:
        # the first candidate (it always completes), offered verified by ``first_feasible``: no
        # plan of the stage's own to verify again
        first, _, bound = find_coordinated(run.problem, AllocationMethod(run.allocation), replace(copts, time_limit=0.0),
                                           run.say, run.cache, _time.perf_counter(),
                                           lambda c: first_feasible(c, baseline=False))
        run.bound = (first.alloc.lower_bound if first is not None else bound.value) or 0.0
        if first is not None and not first.fallback:
            run.retimed(first, "coordinated, its first candidate (the others alongside)")
            run.retimed_first = first
        if not run.base:  # the baseline while the other process works, not before the retiming
            run.make_baseline()
        try:
            coord = other.result()
        except AlongsideFailed as e:
            run.say(f"the coordinated planner's other process gave nothing ({e}); going on from its first candidate")
            coord = None
    finally:
        other.close()
    if coord is None:
        return plan_coordinated(run.problem, run.allocation, replace(copts, time_limit=0.0), run.say, run.cache), first
    return coord, first


def retime_coordinated(run: Run) -> str:
    """The coordinated plan's moves retimed together (unless they were, alongside the
    coordinated planner: its first candidate stayed the best)."""
    if run.start is not None and run.start is run.retimed_first:
        return "retimed alongside the coordinated planner"
    return "ran" if run.retimed(run.start, "coordinated") else "skipped"


def search(run: Run) -> str:
    """Allocation, order, branches, priorities with the coordinator as evaluator (in
    ``workers`` processes when asked)."""
    start, opts = run.start, run.opts
    if start is None or run.proven() or opts.search_work <= 0 or opts.search_evaluations <= 0 or start.fallback:
        return "skipped"
    ts = _time.perf_counter()
    sopts = SearchOptions(evaluations=opts.search_evaluations, work=opts.search_work, patience=opts.search_patience,
                          starts=opts.search_starts, seed=opts.seed, temperature=opts.search_temperature,
                          tolerance=opts.tolerance,
                          fixed_assignment=AllocationMethod(run.allocation) != AllocationMethod.MAKESPAN)
    anchor = run.coord.bound.assignment if run.coord.bound is not None else None
    run.hood = Neighbourhood(run.problem, start, opts.margin, sopts, run.cache)

    def on_improve(c: Coordinated) -> None:
        run.offer(c, Source.SEARCH)

    if opts.workers > 1:  # a portfolio of seeded searches in parallel processes
        from .portfolio import search_portfolio

        port = search_portfolio(run.problem, start, run.bound, opts.margin, sopts, opts.workers, on_improve, run.deadline,
                                anchor, run.stage("search", f"of its work budget (slowest of {opts.workers} workers)"))
        found, stats = port.best, port.stats
        if found is not start:  # the winner, whichever worker's best arrived first at an equal makespan
            run.inc.offer(*run.checked(found), Source.SEARCH, found, ties=True)
    else:
        found, stats = improve(run.problem, start, run.bound, opts.margin, sopts, on_improve, run.deadline, run.cache,
                               anchor, run.hood, run.stage("search", "of its work budget"))
    run.reports["search"] = stats.summary()
    if opts.workers > 1:
        run.reports["search"]["workers"] = port.workers
    run.timings["search"] = _time.perf_counter() - ts
    run.found, run.stats, run.stop = found, stats, stats.stop
    run.interrupted = stats.stop == StopReason.INTERRUPTED
    return stats.stop.value


def refine(run: Run) -> str:
    """The search's neighbourhood again from its best, each neighbour retimed; on problems
    too long to refine (or with ``refine_retimes: 0``) the search's best alone is retimed."""
    found, stats, opts = run.found, run.stats, run.opts
    if found is None or run.interrupted:
        return "skipped"
    refining = opts.retime and opts.refine_retimes > 0 and _fruit_of(found) <= opts.refine_fruit
    if not (refining and not run.proven() and stats.best_state is not None and run.in_time()):
        if found is run.start:
            return "skipped"
        return "retimed the search's best" if run.retimed(found, "search") else "skipped"
    from .refine import RefineOptions, refine as refine_search

    tr = _time.perf_counter()

    def offer_refined(c: Coordinated) -> bool:
        """Offered like any other; the refinement drops what the verifier refuses (and keeps
        its own best, which may trail the incumbent)."""
        p, ver = run.checked(c)
        run.inc.offer(p, ver, Source.REFINE, c)
        return bool(ver.passed)

    ropts = RefineOptions(retimes=opts.refine_retimes, work=opts.retime_work, tolerance=opts.tolerance)
    _, rstats = refine_search(run.problem, run.hood, stats.best_state, found, run.bound, opts.margin, ropts, offer_refined,
                              run.deadline, run.cache.setdefault("curve_tables", {}), run.cache.setdefault("meetings", {}),
                              stats.local_bests, run.stage("refine", "of its retimings"))
    run.reports["refine"] = rstats.summary()
    run.timings["refine"] = _time.perf_counter() - tr
    run.stop = rstats.stop
    run.interrupted = rstats.stop == StopReason.INTERRUPTED
    return rstats.stop.value


def polish(run: Run) -> str:
    """The joint NLP from the incumbent's schedules, where it still waits (``polish``); or,
    when nothing could be verified, the last resort from whatever schedules there are."""
    from ...verify.verifier import verify

    problem, opts, inc, say = run.problem, run.opts, run.inc, run.say
    within = run.in_time()
    src = inc.candidate or run.cand
    if src is None and run.n_reach:  # nothing coordinated: the NLP starts from the decoupled plan
        from ...allocate.allocation import allocate

        a0 = allocate(problem, run.allocation)
        src = Coordinated(a0, decoupled_schedules(problem, a0), a0.estimated_makespan)
        say("no conflict-free coordination found; the joint NLP starts from the decoupled (colliding) plan")
    slack = src is not None and retimable(src.schedules)
    grid = None
    if src is not None and inc.plan is not None and opts.polish and not run.proven():
        if not slack:
            say("joint NLP skipped: the arm that places last never waits and moves straight between its poses, "
                "so no retiming of the same poses and order can finish it sooner")
        else:
            grid = build_grid(src.schedules, opts.h_target)
            n_win = window_count(grid, opts.window, src.schedules)
            if n_win > opts.polish_windows:
                slack = False
                say(f"joint NLP skipped: the schedule needs {n_win} receding windows (polish_windows is {opts.polish_windows})")
    if run.interrupted or not within or src is None or not run.n_reach or run.proven() or not (
            inc.plan is None or (opts.polish and slack)):
        return "skipped"
    run.stage("joint NLP")
    tp = _time.perf_counter()
    popts = replace(opts, ipopt={"ipopt.max_iter": 200} | dict(opts.ipopt),
                    max_rounds=min(opts.max_rounds, opts.polish_rounds)) if inc.plan else opts
    plan, nlp_info, nlp_status = nlp_plan(problem, src.alloc, src.schedules, popts, run.deadline, say,
                                          opts.polish_iterations if inc.plan else None, grid)
    run.reports["nlp"] = nlp_info
    run.timings["polish"] = _time.perf_counter() - tp
    run.interrupted = nlp_status == SolverStatus.INTERRUPTED
    if plan.status != PlanStatus.UNVERIFIED and inc.plan is not None:
        say(f"joint NLP: {plan.solver.get('message', 'no solution')}; kept the incumbent")
    if plan.status == PlanStatus.UNVERIFIED:
        ver = verify(problem, plan)
        accepted = inc.offer(plan, ver, Source.NLP)
        nlp_info["accepted"] = accepted
        nlp_info["verified"] = bool(ver.passed)
        if not accepted and inc.plan is not None:
            why = "not better than the incumbent" if ver.passed else \
                f"refused by the verifier ({len(ver.violations)} violation{'s' * (len(ver.violations) != 1)})"
            say(f"joint NLP: {plan.metrics['makespan']:.3f} s, {why}; kept the incumbent")
    if inc.plan is None:  # nothing verified at all: report the NLP's plan honestly
        ver = verify(problem, plan)
        plan = finalize_plan(plan, ver, run.n_reach)
        inc.plan, inc.verification, inc.source = plan, ver, Source.NLP_UNVERIFIED
    return "accepted" if nlp_info.get("accepted") else "ran"


def widen(run: Run) -> str:
    """More room between neighbours and less jerk at the incumbent's makespan (``widen``)."""
    inc = run.inc
    why = ("the option widen is false" if not run.opts.widen else
           "the run was interrupted first" if run.interrupted else
           "no verified plan with schedules to widen" if inc.plan is None or inc.candidate is None else
           "the incumbent is the joint NLP's plan (no schedules to widen)" if inc.source == Source.NLP else
           "the incumbent harvests nothing: nothing to widen" if not inc.candidate.makespan > 0 else None)
    if why is not None:  # (said in plan.json solver.widen and the summary)
        run.reports["widen"] = {"status": "skipped", "accepted": False, "reason": why}
        return "skipped"
    if not run.in_time():  # said in plan.json and the summary, not skipped silently
        run.reports["widen"] = {"status": "skipped", "accepted": False,
                                "reason": "the time limit came before the widening stage"}
        return "skipped"
    share = run.stage("widen", "of its IPOPT iterations")
    tw = _time.perf_counter()
    run.reports["widen"] = widened(run.problem, inc, run.opts, run.deadline, run.say, proven=run.proven(), share=share)
    run.timings["widen"] = _time.perf_counter() - tw
    # Ctrl-C inside IPOPT stops that program only (its own handler): the run stops here too
    run.interrupted = run.interrupted or any_interrupted(run.reports["widen"])
    return "accepted" if run.reports["widen"]["accepted"] else run.reports["widen"]["status"]


def regroup(run: Run) -> str:
    """Other events where the widened plan keeps less room than the widening's goal (``regroup``)."""
    from .regroup import regrouped

    tg = _time.perf_counter()
    run.reports["regroup"] = report = regrouped(run)
    if report["status"] != "skipped":
        run.timings["regroup"] = _time.perf_counter() - tg
    return "accepted" if report["accepted"] else report["status"]


#: The optimal planner's flow: (name, stage), run in this order over one incumbent.
STAGES: tuple[tuple[str, Callable[[Run], str]], ...] = (
    ("coordinated", coordinated),
    ("retime", retime_coordinated),
    ("search", search),
    ("refine", refine),
    ("polish", polish),
    ("widen", widen),
    ("regroup", regroup),
)


# ----------------------------------------------------------------------------- the joint NLP
_FAIL_STATUS = {
    SolverStatus.INTERRUPTED: PlanStatus.INTERRUPTED,
    SolverStatus.INFEASIBLE: PlanStatus.FAILED,
    SolverStatus.LIMIT_REACHED: PlanStatus.FAILED,
    SolverStatus.NUMERICAL_ERROR: PlanStatus.FAILED,
}


def nlp_plan(problem: Problem, alloc, sched: dict[str, ArmSchedule], opts: OptimalOptions | None = None,
             deadline: float | None = None, say: Callable[[str], None] | None = None, iterations: int | None = None,
             grid: Grid | None = None):
    """The joint NLP over all arms from ``sched`` (receding windows); returns ``(plan, info, status)``.

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
