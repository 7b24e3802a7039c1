"""The ``coplan`` command line (thin: every command calls one library entry function).

Exit codes are :class:`coplan.pipeline.ExitCode`. Bad input prints the file, the key path,
what was expected and what was found -- never a traceback (set ``COPLAN_DEBUG=1`` to see one
for an internal error).
"""

from __future__ import annotations

import functools
import json
import os
import sys
from pathlib import Path
from typing import Annotated, Optional

os.environ.setdefault("MPLBACKEND", "Agg")  # the CLI never needs a display

import typer
from rich.console import Console

from .errors import CoplanError, InputError, printable
from .kinds import AllocationMethod, ExitCode, FclMode, PlannerKind

app = typer.Typer(
    add_completion=False,
    no_args_is_help=True,
    help="Plan coordinated, collision-free, jerk-limited motion for several 2R arms harvesting fruit.",
    pretty_exceptions_enable=False,
)
out_console = Console(soft_wrap=True)
err_console = Console(stderr=True, soft_wrap=True)


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


def _fail(code: ExitCode, message: str):
    err_console.print(f"[bold red]error[/]: {message}", markup=True, highlight=False, soft_wrap=True)
    raise typer.Exit(int(code))


def guarded(fn):
    """Map coplan's errors to exit codes and clear messages (no tracebacks)."""

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        try:
            return fn(*args, **kwargs)
        except typer.Exit:
            raise
        except InputError as e:
            err_console.print(str(e), markup=False, highlight=False, soft_wrap=True)
            raise typer.Exit(int(ExitCode.BAD_INPUT)) from None
        except KeyboardInterrupt:
            err_console.print("interrupted", markup=False)
            raise typer.Exit(int(ExitCode.INTERRUPTED)) from None
        except CoplanError as e:
            _fail(ExitCode.INTERNAL, str(e))
        except OSError as e:  # disk full, permissions: the path and the reason, nothing half-written left
            where = f": {e.filename}" if e.filename else ""
            _fail(ExitCode.IO_ERROR, f"{e.strerror or e}{where} (nothing of this run was left half-written)")
        except Exception as e:  # noqa: BLE001 -- last-resort guard: report, never a raw traceback
            if os.environ.get("COPLAN_DEBUG"):
                raise
            _fail(ExitCode.INTERNAL, f"internal error ({type(e).__name__}): {e}. Set COPLAN_DEBUG=1 for a traceback.")

    return wrapper


def _strict_json(doc) -> str:
    """Strict JSON (RFC 8259): a non-finite number (e.g. no clearance at all: infinity) is null."""
    from .plan import jsonable

    return json.dumps(jsonable(doc), default=str, allow_nan=False)


def _check_time_limit(time_limit: Optional[float]) -> None:
    if time_limit is not None and not time_limit > 0:
        _fail(ExitCode.USAGE, f"--time-limit: expected a positive number of seconds, found {time_limit}")


def _check_out_dir(out: Path) -> None:
    """Before any work: ``out`` must be a folder coplan can create or write into."""
    if out.exists() and not out.is_dir():
        _fail(ExitCode.USAGE, f"--out {out}: expected a folder, found a file")
    probe = out
    while not probe.exists():
        probe = probe.parent
    if not probe.is_dir():
        _fail(ExitCode.USAGE, f"--out {out}: expected a folder, found the file {probe} in its path")
    if not os.access(probe, os.W_OK | os.X_OK):
        _fail(ExitCode.USAGE, f"--out {out}: expected a folder coplan may write to, found {probe} not writable")


def _s(x) -> str:
    """An untrusted string (a name, id or message from a file) safe for the terminal: Rich markup
    escaped, control characters (escape sequences) shown as ``\\x..`` codes."""
    from rich.markup import escape

    return escape(printable(x))


def _solver_options(path: Optional[Path], time_limit: Optional[float], applies: bool):
    """OptimalOptions from ``--options`` (validated; bad values exit 3 with the key and line)
    and ``--time-limit`` (which wins); None when neither is given."""
    if path is None and time_limit is None:
        return None
    if not applies:
        if path is not None:
            _fail(ExitCode.USAGE, "--options: the heuristic planner has no solver options")
        return None
    from dataclasses import replace

    from .optimal import OptimalOptions
    from .options import load_options

    opts = load_options(path) if path is not None else OptimalOptions()
    return replace(opts, time_limit=time_limit) if time_limit is not None else opts


