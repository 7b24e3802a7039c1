"""Plans: the joint trajectories of every arm on one uniform time grid, with events.

A :class:`Plan` is what every planner returns and what ``plan.json`` holds
(format ``coplan.plan/1``). Between two samples the joints move linearly (the replay
contract: that is what :meth:`Plan.sample` does and what the verifier certifies).
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from ..output import OutputError, atomic_file, atomic_text, folder_path
from ..kinds import EventKind, PlannerKind, PlanStatus
from ..plancsv import csv_header
from ..provenance import software_record

__all__ = [
    "PLAN_FORMAT",
    "DEFAULT_RATE",
    "finer_grid",
    "grid_step",
    "TIME_RESOLUTION",
    "on_lattice",
    "jsonable",
    "PlannerKind",
    "PlanStatus",
    "EventKind",
    "Event",
    "Piece",
    "Plan",
    "sample_pieces",
    "compute_metrics",
    "jerk_figures",
    "checked_status",
    "motion_digest",
    "finalize_plan",
    "MAX_PLAN_BYTES",
    "MAX_PLAN_ANGLE",
    "MAX_PLAN_COORD",
]

PLAN_FORMAT = "coplan.plan/1"
DEFAULT_RATE = 100.0  # Hz


def finer_grid(dt: float) -> bool:
    """Whether a grid of spacing ``dt`` (s) is finer than the :data:`DEFAULT_RATE` one coplan plans
    on: there, angles rounded to 1e-7 rad carry more rounding in their differences than a limit
    check can tell from the limit (400 rad/s^3 of jerk at 1 kHz), so plans are written at full
    precision and the verifier takes that rounding only for values that sit on its lattice."""
    return dt < 1.0 / DEFAULT_RATE - 1e-12


#: Plan files keep times to 1e-6 s (plan.json; plan.csv to 1e-7 s): a time grid is uniform where
#: every time lies within half of that of ``t0 + i h`` (:func:`grid_step` ``h``).
TIME_RESOLUTION = 1e-6


def grid_step(time) -> float:
    """The spacing ``h`` (s) of the uniform grid ``time`` (N,) stands for: its mean step
    ``(t[-1] - t[0]) / (N - 1)`` (1 / :data:`DEFAULT_RATE` for fewer than two samples). Not the
    first step: the times are rounded to :data:`TIME_RESOLUTION`, and on a fine grid the first
    step's rounding would scale every velocity, acceleration and jerk a check divides by it."""
    t = np.asarray(time, float)
    return float(t[-1] - t[0]) / (t.size - 1) if t.size > 1 else 1.0 / DEFAULT_RATE


def on_lattice(values, resolution: float = 1e-7) -> bool:
    """Whether every value sits on the ``resolution`` lattice (within a thousandth of a step): the
    1e-7 rad rounding of a plan file, not full precision."""
    v = np.asarray(values, float)
    return v.size == 0 or bool(np.all(np.abs(v / resolution - np.rint(v / resolution)) <= 1e-3))

# Plan files (JSON or CSV) larger than this are refused before they are read: about 2 h of
# three arms at 100 Hz. (A 100 MB plan used to take 27 s and 1.5 GB before any check.)
MAX_PLAN_BYTES = 64 * 1024 * 1024
#: A plan file's joint angles (rad): beyond it a sample is no motion (joint limits lie within
#: 2 pi) and its figures are not printable (a plan with 1e300 rad read as -9e297 m of clearance).
MAX_PLAN_ANGLE = 1000.0
#: A plan file's carriage positions (m): a row's coordinates lie within 1000 m; beyond ten times
#: that a sample is no motion of the carriage (1e300 m read as collisions between arms that ride
#: on one carriage, from the rounding of their bases).
MAX_PLAN_COORD = 10_000.0


@dataclass(frozen=True)
class Event:
    arm: str
    fruit: str
    kind: EventKind
    t_start: float
    t_end: float

    def to_dict(self) -> dict:
        return {"arm": self.arm, "fruit": self.fruit, "kind": self.kind.value, "t_start": self.t_start, "t_end": self.t_end}


@dataclass(frozen=True)
class Piece:
    """One piece of an arm's timeline: ``q(t) = fn(t - t0)`` for t in [t0, t1]."""

    t0: float
    t1: float
    fn: Callable[[np.ndarray], np.ndarray]  # local times (K,) -> (K, 2)


