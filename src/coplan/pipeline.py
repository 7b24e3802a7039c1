"""The end-to-end facade: problem -> allocate -> plan -> verify -> (files).

Entry point: :func:`solve` (re-exported as ``coplan.solve``). Nothing is called a success
unless the independent verifier passed it and every reachable fruit was harvested.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, field
from dataclasses import fields as dataclass_fields
from pathlib import Path

from .allocate.allocation import AllocationMethod, allocate
from .kinds import ExitCode, GantryMode, StopRule
from .output import RunFolder, check_folder, signals_deferred
from .planners.heuristic import plan_heuristic
from .plan import EventKind, Plan, PlannerKind, PlanStatus, finalize_plan
from .plan.model import PLANNED_HEADER
from .problem.model import Problem
from .problem.plausible import check_as_file
from .problem.given import as_problem
from .problem.load import file_record
from .progress import check_progress, guarded

__all__ = ["ExitCode", "SolveResult", "solve", "finalize", "status_exit_code"]

#: a problem made or changed in Python, written beside its plan (:func:`_write`)
PROBLEM_FILE = "planned_problem.yaml"


_STATUS_EXIT = {
    PlanStatus.SUCCESS: ExitCode.OK,
    PlanStatus.PARTIAL: ExitCode.PARTIAL,
    PlanStatus.UNSAFE: ExitCode.UNSAFE,
    PlanStatus.UNVERIFIED: ExitCode.UNSAFE,
    PlanStatus.INFEASIBLE: ExitCode.INFEASIBLE,
    PlanStatus.FAILED: ExitCode.SOLVER_FAILED,
    PlanStatus.INTERRUPTED: ExitCode.INTERRUPTED,
}


def status_exit_code(status: PlanStatus) -> ExitCode:
    return _STATUS_EXIT[status]


@dataclass
class SolveResult:
    """What :func:`solve` returns: the plan, its verification, the baseline, files written.

    ``verification`` is the verifier's :class:`~coplan.verify.verdict.Verification` (every
    violation, the certified clearances); ``plan.verification`` is its summary as plan.json
    holds it (a dict).

    ``timings`` (wall seconds) by planner: heuristic ``allocation``, ``plan``, ``verify``;
    coordinated ``plan`` (its one search: allocation candidates, each scheduled and coordinated)
    and ``verify``; optimal its stages (``baseline``: the heuristic's plan beside it,
    ``coordinated``, ``retime``, ``search``, ``refine``, ``polish``, ``widen``, ``regroup``, those that ran);
    a row stop and go ``reach``, ``stops_and_cells``, ``cells`` (summed over the stops: with workers
    more than the wall time), ``assemble``, ``planning``, ``verify``, ``bounds``; on the move
    ``reach``, ``schedule`` (the kept plan's booking), ``planning`` (the whole speed search),
    ``verify``, ``bounds`` (this solve's time: a row's bounds are remembered, so a second solve of
    it spends none). Every solve: ``total``; a cell's ``write`` when it wrote files (a row's
    ``total`` includes its writing).
    """

    problem: Problem
    plan: Plan
    verification: object | None
    baseline: Plan | None = None
    files: dict[str, Path] = field(default_factory=dict)
    timings: dict[str, float] = field(default_factory=dict)
    previous: Path | None = None  # where the previous run in the output folder was kept
    error: str | None = None  # an internal error stopped the planner; what it had computed is kept
    error_trace: str | None = None  # its traceback (shown with COPLAN_DEBUG=1)
    row: object | None = None  # a row's :class:`coplan.row.plan.RowResult` (stops, cells, reach)

    def __repr__(self) -> str:  # (short: the plan's samples and the problem stay out of a notebook cell)
        m = self.plan.metrics
        passed = None if self.verification is None else bool(getattr(self.verification, "passed", False))
        return (f"SolveResult(problem={self.problem.name!r}, status={self.plan.status.value!r}, verified={passed}, "
                f"harvested={m.get('harvested')}/{m.get('reachable')}, plan={self.plan!r}, files={sorted(self.files)}"
                f"{f', error={self.error!r}' if self.error else ''})")

    @property
    def status(self) -> PlanStatus:
        """The plan's status: success (verified, every reachable fruit harvested), partial
        (verified, some left: ``plan.unreachable`` and the verification say which), unsafe
        (the verifier refused it), interrupted, and so on (:class:`~coplan.kinds.PlanStatus`)."""
        return self.plan.status

    @property
    def exit_code(self) -> ExitCode:
        """The plan's exit code; ``INTERNAL`` (1) when an internal error stopped the planner, even
        though the plan kept from before it (and its files) may be verified."""
        return ExitCode.INTERNAL if self.error else status_exit_code(self.plan.status)

    @property
    def success(self) -> bool:
        """A verified success, and no internal error on the way (``exit_code`` 0): a plan kept
        from before an error may be verified, but the run is not a success."""
        return self.plan.status == PlanStatus.SUCCESS and not self.error


def finalize(problem: Problem, plan: Plan, verification) -> Plan:
    """Set the plan's status from the verifier's verdict (never upgrades a solver failure)."""
    return finalize_plan(plan, verification, len(problem.reachable_ids()))


def _planned_text(problem: Problem) -> str:
    """The YAML text of a problem made or changed in Python, as written beside its plan."""
    from .problem.generate import to_yaml

    return to_yaml(problem, header=f"The problem {problem.name!r} {PLANNED_HEADER}: written by coplan beside its plan")


def _write(out_dir, plan: Plan, ver, baseline: Plan | None = None,
           problem: Problem | None = None) -> tuple[dict[str, Path], Path | None]:
    """The run's files, staged and renamed into place (:mod:`coplan.output`). A ``problem`` that
    came from no file, or was changed in Python since (the plan records no ``problem_file``), is
    written beside the plan as ``planned_problem.yaml`` and recorded as its file, so that ``coplan verify``,
    ``view`` and ``plot`` of the plan find the problem it was planned on -- not the shipped
    problem of the same name (crossing_paths with its fruit moved was verified against the
    shipped one: 4 picks missed)."""
    files: dict[str, Path] = {}
    folder = RunFolder(Path(out_dir))
    text = None
    if problem is not None and plan.problem_file is None:
        from .problem.load import text_digest

        text = plan.planned_on or _planned_text(problem)
        record = {"path": str(folder.path(Path(PROBLEM_FILE)).absolute()), "sha256": text_digest(text)}
        for p in (plan, baseline):
            if p is not None:
                p.problem_file = dict(record)
                p.planned_on = None  # (on disk now, where the run is: a later Plan.save records that file)
    with signals_deferred(folder), folder as stage:  # (whole: a Ctrl-C here threw the verified plan away)
        if text is not None:
            (stage / PROBLEM_FILE).write_text(text, encoding="utf-8")
            files["problem"] = stage / PROBLEM_FILE
        if baseline is not None:
            files.update({f"baseline_{k}": v for k, v in baseline.save(stage, "baseline").items()})
        files.update(plan.save(stage, "plan"))
        if ver is not None:
            files["verification"] = ver.save(stage / "verification.json")
    return {k: folder.path(v) for k, v in files.items()}, folder.previous


def _better_mode(stopping, moving, cut: str | None = None):
    """``--gantry auto``: the row plan (both verified) with more fruit harvested, then more fruit
    per hour; both modes' figures in ``solver.row.auto``, the planning time of both. Where either
    mode's planning was interrupted (Ctrl-C: ``stopping`` None when stop and go has no row,
    ``cut`` saying why if not the speed search) the comparison is cut short: the plan kept is said
    interrupted (exit 130), whichever it is."""
    if stopping is None:  # (interrupted before stop and go had a row: nothing to compare)
        both = {GantryMode.CONTINUOUS.value: None, GantryMode.STOP_AND_GO.value: None, "chosen": GantryMode.CONTINUOUS.value,
                "interrupted": cut or "the speed search was interrupted: stop and go was not planned, nothing compared"}
        both[GantryMode.CONTINUOUS.value] = _mode_figures(moving)
        moving.info["auto"] = both
        moving.plan.solver["row"]["auto"] = both
        return moving

    def key(r):
        m = r.plan.metrics
        span = m.get("makespan") or 0.0
        return (bool(r.verification.passed), m.get("harvested") or 0, (m.get("harvested") or 0) / span if span else 0.0)

    best = moving if key(moving) > key(stopping) else stopping
    both = {GantryMode.STOP_AND_GO.value: _mode_figures(stopping), GantryMode.CONTINUOUS.value: _mode_figures(moving),
            "chosen": GantryMode.CONTINUOUS.value if best is moving else GantryMode.STOP_AND_GO.value}
    if stopping.plan.status == PlanStatus.INTERRUPTED and best.plan.status != PlanStatus.INTERRUPTED:
        # (a stop-and-go part against a whole row on the move is no comparison: the run was stopped, and says so)
        best.mark_interrupted()
        both["interrupted"] = "stop and go's planning was interrupted: its part row is no comparison"
    best.info["auto"] = both
    best.plan.solver["row"]["auto"] = both
    best.timings["planning"] = (stopping.timings.get("planning") or 0.0) + (moving.timings.get("planning") or 0.0)
    return best


def _mode_figures(r) -> dict:
    """One mode's figures in ``solver.row.auto`` (``--gantry auto``)."""
    m = r.plan.metrics
    span = m.get("makespan") or 0.0
    return {"harvested": m.get("harvested"), "row_time": span, "verified": bool(r.verification.passed),
            "fruit_per_hour": 3600.0 * (m.get("harvested") or 0) / span if span else 0.0,
            "planning_time": r.timings.get("planning"), "label": r.plan.label,  # (which stop rule: a summary said only "stop-and-go")
            "interrupted": r.plan.status == PlanStatus.INTERRUPTED}


