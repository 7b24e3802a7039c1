"""The ``coplan sweep`` and ``coplan sweep-report`` commands (registered in :mod:`coplan.cli`).

Imports only typer, rich and the enums at module level: ``import coplan.cli`` stays light;
Dask, pyarrow, NumPy and matplotlib are imported inside the commands.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Annotated, Optional

import typer

from ..errors import plural
from ..workers import MAX_WORKERS
from .checks import check_time_limit, check_workers, choice, choices, in_path, out_path, real
from .console import text_console
from .failures import check_out_dir, usage
from .summary import safe as _safe
from ..errors import printable
from ..kinds import ExitCode, PlannerKind, RowStatus, SweepBase, SweepMode

__all__ = ["sweep_cmd", "sweep_report_cmd"]

_out = text_console()
_err = text_console(stderr=True)


def _mean_eta_column():
    """The time left at the mean time per finished problem so far -- "-:--:--" until three are
    done (rich's own estimate, from the last 30 s of a bursty parallel run, said "ETA 0:03:13" for
    an hour's sweep and "0:00:04" with eight 20 s problems left)."""
    from rich.progress import ProgressColumn
    from rich.text import Text

    class MeanEta(ProgressColumn):
        def render(self, task) -> Text:
            done, total, spent = task.completed, task.total, task.elapsed
            if not total or done < 3 or not spent:
                return Text("-:--:--", style="progress.remaining")
            left = int(round(spent / done * max(total - done, 0)))
            return Text(f"{left // 3600}:{left // 60 % 60:02d}:{left % 60:02d}", style="progress.remaining")

    return MeanEta()


def _notes_before_run(sw, planner) -> None:
    """A note where ``--planner`` replaces the planners the sweep file varies (it was silent; the
    solver options its row files do not take are said by :func:`coplan.sweep.run.run_sweep`)."""
    if planner is not None and "planner" in sw.vary:  # (two sets then make one problem: "e.g. densities that round ...")
        _err.print(f"note: --planner {PlannerKind(planner).value} replaces the planners the sweep varies "
                   f"({', '.join(map(str, sw.vary['planner'])) if isinstance(sw.vary['planner'], (list, tuple)) else sw.vary['planner']}): "
                   "sets that differ only in it are one problem, solved once", highlight=False)


def _counts_text(counts: dict[str, int]) -> str:
    order = [s.value for s in RowStatus]  # (a copy of it left out unverified and interrupted)
    keys = sorted(counts, key=lambda k: order.index(k) if k in order else len(order))
    colour = {"success": "green", "partial": "yellow"}
    return "  ".join(f"[{colour.get(k, 'red')}]{_safe(k)} {counts[k]}[/]" for k in keys) or "[dim]no problem finished yet[/]"


def sweep_cmd(
    spec: Annotated[Path, typer.Argument(parser=in_path, metavar="SPEC", help="Sweep file (YAML): a base, the parameters to vary, planner and options; "
                                          "or a folder or glob of problem files.")],
    out: Annotated[Optional[Path], typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Output folder (default: coplan-sweep/<sweep name>). "
                                                "A re-run into the same folder skips the rows already done.")] = None,
    workers: Annotated[Optional[str], typer.Option(metavar="N|auto", help="Worker processes of the local cluster, "
                                                   f"1 to {MAX_WORKERS} (default and auto: one per core; one thread each).")] = None,
    scheduler: Annotated[Optional[str], typer.Option(help="Use an existing Dask cluster at this address "
                                                     "(e.g. tcp://host:8786) instead of a local one.")] = None,
    planner: Annotated[Optional[PlannerKind], typer.Option(parser=choice(PlannerKind), metavar=choices(PlannerKind), help="Planner for every problem (replaces the file's).")] = None,
    time_limit: Annotated[Optional[float], typer.Option(parser=real, metavar="<float>", help="Per-problem time limit, s (replaces the file's; "
                                                        "default 120).")] = None,
    csv: Annotated[bool, typer.Option("--csv", help="Also write results.csv.")] = False,
    keep_plans: Annotated[bool, typer.Option("--keep-plans", help="Also write every plan as plans/<key>.json, "
                                             "with its problem as plans/<key>.yaml (for coplan verify).")] = False,
):
    """Solve every problem of a design sweep on Dask; one table row per problem (results.parquet)."""
    from ..sweep.spec import load_sweep

    check_time_limit(time_limit, "the sweep file's, or 120 s")
    if workers is not None and scheduler is not None:
        usage("--workers: expected either --workers (a local cluster) or --scheduler (an existing one), found both")
    # (auto was refused here, which run_sweep(workers="auto") and coplan solve --workers take)
    workers = None if workers is None or workers.strip().lower() == "auto" else check_workers(workers)
    if scheduler is not None:
        _check_scheduler(scheduler)
    sw = load_sweep(spec)  # SweepError (an InputError): file:line: key.path messages, exit 3
    if planner == PlannerKind.HEURISTIC and sw.gives_options:
        usage(f"--planner: the heuristic planner has no solver options, and {spec} gives some (options); found heuristic")
    if planner == PlannerKind.HEURISTIC and sw.base == SweepBase.GANTRY:
        usage(f"--planner: expected coordinated or optimal for {spec} (base gantry: each stop's cell planner; the "
              "course's heuristic plans a stationary cell, not a row), found heuristic")
    _notes_before_run(sw, planner)
    folder = out if out is not None else Path("coplan-sweep") / (re.sub(r"[^\w.-]+", "_", sw.name).strip("._") or "sweep")
    check_out_dir(folder, "--out")
    from ..sweep.table import read_sweep_record

    held, _ = read_sweep_record(folder) if folder.is_dir() else (None, None)
    if isinstance(held, dict) and held.get("name") not in (None, sw.name):  # (an --out mistake: it was the sweep file's, exit 3)
        usage(f"--out {folder}: expected the output folder of sweep {sw.name!r} or a new folder, found one holding "
              f"sweep {held['name']!r}; choose another --out")
    n = sw.samples if sw.mode == SweepMode.RANDOM else sw.grid_size()
    if n is not None and n * max(1, len(sw.problems)) >= 1000:  # (a 64,320-problem grid said nothing for minutes while they were made)
        _err.print(f"sweep [bold]{_safe(sw.name)}[/]: making its {n * max(1, len(sw.problems)):,} problems (generating and "
                   f"keying each: a while for this many)", highlight=False)
    from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeElapsedColumn

    from ..sweep.run import run_sweep

    progress = Progress(TextColumn("[bold]{task.fields[name]}[/]"), BarColumn(), MofNCompleteColumn(), TimeElapsedColumn(),
                        TextColumn("ETA"), _mean_eta_column(), TextColumn("{task.description}"), console=_err, transient=False)
    state: dict = {}

    def on_start(o):  # (the display starts here, its refresh thread after the cluster: see below)
        progress.start()
        _err.print(f"sweep [bold]{_safe(sw.name)}[/]: {plural(o.total, 'problem')}, {o.skipped} already done in {_safe(folder)}; "
                   f"{_safe(scheduler) if scheduler else plural(o.workers, 'local worker process', 'local worker processes')}", highlight=False)
        sets = n if sw.mode == SweepMode.GRID and sw.base != SweepBase.FILES else None  # (the grid's size, counted above)
        if sets is not None and sets > o.total:  # (densities that round to one fruit count: 11 asked, 5 run, not a word)
            _err.print(f"note: {sets - o.total} of the {sets} parameter sets make a problem another set makes too (the "
                       f"same problem text: e.g. densities that round to the same number of fruit); each is solved once",
                       highlight=False)
        files = len(sw.problems) * n if sw.mode == SweepMode.GRID and sw.base == SweepBase.FILES and n is not None else None
        if files is not None and files > o.total:  # (a copy of a file in the folder: 4 files, 3 rows, not a word)
            _err.print(f"note: {files - o.total} of the {plural(files, 'problem file')}{' and parameter sets' if n > 1 else ''} "
                       "give a problem another gives too (the same problem text: e.g. a copy of a file); each is solved "
                       "once, under the first file's name", highlight=False)
        asked = n * max(1, len(sw.problems)) if sw.mode == SweepMode.RANDOM and n is not None else None
        if asked is not None and o.total < asked:  # (samples: 5 made 2 problems, and not a word)
            _err.print(f"note: {o.total} distinct problems of the {asked} samples asked: the parameters drawn make no more "
                       "(e.g. densities that round to the same number of fruit); each is solved once", highlight=False)
        state["task"] = progress.add_task(_counts_text(o.counts), total=o.total - o.skipped, name=sw.name)

    def on_row(row, o):
        progress.update(state["task"], advance=1, description=_counts_text(o.counts))

    try:
        # the progress display is started once the cluster is up (on_start): a Ctrl-C while the
        # cluster starts is held for this thread, and a thread started before it could take the
        # signal instead and drop it (the sweep then ran to its end)
        try:
            res = run_sweep(sw, folder, workers=workers, scheduler=scheduler, planner=planner, time_limit=time_limit,
                            csv=csv, keep_plans=keep_plans, on_row=on_row, on_start=on_start,
                            on_note=lambda m: _err.print(f"[yellow]note[/]: {_safe(m)}", highlight=False))
        finally:
            progress.stop()
    except KeyboardInterrupt:
        if (folder / "rows.jsonl").is_file():
            _err.print(f"interrupted: every finished row is kept in {_safe(folder)}; run the same command again to resume",
                       highlight=False)
        elif folder.is_dir() and any(folder.iterdir()):  # (it said "nothing written" beside a table and sweep.json)
            made = sorted(p.name for p in folder.iterdir() if not p.name.startswith("."))
            _err.print(f"interrupted before any problem was solved: no rows; {_safe(folder)} holds "
                       f"{', '.join(made) or 'only the sweep state'} (no row in any); run the same command again to "
                       "start", highlight=False)
        else:  # (it said rows were kept in a folder that did not exist: interrupted before any problem was solved)
            _err.print("interrupted before any problem was solved: nothing written", highlight=False)
        raise
    except OSError as e:
        if "connect" in str(e).lower() or isinstance(e, (ConnectionError, TimeoutError)):
            usage(f"--scheduler {scheduler}: could not connect ({e})")
        raise
    lost = res.counts.get(RowStatus.LOST.value, 0)  # (no row from Dask: not solved; a re-run solves them)
    solved = res.done - lost
    rate = 60.0 * solved / res.elapsed if res.elapsed > 0 else 0.0
    _out.print(f"[bold]{_safe(sw.name)}[/]: {plural(res.total, 'problem')} ({solved} solved now, "
               + (f"{lost} lost, " if lost else "") + f"{res.skipped} already done) "
               f"in {res.elapsed:.1f} s ({rate:.1f} problems/min)", highlight=False)
    if res.others:  # rows of other runs into this folder (another planner, time limit, options or problems): the table holds both
        what = (f"planner {', '.join(res.other_planners)}, or other problems, time limits or options" if res.other_planners
                else "the same planners: other problems, time limits or options; the spec or the command changed")
        _err.print(f"[yellow]note[/]: {_safe(folder)} also holds {plural(len(res.others), 'row')} of other runs of this "
                   f"sweep ({what}): its table and report hold both (their key column tells them apart; index numbers "
                   "each run's problems)", highlight=False)
    if res.snapshot_error:
        _err.print(f"[yellow]note[/]: a snapshot of the table could not be written meanwhile ({_safe(res.snapshot_error)}); "
                   "the sweep went on, every row journaled, and the table was written at its end", highlight=False)
    if keep_plans and res.unplanned:
        _err.print(f"[yellow]note[/]: --keep-plans writes the plans of the rows solved now; {res.unplanned} of the "
                   f"{res.skipped} already done have no plan in {_safe(folder / 'plans')} and were not planned again "
                   "(run into a new --out for every plan)", highlight=False)
    _out.print("  " + (_counts_text(res.counts) if res.counts else "nothing to do"), highlight=False)
    for k, v in res.files.items():
        _out.print(f"  wrote {_safe(v)}", highlight=False)
    _out.print(f"  next: coplan sweep-report {_safe(folder)}", highlight=False)
    lost = res.counts.get(RowStatus.LOST.value, 0)
    if lost:  # no result is not a result: a script must not take the sweep for done (the next run solves them)
        _err.print(f"{plural(lost, 'problem')} of the sweep {'has' if lost == 1 else 'have'} no result (status 'lost': "
                   "the worker process died on every attempt, or the scheduler went away; the reason in the message "
                   "column): run the same command again to solve "
                   f"{'it' if lost == 1 else 'them'}, the rows already done are kept", highlight=False)
        raise typer.Exit(int(ExitCode.INCOMPLETE))
    bad = res.counts.get(RowStatus.BAD_INPUT.value, 0)
    if bad:  # (as compare: every row is written, and the exit code says some inputs were invalid)
        _err.print(f"{plural(bad, 'problem')} of the sweep {'is' if bad == 1 else 'are'} invalid (status 'bad input', "
                   "the reason in each row's message column)", highlight=False)
        raise typer.Exit(int(ExitCode.BAD_INPUT))


