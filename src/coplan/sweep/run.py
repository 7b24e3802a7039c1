"""Run a sweep on Dask: one task per problem, one table row per task, resume by key.

:func:`run_sweep` starts a ``LocalCluster`` of worker *processes* with one thread each (CasADi
is not thread-safe) or connects to an existing scheduler (``--scheduler tcp://host:8786``).
Each problem is one task running :func:`solve_item` in a worker: it never raises -- a bad
problem is a row with exit class "bad input", an internal error a row with its message.

Time limits: the planner gets the sweep's ``time_limit`` as its clock limit (the anytime
planner then returns its verified incumbent); a watchdog thread in the worker stops the whole
worker process should the solve not return (a hung native call) within ``hard_limit(time_limit)``
seconds of CPU (or four times that of wall-clock time), after leaving a marker so the retried
task writes a "timeout" row at once.

Worker deaths: the scheduler re-runs a task whose worker died (``retries`` extra attempts:
Dask's ``distributed.scheduler.allowed-failures``, set for the local cluster); a task whose
workers died on every attempt is a row with status "lost" (re-run on resume).

Resume: a row is journaled (:class:`coplan.sweep.table.RowJournal`) as soon as it arrives;
a re-run of the same sweep into the same folder skips every key already there.
"""

from __future__ import annotations

import json
import logging
import os
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from ..kinds import ExitCode, GantryMode, PlannerKind, RowStatus, SweepBase
from ..errors import Issue, plural
from ..provenance import software_record
from ..output import OutputError, signals_deferred
from ..workers import workers_issue
from .cluster import Interrupt, close_cluster, completed, connect, default_workers, WorkerWatch
from .columns import exit_class, problem_columns, result_columns
from .params import check_value
from .spec import SweepError, SweepItem, SweepSpec, is_row_text, load_sweep
from .table import META, RowJournal, import_arrow, read_rows, read_sweep_record, write_table

__all__ = ["SweepOutcome", "run_sweep", "solve_item", "hard_limit", "exit_class", "Watchdog", "SNAPSHOT_SECONDS", "default_workers", "lost_reason"]

SNAPSHOT_SECONDS = 5.0  # how often results.parquet is rewritten while the sweep runs
STATE = ".sweep-state"
LOCK = ".sweep.lock"  # held (flock) by the sweep writing into the folder: a second one is refused


class FolderBusy(OutputError):
    """The output folder is being written by another sweep (a usage error: choose another ``--out``)."""

    exit_code = ExitCode.USAGE


