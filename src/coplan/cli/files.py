"""The ``coplan export`` and ``coplan schema`` commands (registered in :mod:`coplan.cli`; light to
import: the heavy work is imported inside each command)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated, Optional

import typer
from rich.markup import escape

from ..errors import printable
from ..kinds import ExitCode, ExportFormat, SchemaKind
from .checks import check_still_read, choice, choices, file_state, in_path, into_folder, out_path, real
from .console import text_console
from .failures import Failure, check_out_dir, check_out_file, check_overwrite

__all__ = ["export_cmd", "schema_cmd"]

_out = text_console()
_err = text_console(stderr=True)




def export_cmd(
    plan: Annotated[Path, typer.Argument(parser=in_path, metavar="PLAN", help="plan.json to export.")],
    rate: Annotated[float, typer.Option(parser=real, metavar="<float>", help="Points per second, Hz.")] = 100.0,
    fmt: Annotated[ExportFormat, typer.Option("--format", "-f", parser=choice(ExportFormat), metavar=choices(ExportFormat), help="csv: one file, every arm; json, yaml: a ROS 2 "
                                              "trajectory_msgs/JointTrajectory per arm, in a folder.")] = ExportFormat.CSV,
    out: Annotated[Optional[Path], typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="CSV file, or folder (default: beside the plan; a CSV into a folder that exists, or ends with /, is named <plan>_<rate>hz.csv).")] = None,
    problem: Annotated[Optional[Path], typer.Option("--problem", "-p", help="The plan's problem YAML, to verify the plan against (default: the problem file the plan records, else the shipped problem it names).")] = None,
    unverified: Annotated[bool, typer.Option("--unverified", help="Export without verifying the plan first (a plan the verifier fails is refused otherwise).")] = False,
):
    """Export a plan for a joint controller: positions, velocities and accelerations per joint at a chosen rate.

    The plan is verified against its problem first; one that fails (collisions, limits, missed picks) is refused, exit 6, nothing written."""
    for path in _export(plan, rate, fmt, out, problem, unverified):
        _out.print(f"wrote {escape(printable(path))}")


def schema_cmd(kind: Annotated[SchemaKind, typer.Argument(parser=choice(SchemaKind), metavar="KIND",
                                                           help="Which file format: " + ", ".join(m.value for m in SchemaKind) + ".")]):
    """Print the JSON Schema of problem files, plan files or vision feeds (shipped as coplan/schemas/*.schema.json)."""
    typer.echo((Path(__file__).parents[1] / "schemas" / f"{kind.value}.schema.json").read_text(), nl=False)


def _export(plan_path: Path, rate: float, fmt: ExportFormat | str, out: Path | None, problem: Path | None = None,
            unverified: bool = False) -> list[Path]:
    """``coplan export``: load the plan, check the rate and where to write (usage errors exit 2
    before anything is written), export. Default ``out``: beside the plan,
    ``<plan>_<rate>hz.csv`` or the folder ``<plan>_<rate>hz/``."""
    from ..plan import load_plan
    from ..report.export import check_rate, export_names, export_plan, restored, trajectory

    fmt = ExportFormat(fmt)
    read_as = file_state(plan_path)
    # read once (a plan from a pipe is gone after the first read), with the plan.npz beside it: no
    # 1e-7 rounding for a finer grid to magnify; with its problem unless --unverified (a plan.csv's
    # events then inferred from its motion, for the events file)
    if unverified:
        plan, prob = load_plan(plan_path), None
    else:
        from .figures import plan_with_problem

        prob, plan = plan_with_problem(plan_path, problem)
    try:
        check_rate(rate, plan)
    except ValueError as e:
        raise Failure(ExitCode.USAGE, f"--rate: {e}") from None
    out = _export_target(plan_path, rate, fmt, out)
    # (a folder it cannot write into: "error: No such file or directory: /proc/x.csv", exit 8, after the work)
    if fmt == ExportFormat.CSV:
        check_out_file(out)
    else:
        check_out_dir(out, files_only=True)
    names = export_names(plan)  # (each arm's file and joint-name stem, the carriage's and the events')
    _check_export_overwrites(out, fmt, names)
    if unverified:
        _err.print(f"note: {printable(plan_path)} exported without verifying it (--unverified): nothing here says a "
                   "controller may follow it" + ("; it declares no picks or places, so its events file is empty"
                                                 if not plan.events else ""), markup=False, highlight=False)
    else:  # (an unsafe plan, or one edited after its verdict, was exported with exit 0 and a note that said its rates kept the limits)
        from .figures import checked

        ver = checked(prob, plan)
        if not ver.passed:
            kinds = ", ".join(sorted({v.kind.value for v in ver.violations}))
            raise Failure(ExitCode.UNSAFE, f"{plan_path} does not pass the verifier against problem {prob.name!r} "
                                           f"({len(ver.violations)} violation{'s' * (len(ver.violations) != 1)}: {kinds}; "
                                           f"coplan verify says where): a controller must not follow it, nothing written "
                                           f"(--unverified exports it anyway)")
    stale = []  # an earlier export's per-arm files in the folder that this one does not replace (a plan of other arms)
    if fmt != ExportFormat.CSV and out.is_dir():
        from .failures import file_kind

        new = {f"{stem}.{fmt.value}" for stem in names.values()}
        kinds = {p: file_kind(p) for p in sorted(out.glob(f"*.{fmt.value}"))}
        # only in a folder a coplan export made (its events file says so): someone's own trajectories stay
        if "an export's events" in kinds.values():
            stale = [p for p, k in kinds.items() if p.name not in new and k in ("an export JointTrajectory", "an export's events")]
    # (a plan.json alone, rounded to 1e-7, runs over its limits in its differences: its export did too, by up to 0.4 % in
    # jerk, and coplan verify refused it; the samples are restored within their rounding first where they can be)
    smooth, kept = restored(plan, prob) if not unverified else (plan, True)
    traj = trajectory(smooth, rate)  # (once: the files and the follow error are of the same points)
    import warnings

    with warnings.catch_warnings():  # (an unsafe plan reaches here only with --unverified, which says so itself)
        warnings.filterwarnings("ignore", message="export_plan: writing the plan", category=UserWarning)
        # (the earlier export's files this one does not replace go as its files come -- a controller
        # loading the folder got two plans' trajectories; and the plan is checked as they do -- an
        # export of a plan replaced meanwhile by a solve into its folder was left in the new run's)
        written = export_plan(plan, rate, fmt, out, traj, replaces=stale,
                              before=lambda: check_still_read(plan_path, read_as))
    if stale:
        _err.print(f"note: removed the earlier export's {', '.join(p.name for p in stale)} from {printable(out)} (not of "
                   "this plan: the folder is this export whole)", markup=False, highlight=False)
    _export_notes(plan_path, plan, prob, rate, fmt, out, written, names, traj, unverified, smooth is not plan and kept)
    _follow_note(plan, traj, rate)
    return written


def _hz(rate: float) -> str:
    """A rate as a file name has it: to 12 significant digits (``{rate:g}`` named 333.3333 and 333.3334 Hz
    alike, and the second export replaced the first)."""
    return f"{rate:.12g}"


def _export_target(plan_path: Path, rate: float, fmt: ExportFormat, out: Path | None) -> Path:
    """Where ``coplan export`` writes (usage errors exit 2 before anything is written): ``out``,
    or beside the plan (``<plan>_<rate>hz.csv``, the folder ``<plan>_<rate>hz/``)."""
    if out is None:
        stem = plan_path.with_name(f"{plan_path.stem}_{_hz(rate)}hz")
        out = stem.with_name(stem.name + ".csv") if fmt == ExportFormat.CSV else stem  # (with_suffix took ".5hz" of 12.5 Hz for one)
    if fmt == ExportFormat.CSV and into_folder(out):  # into the folder
        out = Path(out) / f"{plan_path.stem}_{_hz(rate)}hz.csv"
        if out.is_dir():
            raise Failure(ExitCode.USAGE, f"--out {out}: expected a CSV file name, found a folder")
    if fmt != ExportFormat.CSV and out.exists() and not out.is_dir():
        raise Failure(ExitCode.USAGE, f"--out {out}: expected a folder (one {fmt.value} file per arm), found a file")
    if fmt != ExportFormat.CSV and not out.exists() and out.suffix.lower() in (".json", ".yaml", ".yml", ".csv"):
        # (a file name: the export would make a folder of that name)
        raise Failure(ExitCode.USAGE, f"--out {out}: expected a folder (one {fmt.value} file per arm, <arm>.{fmt.value}), "
                                      f"found a file name ending {out.suffix}; give a folder name")
    if out.resolve() == plan_path.resolve():
        raise Failure(ExitCode.USAGE, f"--out {out} is the plan being exported; give another file")
    return out


def _check_export_overwrites(out: Path, fmt: ExportFormat, names: dict) -> None:
    """Refuse to overwrite a file an export did not write (an earlier export is replaced), or a
    folder where one of its files goes (the export stopped at it half-way, exit 8)."""
    from ..report.export import EVENTS, events_path

    targets = [out, events_path(out)] if fmt == ExportFormat.CSV else [out / f"{n}.{fmt.value}" for n in names.values()]
    folder = next((t for t in targets if t.is_dir()), None)
    if folder is not None:
        raise Failure(ExitCode.USAGE, f"--out {out}: expected to write the file {folder}, found a folder of that name")

    if fmt == ExportFormat.CSV:  # an earlier export is replaced; coplan's plan.csv or any other file is not
        check_overwrite(out, "an export CSV", "an earlier export (a CSV with t, <arm>_q1 ... <arm>_qdd2)")
        check_overwrite(events_path(out), "an export's events", "an earlier export's events (arm,fruit,kind,t_start,t_end)")
    else:  # each arm's file likewise: an arm named plan or verification would overwrite those
        for key, name in names.items():
            if key is EVENTS:
                check_overwrite(out / f"{name}.{fmt.value}", "an export's events", "an earlier export's events")
            else:
                check_overwrite(out / f"{name}.{fmt.value}", "an export JointTrajectory",
                                "an earlier export (a JointTrajectory with joint_names and points)")


def _export_notes(plan_path: Path, plan, prob, rate: float, fmt: ExportFormat, out: Path, written: list[Path], names: dict,
                  traj, unverified: bool, restored: bool = False) -> None:
    """What ``coplan export`` says about the files it wrote: a rate coplan verify does not read,
    a file too large for it, an arm in a file of another name, a plan without its full-precision
    samples (``restored``: its samples were restored within their rounding to keep the limits)."""
    from ..plan import MAX_PLAN_BYTES, finer_grid, on_lattice
    from ..report.export import EVENTS, limit_excess, safe_names

    if rate < 100.0:
        _err.print(f"note: at {rate:g} Hz coplan verify does not read this export (it checks a grid of 100 Hz or finer): "
                   "verify the plan it came from", markup=False, highlight=False)
    if fmt == ExportFormat.CSV:
        size = written[0].stat().st_size if written else 0
        if size > MAX_PLAN_BYTES:  # (a 270 MB export at 1 kHz, which coplan verify then refused, said nothing)
            _err.print(f"note: this export is {size / 2**20:.0f} MiB, more than coplan verify reads ({MAX_PLAN_BYTES >> 20} MiB): "
                       f"verify the plan it came from, or an export at a lower rate", markup=False, highlight=False)
    if fmt != ExportFormat.CSV:  # (an arm whose name is not a safe file name: which file it is in was nowhere said)
        for arm, stem in names.items():
            if arm is EVENTS and stem != "events":  # (events.json held an arm's trajectory, without a word)
                _err.print(f"note: the picks and places are in {stem}.{fmt.value} (an arm's trajectory has the name events "
                           f"takes: it keeps its file)", markup=False, highlight=False)
            if isinstance(arm, str) and stem != arm:
                why = ("its name is not a safe file and joint name as it is" if safe_names([arm])[arm] != arm else
                       "another file has its name (file names are told apart case-blind)")
                _err.print(f"note: arm {arm!r} is in {stem}.{fmt.value} (joints {stem}_joint1, {stem}_joint2): {why}",
                           markup=False, highlight=False)
    if all(on_lattice(q) for q in plan.q.values()) and finer_grid(1.0 / rate) and plan.time.size > 1:  # (no plan.npz beside it: it exported in silence)
        from ..verify.verdict import VerifyOptions

        tol = 1.0 + VerifyOptions().rel_tolerance  # (what the verifier lets pass)
        excess = {w: ra for w, ra in (limit_excess(traj, prob) if not unverified else {}).items() if ra[0] > tol}
        over = (": measured on the export, " + ", ".join(f"{arm}'s {w} comes to {r:.4f} x its limit" for w, (r, arm) in excess.items())
                + ", which coplan verify of the export reports" if excess else
                ": where the plan runs at a limit, the export's differences can come out over it, which coplan verify of "
                "the export reports" if unverified else "; measured on the export, every limit holds")
        what = ("its samples rounded to 1e-7 (rad, the carriage m), each moved back within its rounding (at most 5e-8) so that their "
                "differences keep the limits, as the full-precision samples' do" if restored and not excess else
                f"its 1e-7 rad rounding, which differences at {rate:g} Hz magnify")
        _err.print(f"note: no plan.npz with this plan's full-precision samples beside {escape(printable(plan_path))}: the "
                   f"export is of {what}{over}", markup=False, highlight=False)


def _follow_note(plan, traj, rate: float) -> None:
    """How far a controller following the exported points departs from the plan, where more than
    the tolerance (the smoothing's, or the rate's)."""
    from ..report.export import FOLLOW_TOLERANCE, follow_error, smoothing_error

    err, arm, t = follow_error(plan, traj)
    if err <= FOLLOW_TOLERANCE:
        return
    smooth, sarm, st = smoothing_error(plan)
    if err - smooth <= FOLLOW_TOLERANCE:  # (the smoothing's, at any rate: a higher one is no cure)
        _err.print(f"note: the export's curve passes up to {smooth:.3g} rad from the plan's samples ({escape(printable(sarm))} "
                   f"at t = {st + traj.delay:.2f} s of the export), at any rate: it is the smoothing that keeps every "
                   f"rate within the plan's limits (a sixth of a second difference of the samples), large where the "
                   f"plan accelerates hard for its {1.0 / plan.dt:g} Hz samples", markup=False, highlight=False)
    else:  # (0.001 Hz wrote two points, both home: a trajectory that never moves, said nothing)
        _err.print(f"note: at {rate:g} Hz a controller following these points (cubic between them, with their "
                   f"velocities) departs from the plan by up to {err:.3g} rad ({escape(printable(arm))} at t = {t + traj.delay:.2f} s of the export); "
                   f"the plan is sampled at {1.0 / plan.dt:g} Hz", markup=False, highlight=False)
