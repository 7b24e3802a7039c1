"""The ``coplan`` command line (thin: every command calls one library entry function).

Exit codes are :class:`coplan.pipeline.ExitCode`. Bad input prints the file, the key path,
what was expected and what was found -- never a traceback (set ``COPLAN_DEBUG=1`` to see one
for an internal error).
"""

from __future__ import annotations

import functools
import json
import os
from pathlib import Path
from typing import Annotated, Optional

# the CLI never needs a display: always Agg, whatever the shell says (MPLBACKEND=nonsense was exit 1)
os.environ["MPLBACKEND"] = "Agg"

import typer

from . import failures
from .checks import budget_hint as _budget_hint, check_time_limit as _check_time_limit, check_workers as _check_workers
from .checks import between, choice, choices, in_path, optimal_only_note, out_path, real
from .checks import fail as _fail, solver_options as _solver_options, strict_json as _strict_json
from .failures import resolve_problem
from .row import moving_options, refuse_mixed_modes, refuse_rows_in_compare, refused_on_a_row, stop_window
from .summary import fmt as _fmt
from .summary import print_summary, print_table, print_verification
from .summary import safe as _s
from .console import FlagsGroup, ProgressDisplay, run_console, text_console
from ..errors import InputError, plural, printable
from ..kinds import AllocationMethod, ExitCode, FclMode, GantryMode, PlannerKind, SpeedProfile, StopRule

app = typer.Typer(
    cls=FlagsGroup,  # flags shown without a <bool> value in --help
    add_completion=False,
    no_args_is_help=True,
    help="Plan coordinated, collision-free, jerk-limited motion for several 2R arms harvesting fruit.",
    pretty_exceptions_enable=False,
)
out_console = text_console()
err_console = text_console(stderr=True)


def _version(value: bool) -> None:
    if value:
        from importlib.metadata import PackageNotFoundError, version

        try:
            v = version("coplan")
        except PackageNotFoundError:
            v = "unknown (not installed)"
        typer.echo(f"coplan {v}")
        raise typer.Exit(0)


@app.callback()
def root(
    show_version: Annotated[bool, typer.Option("--version", callback=_version, is_eager=True,
                                               help="Print coplan's version and exit.")] = False,
) -> None:
    """Plan coordinated, collision-free, jerk-limited motion for several 2R arms harvesting fruit."""