def sample_pieces(pieces: list[Piece], q_rest, times: np.ndarray) -> np.ndarray:
    """Sample a timeline at ``times`` (N,) -> (N, 2); before/after/between pieces the arm
    holds the nearest piece's end pose (``q_rest`` when there are no pieces)."""
    times = np.asarray(times, float)
    out = np.empty((times.size, 2))
    out[:] = np.asarray(q_rest, float)
    for p in sorted(pieces, key=lambda p: p.t0):
        m = (times >= p.t0) & (times <= p.t1)
        if m.any():
            out[m] = p.fn(times[m] - p.t0)
        out[times > p.t1] = p.fn(np.array([p.t1 - p.t0]))[0]
    return out


@dataclass
class Plan:
    """Joint trajectories of all arms on one uniform grid, events and bookkeeping.

    Attributes
    ----------
    time : (N,) uniform grid from 0, spacing ``1 / rate``
    q : arm name -> (N, 2) joint angles
    events : pick/place events (tip still on the fruit / over the bin)
    allocation : arm name -> fruit ids in the order the arm harvests them
    unreachable : fruit the planner left out as no usable arm reaches them (out of every arm's reach, or
        reached only by an arm the screen locks; ``metrics.fruit_ids`` tells the two apart)
    metrics : computed by :func:`compute_metrics`
    solver : planner-specific information (status, iterations, timings, messages)
    verification : summary of the independent verification, when it ran
    """

    problem: str
    planner: PlannerKind | str  # a plan from elsewhere keeps its planner's own name
    status: PlanStatus  # as judged when verified: an in-place edit of the motion leaves it as it was (changed_since_verified(); saved, the plan is "unverified")
    time: np.ndarray
    q: dict[str, np.ndarray]
    events: list[Event]
    allocation: dict[str, list[str]]
    unreachable: list[str]
    metrics: dict[str, Any] = field(default_factory=dict)
    solver: dict[str, Any] = field(default_factory=dict)
    verification: dict[str, Any] | None = None
    problem_file: dict[str, str] | None = None  # {"path", "sha256"}: the problem file it was planned from
    gantry_x: np.ndarray | None = None  # (N,) a row plan's carriage position on the time grid, m (None: a cell)
    software: dict[str, Any] | None = field(default=None, compare=False)  # what made it (finalize_plan: this process's; a file's)
    #: the :func:`motion_digest` its verdict judged (set by :func:`finalize_plan`; not written)
    verified_motion: str | None = field(default=None, repr=False, compare=False)
    #: the YAML text of the problem it was planned on where that came from no file or was changed in
    #: Python (``coplan.solve`` sets it; not in plan.json): :meth:`save` writes it beside the plan and records it
    planned_on: str | None = field(default=None, repr=False, compare=False)

    def __post_init__(self) -> None:
        # a plan made in Python with lists, or a status by name ("success"), is the plan it
        # means (lists raised "'list' object has no attribute 'size'" in the verifier; a status
        # string was kept, and repr() and save() raised): arrays of floats (the same arrays where
        # they are already), the status a PlanStatus (a name that is none: every choice listed)
        self.time = np.asarray(self.time, dtype=float)
        self.q = {a: np.asarray(v, dtype=float) for a, v in self.q.items()}
        if self.gantry_x is not None:
            self.gantry_x = np.asarray(self.gantry_x, dtype=float)
        self.status = PlanStatus(self.status)

    def __repr__(self) -> str:  # (the samples are the bulk: a notebook cell shows what the plan is, not 10^4 numbers)
        mk = self.metrics.get("makespan")
        return (f"Plan(problem={self.problem!r}, planner={getattr(self.planner, 'value', self.planner)!r}, "
                f"status={self.status.value!r}, arms={list(self.q)}, samples={self.time.size}, "
                f"events={len(self.events)}, makespan={'-' if mk is None else f'{mk:.4f} s'}"
                f"{', row' if self.gantry_x is not None else ''})")

    # ------------------------------------------------------------------ queries
    @property
    def dt(self) -> float:
        """The sample spacing (s): 1 / the plan's rate (:func:`grid_step`)."""
        return grid_step(self.time)

    @property
    def duration(self) -> float:
        """The time of the last sample (s): the plan's whole length, home included (its makespan,
        the last place's end, is ``metrics["makespan"]``)."""
        return float(self.time[-1]) if self.time.size else 0.0

    @property
    def planner_name(self) -> str:
        """The planner's name: one of coplan's (:class:`PlannerKind`) or, for a plan made
        elsewhere, the name its file gives."""
        return self.planner.value if isinstance(self.planner, PlannerKind) else str(self.planner)

    def same_motion(self, other: "Plan") -> bool:
        """Whether ``other`` moves exactly as this plan does: the same times, joints, carriage and
        events (:func:`motion_digest`), whatever their solver reports, timings and metrics say --
        what "the same input gives the same plan" means; ``==`` compares whole files, wall-clock
        timings included, so two solves of one problem are never ``==``."""
        return motion_digest(self) == motion_digest(other)

    def __eq__(self, other: object) -> bool:
        """Equal when their ``plan.json`` would be, its solver timings included (the generated
        comparison raised on the NumPy arrays: a notebook's round-trip check ``load_plan(path) ==
        plan`` could not run); :meth:`same_motion` compares the motion alone."""
        if not isinstance(other, Plan):
            return NotImplemented
        mine, theirs = self.to_dict(), other.to_dict()
        mine.pop("software", None), theirs.pop("software", None)  # (what made it: two installs, one plan)
        return json.dumps(jsonable(mine), sort_keys=True) == json.dumps(jsonable(theirs), sort_keys=True)

    __hash__ = None  # type: ignore[assignment]  (mutable: as before)

    @property
    def label(self) -> str:
        """The planner's name and, for a row's plan, how its carriage moved (its ``solver.row``):
        "coordinated (on the move)", "optimal (stop and go, optimised stops)"; a cell's: the name."""
        row = (self.solver or {}).get("row") if isinstance(self.solver, dict) else None
        if not isinstance(row, dict) or self.gantry_x is None:
            return self.planner_name
        mode = str(row.get("mode") or "")
        if mode.startswith("continuous"):  # (a live run's is "continuous-live": it was called stop and go)
            return f"{self.planner_name} (on the move)"
        rule = row.get("rule")
        return f"{self.planner_name} (stop and go" + (f", {rule} stops)" if isinstance(rule, str) else ")")

    @property
    def arm_names(self) -> list[str]:
        """The arms' names, in the order of ``q``."""
        return list(self.q)

    def _clock(self, t) -> np.ndarray:
        """``t`` (s) as an array within the plan (before it: its start; after it: its end); a
        time that is not a number is refused (ValueError), not answered with NaN (nor a string
        read as one: ``sample("1.0")``)."""
        raw = np.asarray(t)
        if raw.dtype.kind not in "iuf":
            raise ValueError(f"t: expected times in s (numbers), found {type(t).__name__} {t!r:.60}")
        t = raw.astype(float)
        if not np.all(np.isfinite(t)):
            bad = t[~np.isfinite(t)].ravel()[0] if t.ndim else t
            raise ValueError(f"t: expected finite times in s, found {bad}")
        return np.clip(t, 0.0, self.duration)

    def sample(self, t) -> dict[str, np.ndarray]:
        """Joint angles (rad) of every arm at times ``t`` (s; a number or (K,)), linear between
        samples: ``{arm: (K, 2)}``, or ``{arm: (2,)}`` for a number (any other shape S of ``t``:
        ``(*S, 2)``). Before the plan's start and
        after its end, the first and last poses (the arm at rest there)."""
        t = self._clock(t)
        return {a: np.stack([np.interp(t, self.time, q[:, 0]), np.interp(t, self.time, q[:, 1])], axis=-1) for a, q in self.q.items()}

    def carriage(self, t) -> np.ndarray:
        """A row plan's carriage position (m, row coordinates) at times ``t`` (s; a number or
        an array): an array of ``t``'s shape (0-d for a number), linear between samples (the
        arms' bases are there plus their offsets on the carriage); a stationary cell's plan has
        none (ValueError)."""
        if self.gantry_x is None:
            raise ValueError(f"plan of {self.problem!r}: a stationary cell's plan has no carriage (no gantry_x)")
        t = self._clock(t)
        return np.interp(t, self.time, self.gantry_x)

    def _arm_named(self, arm: str) -> None:
        if arm not in self.q:  # (a misspelt arm gave [] or a bare KeyError: 'lefft')
            raise KeyError(f"no arm named {arm!r} in the plan; arms are {list(self.q)}")

    def events_of(self, arm: str, kind: EventKind | str | None = None) -> list[Event]:
        """``arm``'s events (of ``kind``: ``pick`` or ``place``), in the plan's order."""
        self._arm_named(arm)
        kind = None if kind is None else EventKind(kind)  # ("grab": ValueError naming the kinds, not [])
        return [e for e in self.events if e.arm == arm and (kind is None or e.kind == kind)]

    def busy(self, arm: str) -> np.ndarray:
        """(N - 1,) bool: per sampling interval, whether ``arm`` moves (its joints change over it)
        or dwells (the interval's midpoint inside one of its events)."""
        self._arm_named(arm)
        q = self.q[arm]
        busy = np.any(np.abs(np.diff(q, axis=0)) > 1e-9, axis=1)
        mid = (self.time[:-1] + self.time[1:]) / 2
        for e in self.events_of(arm):
            busy |= (mid >= e.t_start) & (mid <= e.t_end)
        return busy

    def with_status(self, status: PlanStatus | str) -> "Plan":
        """A copy with ``status`` (a :class:`PlanStatus` or its name). A verdict's status
        (success, partial) is refused on a plan whose motion changed after it was verified
        (:meth:`changed_since_verified`: its arrays edited in place, say): verify it again
        (:func:`coplan.verify.verify`, then :func:`coplan.plan.finalize_plan`) to judge it."""
        status = PlanStatus(status)
        if status in (PlanStatus.SUCCESS, PlanStatus.PARTIAL) and self.changed_since_verified():
            raise ValueError(f"with_status: expected a plan whose motion is the one its verdict judged, found one changed "
                             f"since it was verified: it cannot be called {status.value} without being verified again")
        return replace(self, status=status)

    # ------------------------------------------------------------------ I/O
    def changed_since_verified(self) -> bool:
        """Whether its motion (times, joints, carriage, events) changed after
        :func:`finalize_plan` judged it: then its verdict is not its own."""
        return self.verified_motion is not None and self.verified_motion != motion_digest(self)

    def to_dict(self) -> dict:
        """The ``plan.json`` document. A plan whose motion was changed after its verdict (its
        arrays edited in place, say) is written ``unverified``, without that verdict, its metrics
        those of the motion it has (no certified margin: that was the verdict's)."""
        fine = finer_grid(self.dt)  # (full precision there: rounded, the file would fail where the plan passed)
        stale = self.changed_since_verified() and self.status in (PlanStatus.SUCCESS, PlanStatus.PARTIAL, PlanStatus.UNSAFE)
        return {
            "format": PLAN_FORMAT,
            "problem": self.problem,
            "planner": self.planner_name,
            "status": (PlanStatus.UNVERIFIED if stale else self.status).value,
            "time": jsonable(np.round(self.time, 6)),
            "arms": {a: {"q": jsonable(q if fine else np.round(q, 7))} for a, q in self.q.items()},
            "events": [e.to_dict() for e in self.events],
            "allocation": self.allocation,
            "unreachable": list(self.unreachable),
            "metrics": jsonable(motion_metrics(self, self.metrics.get("reachable", 0), None) if stale else self.metrics),
            "solver": jsonable(self.solver),
            "verification": None if stale else jsonable(self.verification),
        } | ({"problem_file": dict(self.problem_file)} if self.problem_file else {}) | (
            {"gantry": {"x": jsonable(self.gantry_x if fine else np.round(self.gantry_x, 7))}} if self.gantry_x is not None
            else {}) | ({"software": dict(self.software)} if self.software else {})

    def save(self, out_dir: str | Path, stem: str = "plan") -> dict[str, Path]:
        """Write ``plan.json`` plus ``plan.csv`` (one row per time) and ``plan.npz`` into the
        folder ``out_dir``; a file name ending ``.json`` (``save("my_plan.json")``) writes
        ``my_plan.json``, ``.csv`` and ``.npz`` beside it (it made a folder of that name).

        Each file is written to a temporary name first and renamed, so a crash never
        leaves a half-written one. Returns the paths written. :class:`coplan.output.OutputError`
        (a ``ValueError``) before anything is written where a file is where the folder goes or in
        its path, or for a name ending ``.csv`` or ``.npz`` (not a folder already).
        """
        if not isinstance(out_dir, (str, os.PathLike)) or not isinstance(stem, str) or not stem.strip():
            raise TypeError(f"save: expected a folder or a .json file name (str or Path) and a non-empty stem, found "
                            f"out_dir {type(out_dir).__name__} {out_dir!r}, stem {stem!r}")
        if Path(stem).name != stem or stem in (".", ".."):  # (save(folder, "../escape") wrote beside the folder)
            raise OutputError(f"save: expected a file name stem (no folder in it) for the plan's files, found {stem!r}")
        if isinstance(out_dir, str) and not out_dir:  # (as solve's out_dir: an unset variable's default)
            raise OutputError("save: expected a folder or a .json file name, found an empty string (an unset variable?); "
                              "'.' is the current folder")
        out = Path(out_dir)
        want = "a folder or a file name ending .json (the plan is written as .json, .csv and .npz together)"
        if out.suffix.lower() == ".json" and not out.is_dir():
            out, stem = out.parent, out.stem
        elif out.suffix.lower() in (".csv", ".npz") and not out.is_dir():  # (it made a folder "fresh.csv/")
            raise OutputError(f"save {out}: expected {want}, found a name ending {out.suffix}")
        folder_path(out, "save", want)  # (a file in the way: what was expected and found, not FileExistsError)
        out.mkdir(parents=True, exist_ok=True)
        paths = {"json": out / f"{stem}.json", "csv": out / f"{stem}.csv", "npz": out / f"{stem}.npz"}
        if self.planned_on is not None:
            # (made or changed in Python: written beside the plan, at every save, and recorded, as
            # coplan.solve's out_dir does -- a plan of crossing_paths with its fruit moved, saved so,
            # was verified by `coplan verify` against the shipped crossing_paths: 4 picks missed, exit 6)
            import hashlib

            paths["problem"] = out / f"{stem}_problem.yaml"
            if paths["problem"].exists() and not _written_problem(paths["problem"]):
                raise OutputError(f"save {paths['problem']}: the plan's problem (made or changed in Python) goes there, "
                                  "beside the plan; expected nothing there or a problem coplan wrote, found another "
                                  "file: move it, or save under another name")
            atomic_text(paths["problem"], self.planned_on)
            self.problem_file = {"path": str(paths["problem"].absolute()),  # (the digest a problem file's text has)
                                 "sha256": hashlib.sha256(self.planned_on.encode("utf-8")).hexdigest()}
        atomic_text(paths["json"], json.dumps(self.to_dict(), indent=None, separators=(",", ":"), allow_nan=False))

        cols = [self.time[:, None]] + ([] if self.gantry_x is None else [self.gantry_x[:, None]]) + [self.q[a] for a in self.q]
        fmt = "%.17g" if finer_grid(self.dt) else "%.7f"  # (as plan.json: full precision on a finer grid)
        atomic_file(paths["csv"], lambda tmp: np.savetxt(tmp, np.hstack(cols), delimiter=",", comments="", fmt=fmt,
                                                          header=csv_header(self.q, self.gantry_x is not None)))
        carriage = {} if self.gantry_x is None else {"gantry_x": self.gantry_x}  # (a row's: as in plan.csv)
        atomic_file(paths["npz"], lambda tmp: np.savez_compressed(tmp, time=self.time, **carriage,
                                                                  **{f"q_{a}": q for a, q in self.q.items()}))
        return paths


