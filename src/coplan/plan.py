"""Plans: the joint trajectories of every arm on one uniform time grid, with events.

A :class:`Plan` is what every planner returns and what ``plan.json`` holds
(format ``coplan.plan/1``). Between two samples the joints move linearly (the replay
contract: that is what :meth:`Plan.sample` does and what the verifier certifies).
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from .errors import Issue, PlanFileError

__all__ = [
    "PLAN_FORMAT",
    "DEFAULT_RATE",
    "PlannerKind",
    "PlanStatus",
    "EventKind",
    "Event",
    "Piece",
    "Plan",
    "sample_pieces",
    "compute_metrics",
    "load_plan",
]

PLAN_FORMAT = "coplan.plan/1"
DEFAULT_RATE = 100.0  # Hz


class PlannerKind(str, Enum):
    HEURISTIC = "heuristic"
    OPTIMAL = "optimal"


class PlanStatus(str, Enum):
    """Overall verdict of a plan. Only ``SUCCESS`` means verified and complete."""

    SUCCESS = "success"  # every reachable fruit harvested, verification passed
    PARTIAL = "partial"  # verified safe, but not every reachable fruit harvested
    UNSAFE = "unsafe"  # verification found violations (collisions, limits, missed picks)
    UNVERIFIED = "unverified"  # not yet verified
    INFEASIBLE = "infeasible"  # nothing could be planned
    FAILED = "failed"  # the solver failed; the plan is the best it had
    INTERRUPTED = "interrupted"  # stopped by the user; the plan is the best it had


class EventKind(str, Enum):
    PICK = "pick"
    PLACE = "place"


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
    unreachable : fruit no arm can reach (left out)
    metrics : computed by :func:`compute_metrics`
    solver : planner-specific information (status, iterations, timings, messages)
    verification : summary of the independent verification, when it ran
    """

    problem: str
    planner: PlannerKind
    status: PlanStatus
    time: np.ndarray
    q: dict[str, np.ndarray]
    events: list[Event]
    allocation: dict[str, list[str]]
    unreachable: list[str]
    metrics: dict[str, Any] = field(default_factory=dict)
    solver: dict[str, Any] = field(default_factory=dict)
    verification: dict[str, Any] | None = None

    # ------------------------------------------------------------------ queries
    @property
    def dt(self) -> float:
        return float(self.time[1] - self.time[0]) if self.time.size > 1 else 1.0 / DEFAULT_RATE

    @property
    def duration(self) -> float:
        return float(self.time[-1]) if self.time.size else 0.0

    @property
    def arm_names(self) -> list[str]:
        return list(self.q)

    def sample(self, t) -> dict[str, np.ndarray]:
        """Joint angles of every arm at times ``t`` (K,), linear between samples."""
        t = np.clip(np.asarray(t, float), 0.0, self.duration)
        return {a: np.stack([np.interp(t, self.time, q[:, 0]), np.interp(t, self.time, q[:, 1])], axis=-1) for a, q in self.q.items()}

    def events_of(self, arm: str, kind: EventKind | None = None) -> list[Event]:
        return [e for e in self.events if e.arm == arm and (kind is None or e.kind == kind)]

    def with_status(self, status: PlanStatus) -> "Plan":
        return replace(self, status=status)

    # ------------------------------------------------------------------ I/O
    def to_dict(self) -> dict:
        return {
            "format": PLAN_FORMAT,
            "problem": self.problem,
            "planner": self.planner.value,
            "status": self.status.value,
            "time": [round(float(x), 6) for x in self.time],
            "arms": {a: {"q": np.round(q, 7).tolist()} for a, q in self.q.items()},
            "events": [e.to_dict() for e in self.events],
            "allocation": self.allocation,
            "unreachable": list(self.unreachable),
            "metrics": _jsonable(self.metrics),
            "solver": _jsonable(self.solver),
            "verification": _jsonable(self.verification),
        }

    def save(self, out_dir: str | Path, stem: str = "plan") -> dict[str, Path]:
        """Write ``plan.json`` plus ``plan.csv`` (one row per time) and ``plan.npz``.

        The JSON is written to a temporary name first and renamed, so a crash never
        leaves a half-written plan. Returns the paths written.
        """
        out = Path(out_dir)
        out.mkdir(parents=True, exist_ok=True)
        paths = {"json": out / f"{stem}.json", "csv": out / f"{stem}.csv", "npz": out / f"{stem}.npz"}
        tmp = paths["json"].with_suffix(".json.tmp")
        tmp.write_text(json.dumps(self.to_dict(), indent=None, separators=(",", ":")))
        tmp.replace(paths["json"])
        cols = [self.time[:, None]] + [self.q[a] for a in self.q]
        header = "t," + ",".join(f"{a}_q1,{a}_q2" for a in self.q)
        np.savetxt(paths["csv"], np.hstack(cols), delimiter=",", header=header, comments="", fmt="%.7f")
        np.savez_compressed(paths["npz"], time=self.time, **{f"q_{a}": q for a, q in self.q.items()})
        return paths


