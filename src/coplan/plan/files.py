"""Reading plan files: :func:`load_plan` checks a ``plan.json`` (every problem named by its key
path) or the ``plan.csv`` replay coplan writes beside it, and takes the full-precision samples of
the ``plan.npz`` saved beside either where it holds the same plan (:func:`exact_samples`)."""

from __future__ import annotations

import difflib
import json
import math
import os
import re
import zipfile
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import Issue, PlanFileError, coplan_file_kind, special_file
from ..kinds import EventKind, GantryMode, PlannerKind, PlanStatus
from ..plancsv import csv_planner, read_csv_samples
from .model import (MAX_PLAN_ANGLE, MAX_PLAN_BYTES, MAX_PLAN_COORD, PLAN_FORMAT, TIME_RESOLUTION, Event, Plan, grid_step,
                    motion_digest)

__all__ = ["load_plan", "plan_from_dict", "exact_samples", "time_grid_issues"]


def exact_samples(plan: Plan, path: str | Path) -> Plan:
    """``plan`` (read from ``path``, a ``plan.json`` or ``plan.csv``) with the full-precision samples of the
    ``plan.npz`` saved beside it, where that file holds this plan's samples (the same times,
    arms and carriage, each value within the JSON's 1e-7 rounding); else ``plan`` as it is.
    What a resampling takes: rounding to 1e-7 rad is below 1e-4 of a limit in a 100 Hz
    difference, but a finer grid's differences would magnify it."""
    npz = Path(path).with_suffix(".npz")
    try:
        with np.load(npz, allow_pickle=False) as z:
            keys = set(z.files)
            if keys != {"time"} | {f"q_{a}" for a in plan.q} | ({"gantry_x"} if plan.gantry_x is not None else set()):
                return plan
            arrays = {k: np.asarray(z[k], float) for k in keys}
    except (OSError, ValueError, KeyError, EOFError, zipfile.BadZipFile):
        return plan
    mine = {"time": plan.time} | {f"q_{a}": q for a, q in plan.q.items()} | (
        {"gantry_x": plan.gantry_x} if plan.gantry_x is not None else {})
    if any(arrays[k].shape != np.shape(v) or not np.allclose(arrays[k], v, rtol=0.0, atol=1.01e-7) for k, v in mine.items()):
        return plan
    return replace(plan, time=arrays["time"], q={a: arrays[f"q_{a}"] for a in plan.q}, gantry_x=arrays.get("gantry_x"))