def _fmt(x, unit="", nd=2):
    if x is None:
        return "-"
    return f"{x:.{nd}f}{unit}"


def _resolve_problem(problem: Optional[Path]) -> Path:
    from .problem import default_problem_path

    return problem if problem is not None else default_problem_path()


@app.command()
@guarded
def solve(
    problem: Annotated[Optional[Path], typer.Argument(help="Problem YAML file (default: the shipped greenhouse row).")] = None,
    planner: Annotated[PlannerKind, typer.Option(help="Planner to use.")] = PlannerKind.OPTIMAL,
    allocation: Annotated[
        Optional[AllocationMethod], typer.Option(help="Allocation method (default: the planner's own).")
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")] = Path("coplan-out"),
    time_limit: Annotated[Optional[float], typer.Option(
        help="Wall-clock limit, s: the optimal planner returns its verified incumbent at the limit "
             "(by default it stops on a work budget, so the plan does not depend on the machine).")] = None,
    options_file: Annotated[Optional[Path], typer.Option(
        "--options", help="Solver options (YAML): any field of coplan.optimal.OptimalOptions, e.g. "
                          "search_work: 60000 (recorded in plan.json).")] = None,
    animate: Annotated[bool, typer.Option("--animate", help="Also render an animation of the plan.")] = False,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON document instead of the summary.")] = False,
):
    """Solve a problem, verify the plan and write plan.json (+ CSV, NPZ, verification.json)."""
    from .pipeline import solve as run

    _check_time_limit(time_limit)
    _check_out_dir(out)
    options = _solver_options(options_file, time_limit, planner != PlannerKind.HEURISTIC)
    path = _resolve_problem(problem)
    say = (lambda m: None) if as_json else (lambda m: err_console.print(f"[dim]{_s(m)}[/]", highlight=False))
    if not as_json and planner != PlannerKind.HEURISTIC:
        from .problem import load_problem
        from .screen import screened

        path = load_problem(path)  # the screen's verdict, before solving
        for line in screened(path).lines():
            err_console.print(line, markup=False, highlight=False)
    res = run(path, planner=planner, allocation=allocation, out_dir=out, options=options, progress=say)
    if animate:
        res.files.update(_animate_files(res, out))
    ver = res.plan.verification or {}
    if as_json:
        doc = {
            "problem": res.problem.name,
            "planner": res.plan.planner_name,
            "status": res.plan.status.value,
            "exit_code": int(res.exit_code),
            "metrics": res.plan.metrics,
            "verification": ver,
            "solver": res.plan.solver,
            "files": {k: str(v) for k, v in res.files.items()},
            "previous_run": str(res.previous) if res.previous is not None else None,
        }
        out_console.print_json(_strict_json(doc))
    else:
        _print_summary(res)
    raise typer.Exit(int(res.exit_code))


def _animate_files(res, out: Path) -> dict:
    """Render the animation after the plan files are on disk; a rendering failure only warns,
    so the plan's own exit code stands."""
    from .viz.animate import RenderError, animate_plan

    try:
        path = animate_plan(res.problem, res.plan, out / "plan.gif")
    except RenderError as e:
        err_console.print(f"[yellow]warning[/]: animation not rendered: {_s(e)} (the plan files are written)")
        return {}
    return {"animation": path}


def _print_summary(res) -> None:
    m = res.plan.metrics
    ver = res.plan.verification or {}
    colour = "green" if res.success else "red"
    p = out_console.print
    p(f"[bold]{_s(res.problem.name)}[/] -- planner [bold]{_s(res.plan.planner_name)}[/], status [bold {colour}]{res.plan.status.value}[/]")
    p(f"  fruit harvested   {m.get('harvested')}/{m.get('reachable')} reachable ({m.get('unreachable')} unreachable: {_s(', '.join(res.plan.unreachable)) or 'none'})")
    p(f"  makespan          {_fmt(m.get('makespan'), ' s')}   (lower bound {_fmt(m.get('lower_bound'), ' s')}, ratio {_fmt(m.get('gap_to_lower_bound'), '', 3)})")
    if m.get("optimality") == "proven":
        p("  optimality        [bold green]proven[/]: the makespan meets the lower bound")
    if m.get("coordinated_makespan") is not None:
        p(f"  coordinated plan  {_fmt(m.get('coordinated_makespan'), ' s')}   (improved by {_fmt(100 * (m.get('improvement_over_coordinated') or 0.0), ' %', 1)};"
          f" first verified plan at {_fmt(m.get('time_to_first_verified'), ' s')}, last improvement at {_fmt(m.get('time_of_last_improvement'), ' s')})")
    if m.get("baseline_makespan") is not None:
        p(f"  heuristic plan    {_fmt(m.get('baseline_makespan'), ' s')}   (the course's baseline, {m.get('baseline_status', '?')}; baseline.json)")
    p(f"  cycle time/fruit  {_fmt(m.get('cycle_time'), ' s')} worst arm, {_fmt(m.get('cycle_time_mean'), ' s')} mean")
    if ver:
        p(
            f"  collisions found  {ver.get('collision_count', '-')}   least clearance {_fmt(ver.get('min_clearance'), ' m', 4)}"
            f" (certified {_fmt(ver.get('certified_clearance'), ' m', 4)}, required {_fmt(res.problem.task.clearance, ' m', 3)})"
        )
        if not ver.get("passed", False):
            p(f"  violations        {ver.get('violation_count', '?')} ({', '.join(ver.get('violation_kinds', [])) or 'see verification.json'})")
    solver = res.plan.solver
    if solver.get("message"):
        p(f"  solver            {_s(solver.get('status', ''))}: {_s(solver['message'])}")
    tm = res.plan.solver.get("timings", {})
    parts = [k for k in ("allocation", "coordinated", "search", "polish", "plan", "verify") if k in tm]
    if parts:
        planned = sum(tm[k] for k in parts)
        split = ", ".join(f"{k} {tm[k]:.2f}" for k in parts)
        p(f"  solve time        {planned:.2f} s ({split}; whole command {res.timings.get('total', planned):.2f} s)")
    for k, v in res.files.items():  # every file written: plan (JSON, CSV, NPZ), verification, baseline, animation
        p(f"  wrote             {_s(v)}")
    if res.previous is not None:
        p(f"  previous run      kept in {_s(res.previous)}")


@app.command("problems")
@guarded
def list_problems():
    """List the problem files shipped with coplan."""
    from .problem import load_problem, shipped_problems

    for path in shipped_problems():
        p = load_problem(path)
        out_console.print(f"{_s(path.name):28s} {len(p.arms)} arms, {len(p.fruits):3d} fruit  {_s(p.description)}")
    out_console.print(f"[dim]folder: {shipped_problems()[0].parent}[/]")


@app.command()
@guarded
def check(
    problem: Annotated[Optional[Path], typer.Argument(help="Problem YAML file (default: the shipped greenhouse row).")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print one JSON document instead of the summary.")] = False,
):
    """Validate a problem and say, without solving, what its geometry allows: locked arms,
    harvestable fruit per arm (and why the others are not), the makespan lower bound and the
    heuristic baseline's makespan. Exit 0 when every reachable fruit can be harvested."""
    from .allocation import bound_details
    from .heuristic import plan_heuristic
    from .problem import load_problem
    from .screen import screened
    from .verify import verify

    path = _resolve_problem(problem)
    prob = load_problem(path)
    scr = screened(prob)
    bd = bound_details(prob)
    base = plan_heuristic(prob)
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
    if as_json:
        out_console.print_json(_strict_json(doc))
    else:
        p = out_console.print
        p(f"[bold]{_s(prob.name)}[/] ({_s(path)}): {len(prob.arms)} arms, {len(prob.fruits)} fruit, "
          f"{n_reach} within some arm's reach, {harvestable} harvestable")
        for line in scr.lines():
            p(line, markup=False, highlight=False)
        proof = "proven optimum of the relaxation" if bd.proven else f"MILP stopped: dual bound {bd.dual_bound:.3f} s"
        p(f"lower bound        {bd.value:.3f} s ({proof}); no plan can be faster")
        verdict = "verified" if doc["heuristic_verified"] else f"unsafe: {', '.join(doc['heuristic_violations'] or [])}"
        p(f"heuristic baseline {_fmt(doc['heuristic_makespan'], ' s', 3)} (the course's planner; {verdict})")
    raise typer.Exit(int(ExitCode.OK if harvestable == n_reach else ExitCode.PARTIAL))


# --- commands added by the verification/report and visualisation modules go below ---


# ---- verify / compare (coplan.verify, coplan.report)


def _print_verification(problem, ver, max_rows: int = 25) -> None:
    """Verdict, clearances, peaks and a short table of the violations."""
    from rich.table import Table

    p = out_console.print
    s = ver.summary()
    verdict = "[bold green]passed[/]" if ver.passed else "[bold red]FAILED[/]"
    p(f"[bold]{_s(problem.name)}[/] -- {_s(ver.planner)} plan of {ver.duration:.2f} s: {verdict}"
      + ("" if ver.complete else f" [yellow](not harvested: {_s(', '.join(ver.unharvested))})[/]"))
    if not ver.pairs:
        p("  least clearance   - (no two arms can touch)")
    else:
        p(f"  least clearance   {_fmt(s['min_clearance'], ' m', 4)} sampled, {_fmt(s['certified_clearance'], ' m', 4)} certified"
          f" (required {_fmt(ver.required_clearance, ' m', 3)}); {s['collision_count']} collision intervals")
    for pc in ver.pairs:
        p(f"    {_s(pc.key):18s} {_fmt(pc.min_clearance, ' m', 4)} at {pc.t:.3f} s (links {pc.links[0]}/{pc.links[1]}), certified {_fmt(pc.certified, ' m', 4)}")
    for arm, pk in ver.peaks.items():
        p(f"  peaks {_s(arm):12s} velocity {pk['velocity']:.2f}, acceleration {pk['acceleration']:.2f}, jerk {pk['jerk']:.2f} of the limits")
    if ver.fcl is not None:
        agree = "agrees" if ver.fcl.agree else "[bold red]DISAGREES[/]"
        p(f"  FCL cross-check   {agree} ({ver.fcl.samples} instants, {ver.fcl.queries} link pairs, max diff {ver.fcl.max_abs_diff:.1e} m)")
    if ver.warnings:
        p(f"  warnings          {len(ver.warnings)} ({', '.join(sorted({w.kind.value for w in ver.warnings}))})")
    if not ver.violations:
        return
    table = Table(title=f"{len(ver.violations)} violations", title_justify="left")
    for col in ("kind", "arms", "t (s)", "value", "limit", "detail"):
        table.add_column(col, overflow="fold")
    for v in ver.violations[:max_rows]:
        span = f"{v.t:.3f}" if v.t_start is None or v.t_end is None or v.t_end - v.t_start < 1e-9 else f"{v.t_start:.3f}..{v.t_end:.3f}"
        detail = " ".join(x for x in (f"fruit {v.fruit}" if v.fruit else "", v.message) if x)
        table.add_row(v.kind.value, _s(",".join(v.arms)), span, _fmt(v.value, "", 4), _fmt(v.limit, "", 4), _s(detail))
    out_console.print(table)
    if len(ver.violations) > max_rows:
        p(f"  ... and {len(ver.violations) - max_rows} more (see verification.json: --out)")


@app.command("verify")
@guarded
def verify_cmd(
    problem: Annotated[Path, typer.Argument(help="Problem YAML file.")],
    plan: Annotated[Path, typer.Argument(help="plan.json to verify.")],
    out: Annotated[Optional[Path], typer.Option("--out", "-o", help="Write verification.json (a file or a folder).")] = None,
    fcl: Annotated[FclMode, typer.Option(help="FCL cross-check: critical instants, every sample (slow), or off.")] = FclMode.CRITICAL,
    as_json: Annotated[bool, typer.Option("--json", help="Print verification.json's content instead of the report.")] = False,
):
    """Independently verify a plan: clearance (certified), limits, picks and places.

    Exit codes: 0 passed and every reachable fruit harvested; 5 passed but fruit left;
    6 violations found; 3 bad problem or plan file.
    """
    from .plan import load_plan
    from .problem import load_problem
    from .verify import verify as run_verify

    if out is not None and (out.resolve() == plan.resolve() or (out.is_dir() and (out / "verification.json").resolve() == plan.resolve())):
        _fail(ExitCode.USAGE, f"--out {out} is the plan being verified; give another file or folder")
    prob = load_problem(problem)
    ver = run_verify(prob, load_plan(plan), fcl=fcl)
    written = ver.save(out) if out is not None else None
    if as_json:
        typer.echo(json.dumps(ver.to_dict(), indent=1, allow_nan=False))
    else:
        _print_verification(prob, ver)
        if written is not None:
            out_console.print(f"  wrote             {_s(written)}")
    code = ExitCode.UNSAFE if not ver.passed else ExitCode.OK if ver.complete else ExitCode.PARTIAL
    raise typer.Exit(int(code))


@app.command("compare")
@guarded
def compare_cmd(
    problems: Annotated[
        Optional[Path], typer.Argument(help="Problem YAML file or folder of them (default: the shipped greenhouse row).")
    ] = None,
    planner: Annotated[
        Optional[list[str]],
        typer.Option("--planner", "-p", help="Planner to run, repeatable: heuristic, coordinated, optimal or planner:allocation "
                     "(e.g. heuristic:makespan). Default: heuristic, coordinated and optimal."),
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Output folder.")] = Path("coplan-compare"),
    figures: Annotated[bool, typer.Option("--figures/--no-figures", help="Draw the comparison figures.")] = True,
    time_limit: Annotated[Optional[float], typer.Option(help="Optimal planner: wall-clock limit per solve, s.")] = None,
    options_file: Annotated[Optional[Path], typer.Option(
        "--options", help="Solver options (YAML) for the coordinated and optimal planners.")] = None,
    as_json: Annotated[bool, typer.Option("--json", help="Print compare.json's content instead of the tables.")] = False,
):
    """Solve with several planners, verify each plan, and compare (compare.json, compare.md).

    Exit codes: 0 the comparison ran; 3 a problem file is invalid (the others are still
    compared); 7 a planner failed on some problem (recorded in its row).
    """
    from .report import DEFAULT_PLANNERS, PlannerSpec, compare, rich_tables

    try:
        specs = [PlannerSpec.parse(p) for p in (planner or DEFAULT_PLANNERS)]
    except ValueError as e:
        _fail(ExitCode.USAGE, f"--planner: {e}")
    _check_time_limit(time_limit)
    _check_out_dir(out)
    options = _solver_options(options_file, time_limit, any(s.planner != PlannerKind.HEURISTIC for s in specs))
    say = (lambda m: None) if as_json else (lambda m: err_console.print(f"[dim]{_s(m)}[/]"))
    cmp = compare(_resolve_problem(problems), specs, out, figures=figures, options=options, progress=say)
    if as_json:
        typer.echo(json.dumps(cmp.to_dict(), indent=1, allow_nan=False))
    else:
        for table in rich_tables(cmp):
            out_console.print(table)
        for bad in cmp.bad_inputs:
            err_console.print(bad["error"], markup=False, highlight=False)
        for row in cmp.failed_runs:
            err_console.print(f"{row['problem']}: {row['planner']} failed: {row['error']}", markup=False, highlight=False)
        for note in cmp.notes:
            err_console.print(f"note: {note}", markup=False, highlight=False)
        out_console.print(f"wrote {_s(cmp.files['json'])} and {_s(cmp.files['markdown'])}")
    code = ExitCode.BAD_INPUT if cmp.bad_inputs else ExitCode.SOLVER_FAILED if cmp.failed_runs else ExitCode.OK
    raise typer.Exit(int(code))


# ---- plot / animate (coplan.viz)
from enum import Enum  # noqa: E402


class PlotKind(str, Enum):
    GANTT = "gantt"
    CLEARANCE = "clearance"
    JOINTS = "joints"
    WORKSPACE = "workspace"


def _plan_with_problem(plan_path: Path, problem: Optional[Path]):
    """Load a plan.json and its problem: --problem, else the shipped problem of that name."""
    from .plan import load_plan
    from .problem import load_problem, shipped_problems

    plan = load_plan(plan_path)
    if problem is not None:
        prob = load_problem(problem)
        if prob.name != plan.problem:
            err_console.print(f"[yellow]note[/]: {_s(plan_path)} says it is a plan of {_s(repr(plan.problem))}; {_s(problem)} is {_s(repr(prob.name))}")
    else:
        shipped = [load_problem(p) for p in shipped_problems()]
        prob = next((p for p in shipped if p.name == plan.problem), None)
        if prob is None:
            _fail(
                ExitCode.USAGE,
                f"{plan_path} is a plan of problem {plan.problem!r}, which is not a shipped problem "
                f"({', '.join(p.name for p in shipped)}); give its YAML file with --problem FILE",
            )
    missing = [a.name for a in prob.arms if a.name not in plan.q]
    if missing:
        _fail(
            ExitCode.BAD_INPUT,
            f"{plan_path} does not fit problem {prob.name!r}: no trajectory for arm(s) {', '.join(missing)} "
            f"(the plan has {', '.join(plan.q)})",
        )
    return prob, plan


# the problem a plan belongs to, for the commands that read a plan.json
PlanProblemOption = Annotated[
    Optional[Path], typer.Option("--problem", "-p", help="The plan's problem YAML (default: the shipped problem it names).")
]


@app.command("plot")
@guarded
def plot_cmd(
    plan: Annotated[Path, typer.Argument(help="plan.json to draw (for --kind workspace also a problem YAML).")],
    kind: Annotated[PlotKind, typer.Option("--kind", "-k", help="Which figure.")] = PlotKind.GANTT,
    problem: PlanProblemOption = None,
    out: Annotated[
        Optional[Path], typer.Option("--out", "-o", help="Image file; the suffix sets the format (default: <plan>_<kind>.png).")
    ] = None,
    arm: Annotated[Optional[str], typer.Option(help="joints/workspace: draw only this arm.")] = None,
    dpi: Annotated[int, typer.Option(min=30, max=600, help="Resolution of raster images.")] = 120,
):
    """Draw a figure of a plan: schedule Gantt, clearance, joint motion vs limits, or workspace map."""
    from .viz import plots

    if kind == PlotKind.WORKSPACE and plan.suffix.lower() in (".yaml", ".yml"):
        from .problem import load_problem

        prob, pl = load_problem(plan), None
    else:
        prob, pl = _plan_with_problem(plan, problem)
    if arm is not None and arm not in [a.name for a in prob.arms]:
        _fail(ExitCode.USAGE, f"--arm: no arm named {arm!r}; arms are {', '.join(a.name for a in prob.arms)}")
    if kind == PlotKind.GANTT:
        fig = plots.plot_gantt(prob, {pl.planner_name: pl})
    elif kind == PlotKind.CLEARANCE:
        fig = plots.plot_clearance(prob, {pl.planner_name: pl})
    elif kind == PlotKind.JOINTS:
        fig = plots.plot_joints(prob, pl, arms=None if arm is None else [arm])
    else:
        fig = plots.plot_workspace(prob, arm)
    target = out if out is not None else plan.with_name(f"{plan.stem}_{kind.value}.png")
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        fig.savefig(target, dpi=dpi)
    except ValueError as e:  # unknown format
        _fail(ExitCode.USAGE, f"--out {target}: {e} (use .png, .svg or .pdf)")
    except OSError as e:
        _fail(ExitCode.BAD_INPUT, f"cannot write {target}: {e.strerror or e}")
    out_console.print(f"wrote {_s(target)}")


@app.command("animate")
@guarded
def animate_cmd(
    plan: Annotated[Path, typer.Argument(help="plan.json to animate.")],
    problem: PlanProblemOption = None,
    out: Annotated[
        Optional[Path], typer.Option("--out", "-o", help="Output .gif (default, next to the plan) or .mp4 (needs ffmpeg).")
    ] = None,
    speed: Annotated[float, typer.Option(min=0.01, max=100.0, help="Playback speed: 1 = real time, 2 = twice as fast.")] = 1.0,
    fps: Annotated[float, typer.Option(min=1.0, max=60.0, help="Frames per second of the animation.")] = 10.0,
    dpi: Annotated[int, typer.Option(min=30, max=300, help="Resolution (80: a 720 px wide GIF).")] = 80,
):
    """Render a plan as an animation: arms, fruit, bins, phases, clearance alarms (GIF; MP4 with ffmpeg)."""
    from .viz.animate import animate_plan

    prob, pl = _plan_with_problem(plan, problem)
    target = out if out is not None else plan.with_suffix(".gif")
    path = animate_plan(
        prob, pl, target, speed=speed, fps=fps, dpi=dpi,
        notify=lambda m: err_console.print(f"[yellow]note[/]: {_s(m)}", highlight=False, soft_wrap=True),
    )
    out_console.print(f"wrote {_s(path)}")


def main() -> None:
    """Console-script entry point. SIGTERM is handled like Ctrl-C (the planners save what they
    have), then exits with 143 instead of 130."""
    import signal

    terminated: list[int] = []

    def on_term(signum, frame):
        if not terminated:
            terminated.append(signum)
            err_console.print("terminated (SIGTERM): saving what there is", markup=False)
        raise KeyboardInterrupt

    if hasattr(signal, "SIGTERM"):
        signal.signal(signal.SIGTERM, on_term)
    try:
        app()
    except KeyboardInterrupt:
        sys.exit(int(ExitCode.TERMINATED if terminated else ExitCode.INTERRUPTED))
    except SystemExit as e:
        if terminated and e.code in (int(ExitCode.INTERRUPTED), int(ExitCode.OK)):
            sys.exit(int(ExitCode.TERMINATED))
        raise


if __name__ == "__main__":
    main()