def sweep_report_cmd(
    folder: Annotated[Path, typer.Argument(parser=in_path, metavar="FOLDER", help="A sweep's output folder (or its results.parquet).")],
    out: Annotated[Optional[Path], typer.Option("--out", "-o", parser=out_path, metavar="PATH", help="Where to write report.md and the figures "
                                                "(default: <folder>/report).")] = None,
    figures: Annotated[bool, typer.Option("--figures/--no-figures", help="Draw the figures.")] = True,
):
    """Summarise a sweep: counts by status, medians, worst cases and the designer's figures."""
    from ..sweep.report import sweep_report

    if not folder.exists():
        usage(f"{folder}: expected a sweep output folder, found nothing at this path")
    target = out if out is not None else (folder if folder.is_dir() else folder.parent) / "report"
    check_out_dir(target, "--out")
    try:
        rep = sweep_report(folder, target, figures=figures)
    except FileNotFoundError as e:  # a folder that is not a sweep's (read before anything is written)
        usage(str(e))
    _out.print("\n".join(printable(line) for line in rep.text.splitlines()), markup=False, highlight=False)
    for v in rep.files.values():
        _out.print(f"wrote {_safe(v)}", highlight=False)
    from ..sweep.table import JOURNAL, PARQUET

    if rep.notes.get("missing_columns"):  # (a table trimmed in pandas: its KeyError was an internal error)
        cols = rep.notes["missing_columns"]
        _err.print(f"[yellow]note[/]: {_safe(folder)} lacks {plural(len(cols), 'column')} of a sweep's table "
                   f"({_safe(', '.join(cols[:6]))}{', ...' if len(cols) > 6 else ''}): counted as empty", highlight=False)
    unread, why = rep.notes.get("unread") or [], rep.notes.get("damaged")
    if why:
        _err.print(f"[yellow]note[/]: {_safe(folder / PARQUET)}: {_safe(why)}; the report is made from "
                   f"{JOURNAL}, the rows it was written from ('coplan sweep' into this folder writes it again)", highlight=False)
    if unread:
        _err.print(f"[yellow]note[/]: {_safe(folder / JOURNAL)}: {plural(len(unread), 'line')} "
                   f"({', '.join(map(str, unread[:5]))}{', ...' if len(unread) > 5 else ''}) "
                   f"{'is' if len(unread) == 1 else 'are'} no complete row (torn by a crash, or damaged): not in the report; "
                   f"run the sweep again into this folder to solve {'it' if len(unread) == 1 else 'them'}", highlight=False)


def _check_scheduler(address: str) -> None:
    """Before any work: ``--scheduler`` must be a Dask address (``tcp://host:port``, ``host:port``,
    ``tls://...``); a malformed one was an internal error (exit 1) from deep in Dask."""
    from distributed.comm.addressing import parse_address, parse_host_port
    from distributed.comm.registry import get_backend

    try:
        proto, loc = parse_address(address)
        get_backend(proto)
        if proto in ("tcp", "tls"):
            parse_host_port(loc)
    except ValueError as e:
        usage(f"--scheduler {address!r}: expected a Dask scheduler address such as tcp://10.0.0.5:8786, found {e}")