def load_plan(path: str | Path) -> Plan:
    """Load and check a ``plan.json``, or the ``plan.csv`` replay coplan writes beside it (joint
    samples only: no events, see :mod:`coplan.plancsv`). Raises :class:`PlanFileError` listing
    every problem; a file over :data:`MAX_PLAN_BYTES` is refused before it is read. Where the
    ``plan.npz`` saved beside it holds the same samples at full precision, those are taken
    (:func:`exact_samples`: what a resampling at a finer rate needs)."""
    if isinstance(path, bool) or not isinstance(path, (str, os.PathLike)):  # (5 gave os's bare TypeError)
        raise TypeError(f"path: expected the path of a plan file (str or Path), found {type(path).__name__} {path!r}"[:300])
    p = Path(path)
    src = str(p)
    if not p.exists():
        raise PlanFileError([Issue("", "expected an existing plan file, found no file at this path")], src)
    raw = None
    if not p.is_file():
        found = "a directory" if p.is_dir() else special_file(p)
        if found is not None:
            raise PlanFileError([Issue("", f"expected a plan file, found {found}")], src)
        # a pipe (``coplan verify P /dev/stdin``, as a problem may come): read up to the cap, its kind from its text
        try:
            with open(p, "rb") as fh:
                raw = fh.read(MAX_PLAN_BYTES + 1)
        except OSError as e:
            raise PlanFileError([Issue("", f"expected a readable plan, found an error: {e.strerror}")], src) from None
        if len(raw) > MAX_PLAN_BYTES:
            raise PlanFileError([Issue("", f"expected a plan of at most {MAX_PLAN_BYTES} bytes, found more")], src)
        if raw.removeprefix(b"\xef\xbb\xbf").lstrip().startswith(b"t,"):
            return _plan_from_csv(raw, src)
    else:
        size = p.stat().st_size
        if size > MAX_PLAN_BYTES:
            raise PlanFileError([Issue("", f"expected a plan file of at most {MAX_PLAN_BYTES} bytes ({MAX_PLAN_BYTES >> 20} MiB, "
                                           f"about 2 h of three arms at 100 Hz), found {size} bytes; it was not read")], src)
        if p.suffix.lower() == ".csv":
            return exact_samples(_plan_from_csv(p.read_bytes(), src), p)
    try:
        text = raw.decode("utf-8") if raw is not None else p.read_text(encoding="utf-8")
        text = text.removeprefix("\ufeff")  # (a byte-order mark, as an editor on Windows writes: read as a CSV's is)
        if not text.strip():
            raise PlanFileError([Issue("", "expected a JSON plan (an object with keys format, problem, time, arms, events), "
                                           "found an empty file")], src)
        data = json.loads(text, object_pairs_hook=_unique_keys)  # (NaN, Infinity: named at their key path below)
    except _StrictJSON as e:  # (JSON keeps a repeated key's last value silently, as a problem file never does)
        raise PlanFileError([Issue("", str(e))], src) from None
    except json.JSONDecodeError as e:
        other = re.search(r"^format:\s*['\"]?(coplan\.(\w+)/\w+)", text, re.MULTILINE)  # a feed or other coplan YAML file
        looks = (p.suffix.lower() in (".yaml", ".yml") or any(text.lstrip().startswith(k) for k in ("name:", "arms:", "task:", "gantry:"))
                 or "\narms:" in text)
        if other:
            raise PlanFileError([Issue("", f"expected a plan file (plan.json or plan.csv), found a coplan {other.group(2)} file "
                                           f"(format {other.group(1)!r}); were the arguments swapped?", 1)], src) from None
        export = ("an export's events" if re.match(r"\s*events:", text) else
                  "a JointTrajectory (one arm" if re.search(r"(?m)^joint_names:", text) else None)
        if export:  # (a `coplan export --format yaml` file was "a problem file (YAML): swapped?")
            raise PlanFileError([Issue("", f"expected a plan file (plan.json or plan.csv), found {export} of a `coplan export "
                                           f"--format yaml`{')' if 'arm' in export else ''}: verify the plan.json it was "
                                           f"exported from, or its CSV export", 1)], src) from None
        hint = "; it looks like a problem file (YAML): were the problem and the plan swapped?" if looks else ""
        body = text.rstrip()
        if not hint and body.startswith("{") and not body.endswith("}") and (
                e.pos >= len(body) - 200 or e.msg.startswith("Unterminated string")):  # the error where the text ends: cut short
            hint = (f"; the file ends at character {len(text)} with the JSON unfinished: it looks cut short "
                    f"(a copy or a write that did not finish); write the plan again")
        raise PlanFileError([Issue("", f"expected JSON, found a syntax error: {e.msg} (column {e.colno}){hint}", e.lineno)], src) from None
    except UnicodeDecodeError as e:
        if p.suffix.lower() == ".npz" or (raw if raw is not None else p.read_bytes())[:2] == b"PK":
            raise PlanFileError([Issue("", "expected a plan file (plan.json or plan.csv), found a NumPy .npz archive (the "
                                           "full-precision samples coplan writes beside plan.json, which takes them): give "
                                           "the plan.json beside it")], src) from None
        raise PlanFileError([Issue("", f"expected UTF-8 JSON, found an undecodable byte at offset {e.start}")], src) from None
    plan = plan_from_dict(data, src)  # (its motion recorded as the one its verdict is about)
    if raw is not None:  # (a pipe: no plan.npz beside it)
        return plan
    exact = exact_samples(plan, p)
    return exact if exact is plan else _as_judged(exact)  # (the npz's samples: recorded again, once)


#: the keys of a plan file (coplan.plan/1); others may be there (a writer's own), unread
PLAN_KEYS = ("format", "problem", "planner", "status", "time", "arms", "events", "allocation", "unreachable", "metrics",
             "solver", "verification", "gantry", "software", "problem_file")


class _StrictJSON(ValueError):
    """JSON that :func:`json.loads` takes and a plan file may not hold (a repeated key)."""


