"""The figure commands: ``coplan plot``, ``coplan animate`` and ``coplan view`` (registered in
:mod:`coplan.cli.commands`), and how they find a plan's problem and hold its status to the verifier.

Imports only typer, rich and the enums at module level: ``import coplan.cli`` stays light;
NumPy, the planners and matplotlib are imported inside the commands.
"""

from __future__ import annotations

import warnings
from enum import Enum
from pathlib import Path
from typing import Annotated, Optional

import typer

from . import failures
from .checks import between, check_still_read, choice, choices, fail, file_state, in_path, into_folder, out_path, real, whole
from .console import ProgressDisplay, text_console
from .failures import resolve_problem
from .summary import safe as _s
from ..kinds import ExitCode

__all__ = ["PlotKind", "plot_cmd", "animate_cmd", "view_cmd", "plan_with_problem", "problem_of_plan"]

_out = text_console()
_err = text_console(stderr=True)


def _note(message: str) -> None:
    """A library's note to the user (``notify=``), on stderr."""
    _err.print(f"[yellow]note[/]: {_s(message)}", highlight=False, soft_wrap=True)


def _resolve_problem(problem: Optional[Path]) -> Path:
    return resolve_problem(problem, lambda m: _err.print(f"[dim]{_s(m)}[/]", highlight=False))


class PlotKind(str, Enum):
    GANTT = "gantt"
    CLEARANCE = "clearance"
    JOINTS = "joints"
    WORKSPACE = "workspace"
    SPEED = "speed"  # a row on the move: fruit per hour and share harvested against speed (viz.speed)


def problem_of_plan(plan, plan_path: Path, problem: Optional[Path]):
    """A loaded plan's problem: ``problem`` (--problem; a note where the plan names another or
    was planned from another text); else the problem file the plan records (``problem_file``:
    its path, and its digest, so a file changed since is not taken for it); else the shipped
    problem of the plan's name. A usage error (exit 2) says what to give where none fits."""
    from ..problem.load import load_problem

    record = plan.problem_file
    if problem is not None:
        prob = load_problem(_resolve_problem(problem))
        if plan.problem and prob.name != plan.problem:  # (a plan.csv names no problem)
            _err.print(f"[yellow]note[/]: {_s(plan_path)} says it is a plan of {_s(repr(plan.problem))}; {_s(problem)} is {_s(repr(prob.name))}")
        elif record is not None and prob.digest is not None and prob.digest != record["sha256"]:  # (as coplan verify says it)
            _err.print(f"[yellow]note[/]: {_s(plan_path)} was planned from {_s(record['path'])}; {_s(problem)} is not that "
                       "text (another file, or changed since: its sha256 differs): the plan is drawn and verified against "
                       f"{_s(problem)} as it is now", highlight=False, soft_wrap=True)
    else:  # (the one rule coplan.view(plan) follows too)
        from ..errors import PlanFileError
        from ..problem.recorded import recorded_problem

        try:
            found = recorded_problem(plan.problem, record, "give its YAML file with --problem FILE")
        except PlanFileError as e:
            fail(ExitCode.USAGE, f"{plan_path}: {e.issues[0].message}")
        prob = found.problem
        if found.note:  # (a problem changed in Python records no file: say what is used; a recorded copy of a shipped one)
            _note(f"{plan_path}: {found.note}")
    return prob


def plan_with_problem(plan_path: Path, problem: Optional[Path]):
    """Load a plan.json and its problem (:func:`problem_of_plan`); a plan that does not fit the
    problem (:func:`coplan.plan.fit_issue`: its arms, a row's or a cell's, its fruit) is refused,
    and a plan that declares no events (a plan.csv) has them inferred."""
    from ..plan import fit_issue, load_plan

    plan = load_plan(plan_path)
    prob = problem_of_plan(plan, plan_path, problem)
    names = [a.name for a in prob.arms]
    missing = [n for n in names if n not in plan.q]
    extra = [n for n in plan.q if n not in names]
    if missing or extra:  # (an arm the problem does not have was silently left out of the figure)
        fail(
            ExitCode.BAD_INPUT,
            f"{plan_path} does not fit problem {prob.name!r}" + (f" ({prob.source})" if prob.source else "")
            + f": expected the problem's arms {names}, found {list(plan.q)}"
            + (f" (missing {missing})" if missing else "") + (f" (unknown {extra})" if extra else ""),
        )
    if not plan.events and plan.q:  # (a plan.csv declares none): as the verifier infers them
        from dataclasses import replace

        from ..verify.clearance import arm_motions
        from ..verify.infer import infer_events

        plan = replace(plan, events=infer_events(prob, plan, arm_motions(prob, plan)))
        _err.print(f"[yellow]note[/]: {_s(plan_path)} declares no picks or places: {len(plan.events)} inferred "
                          "from its motion, as `coplan verify` does")
    bad = fit_issue(prob, plan)  # (a row's plan over a cell, or picks of fruit the problem lacks: `coplan plot` ended
    if bad:                      # in "internal error", view and animate drew it)
        fail(ExitCode.BAD_INPUT, f"{plan_path} does not fit problem {prob.name!r}" + (f" ({prob.source})" if prob.source else "")
             + f": {bad}")
    return prob, plan