def _options_for(planner: PlannerKind, options, row: GantryMode | None = None) -> None:
    """TypeError unless ``options`` is of a kind ``planner`` (or a row in mode ``row``) takes."""
    from .planners.coordinated.planner import CoordinatedOptions
    from .planners.optimal.options import OptimalOptions

    if options is None:
        return
    if row is not None:
        from .row.continuous import MovingOptions
        from .row.plan import RowOptions

        kinds = {GantryMode.STOP_AND_GO: (RowOptions,), GantryMode.CONTINUOUS: (MovingOptions,),
                 GantryMode.AUTO: (RowOptions, MovingOptions)}[row]
        what = f"a row {'on the move' if row == GantryMode.CONTINUOUS else 'stop and go' if row == GantryMode.STOP_AND_GO else '(gantry auto)'}"
    else:
        kinds = {PlannerKind.HEURISTIC: (), PlannerKind.COORDINATED: (CoordinatedOptions, OptimalOptions),
                 PlannerKind.OPTIMAL: (OptimalOptions,)}[planner]
        what = f"the {planner.value} planner"
    if not isinstance(options, kinds):
        takes = " or ".join(k.__name__ for k in kinds) or "no options"
        raise TypeError(f"options: {what} takes {takes}, found {type(options).__name__}")