class _FolderLock:
    """An exclusive lock on a sweep's output folder (``fcntl.flock`` on :data:`LOCK`, which the
    system releases when the process ends, however it ends): two sweeps into one folder solved
    every problem twice and journaled each row twice. Where the platform has no ``flock``, none."""

    def __init__(self, out: Path, spec: SweepSpec):
        self.out, self.spec, self.fd = out, spec, None

    def acquire(self) -> None:
        try:
            import fcntl
        except ImportError:  # (not on this platform)
            return
        if self.fd is not None:
            return
        fd = os.open(self.out / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            who = os.read(fd, 200).decode("utf-8", "replace").strip() or "another process"
            os.close(fd)
            raise FolderBusy(f"{self.out}: expected an output folder no other coplan sweep is writing to, found it being "
                             f"written by {who}; wait for it to finish (a re-run then skips every row it did), or "
                             f"choose another --out") from None
        os.ftruncate(fd, 0)
        os.write(fd, f"coplan sweep {self.spec.name!r}, process {os.getpid()}".encode())
        self.fd = fd

    def release(self) -> None:
        if self.fd is not None:  # (closing releases it; the file stays: removed, a sweep that had opened it
            os.close(self.fd)    # could lock it while a third locked a new one -- two writing the folder)
            self.fd = None


def hard_limit(time_limit: float) -> float:
    """CPU seconds after which the watchdog stops a worker whose solve has not returned (four
    times as many wall-clock seconds also stop it)."""
    return 1.5 * time_limit + 30.0


@dataclass
class SweepOutcome:
    """What :func:`run_sweep` did: rows written now, rows skipped (already done), counts by status;
    ``others``: the rows of other runs of the sweep already in the folder (another planner, time
    limit or options), which its table keeps beside these."""

    out: Path
    total: int
    skipped: int
    done: int = 0
    counts: dict[str, int] = field(default_factory=dict)
    files: dict[str, Path] = field(default_factory=dict)
    elapsed: float = 0.0
    workers: int = 0
    interrupted: bool = False
    others: dict[str, str] = field(default_factory=dict)  # key -> planner: rows of other runs in the folder (kept)
    other_planners: list[str] = field(default_factory=list)  # of those rows, planners this run does not use
    unplanned: int = 0  # with keep_plans: rows already done whose plan is not in plans/ (not planned again)
    snapshot_error: str | None = None  # why a snapshot of the table could not be written meanwhile (the sweep went on)


# ---------------------------------------------------------------------- in the worker
def _worker_name() -> str:
    try:
        from distributed import get_worker

        return str(get_worker().name)
    except (ImportError, ValueError):  # not inside a Dask worker (a direct call)
        return f"pid{os.getpid()}"


def _base_row(item: SweepItem) -> dict[str, Any]:
    """The row's columns known before the problem is read: the design's parameters (a problem
    that cannot be made or read keeps them: its row is still that design's), replaced by the
    problem's own figures once it is read (:func:`coplan.sweep.columns.problem_columns`)."""
    p = item.params
    links = p.get("links")
    links = (links, links) if isinstance(links, (int, float)) else links
    generated = "problem" not in p  # (base files: the file's figures only)
    return {
        "key": item.key, "index": item.index, "source": item.source, "planner": item.planner,
        "params": json.dumps(p, sort_keys=True, default=str), "options": json.dumps(item.options, sort_keys=True, default=str),
        "seed": p.get("seed", 0 if generated else None),  # (a generator's default seed is 0)
        "density": p.get("density"), "time_limit": item.time_limit, "worker": _worker_name(),
        "n_arms": p.get("n_arms"), "n_fruits": p.get("n_fruits"), "spacing": p.get("spacing"), "row_length": item.row_length,
        "link_1": links[0] if links else None, "link_2": links[1] if links else None, "link_radius": p.get("link_radius"),
        "gantry": p.get("gantry"),
    }


def _fail_row(row: dict[str, Any], status: RowStatus, code: ExitCode, message: str) -> dict[str, Any]:
    row.update(status=status.value, exit_code=int(code), exit_class=exit_class(code), message=message, finished=time.time())
    return row


class Watchdog:
    """Stops this worker process when the solve has used ``seconds`` of CPU time, or
    ``wall_factor`` x ``seconds`` of wall-clock time, without returning; leaves a marker first.

    CPU time, not the clock, is the main measure: on a shared machine (or under ``nice``) a
    solve that is merely starved of CPU is not hung; a native call spinning forever uses CPU,
    one blocked forever is caught by the wall-clock bound.
    """

    POLL = 0.25  # s between checks

    def __init__(self, seconds: float, marker: Path | None, wall_factor: float = 4.0):
        self.marker, self.seconds, self.wall = marker, float(seconds), float(seconds) * wall_factor
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._watch, name="coplan-sweep-watchdog", daemon=True)

    def _watch(self) -> None:
        cpu0, wall0 = time.process_time(), time.monotonic()
        while not self._stop.wait(min(self.POLL, self.seconds)):
            if time.process_time() - cpu0 > self.seconds or time.monotonic() - wall0 > self.wall:
                self._expire()

    def _expire(self) -> None:
        if self.marker is not None:
            try:
                self.marker.parent.mkdir(parents=True, exist_ok=True)
                self.marker.write_text(str(time.time()))
            except OSError:  # no shared folder (a remote cluster): the task ends as "lost"
                pass
        os._exit(int(ExitCode.SOLVER_FAILED))

    def __enter__(self):
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._stop.set()
        return False