#: the words of the first line of a problem file coplan writes beside a plan (``# The problem 'x' ...``)
PLANNED_HEADER = "as planned (made or changed in Python)"


def _written_problem(path: Path) -> bool:
    """Whether the file at ``path`` is a problem coplan wrote beside a plan (its first line), which
    a save may replace; a user's own file is never overwritten."""
    try:
        with open(path, encoding="utf-8") as fh:
            first = fh.readline()
    except (OSError, UnicodeDecodeError):
        return False
    return first.startswith("# The problem ") and PLANNED_HEADER in first


def jsonable(x):
    """``x`` with plain JSON types only: enums as their values, arrays as lists, NumPy scalars
    as Python ones, and a non-finite float (which strict JSON cannot hold) as None."""
    if isinstance(x, dict):
        return {str(k): jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v) for v in x]
    if isinstance(x, Enum):
        return x.value
    if isinstance(x, np.ndarray):
        if x.dtype.kind in "iub" or (x.dtype.kind == "f" and np.isfinite(x).all()):
            return x.tolist()  # the common case (time grids, joint samples): no element-wise walk
        return jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x


def compute_metrics(plan: Plan, n_reachable: int) -> dict[str, Any]:
    """Makespan, cycle times, throughput and per-arm figures (fruit, cycle time, idle share,
    RMS and peak jerk) from a plan's events and samples.

    ``makespan`` is the end of the last place event. An arm's cycle time is its last place
    time divided by its fruit count; ``cycle_time`` is the worst arm's.
    """
    places = [e for e in plan.events if e.kind == EventKind.PLACE]
    makespan = max((e.t_end for e in places), default=0.0)
    per_arm: dict[str, Any] = {}
    for a in plan.q:
        pa = [e for e in places if e.arm == a]
        n = len(pa)
        last = max((e.t_end for e in pa), default=0.0)
        busy = _busy_time(plan, a)
        per_arm[a] = {
            "fruit": n,
            "last_place": last,
            "cycle_time": last / n if n else None,
            "idle_fraction": min(1.0, max(0.0, 1.0 - busy / makespan)) if makespan > 0 else None,
        }
    for a, jf in jerk_figures(plan).items():
        per_arm[a].update(jf)
    cycles = [v["cycle_time"] for v in per_arm.values() if v["cycle_time"] is not None]
    harvested = len(places)
    return {
        "harvested": harvested,
        "reachable": n_reachable,
        "unreachable": len(plan.unreachable),
        "makespan": makespan,
        "cycle_time": max(cycles) if cycles else None,
        "cycle_time_mean": float(np.mean(cycles)) if cycles else None,
        "throughput": harvested / makespan if makespan > 0 else 0.0,
        "per_arm": per_arm,
    }