def _unique_keys(pairs: list) -> dict:
    seen: set = set()
    for k, _ in pairs:
        if k in seen:
            raise _StrictJSON(f"expected every key once in an object, found {k!r} twice (JSON would keep the last "
                              f"silently; a plan file is refused instead, as a problem file is)")
        seen.add(k)
    return dict(pairs)


def _as_judged(plan: Plan) -> Plan:
    """``plan`` with its motion recorded as the one its file's verdict is about (when it has
    one): edited after it was read, it is saved ``unverified`` (it was saved with that verdict)."""
    plan.verified_motion = motion_digest(plan) if plan.verification is not None else None
    return plan


def _kind(v: Any) -> str:
    names = {bool: "boolean", int: "number", float: "number", str: "string", list: "array", dict: "object"}
    if v is None:
        return "null"
    text = repr(v)
    return f"{names.get(type(v), type(v).__name__)} {text[:57] + '...' if len(text) > 60 else text}"


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _number_array(v: Any, path: str, bad, pair: bool) -> np.ndarray | None:
    """``v`` as a float array of shape (N,) (``pair=False``) or (N, 2), or None after reporting
    the first offending element with its exact key path."""
    if not isinstance(v, list):
        bad(path, f"expected an array of {'[t1, t2] pairs' if pair else 'numbers'}, found {_kind(v)}")
        return None
    for i, x in enumerate(v):
        items = x if pair else [x]
        if pair and not (isinstance(x, list) and len(x) == 2):
            bad(f"{path}[{i}]", f"expected a [t1, t2] pair of numbers, found {_kind(x)}")
            return None
        for k, y in enumerate(items):
            where = f"{path}[{i}][{k}]" if pair else f"{path}[{i}]"
            if not _is_number(y):
                bad(where, f"expected a number, found {_kind(y)}")
                return None
            if not math.isfinite(y):
                bad(where, f"expected a finite number, found {y}")
                return None
    return np.asarray(v, dtype=float).reshape(-1, 2) if pair else np.asarray(v, dtype=float)


def time_grid_issues(time: np.ndarray) -> list[tuple[int | None, str]]:
    """``(sample index or None, message)`` for what is wrong with a plan's time grid: it must be
    non-empty, start at 0, increase strictly and uniformly -- every time within half of
    :data:`TIME_RESOLUTION` (the rounding plan files keep) of ``i h``, ``h`` its mean step
    (:func:`grid_step`, the step the verifier's limit checks divide by) -- at 100 Hz or finer.
    (Each step within 1e-4 h + 1e-6 s of the mean let a 10 kHz grid run 1 % fast, or its first
    step set every difference's scale: velocities 1.01 x, jerk 1.03 x the limits, passed.)"""
    if time.size < 1:
        return [(None, "expected a non-empty array of times, found an empty one")]
    out: list[tuple[int | None, str]] = []
    if time[0] != 0.0:
        out.append((0, f"expected 0, found {time[0]}"))
    if time.size > 1:
        d = np.diff(time)
        h = grid_step(time)
        tol = 0.5 * TIME_RESOLUTION + 16.0 * np.finfo(float).eps * float(np.max(np.abs(time)))
        dev = np.abs(time - (time[0] + h * np.arange(time.size)))
        if np.any(d <= 0):
            i = int(np.argmax(d <= 0)) + 1
            out.append((i, f"expected strictly increasing times, found {time[i]} after {time[i - 1]}"))
        elif float(np.max(dev)) > tol:
            # (the spacing most steps have: a sample missing from a 100 Hz grid is a step of
            # 0.02 s against 0.01 s, not against the mean step, 0.0100106 s)
            usual = float(np.median(d))
            off = np.abs(d - usual) > 2.0 * tol
            i = int(np.argmax(off)) + 1 if off.any() else max(1, int(np.argmax(dev)))
            out.append((i, f"expected a uniform grid with spacing {usual:.6g} s, found a step of {d[i - 1]:.6g} s"))
        elif h > 0.01 + 1e-9:
            out.append((None, f"expected a grid of 100 Hz or finer (spacing <= 0.01 s), found spacing {h:.4g} s"))
    return out