def solve_item(item: SweepItem, state_dir: str | None = None, keep_plan: bool = False) -> tuple[dict[str, Any], dict | None]:
    """Solve one sweep problem in this process: ``(row, plan dict or None)``. Never raises for a
    bad problem or a solver error: the row carries the status, exit class and message."""
    import yaml

    from ..errors import CoplanError, InputError
    from ..planners.optimal.options import parse_options
    from ..pipeline import solve
    from ..problem.load import parse_problem

    row = _base_row(item)
    if item.error is not None:
        return _fail_row(row, RowStatus.BAD_INPUT, ExitCode.BAD_INPUT, item.error), None
    marker = Path(state_dir) / "timeouts" / item.key if state_dir else None
    if marker is not None and marker.exists():
        return _timeout_row(row, item), None
    t0 = time.perf_counter()
    plan = None
    try:
        with Watchdog(hard_limit(item.time_limit), marker):
            problem = parse_problem(item.problem_text or "", item.source)
            row.update(problem_columns(problem, item))
            options = None
            if problem.gantry is not None:  # a row: the cell planner at each stop, or on the move (no cell planner)
                mode = GantryMode(item.params.get("gantry", GantryMode.STOP_AND_GO.value))
                if mode != GantryMode.CONTINUOUS and item.planner == PlannerKind.HEURISTIC.value:  # (was 'internal error')
                    raise InputError([Issue("planner", "expected coordinated or optimal for a row on a gantry stop and go "
                                                       "(each stop's cell planner; the course's heuristic plans a stationary "
                                                       "cell), found heuristic")], item.source)
                res = solve(problem, planner=None if mode == GantryMode.CONTINUOUS else item.planner, gantry=mode)
            else:
                if item.planner != PlannerKind.HEURISTIC.value:
                    options = parse_options(yaml.safe_dump(dict(item.options, time_limit=item.time_limit)), "sweep options")
                res = solve(problem, planner=item.planner, options=options)
        row.update(result_columns(res, row))
        plan = res.plan.to_dict() if keep_plan else None
    except InputError as e:
        _fail_row(row, RowStatus.BAD_INPUT, ExitCode.BAD_INPUT, str(e))
    except CoplanError as e:
        _fail_row(row, RowStatus.ERROR, ExitCode.INTERNAL, f"{type(e).__name__}: {e}")
    except Exception as e:  # noqa: BLE001 -- one problem's bug is a row with its message, never the end of the sweep
        _fail_row(row, RowStatus.ERROR, ExitCode.INTERNAL, f"internal error ({type(e).__name__}): {e}")
    if row.get("solve_time") is None:
        row["solve_time"] = time.perf_counter() - t0
    row["finished"] = time.time()
    return row, plan


# ---------------------------------------------------------------------- the driver
def lost_reason(err: BaseException, attempts: int | None) -> str:
    """Why Dask returned no row: every attempt's worker died (``KilledWorker``), or the task
    was cancelled -- the connection to the scheduler lost, the client closed -- or another error."""
    name, text = type(err).__name__, str(err)
    if name == "KilledWorker":
        return (f"the worker process died on all {attempts} attempts ({name}: {text})" if attempts is not None else
                f"the worker process died on every attempt the Dask scheduler allows (its distributed.scheduler."
                f"allowed-failures: a sweep's retries apply to its own local cluster) ({name}: {text})")
    if "cancel" in name.lower() or "cancel" in text.lower():
        why = ("the connection to the Dask scheduler was lost" if "connection-lost" in text or "connection lost" in text.lower()
               else "Dask cancelled the task")
        return f"{why} before it finished ({name}: {text}); run the same command again to solve it"
    return f"Dask returned no result ({name}: {text}); run the same command again to solve it"