def jerk_figures(plan: Plan) -> dict[str, dict[str, float]]:
    """Per arm, the RMS and peak joint jerk (rad/s^3) of the replayed plan: third differences
    of the samples over ``dt^3`` (each a weighted mean of the jerk of any smooth trajectory
    through the samples, as the verifier reads them), RMS over both joints and the whole plan."""
    out: dict[str, dict[str, float]] = {}
    for a, q in plan.q.items():
        if q.shape[0] < 4:
            out[a] = {"rms_jerk": 0.0, "peak_jerk": 0.0}
            continue
        j = np.diff(np.asarray(q, float), n=3, axis=0) / plan.dt**3
        out[a] = {"rms_jerk": float(np.sqrt(np.mean(np.sum(j * j, axis=1)))), "peak_jerk": float(np.max(np.abs(j)))}
    return out


def fit_issue(problem, plan: Plan) -> str | None:
    """Why ``plan`` is not a plan of ``problem`` (None: it fits): other arms, a row's plan over a
    cell or a cell's over a row, or picks of fruit the problem does not have. The figures, the
    viewer and the CLI's plan commands refuse a plan drawn over another problem so (a row's plan
    over a cell of the same arm names showed -0.08 m "collisions")."""
    names = [a.name for a in problem.arms]
    if sorted(plan.q) != sorted(names):
        return f"expected the problem's arms {names}, found {list(plan.q)}"
    row_plan = getattr(plan, "gantry_x", None) is not None
    if row_plan != (problem.gantry is not None):
        return ("the plan is a row's (its carriage moves), and problem {0!r} is a cell" if row_plan else
                "the plan is a cell's (no carriage), and problem {0!r} is a row").format(problem.name)
    ids = {f.id for f in problem.fruits}
    other = sorted({e.fruit for e in plan.events if e.fruit not in ids})
    if other:
        return f"it picks fruit the problem does not have ({', '.join(other[:5])}{', ...' if len(other) > 5 else ''})"
    return None