def _plan_from_csv(raw: bytes, source: str | None) -> Plan:
    """The :class:`Plan` of a ``plan.csv`` (no events), its time grid checked."""
    time, q, lines, gantry_x = read_csv_samples(raw, source)
    grid = time_grid_issues(time)
    if grid:
        raise PlanFileError([Issue("t", msg, None if i is None else int(lines[i])) for i, msg in grid], source)
    # values no motion has, named by their column and line (the verifier checks a plan.json's
    # by key path)
    far: list[Issue] = []
    cols = [] if gantry_x is None else [("gantry_x", gantry_x, MAX_PLAN_COORD, "carriage positions", "m")]
    cols += [(f"{a}_q{k + 1}", v[:, k], MAX_PLAN_ANGLE, "joint angles", "rad") for a, v in q.items() for k in range(2)]
    for name, col, cap, what, unit in cols:
        rows = np.flatnonzero(np.abs(col) > cap)
        if rows.size:
            r = int(rows[0])
            far.append(Issue(name, f"expected {what} within +-{cap:g} {unit} (coplan.plausible.{'MAX_PLAN_COORD' if unit == 'm' else 'MAX_PLAN_ANGLE'}), "
                                   f"found {float(col[r]):g} (t = {time[r]:.3f} s)" + (f" and {rows.size - 1} more rows" if rows.size > 1 else ""),
                             int(lines[r])))
    if far:
        raise PlanFileError(far, source)
    return Plan(problem="", planner=csv_planner(raw), status=PlanStatus.UNVERIFIED, time=time, q=q, events=[],
                allocation={}, unreachable=[], gantry_x=gantry_x)


#: the figures of ``metrics`` that coplan reads back (titles, the viewer, the stated-figures
#: check): ``(key path, whole count)``; each a number or null where present
_READ_FIGURES = (("makespan", False), ("lower_bound", False), ("gap_to_lower_bound", False), ("harvested", True),
                 ("reachable", True), ("harvestable", True), ("row.row_time", False), ("row.fruit_per_hour", False))


def _figures(metrics: Any, bad) -> None:
    """The figures of ``metrics`` coplan reads (:data:`_READ_FIGURES`): a finite number (a whole
    count, not negative, for the counts) or null ("fast" stopped `coplan plot` with an internal
    error in its title)."""
    if not isinstance(metrics, dict):
        return
    for path, whole in _READ_FIGURES:
        where: Any = metrics
        for part in path.split("."):
            where = where.get(part) if isinstance(where, dict) else None
        if where is None:
            continue
        number = isinstance(where, (int, float)) and not isinstance(where, bool) and math.isfinite(where)
        if whole and not (number and where >= 0 and float(where).is_integer()):
            bad(f"metrics.{path}", f"expected a whole number of fruit (0 or more) or null, found {_kind(where)}")
        elif not whole and not number:
            bad(f"metrics.{path}", f"expected a finite number or null, found {_kind(where)}")


#: what coplan reads of a row plan's ``solver.row`` (the viewer, ``plot --kind speed``):
#: ``(key, kind)`` where present and not null; and of each ``solver.row.speed_curve`` point (``!``:
#: required)
_ROW_SOLVER = (("mode", "string"), ("profile", "string"), ("mean_speed", "number"), ("speed_curve", "array"))
_SPEED_POINT = (("mean_speed", "number!"), ("fruit_per_hour", "number!"), ("harvested", "count"),
                ("harvestable", "count"), ("verified", "boolean"), ("profile", "string"))