def guarded(fn):
    """Map every failure to its exit code and a clear message (no tracebacks); with ``--json``
    also one JSON document on stdout (:mod:`coplan.cli.failures`)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        failures.STARTED.append(fn.__name__)
        try:
            return fn(*args, **kwargs)
        except typer.Exit:
            raise
        except (Exception, KeyboardInterrupt) as e:  # noqa: BLE001 -- last-resort guard: report, never a raw traceback
            code, message = failures.failure_of(e)
            if code == ExitCode.INTERNAL and not isinstance(e, failures.Failure) and os.environ.get("COPLAN_DEBUG"):
                raise
            if isinstance(e, (InputError, KeyboardInterrupt)):
                err_console.print(message, markup=False, highlight=False, soft_wrap=True)
            else:
                err_console.print(f"[bold red]error[/]: {_s(message)}", highlight=False, soft_wrap=True)
            if kwargs.get("as_json"):
                typer.echo(failures.dumps(failures.error_document(fn.__name__.removesuffix("_cmd"), code, message, e)))
            raise typer.Exit(int(code)) from None

    return wrapper


#: ``coplan check`` says its stages as it goes on cells of this many fruit or more (about 20 s).
CHECK_STAGES_FROM = 500


def _resolve_problem(problem: Optional[Path]) -> Path:
    return resolve_problem(problem, lambda m: err_console.print(f"[dim]{_s(m)}[/]", highlight=False))


# a row's screen: the spacing of the carriage positions it tries (solve and check)
ResolutionOption = Annotated[Optional[float], typer.Option(parser=real, metavar="<float>",
    callback=between(0.01, 0.5, "m"),  # (a 200 m row of 2,000 fruit, 6 arms: a 240 MB screen at 0.01)
    help="A row: spacing of the carriage positions its screen tries as stops, m (default 0.05; finer serves a "
         "fruit an arm reaches only from a narrower window of rail, and takes longer).")]


@app.command()
@guarded
def solve(
    problem: Annotated[Optional[Path], typer.Argument(parser=in_path, metavar="PROBLEM", help="Problem YAML file, or a shipped problem's name (coplan problems lists them; default: greenhouse_row, the course's cell).")] = None,
    planner: Annotated[Optional[PlannerKind], typer.Option(
        "--planner", "-p", parser=choice(PlannerKind), metavar=choices(PlannerKind), help="Planner to use (default optimal; for a row, the cell planner at each stop: default coordinated).")] = None,
    stops: Annotated[Optional[StopRule], typer.Option(
        parser=choice(StopRule), metavar=choices(StopRule), help="A row (a problem with a gantry): where the carriage stops (default optimised).")] = None,
    gantry: Annotated[Optional[GantryMode], typer.Option(
        parser=choice(GantryMode), metavar=choices(GantryMode), help="A row: stop-and-go (default), continuous (pick on the move, the speed searched) or auto "
             "(both, each verified; the better kept).")] = None,
    speed: Annotated[Optional[float], typer.Option(parser=real, metavar="<float>",
        help="A row on the move (implies --gantry continuous): one cruising speed, m/s (default: the speed search, a speed per metre of rail).")] = None,
    profile: Annotated[Optional[SpeedProfile], typer.Option(
        parser=choice(SpeedProfile), metavar=choices(SpeedProfile), help="A row on the move (implies --gantry continuous): what the speed search "
             "varies -- density (default: a speed per metre of rail, slower where the fruit need more of the arms' "
             "time), constant (one cruising speed for the row; faster on some dense rows with many arms) or auto (both, each "
             "verified, the better kept; twice the planning).")] = None,
    resolution: ResolutionOption = None,
    stop_price: Annotated[Optional[float], typer.Option(
        "--stop-price", parser=real, metavar="S", callback=between(0.0, 600.0, "s"),
        help="A row, stop and go, the optimised rule: seconds it charges each stop on top of its estimated time "
             "(default 0: time alone; e.g. 2 for fewer stops at a little more row time).")] = None,
    pace_price: Annotated[Optional[float], typer.Option(
        "--pace-price", parser=real, metavar="S", callback=between(0.0, 600.0, "s"),
        help="A row, stop and go, the optimised rule: seconds it charges each stop where it is ahead of the fixed "
             "stride's pace (more stops so far than a stop every carriage span), to keep to about the fixed stride's "
             "count (default 0: off; 3 keeps every shipped row within it).")] = None,
    allocation: Annotated[
        Optional[AllocationMethod], typer.Option(help="Allocation method (default: the planner's own).")
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Output folder.")] = Path("coplan-out"),
    time_limit: Annotated[Optional[float], typer.Option(parser=real, metavar="<float>",
        help="Wall-clock limit, s: the optimal planner returns its verified incumbent at the limit, the coordinated "
             "planner its best candidate so far (by default they stop on a work budget, so the plan does not depend on "
             "the machine). A cell's: a row refuses it (its stops' cells keep ahead of the carriage by their budgets).")] = None,
    options_file: Annotated[Optional[Path], typer.Option(
        "--options", help="Solver options (YAML): any field of coplan.optimal.OptimalOptions, e.g. "
                          "search_work: 60000 (recorded in plan.json).")] = None,
    workers: Annotated[Optional[str], typer.Option(
        metavar="N|auto", help="Processes the optimal planner's search runs in (on a row: the stops' cells, or on the move the speed search): a number, or auto "
             "(this machine's cores, at most 8). Default 1: the plan then does not depend on the machine; the same N "
             "gives the same plan.")] = None,
    animate: Annotated[bool, typer.Option("--animate", help="Also render an animation of the plan.")] = False,
    html: Annotated[bool, typer.Option("--html", help="Also write plan.html: the interactive viewer of the plan (one self-contained page).")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON document instead of the summary.")] = False,
):
    """Solve a problem, verify the plan and write plan.json (+ CSV, NPZ, verification.json)."""
    from ..pipeline import solve as run

    from ..problem.load import load_problem

    _check_time_limit(time_limit)
    n_workers = _check_workers(workers)
    failures.check_out_dir(out)
    path = load_problem(_resolve_problem(problem))
    if path.gantry is not None:  # a row: the stop rule and the cell planner at each stop, or on the move
        if gantry is None and (speed is not None or profile is not None) and stops is None and stop_price is None \
                and pace_price is None:  # (on-the-move flags alone mean on the move, as `coplan run --speed` does)
            gantry = GantryMode.CONTINUOUS
        elif gantry is None:
            refuse_mixed_modes(speed, profile, stops, stop_price, pace_price)
        named, refused = refused_on_a_row(planner, allocation, options_file, time_limit, gantry)
        if refused:  # (led by the options' names: the JSON error's path)
            _fail(ExitCode.USAGE, f"{'/'.join(named)}: {path.name} is a row (it has a gantry): {'; '.join(refused)}")
        moving = moving_options(path, gantry, speed, stops, planner, profile)
        row_options = moving
        # --workers: on the move the speed search's processes, stop and go the stops' cells';
        # --resolution: the screen's grid, both modes; --stop-price: the optimised rule's window
        given = {k: v for k, v in (("workers", n_workers), ("resolution", resolution)) if v is not None}
        window = stop_window(stop_price, pace_price, gantry, moving, stops)
        if window is not None:
            given["window"] = window
        if given:
            from dataclasses import replace as _replace

            from ..row.plan import RowOptions

            row_options = _replace(moving, **given) if moving is not None else RowOptions(**given)
        from ..errors import OptionsError

        try:
            with ProgressDisplay(err_console, quiet=as_json) as say:
                res = run(path, planner=planner, out_dir=out, progress=say, stops=stops, gantry=gantry, options=row_options)
        except OptionsError as e:  # --speed so slow that the row's cruise outgrows the longest plan (known once screened)
            slow = [i for i in e.issues if i.path == "level"] if speed is not None else []
            if not slow:
                raise
            _fail(ExitCode.USAGE, f"--speed: {slow[0].message.replace('a pace', 'a cruising speed (m/s)')} ({path.name!r})")
        return _report_solve(res, out, animate, html, as_json)
    row_only = [flag for flag, v in (("--gantry", gantry), ("--speed", speed), ("--profile", profile), ("--resolution", resolution),
                                     ("--stop-price", stop_price), ("--pace-price", pace_price)) if v is not None]
    if row_only:  # (the flags given, not the six a row takes: "--gantry/--speed/.../--pace-price" for --speed alone)
        _fail(ExitCode.USAGE, f"{'/'.join(row_only)}: {path.name} is a stationary cell (no gantry section); "
                              f"{'it applies' if len(row_only) == 1 else 'they apply'} to a row")
    if stops is not None:
        _fail(ExitCode.USAGE, f"--stops: {path.name} is a stationary cell (no gantry section); a stop rule applies to a row")
    planner = planner or PlannerKind.OPTIMAL
    if time_limit is not None and planner == PlannerKind.HEURISTIC:  # (as --options and --workers: said, not ignored)
        _fail(ExitCode.USAGE, "--time-limit: the heuristic planner plans in one pass and has no time limit; "
                              "it applies to --planner optimal or coordinated")
    options = _solver_options(options_file, time_limit, planner != PlannerKind.HEURISTIC)
    if n_workers is not None:
        if planner != PlannerKind.OPTIMAL:
            _fail(ExitCode.USAGE, f"--workers: the {planner.value} planner has no search to run in parallel; "
                                  "it applies to --planner optimal")
        from dataclasses import replace

        from ..planners.optimal.planner import OptimalOptions

        options = replace(options or OptimalOptions(), workers=n_workers)
    note = optimal_only_note(options) if planner == PlannerKind.COORDINATED and options is not None else None
    if note is not None:
        err_console.print(f"note: {note}", markup=False, highlight=False)
    if not as_json and planner != PlannerKind.HEURISTIC:
        from ..allocate.screen import screened

        for line in screened(path).lines():  # the screen's verdict, before solving (names escaped)
            err_console.print(printable(line), markup=False, highlight=False)
    with ProgressDisplay(err_console, quiet=as_json, hint=_budget_hint(planner, time_limit)) as say:
        res = run(path, planner=planner, allocation=allocation, out_dir=out, options=options, progress=say)
    return _report_solve(res, out, animate, html, as_json)


def _report_solve(res, out: Path, animate: bool, html: bool, as_json: bool):
    """What ``coplan solve`` does once the plan is on disk: animation, viewer, summary, exit code."""
    with ProgressDisplay(err_console, quiet=as_json) as say:
        if animate:
            res.files.update(_animate_files(res, out, say))
    if html:  # like the animation: written beside plan.json once the run's files are in place
        from ..viz.viewer import write_html

        res.files["viewer"] = write_html(out / "plan.html", res.problem, res.plan, verification=res.verification)
    failures.work_done()  # (every file written: the summary and the verdict follow)
    ver = res.plan.verification or {}
    if as_json:
        doc = {
            "problem": res.problem.name,
            "planner": res.plan.planner_name,
            "status": res.plan.status.value,
            "exit_code": int(failures.as_exited(res.exit_code)),  # (143 after a SIGTERM, as the command exits: it said 130)
            "metrics": res.plan.metrics,
            "verification": ver,
            "solver": res.plan.solver,
            "files": {k: str(v) for k, v in res.files.items()},
            "previous_run": str(res.previous) if res.previous is not None else None,
        }
        out_console.print_json(_strict_json(doc), ensure_ascii=True)  # (valid JSON whatever stdout encodes)
    else:
        print_summary(out_console, res)
    if res.error:  # a bug stopped the planner: what it had computed is on disk; exit 1 (res.exit_code)
        debug = os.environ.get("COPLAN_DEBUG")
        err_console.print(f"[bold red]error[/]: {_s(res.plan.solver.get('message') or res.error)}; files in {_s(out)}."
                          + ("" if debug else " Set COPLAN_DEBUG=1 for a traceback."), highlight=False, soft_wrap=True)
        if debug:
            err_console.print(res.error_trace, markup=False, highlight=False)
    raise typer.Exit(int(res.exit_code))


def _animate_files(res, out: Path, say=None) -> dict:
    """Render the animation after the plan files are on disk; a rendering failure only warns,
    so the plan's own exit code stands."""
    from ..viz.animate import RenderError, animate_plan

    try:
        path = animate_plan(res.problem, res.plan, out / "plan.gif", progress=say,
                            notify=lambda m: err_console.print(f"[yellow]note[/]: {_s(m)}", highlight=False, soft_wrap=True))
    except RenderError as e:
        err_console.print(f"[yellow]warning[/]: animation not rendered: {_s(e)} (the plan files are written)")
        return {}
    return {"animation": path}