def checked_status(status: PlanStatus, verification) -> PlanStatus:
    """The status a plan (its file) claims, held to a verifier's verdict: a solver failure, an
    interruption or nothing to plan stays as it is; otherwise unsafe where the verdict fails,
    partial where it passes with reachable fruit unharvested, success where it passes complete.
    (The viewer, plots and animations of a plan file show this, not the file's word.)"""
    if status in (PlanStatus.FAILED, PlanStatus.INTERRUPTED, PlanStatus.INFEASIBLE):
        return status
    if not verification.passed:
        return PlanStatus.UNSAFE
    return PlanStatus.PARTIAL if verification.unharvested else PlanStatus.SUCCESS


def motion_digest(plan: Plan) -> str:
    """A sha256 of a plan's motion: its times, every arm's joints, the carriage, its events."""
    import hashlib

    h = hashlib.sha256()
    for a in [plan.time, plan.gantry_x] + [plan.q[k] for k in plan.q]:
        if a is not None:
            h.update(np.ascontiguousarray(a, dtype=float).tobytes())
    h.update(repr([(a, len(plan.q[a])) for a in plan.q]).encode())
    h.update(repr([(e.arm, e.fruit, e.kind.value, e.t_start, e.t_end) for e in plan.events]).encode())
    return h.hexdigest()