def _timeout_row(row: dict[str, Any], item: SweepItem) -> dict[str, Any]:
    """The row of a solve the watchdog stopped: its problem's columns, and as its ``solve_time``
    the CPU limit it ran past (it had none, nor its problem's columns: the solve-time figure and
    the worst cases left the slowest solves out)."""
    from ..problem.load import parse_problem

    limit = hard_limit(item.time_limit)
    try:
        row.update(problem_columns(parse_problem(item.problem_text or "", item.source), item))
    except Exception:  # noqa: BLE001 -- the columns are a courtesy: the row is the timeout's whatever its problem
        pass
    row["solve_time"] = limit
    return _fail_row(row, RowStatus.TIMEOUT, ExitCode.SOLVER_FAILED,
                     f"the solve did not return within the hard limit ({limit:g} s of CPU, {4 * limit:g} s of "
                     f"wall-clock time; its solve_time is that limit, which it ran past); worker stopped")


def _lost_row(item: SweepItem, sweep: str, attempts: int | None, err: BaseException, state: Path | None = None) -> dict[str, Any]:
    """The row of a task Dask returned nothing for: a timeout where the watchdog left its marker
    (with ``retries: 0`` the stopped solve was said lost), else lost. ``attempts``: None where an
    external scheduler decides how many (its ``allowed-failures``)."""
    row = _base_row(item)
    row.update(sweep=sweep, worker=None)
    if state is not None and (state / "timeouts" / item.key).exists():
        return _timeout_row(row, item)
    return _fail_row(row, RowStatus.LOST, ExitCode.INCOMPLETE, lost_reason(err, attempts))


def _write_json(path: Path, doc: dict) -> None:
    tmp = path.with_name(f".{path.name}.tmp")
    tmp.write_text(json.dumps(doc, indent=2, default=str))
    os.replace(tmp, path)


#: Row statuses that come with no plan (nothing for ``--keep-plans`` to have written).
_NO_PLAN = (RowStatus.BAD_INPUT.value, RowStatus.ERROR.value, RowStatus.TIMEOUT.value)


def _checked_call(spec, workers, time_limit, scheduler=None) -> tuple[SweepSpec, int | None, float | None]:
    """:func:`run_sweep`'s arguments as the command line checks them (a sweep file's path is
    loaded): a bad one raises before any work (a workers of 0 ran on the default, a time limit
    of -1 wrote a 'bad input' row per problem, workers beside a scheduler were ignored)."""
    if workers is not None and scheduler is not None:
        raise ValueError("run_sweep(): workers: expected either workers (a local cluster) or scheduler (an existing one), "
                         "found both")
    if isinstance(spec, (str, os.PathLike)):
        spec = load_sweep(spec)
    elif not isinstance(spec, SweepSpec):
        raise TypeError(f"run_sweep(): spec: expected a SweepSpec (coplan.sweep.load_sweep) or a sweep file's path, "
                        f"found {type(spec).__name__}")
    if workers is not None:
        msg = workers_issue(workers)
        if msg is not None:
            raise ValueError(f"run_sweep(): workers: {msg}")
        workers = None if isinstance(workers, str) else int(workers)  # (auto: the default)
    if time_limit is not None and check_value("positive", time_limit) is not None:  # (the sweep file's rule)
        raise ValueError(f"run_sweep(): time_limit: expected a positive, finite number of seconds per problem, "
                         f"or None (the sweep file's), found {time_limit!r}")
    return spec, workers, time_limit