def checked(prob, plan):
    """``plan``'s status held to the verifier's verdict (:func:`coplan.plan.checked_status`):
    a figure never calls a plan the verifier fails a success; a note says where they differ.
    Returns the verification."""
    from ..plan import PlanStatus, checked_status
    from ..verify.verifier import verify

    ver = verify(prob, plan)
    status = checked_status(plan.status, ver)
    if status != plan.status:
        said = ("carries no verdict (unverified)" if plan.status == PlanStatus.UNVERIFIED  # (a CSV, or no status key)
                else f"says {plan.status.value}")
        _err.print(f"[yellow]note[/]: the plan file {said}; verified, it is {status.value}"
                          + (f" ({len(ver.violations)} violation{'s' * (len(ver.violations) != 1)}: "
                             f"{', '.join(sorted({v.kind.value for v in ver.violations}))})" if ver.violations else ""))
        plan.status = status
    if ver.stated_figures:  # (a title said "makespan 5.00 s" beside a 12.88 s motion: its figures are the motion's)
        from ..verify.verdict import WarningKind, measured_metrics

        said = next(w.message for w in ver.warnings if w.kind == WarningKind.STATED_FIGURES)
        _err.print(f"[yellow]note[/]: {said}; the measured ones are shown")
        plan.metrics = measured_metrics(plan.metrics, ver.stated_figures)  # (a row's fruit per hour and share too)
    return ver


# the problem a plan belongs to, for the commands that read a plan.json
PlanProblemOption = Annotated[
    Optional[Path], typer.Option("--problem", "-p", help="The plan's problem YAML (default: the problem file the plan records, else the shipped problem it names).")
]