def motion_metrics(plan: Plan, n_reachable: int, summary: dict | None) -> dict[str, Any]:
    """The plan's metrics of its motion (:func:`compute_metrics`, with what its planner set
    itself kept and its gap to the lower bound) and, from a verifier's ``summary``, the certified
    margin overall and per neighbouring pair."""
    metrics = compute_metrics(plan, n_reachable) | {k: v for k, v in plan.metrics.items() if k in _KEPT_METRICS}
    if summary and "margin" in summary:  # least certified clearance less the required, overall and per neighbouring pair
        # (None without a pair of neighbours, as its file says: it was inf here and null in plan.json)
        metrics["margin"] = summary["margin"] if summary["margin"] is not None and math.isfinite(summary["margin"]) else None
        metrics["margin_per_pair"] = {k: v.get("margin") for k, v in (summary.get("pairs") or {}).items()}
    lb = metrics.get("lower_bound")
    if lb:
        metrics["gap_to_lower_bound"] = metrics["makespan"] / lb if metrics["makespan"] else None
    return metrics


def finalize_plan(plan: Plan, verification, n_reachable: int) -> Plan:
    """Set the plan's metrics and status from the verifier's verdict (never upgrades a solver
    failure or an interruption). ``verification`` is the verifier's result (or None)."""
    plan.verification = verification.summary() if verification is not None else None
    if plan.software is None:  # (made here: what made it; a file's own record is kept)
        plan.software = software_record()
    plan.metrics = motion_metrics(plan, n_reachable, plan.verification)
    plan.verified_motion = motion_digest(plan) if verification is not None else None  # (what the verdict is about)
    if plan.status in (PlanStatus.FAILED, PlanStatus.INTERRUPTED, PlanStatus.INFEASIBLE):
        return plan
    if verification is None:
        plan.status = PlanStatus.UNVERIFIED
    elif not verification.passed:
        plan.status = PlanStatus.UNSAFE
    elif n_reachable == 0:
        plan.status = PlanStatus.INFEASIBLE
    elif plan.metrics["harvested"] < n_reachable:
        plan.status = PlanStatus.PARTIAL
    else:
        plan.status = PlanStatus.SUCCESS
    return plan


# metrics a planner sets itself (kept when the metrics are recomputed)
_KEPT_METRICS = ("lower_bound", "optimality", "coordinated_makespan", "improvement_over_coordinated",
                 "baseline_makespan", "baseline_status", "time_to_first_verified", "time_of_last_improvement",
                 "fruit", "harvestable", "fruit_ids", "row", "time_to_ratio")


def _busy_time(plan: Plan, arm: str) -> float:
    """Seconds, up to the arm's last place, during which it moves or dwells.

    Each sampling interval counts once (:meth:`Plan.busy`).
    """
    places = plan.events_of(arm, EventKind.PLACE)
    if plan.q[arm].shape[0] < 2 or not places:
        return 0.0
    end = max(e.t_end for e in places)
    busy = plan.busy(arm) & ((plan.time[:-1] + plan.time[1:]) / 2 <= end)
    return float(min(busy.sum() * plan.dt, end))