def run_sweep(
    spec: SweepSpec | str | Path,
    out: str | Path,
    workers: int | None = None,
    scheduler: str | None = None,
    planner: PlannerKind | str | None = None,
    time_limit: float | None = None,
    csv: bool = False,
    keep_plans: bool = False,
    on_row: Callable[[dict, SweepOutcome], None] | None = None,
    on_start: Callable[[SweepOutcome], None] | None = None,
    task: Callable = solve_item,
    on_note: Callable[[str], None] | None = None,
) -> SweepOutcome:
    """Run ``spec`` into the folder ``out`` (``rows.jsonl``, ``results.parquet``, ``sweep.json``;
    ``results.csv`` with ``csv``; with ``keep_plans`` every plan and its problem as
    ``plans/<key>.json`` and ``plans/<key>.yaml``, for ``coplan verify``).

    Rows already in ``out`` (same key) are skipped. ``on_start(outcome)`` is called once the
    work is known, ``on_row(row, outcome)`` after each row is journaled. ``task`` is the
    function run per problem (:func:`solve_item`; tests wrap it). ``on_note(message)``: what the
    user should know meanwhile (a ``scheduler`` with no workers). Ctrl-C stops the sweep:
    every finished row is kept, the table written, and ``KeyboardInterrupt`` re-raised.
    """
    t0 = time.perf_counter()
    spec, workers, time_limit = _checked_call(spec, workers, time_limit, scheduler)
    out = Path(out)
    other = _folder_sweep(out) if (out / META).exists() else spec.name
    if other != spec.name:
        raise SweepError([Issue("name", f"expected the output folder of sweep {spec.name!r} or a new folder, found {out} "
                                        f"holding sweep {other!r}; choose another --out")], spec.source)
    lock = _FolderLock(out, spec)
    try:  # (whatever stops it before the sweep's own try below: the folder's lock released)
        if out.is_dir():  # (before reading what is done: another sweep writing here would change it)
            lock.acquire()
        items = spec.items(planner, time_limit)
        rows = sorted({Path(it.source).name for it in items if is_row_text(it.problem_text)}) \
            if spec.base == SweepBase.FILES and spec.gives_options else []
        if rows and on_note is not None:  # (its solver options were dropped for them without a word)
            on_note(f"{plural(len(rows), 'problem file is a row', 'problem files are rows')} ({', '.join(rows[:3])}"
                    f"{', ...' if len(rows) > 3 else ''}): solved as coplan solve ROW solves it, without the sweep's "
                    "solver options (they apply to its cells)")
        previous = {r["key"]: r for r in read_rows(out)}
        done = {k for k, r in previous.items() if r["status"] != RowStatus.LOST.value}
        todo = [it for it in items if it.key not in done]
        n_workers = workers or default_workers()
        outcome = SweepOutcome(out=out, total=len(items), skipped=len(items) - len(todo), workers=n_workers)
        keys = {it.key for it in items}
        positions = {it.key: it.index for it in items}
        outcome.others = {k: str(r.get("planner")) for k, r in previous.items() if k not in keys}
        outcome.other_planners = sorted(set(outcome.others.values()) - {str(it.planner) for it in items})
        for it in items:
            if it.key in done:
                s = previous[it.key]["status"]
                outcome.counts[s] = outcome.counts.get(s, 0) + 1
                if keep_plans and s not in _NO_PLAN and not (out / "plans" / f"{it.key}.json").exists():
                    outcome.unplanned += 1
        client = cluster = None
        # (a scheduler that goes away printed the client's tracebacks for every task: each becomes a
        # 'lost' row saying so, which a re-run solves; the level is restored when the sweep ends)
        client_log = logging.getLogger("distributed.client")
        client_level = client_log.level
        if scheduler is not None:
            client_log.setLevel(logging.CRITICAL)
        try:
            if todo:  # (first: a scheduler that cannot be reached leaves nothing behind, not an empty sweep)
                client, cluster = connect(n_workers, scheduler, spec.retries)
        except BaseException:
            client_log.setLevel(client_level)
            raise
        out.mkdir(parents=True, exist_ok=True)
        try:
            lock.acquire()  # (a new folder: made now)
        except BaseException:
            for closing in (client, cluster):
                if closing is not None:
                    closing.close()
            client_log.setLevel(client_level)
            raise
        state = out / STATE
        state.mkdir(exist_ok=True)
        _write_meta(out, spec, len(items), outcome.skipped, planner, time_limit, scheduler, n_workers)
        if on_start is not None:
            on_start(outcome)
        journal = RowJournal(out)
        if keep_plans:
            (out / "plans").mkdir(exist_ok=True)
        import_arrow()  # (before Ctrl-C may stop the sweep: see import_arrow)
    except BaseException:
        lock.release()
        raise
    stop = Interrupt().__enter__()
    try:
        if todo:
            from distributed import as_completed

            by_key = {}
            futures = []
            for it in todo:
                f = client.submit(task, it, str(state.resolve()), keep_plans, key=f"coplan-sweep-{spec.name}-{it.key}", pure=False)
                by_key[f.key] = it
                futures.append(f)
            last = time.monotonic()
            watch = WorkerWatch(client, scheduler, on_note) if scheduler is not None and on_note is not None else None
            for fut in completed(as_completed(futures), stop, idle=watch):
                it = by_key[fut.key]
                plan = None
                try:
                    row, plan = fut.result()
                except Exception as e:  # noqa: BLE001 -- KilledWorker (every attempt died) or a scheduler error: a row
                    row = _lost_row(it, spec.name, None if scheduler is not None else spec.retries + 1, e, state)
                row["sweep"] = spec.name
                journal.append(row)
                if plan is not None:  # coplan verify plans/<key>.yaml plans/<key>.json checks it again
                    _keep_plan(out, it, plan)
                fut.release()
                outcome.done += 1
                outcome.counts[row["status"]] = outcome.counts.get(row["status"], 0) + 1
                if on_row is not None:
                    on_row(row, outcome)
                if time.monotonic() - last > SNAPSHOT_SECONDS:
                    try:  # (results.csv open in a spreadsheet on Windows stopped the sweep part-way: exit 8)
                        write_table(out, csv=csv, positions=positions)
                    except OSError as e:  # the rows are in the journal; the table is written again at the end
                        outcome.snapshot_error = f"{e.strerror or e}: {e.filename}"
                    last = time.monotonic()
    except KeyboardInterrupt:
        outcome.interrupted = True
        raise
    finally:
        stop.__exit__()
        try:
            with signals_deferred():  # (a second Ctrl-C here left no results.parquet: the rows' table is written whole first)
                journal.close()
                outcome.files = write_table(out, csv=csv, positions=positions)
        except KeyboardInterrupt:  # (held until the table was written, then answered)
            outcome.interrupted = True
            raise
        finally:
            outcome.elapsed = time.perf_counter() - t0
            close_cluster(client, cluster, outcome.interrupted, client_log, client_level, lock)
    return outcome