def _jsonable(x):
    if isinstance(x, dict):
        return {str(k): _jsonable(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_jsonable(v) for v in x]
    if isinstance(x, Enum):
        return x.value
    if isinstance(x, np.ndarray):
        return _jsonable(x.tolist())
    if isinstance(x, (np.floating, float)):
        v = float(x)
        return v if math.isfinite(v) else None
    if isinstance(x, (np.integer,)):
        return int(x)
    if isinstance(x, (np.bool_,)):
        return bool(x)
    return x


def compute_metrics(plan: Plan, n_reachable: int) -> dict[str, Any]:
    """Makespan, cycle times, throughput and per-arm figures from a plan's events.

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
            "idle_fraction": (1.0 - busy / makespan) if makespan > 0 else None,
        }
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


def _busy_time(plan: Plan, arm: str) -> float:
    """Seconds, up to the makespan's end, during which the arm moves or dwells."""
    q = plan.q[arm]
    if q.shape[0] < 2:
        return 0.0
    moving = np.any(np.abs(np.diff(q, axis=0)) > 1e-9, axis=1)
    busy = np.zeros(plan.time.size, bool)
    busy[1:] |= moving
    busy[:-1] |= moving
    for e in plan.events_of(arm):
        busy |= (plan.time >= e.t_start) & (plan.time <= e.t_end)
    places = plan.events_of(arm, EventKind.PLACE)
    end = max((e.t_end for e in places), default=0.0)
    busy &= plan.time <= max(end, 0.0) if places else np.zeros_like(busy)
    return float(busy.sum() * plan.dt)


# ---------------------------------------------------------------------- loading
def load_plan(path: str | Path) -> Plan:
    """Load and check a ``plan.json`` (raises :class:`PlanFileError` listing every problem)."""
    p = Path(path)
    src = str(p)
    if not p.is_file():
        raise PlanFileError([Issue("", "file not found" if not p.exists() else "expected a file, found a directory")], src)
    try:
        data = json.loads(p.read_text(encoding="utf-8"))
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        line = getattr(e, "lineno", None)
        raise PlanFileError([Issue("", f"not valid JSON: {e}", line)], src) from None
    return plan_from_dict(data, src)


def plan_from_dict(data: Any, source: str | None = None) -> Plan:
    issues: list[Issue] = []

    def bad(path, msg):
        issues.append(Issue(path, msg))

    if not isinstance(data, dict):
        raise PlanFileError([Issue("", f"expected a JSON object, found {type(data).__name__}")], source)
    if data.get("format") != PLAN_FORMAT:
        bad("format", f"expected {PLAN_FORMAT!r}, found {data.get('format')!r}")
    for key in ("problem", "planner", "status", "time", "arms", "events"):
        if key not in data:
            bad(key, "missing required field")
    if issues:
        raise PlanFileError(issues, source)
    try:
        planner = PlannerKind(data["planner"])
    except ValueError:
        bad("planner", f"expected one of {[k.value for k in PlannerKind]}, found {data['planner']!r}")
        planner = PlannerKind.HEURISTIC
    try:
        status = PlanStatus(data["status"])
    except ValueError:
        bad("status", f"expected one of {[k.value for k in PlanStatus]}, found {data['status']!r}")
        status = PlanStatus.UNVERIFIED
    try:
        time = np.asarray(data["time"], dtype=float)
    except (TypeError, ValueError):
        time = np.zeros(0)
        bad("time", "expected a list of numbers")
    if time.ndim != 1 or time.size < 1:
        bad("time", f"expected a non-empty list of numbers, found shape {time.shape}")
    elif not np.all(np.isfinite(time)):
        bad("time", "expected finite numbers, found NaN/inf")
    elif time.size > 1:
        d = np.diff(time)
        if np.any(d <= 0):
            bad("time", "expected strictly increasing times")
        elif np.max(np.abs(d - d.mean())) > 1e-4 * max(d.mean(), 1e-9) + 1e-6:
            bad("time", "expected a uniform grid")
        elif d.mean() > 0.01 + 1e-9:
            bad("time", f"expected a grid of 100 Hz or finer, found spacing {d.mean():.4g} s")
        if abs(time[0]) > 1e-9:
            bad("time[0]", f"expected 0, found {time[0]}")
    q: dict[str, np.ndarray] = {}
    arms = data["arms"]
    if not isinstance(arms, dict) or not arms:
        bad("arms", "expected an object mapping arm names to {q: [[t1, t2], ...]}")
    else:
        for name, v in arms.items():
            if not isinstance(v, dict) or "q" not in v:
                bad(f"arms.{name}", "expected an object with key 'q'")
                continue
            try:
                arr = np.asarray(v["q"], dtype=float)
            except (TypeError, ValueError):
                bad(f"arms.{name}.q", "expected a list of [t1, t2] pairs of numbers")
                continue
            if arr.ndim != 2 or arr.shape[1] != 2:
                bad(f"arms.{name}.q", f"expected shape (N, 2), found {arr.shape}")
            elif arr.shape[0] != time.size:
                bad(f"arms.{name}.q", f"expected {time.size} rows (one per time), found {arr.shape[0]}")
            elif not np.all(np.isfinite(arr)):
                bad(f"arms.{name}.q", "expected finite numbers, found NaN/inf")
            else:
                q[name] = arr
    events = []
    if not isinstance(data["events"], list):
        bad("events", "expected a list")
    else:
        for i, e in enumerate(data["events"]):
            try:
                ev = Event(str(e["arm"]), str(e["fruit"]), EventKind(e["kind"]), float(e["t_start"]), float(e["t_end"]))
            except (KeyError, TypeError, ValueError) as ex:
                bad(f"events[{i}]", f"expected {{arm, fruit, kind: pick|place, t_start, t_end}}, found {e!r} ({ex})")
                continue
            if isinstance(arms, dict) and ev.arm not in arms:
                bad(f"events[{i}].arm", f"unknown arm {ev.arm!r}")
            if not ev.t_end >= ev.t_start:
                bad(f"events[{i}]", f"expected t_end >= t_start, found {ev.t_start} > {ev.t_end}")
            events.append(ev)
    if issues:
        raise PlanFileError(issues, source)
    return Plan(
        problem=str(data["problem"]),
        planner=planner,
        status=status,
        time=time,
        q=q,
        events=events,
        allocation={k: list(v) for k, v in (data.get("allocation") or {}).items()},
        unreachable=list(data.get("unreachable") or []),
        metrics=data.get("metrics") or {},
        solver=data.get("solver") or {},
        verification=data.get("verification"),
    )