def _solver_row(solver: Any, metrics: Any, bad) -> None:
    """``metrics.row`` and ``solver.row`` objects where present, and the keys of ``solver.row``
    coplan reads of the right kind (``solver.row: [1]`` stopped `coplan view` with an internal
    error; a speed point's ``mean_speed: "a"`` `plot --kind speed` with a bare float message)."""
    if isinstance(metrics, dict) and metrics.get("row") is not None and not isinstance(metrics["row"], dict):
        bad("metrics.row", f"expected an object (the row's figures), found {_kind(metrics['row'])}")
    if not isinstance(solver, dict) or solver.get("row") is None:
        return
    row = solver["row"]
    if not isinstance(row, dict):
        bad("solver.row", f"expected an object (how the row was planned), found {_kind(row)}")
        return

    def check(where: dict, path: str, keys) -> None:
        for key, kind in keys:
            v, needed = where.get(key), kind.endswith("!")  # ("!": a figure the point is drawn at, never null)
            kind = kind.rstrip("!")
            ok = ((v is None and not needed) or (kind == "string" and isinstance(v, str))
                  or (kind == "array" and isinstance(v, list)) or (kind == "boolean" and isinstance(v, bool))
                  or (kind == "number" and _is_number(v) and math.isfinite(v))
                  or (kind == "count" and _is_number(v) and math.isfinite(v) and v >= 0 and float(v).is_integer()))
            if not ok:
                said = {"count": "a whole number of fruit (0 or more)", "number": "a finite number"}.get(kind, f"{'an' if kind[0] in 'aeiou' else 'a'} {kind}")
                bad(f"{path}.{key}", f"expected {said}{'' if needed else ' or null'}, found {_kind(v)}")

    check(row, "solver.row", _ROW_SOLVER)
    modes = [m.value for m in (GantryMode.STOP_AND_GO, GantryMode.CONTINUOUS)]
    modes += [f"{m}-live" for m in modes]  # (a live run's executed plan)
    if isinstance(row.get("mode"), str) and row["mode"] not in modes:  # ("teleport" was read as stop and go, and passed)
        bad("solver.row.mode", f"expected one of {', '.join(repr(m) for m in modes)} (how the carriage moved), found {row['mode']!r}")
    for i, point in enumerate(row.get("speed_curve") if isinstance(row.get("speed_curve"), list) else []):
        if not isinstance(point, dict):
            bad(f"solver.row.speed_curve[{i}]", f"expected an object (a plan the speed search tried), found {_kind(point)}")
        else:
            check(point, f"solver.row.speed_curve[{i}]", _SPEED_POINT)


def plan_from_dict(data: Any, source: str | None = None) -> Plan:
    """Check a decoded ``plan.json`` document and build the :class:`Plan` (raises
    :class:`PlanFileError` listing every problem, each with its key path)."""
    issues: list[Issue] = []

    def bad(path: str, msg: str) -> None:
        issues.append(Issue(path, msg))

    _check_kind(data, source, bad)
    if issues:
        raise PlanFileError(issues, source)
    if not isinstance(data["problem"], str):
        bad("problem", f"expected a string, found {_kind(data['problem'])}")
    # any planner may have made the plan: coplan's own names become PlannerKind, others are kept
    planner: PlannerKind | str = data.get("planner", "external")
    if not isinstance(planner, str) or not planner.strip():
        bad("planner", f"expected the planner's name (a non-empty string), found {_kind(planner)}")
        planner = "external"
    elif planner in {k.value for k in PlannerKind}:
        planner = PlannerKind(planner)
    # the file's own status is only what its writer claimed: the verdict is the verifier's
    try:
        status = PlanStatus(data.get("status", PlanStatus.UNVERIFIED.value))
    except ValueError:
        status = PlanStatus.UNVERIFIED
    time = _time_grid(data["time"], bad)
    arms, q = _arm_samples(data["arms"], time, bad)
    events = _events(data["events"], arms, bad)
    allocation, unreachable, gantry_x, software, record = _bookkeeping(data, time, bad)
    if issues:
        raise PlanFileError(issues, source)
    return _as_judged(Plan(
        problem=str(data["problem"]),
        planner=planner,
        status=status,
        time=time,
        q=q,
        events=events,
        allocation={k: list(v) for k, v in allocation.items()},
        unreachable=list(unreachable),
        metrics=data.get("metrics") or {},
        solver=data.get("solver") or {},
        verification=data.get("verification"),
        problem_file={"path": record["path"], "sha256": record["sha256"]} if record else None,
        gantry_x=gantry_x,
        software=software,
    ))