@app.command("problems")
@guarded
def list_problems():
    """List the problem files shipped with coplan."""
    from ..problem.load import load_problem, shipped_problems, shipped_rows

    for path in shipped_problems() + shipped_rows():
        p = load_problem(path)
        kind = "" if p.gantry is None else f"row {p.gantry.length:g} m, "
        out_console.print(f"{_s(path.name):28s} {kind}{plural(len(p.arms), 'arm') + ',':8s} {len(p.fruits):3d} fruit  {_s(p.description)}")
    out_console.print(f"[dim]folder: {shipped_problems()[0].parent} (rows in rows/)[/]")


@app.command()
@guarded
def check(
    problem: Annotated[Optional[Path], typer.Argument(parser=in_path, metavar="PROBLEM", help="Problem YAML file, or a shipped problem's name (coplan problems lists them; default: greenhouse_row, the course's cell).")] = None,
    resolution: ResolutionOption = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON document instead of the summary.")] = False,
):
    """Validate a problem and say, without solving, what its geometry allows: locked arms, harvestable fruit per arm (and why the others are not), the makespan lower bound and the heuristic baseline's makespan.

    Exit 0 when every reachable fruit can be harvested, 5 when some cannot, 4 when no fruit is harvestable at all (nothing to plan, as solve).
    """  # (one line per paragraph: the help keeps a docstring's line breaks)
    from ..allocate.allocation import bound_details
    from ..planners.heuristic import plan_heuristic
    from ..problem.load import load_problem
    from ..allocate.screen import screened
    from ..verify.verifier import verify

    path = _resolve_problem(problem)
    prob = load_problem(path)
    if prob.gantry is not None:
        from .row import check_row

        raise typer.Exit(int(check_row(prob, path, as_json, out_console, resolution)))
    if resolution is not None:
        _fail(ExitCode.USAGE, f"--resolution: {path.name} is a stationary cell (no gantry section); it applies to a row")
    # (a cell of 1500 fruit took a minute, 3000 two and a half, saying nothing: its stages are said
    # from CHECK_STAGES_FROM fruit, about 20 s; a small cell's check stays as quiet as it is quick)
    with ProgressDisplay(err_console, quiet=as_json or len(prob.fruits) < CHECK_STAGES_FROM) as say:
        say(f"screen: {plural(len(prob.arms), 'arm')}, {len(prob.fruits)} fruit")
        scr = screened(prob)
        say("lower bound (MILP)")
        bd = bound_details(prob)
        say("the course's heuristic baseline")
        base = plan_heuristic(prob)
        say("verifying the baseline")
        base_ver = verify(prob, base).summary()
    n_reach = len(prob.reachable_ids())
    harvestable = int(scr.reach.any(axis=0).sum())
    doc = {
        "problem": prob.name,
        "file": str(path),
        "arms": len(prob.arms),
        "fruit": len(prob.fruits),
        "reachable": n_reach,
        "harvestable": harvestable,
        "screen": scr.summary(),
        "lower_bound": {"value": bd.value, "proven": bd.proven, "dual_bound": bd.dual_bound,
                        "assignment": {a: list(v) for a, v in bd.assignment.items()}},
        "heuristic_makespan": base.metrics.get("makespan"),
        "heuristic_verified": bool(base_ver.get("passed")),
        "heuristic_violations": base_ver.get("violation_kinds"),
    }
    code = ExitCode.INFEASIBLE if harvestable == 0 else ExitCode.OK if harvestable == n_reach else ExitCode.PARTIAL
    doc.update(failures.exit_fields(code))  # (the status as the exit code says it, as verify's)
    if as_json:
        out_console.print_json(_strict_json(doc), ensure_ascii=True)  # (valid JSON whatever stdout encodes)
    else:
        p = out_console.print
        p(f"[bold]{_s(prob.name)}[/] ({_s(path)}): {plural(len(prob.arms), 'arm')}, {len(prob.fruits)} fruit: "
          f"{n_reach} reachable, {harvestable} harvestable")
        for line in scr.lines():  # (its names and ids escaped: they come from the file)
            p(printable(line), markup=False, highlight=False)
        if harvestable == 0:
            p("nothing to plan: no fruit can be harvested by any arm (solve would exit 4, infeasible)")
        else:
            proof = "proven optimum of the relaxation" if bd.proven else f"MILP stopped: dual bound {bd.dual_bound:.3f} s"
            p(f"lower bound        {bd.value:.3f} s ({proof}); no plan can be faster")
            verdict = "verified" if doc["heuristic_verified"] else f"unsafe: {', '.join(doc['heuristic_violations'] or [])}"
            hm = doc["heuristic_makespan"]
            if not doc["heuristic_verified"] and hm is not None and hm < bd.value:
                verdict += "; below the lower bound only because it breaks these limits"
            p(f"heuristic baseline {_fmt(hm, ' s', 3)} (the course's planner; {verdict})")
    raise typer.Exit(int(code))