def _folder_sweep(out: Path) -> str:
    """The name of the sweep an output folder's ``sweep.json`` says it holds; a file that is no
    such record (cut short, edited) is a :class:`SweepError` naming it (a JSONDecodeError was an
    internal error)."""
    doc, why = read_sweep_record(out)
    if doc is None:
        raise SweepError([Issue("", f"expected the record of the sweep in this folder (its name, problems and "
                                    f"planner), found a damaged file ({why}); remove it to run the sweep here again "
                                    "(its rows in rows.jsonl are kept and skipped), or choose another --out")], str(out / META))
    return doc["name"]


def _write_meta(out: Path, spec: SweepSpec, problems: int, already: int, planner, time_limit, scheduler, n_workers: int) -> None:
    """``sweep.json``: what the sweep is and how it runs."""
    _write_json(out / META, {
        "name": spec.name, "source": spec.source, "base": spec.base.value, "mode": spec.mode.value,
        "problems": problems, "already_done": already, "planner": (PlannerKind(planner).value if planner else spec.planner.value),
        "time_limit": time_limit if time_limit is not None else spec.time_limit, "retries": spec.retries,
        "vary": {k: v for k, v in spec.vary.items()}, "fixed": spec.fixed, "options": spec.options,
        "scheduler": scheduler or f"LocalCluster({n_workers} worker processes x 1 thread)", "started": time.time(),
        "software": software_record(),
    })


def _keep_plan(out: Path, it, plan: dict) -> None:
    """``plans/<key>.yaml`` (the problem) and ``plans/<key>.json`` (its plan, naming that file
    and its digest, as a plan coplan solve writes does: copied away, it still says which problem
    it solved)."""
    from ..problem.load import text_digest

    (out / "plans" / f"{it.key}.yaml").write_text(it.problem_text or "", encoding="utf-8")
    plan["problem_file"] = {"path": str((out / "plans" / f"{it.key}.yaml").resolve()),
                            "sha256": text_digest(it.problem_text or "")}
    _write_json(out / "plans" / f"{it.key}.json", plan)