def _check_kind(data: Any, source: str | None, bad) -> None:
    """That ``data`` is a plan document with its required keys: another kind of file (an
    export's events, a JointTrajectory, another coplan file) raises :class:`PlanFileError` at
    once saying what it is; a wrong format or a missing or misspelt key goes to ``bad``."""
    if not isinstance(data, dict):
        raise PlanFileError([Issue("", f"expected a JSON object, found {_kind(data)}")], source)
    fmt = data.get("format")
    kind = coplan_file_kind(data)
    if kind is None and set(data) == {"events"}:  # (an export's events.json: it listed four missing keys)
        raise PlanFileError([Issue("", "expected a plan file (plan.json or plan.csv), found an export's events (the picks "
                                       "and places beside a `coplan export --format json`): verify the plan.json it was "
                                       "exported from, or its CSV export")], source)
    if kind is None and {"joint_names", "points"} <= set(data):  # (it listed five missing keys)
        raise PlanFileError([Issue("", "expected a plan file (plan.json or plan.csv), found a JointTrajectory (one arm of a "
                                       "`coplan export --format json`): verify the plan.json it was exported from, or its "
                                       "CSV export (`coplan export PLAN --rate HZ`), which holds every arm")], source)
    if kind is not None and kind != "plan":  # another kind of coplan file: say only that (another version: below)
        raise PlanFileError([Issue("", f"expected a plan file (plan.json or plan.csv), found a coplan {kind} file (format "
                                       f"{fmt!r}); were the arguments swapped?")], source)
    if data.get("format") != PLAN_FORMAT:
        bad("format", f"expected {PLAN_FORMAT!r}, found {_kind(data.get('format')) if 'format' in data else 'nothing'}")
    # other keys are a writer's own (the schema leaves a plan open: problem_id, planned, ...); a near
    # miss of a key that is missing is a typo: 'gantri' for 'gantry' read a row plan as a cell's
    extra = [str(k) for k in data if k not in PLAN_KEYS]

    def near(key: str) -> str | None:
        return next((k for k in extra if difflib.get_close_matches(k.lower(), [key], n=1, cutoff=0.8)), None)

    for key in ("problem", "time", "arms", "events"):
        if key not in data:
            hit = near(key)
            bad(key, "expected a value, found nothing (required field)" + (f"; found {hit!r}: did you mean {key!r}?" if hit else ""))
    for key in ("gantry", "status"):  # (optional, but a typo changes what the plan is: a cell's, unverified)
        hit = near(key) if key not in data else None
        if hit is not None:
            bad(hit, f"expected one of the plan file's keys, found unknown key {hit!r}; did you mean {key!r}?")


def _time_grid(raw: Any, bad) -> np.ndarray | None:
    """The plan's times (None where they are unusable: the issues go to ``bad``)."""
    time = _number_array(raw, "time", bad, pair=False)
    if time is not None:
        for i, msg in time_grid_issues(time):
            bad("time" if i is None else f"time[{i}]", msg)
        if time.size < 1:
            time = None
    return time


def _arm_samples(arms: Any, time: np.ndarray | None, bad) -> tuple[dict | None, dict[str, np.ndarray]]:
    """Joint trajectories: one [t1, t2] pair per time for every arm. Returns the ``arms``
    object (None when it is not one) and each usable arm's samples."""
    q: dict[str, np.ndarray] = {}
    if not isinstance(arms, dict) or not arms:
        bad("arms", f"expected an object mapping arm names to {{q: [[t1, t2], ...]}}, found {_kind(arms)}")
        return None, q
    for name, v in arms.items():
        if not isinstance(v, dict) or "q" not in v:
            bad(f"arms.{name}", f"expected an object with key 'q', found {_kind(v)}")
            continue
        arr = _number_array(v["q"], f"arms.{name}.q", bad, pair=True)
        if arr is None:
            continue
        if time is not None and arr.shape[0] != time.size:
            bad(f"arms.{name}.q", f"expected {time.size} [t1, t2] pairs (one per time), found {arr.shape[0]}")
            continue
        q[name] = arr
    return arms, q