def _solve_row(prob: Problem, planner, out_dir, options, progress, stops, t0: float, gantry=None) -> SolveResult:
    """A row: stop and go (stops, each stop's cell) or on the move (:mod:`coplan.row.continuous`),
    the row plan verified in the row frame (:mod:`coplan.row`)."""
    from dataclasses import replace

    from .allocate.row_bound import row_bounds
    from .row.continuous import MovingOptions
    from .row.moving import plan_moving
    from .row.metrics import row_metrics
    from .row.plan import RowOptions, plan_row
    from .row.reach import DEFAULT_RESOLUTION

    mode = GantryMode(gantry or (GantryMode.CONTINUOUS if isinstance(options, MovingOptions) else GantryMode.STOP_AND_GO))
    _options_for(PlannerKind.COORDINATED, options, row=mode)
    if mode != GantryMode.STOP_AND_GO:
        if stops is not None and mode == GantryMode.CONTINUOUS:
            raise ValueError("stops: on the move (gantry continuous) the carriage does not stop; a stop rule applies to stop and go")
        if planner is not None and PlannerKind(planner) != PlannerKind.COORDINATED and mode == GantryMode.CONTINUOUS:
            raise ValueError("planner: on the move the arms are planned by the row's own booking of coordinated, "
                             "time-optimal moves; the cell planners apply to stop and go")
        moving = plan_moving(prob, options if isinstance(options, MovingOptions) else MovingOptions(
            resolution=getattr(options, "resolution", DEFAULT_RESOLUTION)), progress)
    # auto: a speed search cut short (Ctrl-C) stops there -- its plan kept, said interrupted, stop and go not planned
    cut = None
    if mode == GantryMode.CONTINUOUS or (mode == GantryMode.AUTO and moving.plan.status == PlanStatus.INTERRUPTED):
        stopping = None
    else:
        # (auto: both modes, the stops' cells in as many processes as the speed search)
        opts = options if isinstance(options, RowOptions) else RowOptions(
            workers=getattr(options, "workers", 1), resolution=getattr(options, "resolution", DEFAULT_RESOLUTION))
        # the arguments, where given, win over the options' fields (as stops=; the options' own otherwise)
        cell_planner = PlannerKind(planner) if planner is not None else PlannerKind(opts.planner)
        if cell_planner == PlannerKind.HEURISTIC:
            raise ValueError("planner: the course's heuristic plans a stationary cell, not a row; use coordinated or optimal")
        opts = replace(opts, planner=cell_planner, stops=StopRule(stops or opts.stops))
        try:
            stopping = plan_row(prob, opts, progress)
        except KeyboardInterrupt:  # (auto: before stop and go had a row to keep -- the verified plan on the move is kept)
            if mode != GantryMode.AUTO:
                raise
            stopping, cut = None, "interrupted before stop and go had a row: nothing compared"
            moving.mark_interrupted()
    if mode == GantryMode.AUTO:
        res = _better_mode(stopping, moving, cut)
    else:
        res = moving if mode == GantryMode.CONTINUOUS else stopping
    tb = _time.perf_counter()
    plan = res.plan
    try:
        placed = {e.fruit for e in plan.events if e.kind == EventKind.PLACE}
        if plan.status == PlanStatus.INTERRUPTED and len(placed) < len(res.reach.harvestable()):
            # (a SIGTERM on a long row: 60 s of bounds after it, past a scheduler's grace; the part of the row
            # planned is written at once, without them -- it has no ratio to them; a whole row keeps them)
            bounds = None
            if progress is not None:
                progress("row: interrupted; its lower bounds are not computed (the row kept as far as it was planned)")
        else:
            if progress is not None:  # (the stop-by-stop bound's weight rounds: seconds on a long row, after the plan)
                progress("row: the lower bounds (any plan; stop by stop, its weights over the arms searched)")
            bounds = row_bounds(prob)  # (remembered for a row and its settings: a second solve spends nothing here)
    except KeyboardInterrupt:
        bounds = None
        res.mark_interrupted("interrupted (Ctrl-C) while its lower bounds were computed: the row is planned and verified")
        if progress is not None:
            progress("row: interrupted while its lower bounds were computed; keeping the row, planned and verified, without them")
    bounds_seconds = _time.perf_counter() - tb
    try:
        with signals_deferred():  # (its figures, in a moment: a Ctrl-C is answered once they are)
            plan.metrics["row"] = row_metrics(prob, res, bounds)
            span = plan.metrics.get("makespan") or 0.0
            for a, causes in plan.metrics["row"]["idle_share"].items():  # (a row's idle fraction: the sum of its causes)
                if a in plan.metrics.get("per_arm", {}):
                    plan.metrics["per_arm"][a]["idle_fraction"] = float(sum(causes.values())) if span > 0 else None
            plan.metrics["lower_bound"] = None if bounds is None else bounds.any_plan
            plan.metrics.update(_row_fruit_counts(prob, plan))
            plan.problem_file = file_record(prob)
            plan.planned_on = _planned_text(prob) if plan.problem_file is None else None  # (Plan.save writes it beside the plan)
    except KeyboardInterrupt:
        res.mark_interrupted("interrupted (Ctrl-C) as the row's figures were computed: the row is planned and verified")
    timings = dict(res.timings) | {"bounds": bounds_seconds}  # (this solve's: bounds.seconds is when they were computed)
    plan.solver["timings"] = dict(timings)
    files, previous = _write(out_dir, plan, res.verification, problem=prob) if out_dir is not None else ({}, None)
    timings["total"] = _time.perf_counter() - t0
    errors = (getattr(res, "info", None) or {}).get("cell_errors") or {}
    error = (f"internal error in the cell planner at {len(errors)} stop{'s' * (len(errors) != 1)} (x = "
             f"{', '.join(errors)} m; the first: {next(iter(errors.values()))}): each kept its plan from before the error"
             if errors else None)
    return SolveResult(prob, plan, res.verification, None, files, timings, previous, error=error, row=res)


