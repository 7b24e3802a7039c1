"""The sweep table: one row per problem, a journal that loses nothing, Parquet (and CSV) snapshots.

Every finished row is appended at once to ``rows.jsonl`` in the output folder (one JSON object
a line, flushed and fsync'd): that journal is what a re-run reads to skip the rows already
done, so a crash or Ctrl-C loses at most the problems still being solved. ``results.parquet``
(and ``results.csv`` on request) is a snapshot of the journal, rewritten atomically (temporary
name, then rename) every few seconds while the sweep runs and at its end, so it is always a
complete, readable file. A torn last line of the journal (a crash mid-write) is ignored.
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path
from typing import Any

from ..errors import InputError, Issue

__all__ = ["SweepTableError", "COLUMNS", "JOURNAL", "PARQUET", "CSV", "RowJournal", "normalise", "read_rows", "read_table", "write_table", "schema"]

JOURNAL = "rows.jsonl"
PARQUET = "results.parquet"
CSV = "results.csv"

# column -> (Arrow type name, meaning); every row has every column (null where not computed)
COLUMNS: dict[str, tuple[str, str]] = {
    "key": ("string", "hash of the problem text + planner + options + time limit"),
    "sweep": ("string", "the sweep's name"),
    "index": ("int64", "position in the sweep"),
    "name": ("string", "the problem's name"),
    "source": ("string", "problem file or generator"),
    "params": ("string", "the varied and fixed parameters, JSON"),
    "seed": ("int64", "generator seed (parameter)"),
    "density": ("float64", "fruit per metre of row (parameter, else fruit / row length)"),
    "n_arms": ("int64", "arms in the problem"),
    "n_fruits": ("int64", "fruit in the problem"),
    "locked_arms": ("string", "arms the screen locks (they can never reach their bins: they harvest nothing), comma-separated"),
    "spacing": ("float64", "mean distance between neighbouring bases, m"),
    "row_length": ("float64", "m of row the cell covers (arms x spacing unless the generator says)"),
    "link_1": ("float64", "first link of the first arm, m"),
    "link_2": ("float64", "second link of the first arm, m"),
    "link_radius": ("float64", "link radius of the first arm, m"),
    "planner": ("string", "heuristic | coordinated | optimal"),
    "options": ("string", "solver options given, JSON"),
    "time_limit": ("float64", "per-problem time limit, s"),
    "status": ("string", "plan status, or bad input / error / timeout / lost"),
    "exit_class": ("string", "the exit class coplan solve would give (ok, bad input, partial, ...)"),
    "exit_code": ("int64", "the exit code coplan solve would give"),
    "reachable": ("int64", "fruit within some arm's reach (screened)"),
    "harvested": ("int64", "fruit harvested"),
    "makespan": ("float64", "time of the last place, s"),
    "lower_bound": ("float64", "no plan can be faster, s"),
    "ratio": ("float64", "makespan / lower bound (a row: / its bound for any carriage motion)"),
    "optimality": ("string", "proven | not proven (optimal planner)"),
    "coordinated_makespan": ("float64", "coordinated planner's makespan, s"),
    "heuristic_makespan": ("float64", "the course's heuristic planner's makespan, s"),
    "heuristic_status": ("string", "the heuristic plan's status"),
    "cycle_worst": ("float64", "worst arm's time per fruit, s"),
    "cycle_mean": ("float64", "mean time per fruit over arms, s"),
    "throughput": ("float64", "fruit per minute (plan.json's metrics.throughput: per second)"),
    "throughput_per_m": ("float64", "fruit per minute per metre of row"),
    "gantry": ("string", "a row on a gantry: the mode asked, stop-and-go | continuous | auto"),
    "gantry_mode": ("string", "a row on a gantry: the mode its plan used (auto: the better kept)"),
    "fruit_per_hour": ("float64", "a row: fruit harvested per hour of row time"),
    "share_harvested": ("float64", "a row: share of the harvestable fruit harvested"),
    "mean_speed": ("float64", "a row on the move: the carriage's mean speed, m/s"),
    "certified_clearance": ("float64", "least certified clearance between links, m"),
    "required_clearance": ("float64", "clearance the task requires (+ margin), m"),
    "verified": ("bool", "the independent verifier passed the plan"),
    "solve_time": ("float64", "wall-clock time of the solve, s"),
    "stopped_by": ("string", "why the planner stopped (optimal: budget, time_limit: the clock, so machine-dependent, ...; "
                             "coordinated: time_limit where its clock limit cut its candidates short)"),
    "worker": ("string", "the worker that solved it"),
    "message": ("string", "why it failed (or the solver's message)"),
    "finished": ("float64", "UNIX time the row was written"),
}



#: A sweep's output folder's record of what it holds and how it last ran (written by the run).
META = "sweep.json"


def read_sweep_record(folder: Path) -> tuple[dict | None, str | None]:
    """The folder's ``sweep.json`` as ``(record, None)``; ``(None, None)`` when there is none;
    ``(None, why)`` when it is no such record (cut short, edited: not an object naming its sweep).
    One reader for the run (which refuses a damaged one) and the report (which says nothing of it)."""
    meta = Path(folder) / META
    if not meta.is_file():
        return None, None
    try:
        doc = json.loads(meta.read_text(encoding="utf-8"))
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as e:
        return None, f"{type(e).__name__}: {e}"
    if not isinstance(doc, dict) or not isinstance(doc.get("name"), str):
        return None, f"{type(doc).__name__} without a sweep name"
    return doc, None

def schema():
    import pyarrow as pa

    types = {"string": pa.string(), "int64": pa.int64(), "float64": pa.float64(), "bool": pa.bool_()}
    return pa.schema([(k, types[t]) for k, (t, _) in COLUMNS.items()])


def _clean(v: Any, kind: str) -> Any:
    if v is None:
        return None
    if kind == "float64":
        x = float(v)
        return x if math.isfinite(x) else None
    if kind == "int64":
        return int(v)
    if kind == "bool":
        return bool(v)
    return str(v)


def normalise(row: dict[str, Any]) -> dict[str, Any]:
    """A row with exactly the table's columns, in order, each value of its column's type."""
    return {k: _clean(row.get(k), t) for k, (t, _) in COLUMNS.items()}


class RowJournal:
    """Append-only ``rows.jsonl``: one row per line, flushed and fsync'd as it is written."""

    def __init__(self, folder: str | Path):
        self.path = Path(folder) / JOURNAL
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._fh = None

    def append(self, row: dict[str, Any]) -> None:
        if self._fh is None:
            self._repair()
            self._fh = open(self.path, "a", encoding="utf-8")
        self._fh.write(json.dumps(normalise(row), allow_nan=False) + "\n")
        self._fh.flush()
        os.fsync(self._fh.fileno())

    def _repair(self) -> None:
        """Cut a torn last line (a crash mid-write) so the next row starts on its own line."""
        if not self.path.exists():
            return
        data = self.path.read_bytes()
        if data and not data.endswith(b"\n"):
            keep = data.rfind(b"\n") + 1
            with open(self.path, "r+b") as fh:
                fh.truncate(keep)

    def close(self) -> None:
        if self._fh is not None:
            self._fh.close()
            self._fh = None