def _events(evs: Any, arms: dict | None, bad) -> list[Event]:
    """The picks and places, each checked (``arms``: the plan's, None when unusable)."""
    events: list[Event] = []
    if not isinstance(evs, list):
        bad("events", f"expected an array of events, found {_kind(evs)}")
        evs = []
    unsampled: set[str] = set()  # event arms with no samples, said once each
    for i, e in enumerate(evs):
        where = f"events[{i}]"
        if not isinstance(e, dict):
            bad(where, f"expected an object {{arm, fruit, kind, t_start, t_end}}, found {_kind(e)}")
            continue
        ok = True
        for key in ("arm", "fruit", "kind", "t_start", "t_end"):
            if key not in e:
                bad(f"{where}.{key}", "expected a value, found nothing (required field)")
                ok = False
        for key in set(e) - {"arm", "fruit", "kind", "t_start", "t_end"}:
            bad(f"{where}.{key}", f"expected one of arm, fruit, kind, t_start, t_end, found unknown key {key!r}")
            ok = False
        if not ok:
            continue
        for key in ("arm", "fruit"):
            if not isinstance(e[key], str):
                bad(f"{where}.{key}", f"expected a string, found {_kind(e[key])}")
                ok = False
        if arms is not None and isinstance(e["arm"], str) and e["arm"] not in arms:
            if e["arm"] not in unsampled:  # (once per arm: an arm cut from arms gave one error per event, hundreds on a row)
                n = sum(isinstance(x, dict) and x.get("arm") == e["arm"] for x in evs)
                bad(f"{where}.arm", f"expected one of the plan's arms {list(arms)}, found {e['arm']!r} "
                                    f"(arms has no samples of {e['arm']!r}: missing, or the event misnames its arm; "
                                    + ("1 event names it)" if n == 1 else f"{n} events name it, this the first)"))
            unsampled.add(e["arm"])
            ok = False
        if e["kind"] not in [k.value for k in EventKind]:
            bad(f"{where}.kind", f"expected 'pick' or 'place', found {_kind(e['kind'])}")
            ok = False
        for key in ("t_start", "t_end"):
            if not _is_number(e[key]) or not math.isfinite(e[key]):
                bad(f"{where}.{key}", f"expected a finite time in s, found {_kind(e[key])}")
                ok = False
        if ok and not e["t_end"] >= e["t_start"]:
            bad(f"{where}.t_end", f"expected t_end >= t_start = {e['t_start']}, found {e['t_end']}")
            ok = False
        if ok:
            events.append(Event(e["arm"], e["fruit"], EventKind(e["kind"]), float(e["t_start"]), float(e["t_end"])))
    return events


def _bookkeeping(data: dict, time: np.ndarray | None, bad) -> tuple[dict, list, np.ndarray | None, dict | None, dict | None]:
    """The optional keys: allocation, unreachable fruit, the carriage's positions (a row plan),
    the software and the problem file's record (each None or empty where unusable)."""
    allocation = data.get("allocation") or {}
    if not isinstance(allocation, dict) or not all(
        isinstance(v, list) and all(isinstance(f, str) for f in v) for v in allocation.values()
    ):
        bad("allocation", f"expected an object mapping arm names to arrays of fruit ids, found {_kind(allocation)}")
        allocation = {}
    unreachable = data.get("unreachable") or []
    if not isinstance(unreachable, list) or not all(isinstance(f, str) for f in unreachable):
        bad("unreachable", f"expected an array of fruit ids, found {_kind(unreachable)}")
        unreachable = []
    for key in ("metrics", "solver", "verification"):
        if data.get(key) is not None and not isinstance(data[key], dict):
            bad(key, f"expected an object, found {_kind(data[key])}")
    _figures(data.get("metrics"), bad)
    _solver_row(data.get("solver"), data.get("metrics"), bad)
    gantry_x = None
    if data.get("gantry") is not None:  # a row plan: the carriage's position on the same grid
        g = data["gantry"]
        if not isinstance(g, dict) or "x" not in g:
            bad("gantry", f"expected an object {{x: [one carriage position per time]}}, found {_kind(g)}")
        else:
            for key in sorted(set(g) - {"x"}):  # (a typo's "gantry.v" verified silently)
                bad(f"gantry.{key}", f"expected only the key x (the carriage's positions), found the unknown key {key!r}")
            gantry_x = _number_array(g["x"], "gantry.x", bad, pair=False)
            if gantry_x is not None and time is not None and gantry_x.size != time.size:
                bad("gantry.x", f"expected {time.size} positions (one per time), found {gantry_x.size}")
                gantry_x = None
    software = data.get("software")
    if software is not None and not isinstance(software, dict):
        bad("software", f"expected an object (the versions that made the plan), found {_kind(software)}")
        software = None
    record = data.get("problem_file")
    if record is not None and not (isinstance(record, dict) and all(isinstance(record.get(k), str) for k in ("path", "sha256"))):
        bad("problem_file", f"expected an object {{path, sha256}} (strings), found {_kind(record)}")
        record = None
    return allocation, unreachable, gantry_x, software, record