def _row_fruit_counts(problem: Problem, plan: Plan) -> dict:
    """A row plan's :func:`fruit_counts`, from its row metrics' screen (``metrics.row``): the same
    keys at the top of ``metrics`` as a cell plan's (a notebook's ``plan.metrics["harvestable"]``
    was a KeyError on a row), and ``gap_to_lower_bound``, the ratio to the bound for any motion
    (as a cell's, 1.0: no gap), None where the bound counts a fruit the plan left out."""
    screened = set(plan.metrics["row"].get("screened_out") or {})
    out = _counts(problem, {f.id for f in problem.fruits} - screened, plan)
    del out["reachable"], out["unreachable"]  # (the row's, over the rail, are the plan's already)
    span, bound = plan.metrics.get("makespan"), plan.metrics.get("lower_bound")
    whole = plan.metrics["row"].get("ratio_any_plan_bound") is not None  # (None for a partial harvest)
    out["gap_to_lower_bound"] = span / bound if whole and span and bound and not out["fruit_ids"]["left_out"] else None
    return out


def fruit_counts(problem: Problem, scr, plan: Plan) -> dict:
    """One vocabulary for every command and file: of the problem's ``fruit``, ``reachable``
    (within some arm's reach, ``reach_margin`` kept), ``harvestable`` (reachable and not ruled
    out by the screen), ``harvested``; ``fruit_ids``: the ids of those ``unreachable``,
    ``screened_out`` (reachable, not harvestable) and ``left_out`` (harvestable, not harvested),
    each one's reason in the screen (``coplan check``) or ``plan.solver.left_out``."""
    return _counts(problem, {f.id for j, f in enumerate(problem.fruits) if scr.reach[:, j].any()}, plan)