class SweepTableError(InputError):
    kind = "sweep table"


def read_rows(folder: str | Path, unread: list[int] | None = None) -> list[dict[str, Any]]:
    """Every complete row in the journal, the last row of each key winning; ``unread`` (a list)
    receives the line numbers of lines that are no complete row (torn by a crash, or damaged)."""
    path = Path(folder) / JOURNAL
    if not path.exists():
        return []
    rows: dict[str, dict] = {}
    with open(path, encoding="utf-8", errors="replace") as fh:
        for n, line in enumerate(fh, start=1):
            if not line.endswith("\n"):
                if unread is not None and line.strip():
                    unread.append(n)
                break  # a torn last line: that row was not finished
            try:
                row = json.loads(line)
            except json.JSONDecodeError:
                row = None
            if isinstance(row, dict) and isinstance(row.get("key"), str):
                try:
                    rows[row["key"]] = normalise(row)
                    continue
                except (TypeError, ValueError, OverflowError):  # valid JSON, a value of the wrong type ("exit_code": "three")
                    pass
            if unread is not None and line.strip():
                unread.append(n)
    return sorted(rows.values(), key=_table_order)


def _table_order(row: dict[str, Any]):
    """A table's rows in order: by sweep, then by place in it."""
    return row["sweep"] or "", row["index"] if row["index"] is not None else 0


def _atomic(path: Path, write) -> Path:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        write(tmp)
        try:
            os.replace(tmp, path)
        except OSError as e:  # (it named the hidden temporary file: the file the user has open is this one)
            hint = " (open in another program?)" if isinstance(e, PermissionError) else ""
            raise OSError(e.errno, f"{e.strerror or e}{hint}", str(path)) from None
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def import_arrow() -> None:
    """Import the pyarrow modules :func:`write_table` uses, now. A sweep calls it before its work
    starts: imported lazily at the first snapshot, a Ctrl-C that came during the import left
    pyarrow half imported, and the table written after it failed ("module 'pyarrow' has no
    attribute 'lib'"): an internal error, exit 1, instead of the interrupted sweep's 130."""
    import importlib

    for name in ("pyarrow", "pyarrow.csv", "pyarrow.parquet"):
        importlib.import_module(name)