def plot_cmd(
    plan: Annotated[Path, typer.Argument(parser=in_path, metavar="PLAN", help="plan.json to draw (for --kind workspace also a problem YAML).")],
    kind: Annotated[PlotKind, typer.Option("--kind", "-k", parser=choice(PlotKind), metavar=choices(PlotKind), help="Which figure.")] = PlotKind.GANTT,
    problem: PlanProblemOption = None,
    out: Annotated[
        Optional[Path], typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Image file; the suffix sets the format (default: <plan>_<kind>.png; plan.csv's <plan>_csv_<kind>.png).")
    ] = None,
    arm: Annotated[Optional[str], typer.Option(help="joints/workspace: draw only this arm.")] = None,
    dpi: Annotated[int, typer.Option(parser=whole, metavar="<int>", callback=between(30, 600), help="Resolution of raster images, 30-600 dpi.")] = 120,
):
    """Draw a figure of a plan: schedule Gantt, clearance, joint motion vs limits, workspace map, or (a row on the move) fruit per hour against speed."""
    from ..viz import plots

    if arm is not None and kind in (PlotKind.GANTT, PlotKind.CLEARANCE, PlotKind.SPEED):  # (it was ignored: every arm drawn)
        shows = "the whole row's plans" if kind == PlotKind.SPEED else "every arm or pair"
        fail(ExitCode.USAGE, f"--arm: expected with --kind joints or workspace (a {kind.value} figure shows {shows}), "
                              f"found --kind {kind.value}")
    # (plan.csv's and plan.npz's figures keep their format in the name: "plot plan.csv" overwrote
    # plan_gantt.png, the figure of plan.json beside it)
    stem = plan.stem if plan.suffix.lower() in (".json", ".yaml", ".yml", "") else f"{plan.stem}_{plan.suffix[1:].lower()}"
    target = out if out is not None else plan.with_name(f"{stem}_{kind.value}.png")
    if into_folder(out):  # (it wrote FOLDER.png beside the folder; given as new/, new.png)
        target = out / f"{stem}_{kind.value}.png"
    if not target.suffix:  # (matplotlib writes NAME.png and it said "wrote NAME", a file of the user's of that name)
        target = target.with_name(target.name + ".png")
    failures.check_out_file(target)  # (before any work)
    failures.check_figure_overwrite(target)
    read_as = file_state(plan)

    if kind == PlotKind.WORKSPACE and plan.suffix.lower() in (".yaml", ".yml"):
        from ..problem.load import load_problem

        prob, pl = load_problem(_resolve_problem(plan)), None
    else:
        prob, pl = plan_with_problem(plan, problem)
    if arm is not None and arm not in [a.name for a in prob.arms]:
        fail(ExitCode.USAGE, f"--arm: no arm named {arm!r}; arms are {', '.join(a.name for a in prob.arms)}")
    if kind == PlotKind.WORKSPACE and prob.gantry is not None:
        fail(ExitCode.USAGE, f"--kind workspace: expected a stationary cell, found the row {prob.name!r} (its arms ride on "
                              "the carriage, so what they reach depends on where it stops): `coplan check` screens a row, "
                              "`coplan view` shows its fruit by arm and stop; --kind gantt, clearance and joints draw its plan, "
                              "and --kind speed the speed search of a plan made on the move")
    if kind == PlotKind.SPEED:  # (before the verifier runs: a plan with no speed search is refused at once)
        from ..viz.speed import speed_curve

        try:
            speed_curve(pl)
        except ValueError as e:
            fail(ExitCode.USAGE, f"--kind speed: {e}; --kind gantt, clearance and joints draw any plan"
                                 + ("" if prob.gantry is not None else ", and --kind workspace a cell's arms' reach"))
    if pl is not None:  # (the title's status: the verdict's, not the file's word)
        checked(prob, pl)
    if kind == PlotKind.GANTT:
        fig = plots.plot_gantt(prob, {pl.label: pl})  # (a row's: how its carriage moved too)
    elif kind == PlotKind.CLEARANCE:
        fig = plots.plot_clearance(prob, {pl.label: pl})
    elif kind == PlotKind.JOINTS:
        fig = plots.plot_joints(prob, pl, arms=None if arm is None else [arm])
    elif kind == PlotKind.SPEED:
        from ..viz.speed import plot_speed_curve

        fig = plot_speed_curve(pl)
    else:
        fig = plots.plot_workspace(prob, arm)
    check_still_read(plan, read_as)  # (the plan replaced while drawn: nothing written)
    new = not target.exists()
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with warnings.catch_warnings(record=True) as said:  # (matplotlib's printed its source line: a note instead)
            warnings.simplefilter("always")
            fig.savefig(target, dpi=dpi)
        for w in {str(w.message): w for w in said}.values():  # (each once)
            _err.print(f"[yellow]note[/]: matplotlib: {_s(str(w.message))}", highlight=False, soft_wrap=True)
    except ValueError as e:  # unknown format
        fail(ExitCode.USAGE, f"--out {target}: {e} (use .png, .svg or .pdf)")
    except OSError as e:
        fail(ExitCode.IO_ERROR, f"cannot write {target}: {e.strerror or e}")
    check_still_read(plan, read_as, [target] if new else [])
    _out.print(f"wrote {_s(target)}")


def animate_cmd(
    plan: Annotated[Path, typer.Argument(parser=in_path, metavar="PLAN", help="plan.json to animate.")],
    problem: PlanProblemOption = None,
    out: Annotated[
        Optional[Path], typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Output .gif (default, next to the plan) or .mp4, or a folder to write <plan>.gif in.")
    ] = None,
    speed: Annotated[float, typer.Option(parser=real, metavar="<float>", callback=between(0.01, 100.0), help="Playback speed: 1 = real time, 2 = twice as fast (0.01-100).")] = 1.0,
    fps: Annotated[float, typer.Option(parser=real, metavar="<float>", callback=between(1.0, 60.0), help="Frames per second of the animation (1-60).")] = 10.0,
    dpi: Annotated[int, typer.Option(parser=whole, metavar="<int>", callback=between(30, 300), help="Resolution, 30-300 dpi (80: a 720 px wide GIF).")] = 80,
):
    """Render a plan as an animation: arms, fruit, bins, phases, clearance alarms (GIF or MP4)."""
    from ..viz.animate import animate_plan

    if into_folder(out):  # (into the folder, as plot, view, verify and export take one: it was refused)
        out = out / f"{plan.stem}.gif"
    if out is not None and out.suffix.lower() not in (".gif", ".mp4"):
        fail(ExitCode.USAGE, f"--out: expected a .gif or .mp4 file, found {_s(out)!r}")
    target = out if out is not None else plan.with_suffix(".gif")
    failures.check_out_file(target)  # (before any work: as plot's, view's)
    failures.check_figure_overwrite(target)
    read_as = file_state(plan)
    prob, pl = plan_with_problem(plan, problem)
    checked(prob, pl)  # (the title's status: the verdict's, not the file's word)
    new = not target.exists()
    with ProgressDisplay(_err) as bars:
        path = animate_plan(
            prob, pl, target, speed=speed, fps=fps, dpi=dpi,
            notify=_note,
            progress=bars,
        )
    check_still_read(plan, read_as, [path] if new else [])
    failures.work_done()
    _out.print(f"wrote {_s(path)}")


def view_cmd(
    plan: Annotated[Path, typer.Argument(parser=in_path, metavar="PLAN", help="plan.json to view.")],
    problem: PlanProblemOption = None,
    compare: Annotated[Optional[Path], typer.Option("--compare", help="A second plan.json of the same problem, side by side on one clock.")] = None,
    out: Annotated[Optional[Path], typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="HTML file, or a folder to write <plan>.html in (default: the plan's name with .html, next to it).")] = None,
    open_page: Annotated[bool, typer.Option("--open", help="Open the page in the default browser.")] = False,
):
    """Write the interactive viewer of a plan: one self-contained HTML page (works offline) to scrub, play, hover, jump to violations."""
    from ..viz.viewer import write_view

    if into_folder(out):  # (into the folder, as verify and export take one: it was refused; given as new/ too)
        out = out / f"{plan.stem}.html"
    if out is not None and out.suffix.lower() not in (".html", ".htm"):  # (a usage error, before any work: as plot's and animate's --out)
        failures.usage(f"--out: expected a file name ending in .html, found {out.name!r}")
    # (beside the plan by default: a folder it cannot write into was "Read-only file system", exit 8, after the work)
    failures.check_out_file(out if out is not None else plan.with_suffix(".html"))
    failures.check_figure_overwrite(out if out is not None else plan.with_suffix(".html"))
    read_as = file_state(plan)
    prob, pl = plan_with_problem(plan, problem)
    other = None
    if compare is not None:
        oprob, other = plan_with_problem(compare, problem)
        if problem is None and prob.digest and oprob.digest and prob.digest != oprob.digest:
            # (the second plan was checked against the first's problem: a valid plan shown as failed)
            fail(ExitCode.USAGE, f"--compare {compare}: expected a plan of the same problem text as {plan}, found one "
                                  f"planned from {oprob.source} (its sha256 differs from {prob.source}'s); give the "
                                  "problem both are to be checked against with --problem FILE")
    # (a plan.csv names no problem: only two names that differ are refused)
    if other is not None and pl.problem and other.problem and other.problem != pl.problem:  # (the message named the option, not the file)
        fail(ExitCode.USAGE, f"--compare {compare}: expected a plan of the same problem {pl.problem!r} as {plan}, "
                              f"found a plan of {other.problem!r}")
    # each plan verified once, here: the page shows the verdict, and a note says where the file's word differs (as plot)
    vers = {"verification": checked(prob, pl)} | ({"compare_verification": checked(prob, other)} if other is not None else {})
    target = out if out is not None else plan.with_suffix('.html')
    check_still_read(plan, read_as)  # (the plan replaced while read: nothing written)
    new = not target.exists()
    page = write_view(prob, pl, other, target, open_page, notify=_note, **vers)
    check_still_read(plan, read_as, [page] if new else [])
    _out.print(f"wrote {_s(page)}")