def _counts(problem: Problem, can: set[str], plan: Plan) -> dict:
    """:func:`fruit_counts` with the fruit the screen lets some arm harvest, ``can`` (of those
    some arm reaches, ``problem.reachable_ids()``)."""
    reach = set(problem.reachable_ids())
    can = can & reach
    picked = {e.fruit for e in plan.events if e.kind == EventKind.PLACE}
    ids = {"unreachable": [f.id for f in problem.fruits if f.id not in reach],
           "screened_out": [f.id for f in problem.fruits if f.id in reach and f.id not in can],
           "left_out": [f.id for f in problem.fruits if f.id in can and f.id not in picked]}
    # (the counts too: the planners' own ``unreachable`` list holds the screened-out fruit as well,
    # which counted a fruit only a locked arm reaches as both reachable and unreachable)
    return {"fruit": len(problem.fruits), "reachable": len(reach), "harvestable": len(can),
            "unreachable": len(ids["unreachable"]), "screened_out": len(ids["screened_out"]), "fruit_ids": ids}


def solve(
    problem: Problem | str | Path,
    planner: PlannerKind | str | None = None,
    allocation: AllocationMethod | str | None = None,
    out_dir: str | Path | None = None,
    options=None,
    progress=None,
    stops: StopRule | str | None = None,
    gantry: GantryMode | str | None = None,
) -> SolveResult:
    """Solve a problem end to end and verify the result.

    Parameters
    ----------
    problem : a :class:`Problem`, the path of a YAML problem file, or a problem as a mapping
        (:mod:`coplan.generate` makes them), checked as a file is
    planner : ``optimal`` (default, anytime: never slower than ``coordinated`` harvesting as much),
        ``coordinated`` (fast: no NLP) or ``heuristic`` (the course's baseline)
    allocation : ``makespan`` or ``heuristic``; default: the planner's own
        (``heuristic`` for the baseline, ``makespan`` for the others)
    out_dir : when given, ``plan.json`` (+ CSV, NPZ), ``verification.json`` and, for the
        optimal planner, ``baseline.json`` are written there
    options : :class:`coplan.optimal.OptimalOptions` for the optimal planner,
        :class:`coplan.planners.coordinated.planner.CoordinatedOptions` for the coordinated one (an
        ``OptimalOptions`` lends it its margin, budget and time limit)
    progress : optional callable(str) receiving progress messages
    stops : a row (a problem with a gantry): the stop rule (``optimised`` by default, ``fixed``,
        ``fewest``); ``planner`` is then the cell planner at each stop (``coordinated`` by
        default: planning keeps ahead of the carriage; ``optimal`` gives each stop a search
        budget) and ``options`` may be :class:`coplan.row.plan.RowOptions` (``planner`` and
        ``stops``, where given, win over its fields of the same name)
    gantry : a row: ``stop-and-go`` (default; ``continuous`` where ``options`` is a
        :class:`~coplan.row.continuous.MovingOptions`), ``continuous`` (pick on the move: ``options`` may
        be :class:`coplan.row.continuous.MovingOptions`; the speed is searched unless it gives one)
        or ``auto`` (both, each verified: the one with more fruit, then more fruit per hour)
    """
    from .verify.verifier import verify

    t0 = _time.perf_counter()
    check_progress(progress)
    progress = guarded(progress)  # (an exception in it is the caller's, whichever planner: ProgressCallbackError)
    if out_dir is not None:
        check_folder(out_dir, "out_dir")  # (before any work: a solve is not lost to where it goes)
    prob = as_problem(problem)  # (anything but a Problem, a mapping or a path: load_problem's own refusal)
    if isinstance(problem, Problem):  # (built or changed in Python: the plausible ranges and plan length a file gets)
        check_as_file(problem)
    if prob.gantry is not None:
        if allocation is not None:
            raise ValueError("allocation: a row's cells are allocated by the cell planner at each stop (stop and go) "
                             "or by the row's booking (on the move); it applies to a stationary cell")
        return _solve_row(prob, planner, out_dir, options, progress, stops, t0, gantry)
    if gantry is not None:
        raise ValueError(f"gantry: {prob.name!r} is a stationary cell (no gantry section)")
    if stops is not None:
        raise ValueError(f"stops: {prob.name!r} is a stationary cell (no gantry); a stop rule applies to a row")
    planner = PlannerKind(planner or PlannerKind.OPTIMAL)
    _options_for(planner, options)
    say = progress or (lambda msg: None)
    timings: dict[str, float] = {}
    baseline = None
    error = error_trace = None
    files: dict[str, Path] = {}
    if planner == PlannerKind.HEURISTIC:
        method = AllocationMethod(allocation or AllocationMethod.HEURISTIC)
        ta = _time.perf_counter()
        alloc = allocate(prob, method)
        timings["allocation"] = _time.perf_counter() - ta
        tp = _time.perf_counter()
        plan = plan_heuristic(prob, alloc)
        timings["plan"] = _time.perf_counter() - tp
        tv = _time.perf_counter()
        ver = verify(prob, plan)
        timings["verify"] = _time.perf_counter() - tv
        plan = finalize(prob, plan, ver)
    elif planner == PlannerKind.COORDINATED:
        from .planners.coordinated.planner import CoordinatedOptions, plan_coordinated

        method = AllocationMethod(allocation or AllocationMethod.MAKESPAN)
        from .planners.optimal.options import COORDINATED_FIELDS

        copts = options if isinstance(options, CoordinatedOptions) else CoordinatedOptions(
            **{theirs: getattr(options, ours) for ours, theirs in COORDINATED_FIELDS.items()}
        ) if options is not None else None
        res = plan_coordinated(prob, allocation=method, options=copts, progress=say)
        plan, ver = res.plan, res.verification
        if copts is not None:  # (as the optimal planner's: the run can be made again from its file)
            plan.solver["options"] = {f.name: getattr(copts, f.name) for f in dataclass_fields(copts)}
        timings.update(res.timings)
    else:
        from .planners.optimal.planner import plan_optimal

        method = AllocationMethod(allocation or AllocationMethod.MAKESPAN)
        res = plan_optimal(prob, allocation=method, options=options, progress=say)
        plan, ver, baseline = res.plan, res.verification, res.baseline
        error, error_trace = res.error, res.error_trace
        timings.update(res.timings)
    plan.solver.setdefault("timings", {}).update(timings)
    from .allocate.screen import screened

    scr = screened(prob)
    record = file_record(prob)  # (it reads the file back: once)
    for p in (plan, baseline):  # the problem file they come from: plot, animate and view find it again
        if p is not None:
            p.problem_file = record
            p.planned_on = _planned_text(prob) if record is None else None  # (Plan.save writes it beside the plan)
            p.metrics.update(fruit_counts(prob, scr, p))
            if p.metrics.get("gap_to_lower_bound") is not None and p.metrics.get("harvested", 0) < p.metrics["harvestable"]:
                p.metrics["gap_to_lower_bound"] = None  # (the bound counts the fruit it left out: "ratio 0.657")
    timings["total"] = _time.perf_counter() - t0
    previous = None
    if out_dir is not None:  # the whole set is staged and renamed into place (coplan.output): never a mix of runs
        files, previous = _write(out_dir, plan, ver, baseline, prob)
        timings["write"] = _time.perf_counter() - t0 - timings["total"]
    return SolveResult(prob, plan, ver, baseline, files, timings, previous, error, error_trace)