def write_table(folder: str | Path, rows: list[dict[str, Any]] | None = None, csv: bool = False,
                positions: dict[str, int] | None = None) -> dict[str, Path]:
    """Write ``results.parquet`` (and ``results.csv``: with ``csv``, or when the folder has one
    already, which would otherwise disagree with the table) from ``rows`` (default: the journal).
    ``positions`` (key -> index): the rows of the sweep now run take their place in it, also
    those done by an earlier run of a smaller grid (which kept that grid's: 0, 1, 2, 2, 3, 5)."""
    import pyarrow as pa
    import pyarrow.csv as pacsv
    import pyarrow.parquet as pq

    folder = Path(folder)
    rows = read_rows(folder) if rows is None else [normalise(r) for r in rows]
    if positions:
        rows = sorted(({**r, "index": positions.get(r["key"], r["index"])} for r in rows), key=_table_order)
    table = pa.Table.from_pylist(rows, schema=schema())
    out = {"parquet": _atomic(folder / PARQUET, lambda p: pq.write_table(table, p))}
    if csv or (folder / CSV).exists():
        out["csv"] = _atomic(folder / CSV, lambda p: pacsv.write_csv(table, p))
    return out


def read_table(folder_or_file: str | Path, notes: dict | None = None):
    """The sweep table as a ``pyarrow.Table``: ``results.parquet`` of a folder (or the file
    given); when the folder has only a journal (a sweep still running), or its results.parquet
    does not read, the journal's rows. ``notes`` (a dict) receives, for a folder, ``unread``:
    the journal's line numbers that are no complete row, and ``damaged``: why results.parquet
    did not read, if it did not."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    def parquet(path: Path):
        try:
            return pq.read_table(path)  # (its footer is checked on opening: a cut-short file is refused there)
        except (pa.ArrowException, OSError) as e:
            raise SweepTableError([Issue("", f"expected a sweep's results table (Parquet), found a damaged or other "
                                             f"file ({str(e).splitlines()[0] if str(e) else type(e).__name__})")], str(path)) from None

    p = Path(folder_or_file)
    if p.is_file():
        return _checked(parquet(p), p, notes)
    if not (p / PARQUET).exists() and not (p / JOURNAL).exists():
        if (p / META).is_file():  # (a sweep stopped before its first problem was done: "a folder with neither")
            raise FileNotFoundError(f"{p}: expected a sweep with finished problems, found a sweep that has none yet "
                                    f"(stopped before its first was done: run it again into this folder to go on)")
        raise FileNotFoundError(f"{p}: expected a sweep's output folder (with {PARQUET} or {JOURNAL}), found a folder with neither")
    unread: list[int] = []
    rows = read_rows(p, unread)
    if notes is not None:
        notes["unread"] = unread
    if (p / PARQUET).exists():
        try:
            t = parquet(p / PARQUET)
        except SweepTableError as e:
            if not rows:
                raise
            t = None  # (damaged: the journal it was written from has the rows)
            if notes is not None:
                notes["damaged"] = e.issues[0].message
        if t is not None and t.num_rows >= len(rows):
            return _checked(t, p / PARQUET, notes)
    return pa.Table.from_pylist(rows, schema=schema())


def _checked(t, path: Path, notes: dict | None = None):
    """``t`` as a sweep table: it must have the ``key`` and ``status`` columns (a table written
    by coplan, or trimmed in pandas; another Parquet file stopped the report with a KeyError);
    a column it lacks is added empty, and named in ``notes["missing_columns"]``."""
    import pyarrow as pa

    want = schema()
    core = [c for c in ("key", "status") if c not in t.column_names]
    if core:
        raise SweepTableError([Issue("", f"expected a sweep's results table (coplan sweep's columns), found a Parquet "
                                         f"table without {' and '.join(core)} (its columns: "
                                         f"{', '.join(t.column_names[:6])}{', ...' if t.num_columns > 6 else ''})")],
                              str(path))
    missing = [f for f in want if f.name not in t.column_names]
    for f in missing:
        t = t.append_column(f, pa.nulls(t.num_rows, f.type))
    if missing and notes is not None:
        notes["missing_columns"] = [f.name for f in missing]
    for f in want:  # (columns of another type: cast where the values allow, else said)
        i = t.schema.get_field_index(f.name)
        if not t.schema.field(i).type.equals(f.type):
            try:
                t = t.set_column(i, f, t.column(i).cast(f.type))
            except (pa.ArrowException, ValueError) as e:
                raise SweepTableError([Issue("", f"expected a sweep's results table, found column {f.name} of type "
                                                 f"{t.schema.field(i).type}, not {f.type} "
                                                 f"({str(e).splitlines()[0] if str(e) else type(e).__name__})")],
                                      str(path)) from None
    return t