# --- commands added by the verification/report and visualisation modules go below ---


# ---- verify / compare (coplan.verify, coplan.report)


@app.command("verify")
@guarded
def verify_cmd(
    problem: Annotated[Path, typer.Argument(parser=in_path, metavar="PROBLEM", help="Problem YAML file, or a shipped problem's name (coplan problems lists them). Given the plan alone, as the other plan commands take it: its problem is --problem, else the problem file the plan records, else the shipped problem it names.")],
    plan: Annotated[Optional[Path], typer.Argument(parser=in_path, metavar="PLAN", help="Plan to verify: plan.json, the plan.csv replay coplan writes, or a coplan export CSV (no events: they are inferred).")] = None,
    problem_opt: Annotated[Optional[Path], typer.Option("--problem", "-p", parser=in_path, metavar="PATH", help="With the plan given alone: the plan's problem YAML (default: the problem file the plan records, else the shipped problem it names).")] = None,
    out: Annotated[Optional[Path], typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Write verification.json (a folder, or a file name ending .json).")] = None,
    fcl: Annotated[FclMode, typer.Option(parser=choice(FclMode), metavar=choices(FclMode), help="FCL cross-check: critical instants, every sample (slow), or off.")] = FclMode.CRITICAL,
    as_json: Annotated[bool, typer.Option("--json", help="Print verification.json's content instead of the report.")] = False,
    tolerance: Annotated[float, typer.Option("--tolerance", parser=real, callback=between(0.1, 50.0, "mm"), metavar="MM", help="How close the tip must come to the fruit (or over the bin) during a pick (a place), mm.")] = 5.0,
):
    """Independently verify a plan: clearance (certified), limits, picks and places.

    coplan verify PROBLEM PLAN, or coplan verify PLAN [-p PROBLEM] (the plan alone: against the problem file it records).

    Exit codes: 0 passed and every reachable fruit harvested; 5 passed but fruit left; 4 passed but the problem has no reachable fruit (as solve); 6 violations found; 3 bad problem or plan file.
    """  # (one line per paragraph: the help keeps a docstring's line breaks)
    from ..plan import load_plan
    from ..problem.load import load_problem
    from ..verify.verifier import verify as run_verify

    if plan is None:  # `coplan verify plan.json [-p PROBLEM]`, as plot, animate, view and export take a plan
        plan, problem = problem, problem_opt
        if plan.suffix.lower() in (".yaml", ".yml") or not (plan.suffix or plan.exists()):  # (a problem, its plan forgotten)
            _fail(ExitCode.USAGE, f"{plan}: expected a plan (plan.json, or a plan's CSV) after the problem, or the plan "
                                  f"alone; found {'a YAML file' if plan.suffix else 'a name'} and no plan: coplan verify "
                                  "PROBLEM PLAN")
    elif problem_opt is not None:
        _fail(ExitCode.USAGE, f"the problem is given twice ({problem} and --problem {problem_opt}): give "
                              "PROBLEM PLAN, or PLAN --problem FILE")
    if out is not None and (out.resolve() == plan.resolve() or (out.is_dir() and (out / "verification.json").resolve() == plan.resolve())):
        _fail(ExitCode.USAGE, f"--out {out} is the plan being verified; give another file or folder")
    if out is not None and out.is_file() and out.suffix != ".json":  # (the report is a .json file, or goes into a folder)
        _fail(ExitCode.USAGE, f"--out {out}: expected a folder or a file name ending .json, found a file "
                              f"({'without an ending' if not out.suffix else 'ending ' + out.suffix})")
    if out is not None and not out.exists() and out.suffix not in ("", ".json"):  # (it made a folder report.txt/)
        _fail(ExitCode.USAGE, f"--out {out}: expected a folder or a file name ending .json, found a new name ending "
                              f"{out.suffix} (for a new folder of that name, make it first)")
    if out is not None and (out.is_dir() or not out.suffix):  # (a folder, or a file: it must take it, before the work)
        failures.check_out_dir(out)
    elif out is not None:
        failures.check_out_file(out)
    if out is not None:  # an earlier report is replaced; a plan, a baseline or any other file is not
        from ..verify.verdict import report_path

        failures.check_overwrite(report_path(out), "a coplan.verification file", "a verification report")
    from ..errors import PlanFileError

    if problem is None:  # (the plan alone: its problem as the figure commands find it)
        from .figures import problem_of_plan

        loaded = load_plan(plan)
        prob = problem_of_plan(loaded, plan, None)
    else:
        prob = load_problem(_resolve_problem(problem))
        loaded = load_plan(plan)
    record = loaded.problem_file
    # (a plan of another problem by name is refused with both names by the verifier's own check)
    if problem is not None and record is not None and prob.digest is not None and prob.digest != record["sha256"]:
        err_console.print(f"[yellow]note[/]: {_s(plan)} was planned from {_s(record['path'])}; {_s(problem)} is not that "
                          "text (another file, or changed since: its sha256 differs): the plan is verified against "
                          f"{_s(problem)} as it is now")
    try:
        ver = run_verify(prob, loaded, fcl=fcl, position_tolerance=tolerance / 1000.0)
    except PlanFileError as e:  # a well-formed plan that does not fit this problem: name both files
        raise PlanFileError(e.issues, f"{plan} (a {e.source}, checked against {problem or prob.source or prob.name})") from None
    written = ver.save(out) if out is not None else None
    # no reachable fruit: infeasible (4), as `solve` says of the same problem
    code = ExitCode.UNSAFE if not ver.passed else ExitCode.INFEASIBLE if not prob.reachable_ids() \
        else ExitCode.OK if ver.complete else ExitCode.PARTIAL
    if as_json:  # (the verdict as the exit code says it, as `solve --json` carries it: a script reads one document)
        typer.echo(json.dumps(ver.to_dict() | failures.exit_fields(code),
                              indent=1, allow_nan=False))
    else:
        how = "given" if problem is not None else "the file the plan records" if record is not None and \
            prob.digest == record["sha256"] else "the shipped problem of the plan's name"
        print_verification(out_console, prob, ver, makespan=ver.measured["makespan"] or None,
                           label=getattr(loaded, "label", None), against=f"{prob.source or prob.name} ({how})")
        if code == ExitCode.INFEASIBLE:  # (it said "passed" and exited 4 without a word why)
            out_console.print("  nothing to plan   no fruit of the problem is reachable: exit 4 (infeasible), as "
                              "`coplan solve` and `coplan check` say of it")
        if written is not None:
            out_console.print(f"  wrote             {_s(written)}")
    raise typer.Exit(int(code))


@app.command("compare")
@guarded
def compare_cmd(
    problems: Annotated[
        Optional[Path], typer.Argument(parser=in_path, metavar="PROBLEMS", help="Problem YAML file, a shipped problem's name, or a folder of problem files (default: greenhouse_row, the course's cell).")
    ] = None,
    planner: Annotated[
        Optional[list[str]],
        typer.Option("--planner", "-p", metavar="PLANNER[:ALLOCATION]", help="Planner to run, repeatable: heuristic, coordinated, optimal or planner:allocation "
                     "(e.g. heuristic:makespan). Default: heuristic, coordinated and optimal."),
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Output folder.")] = Path("coplan-compare"),
    figures: Annotated[bool, typer.Option("--figures/--no-figures", help="Draw the comparison figures (cells; a row's comparison is its tables).")] = True,
    time_limit: Annotated[Optional[float], typer.Option(parser=real, metavar="<float>", help="Coordinated and optimal planners: wall-clock limit per solve, s.")] = None,
    options_file: Annotated[Optional[Path], typer.Option(
        "--options", help="Solver options (YAML) for the coordinated and optimal planners.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print compare.json's content instead of the tables.")] = False,
    workers: Annotated[Optional[str], typer.Option(
        metavar="N|auto", help="Processes each optimal solve's search runs in (a row: each stop rule's cells), as for "
                               "coplan solve.")] = None,
    clearance_sweep: Annotated[bool, typer.Option(
        "--clearance-sweep", help="Instead: the makespan against the clearance asked for (the problem's, +10, +25, +50, "
        "+100 mm; --extra to choose), one planner (a single --planner, default optimal; a row's cells: coordinated, as coplan solve), every plan verified.")] = False,
    extra: Annotated[Optional[list[float]], typer.Option(
        "--extra", parser=real, metavar="MM", help="With --clearance-sweep: an extra clearance in mm, repeatable (the problem's own is always planned too: the ratios' reference).")] = None,
    gantry: Annotated[Optional[GantryMode], typer.Option(
        parser=choice(GantryMode), metavar=choices(GantryMode), help="A row: auto (default) compares its stop rules and "
             "on the move (the speed searched); stop-and-go the stop rules alone; continuous on the move alone.")] = None,
    profile: Annotated[Optional[SpeedProfile], typer.Option(
        parser=choice(SpeedProfile), metavar=choices(SpeedProfile), help="A row on the move: what the speed search "
             "varies, as for coplan solve (density, the default; constant; auto: both, the better kept).")] = None,
):
    """Solve with several planners, verify each plan, and compare (compare.json, compare.md).

    A row: its stop rules (stop and go) and on the move side by side, each plan verified.

    With --clearance-sweep: one problem file planned at its clearance plus each extra (clearance.json, clearance.md, clearance_cost.png).

    Exit codes: 0 the comparison ran; 3 a problem file is invalid (the others are still compared); 7 a planner failed on some problem (recorded in its row).
    """  # (one line per paragraph: the help keeps a docstring's line breaks)
    from ..report.comparison import DEFAULT_PLANNERS, PlannerSpec, compare, rich_tables

    source = _resolve_problem(problems)
    refuse_rows_in_compare(source, time_limit, options_file)
    n_workers = _check_workers(workers)
    given = "/".join(f for f, v in (("--gantry", gantry), ("--profile", profile)) if v is not None)  # (the flags given)
    if clearance_sweep and given:
        _fail(ExitCode.USAGE, f"{given}: a row's comparison of its modes; --clearance-sweep plans one planner at "
                              "several clearances")
    if clearance_sweep:
        from .clearance import clearance_sweep

        raise typer.Exit(int(clearance_sweep(source, planner, extra, out, figures, time_limit, options_file, as_json,
                                             out_console, err_console)))
    if extra:
        _fail(ExitCode.USAGE, "--extra: only with --clearance-sweep")
    if source.is_file():
        from ..problem.load import load_problem

        prob = load_problem(source)
        if prob.gantry is not None:  # a row: its stop rules and on the move side by side
            from .row import compare_row

            raise typer.Exit(int(compare_row(prob, planner, out, as_json, out_console, err_console, n_workers, gantry,
                                             profile)))
    if given:  # (a cell has no carriage; the flags given named)
        _fail(ExitCode.USAGE, f"{given}: {source.name} is not a row (no gantry section): "
                              f"{'they apply' if '/' in given else 'it applies'} to a row's file")
    try:
        specs = [PlannerSpec.parse(p) for p in (planner or DEFAULT_PLANNERS)]
    except ValueError as e:
        _fail(ExitCode.USAGE, f"--planner: {e}")
    _check_time_limit(time_limit)
    if time_limit is not None and all(s.planner == PlannerKind.HEURISTIC for s in specs):  # (as solve: said, not ignored)
        _fail(ExitCode.USAGE, "--time-limit: the heuristic planner plans in one pass and has no time limit; "
                              "it applies to --planner optimal or coordinated")
    failures.check_out_dir(out)
    options = _solver_options(options_file, time_limit, any(s.planner != PlannerKind.HEURISTIC for s in specs))
    if n_workers is not None and not any(s.planner == PlannerKind.OPTIMAL for s in specs):  # (as solve: said, not ignored)
        _fail(ExitCode.USAGE, f"--workers: no planner compared has a search to run in parallel "
                              f"({', '.join(s.planner.value for s in specs)}); it applies to --planner optimal")
    if n_workers is not None:
        from dataclasses import replace

        from ..planners.optimal.planner import OptimalOptions

        options = replace(options or OptimalOptions(), workers=n_workers)
    hint = _budget_hint(PlannerKind.OPTIMAL, time_limit) if any(s.planner == PlannerKind.OPTIMAL for s in specs) else None
    try:
        with ProgressDisplay(err_console, quiet=as_json, hint=hint) as say:
            cmp = compare(source, specs, out, figures=figures, options=options, progress=say)
    except KeyboardInterrupt:  # (as a row's comparison: it exited 130 saying nothing of what it kept)
        if (out / "compare.json").exists():
            err_console.print(f"interrupted: the report of what finished is in {_s(str(out / 'compare.json'))} and "
                              f"compare.md (its notes say where it stopped); each finished run's folder is kept", highlight=False)
        raise
    failures.work_done()  # (the report is written: the tables and the verdict follow)
    code = ExitCode.BAD_INPUT if cmp.bad_inputs else ExitCode.SOLVER_FAILED if cmp.failed_runs else ExitCode.OK
    if as_json:  # (with the exit code: a folder with a bad file exited 3 with nothing in the document to say so)
        typer.echo(json.dumps(cmp.to_dict() | failures.exit_fields(code), indent=1, allow_nan=False))
    else:
        for table in rich_tables(cmp):
            print_table(out_console, table)
        for bad in cmp.bad_inputs:
            err_console.print(bad["error"], markup=False, highlight=False)
        for row in cmp.failed_runs:
            err_console.print(f"{row['problem']}: {row['planner']} failed: {row['error']}", markup=False, highlight=False)
        for note in cmp.notes:
            err_console.print(f"note: {note}", markup=False, highlight=False)
        figs = [k for k in cmp.files if k.endswith((".png", ".gif"))]  # (it named the two tables alone)
        out_console.print(f"wrote {_s(str(out))}/: {Path(cmp.files['json']).name}, {Path(cmp.files['markdown']).name}"
                          + (f", {len(figs)} figure{'s' * (len(figs) != 1)}" if figs else "")
                          + " and each run's plan files, in a folder per problem")
    raise typer.Exit(int(code))


# figures of a plan: plot, animate, view (bodies in coplan.cli.figures; light to import)
from .figures import animate_cmd, plot_cmd, view_cmd  # noqa: E402

app.command("plot")(guarded(plot_cmd))
app.command("animate")(guarded(animate_cmd))
app.command("view")(guarded(view_cmd))


# design sweeps on Dask (bodies in coplan.sweep.command; light to import)
from .sweep import sweep_cmd, sweep_report_cmd  # noqa: E402

app.command("sweep")(guarded(sweep_cmd))
app.command("sweep-report")(guarded(sweep_report_cmd))


# plan export for controllers, file-format schemas (bodies in coplan.cli.files; light to import)
from .files import export_cmd, schema_cmd  # noqa: E402

app.command("export")(guarded(export_cmd))
app.command("schema")(guarded(schema_cmd))


# live cell: vision feeds and the simulated run (bodies in coplan.live.command; light to import)
from .live import feed_cmd, run_cmd  # noqa: E402

app.command("feed")(guarded(feed_cmd))
app.command("run")(guarded(run_cmd))


def main() -> None:
    """Console-script entry point (:func:`coplan.cli.console.run_console`): SIGTERM is handled like
    Ctrl-C and exits 143; a reader closing stdout is no error; with ``--json`` usage errors are JSON."""
    run_console(app, err_console)


if __name__ == "__main__":
    main()
