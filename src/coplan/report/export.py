"""A plan as a joint controller takes it (``coplan export PLAN --rate HZ --format csv|json|yaml``).

:func:`trajectory` resamples every arm's joints at a chosen rate with their velocities and
accelerations; :func:`export_plan` writes them as

* ``csv``: one file, one row per time: ``t`` then, per arm, ``<arm>_q1, <arm>_q2, <arm>_qd1,
  <arm>_qd2, <arm>_qdd1, <arm>_qdd2`` (rad, rad/s, rad/s^2; names quoted by the ``csv`` module);
* ``json`` / ``yaml``: one file per arm in a folder, each a ROS 2
  ``trajectory_msgs/msg/JointTrajectory`` (``header``, ``joint_names``, ``points`` with
  ``positions``, ``velocities``, ``accelerations``, ``effort``, ``time_from_start: {sec,
  nanosec}``), loadable field for field into the message (e.g. ``rosidl_runtime_py.set_message_fields``).

Where the derivatives come from: ``plan.json`` holds positions on a uniform grid (100 Hz). The
export interpolates them with the C^2 cubic spline through every sample, clamped at rest at both
ends (the arms start and end still, as the verifier assumes), and differentiates the spline. So
the positions are the plan's own at every grid time, the velocities and accelerations are the
exact derivatives of the exported positions (a controller integrating them stays on the plan),
and for a coordinated plan's time-optimal S-curve move they agree with the analytic profile
(:meth:`coplan.kinematics.timing.SCurve.derivatives`) to about 1e-3 rad/s and 1.5 % of the acceleration
limit (jerk switches fall between samples; tested). For the same reason the exported
accelerations can exceed a joint's acceleration limit slightly where the plan runs at it
(measured on the coordinated plans of the shipped problems at 1 kHz: at most 1.1 % over the
acceleration limit, 0.01 % over the velocity limit); a controller that refuses any excess
should be given limits with that margin.
"""

from __future__ import annotations

import csv
import io
import json
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..kinds import ExportFormat
from ..plan import Plan
from ..output import atomic_text

__all__ = ["ExportFormat", "Trajectory", "trajectory", "export_plan", "follow_error", "FOLLOW_TOLERANCE", "MAX_POINTS",
           "MAX_RATE"]

#: rad: an export whose points a controller follows (cubic, with their velocities) within this of
#: the plan says nothing; beyond it ``coplan export`` notes how far (about 1.8 mm at a 1.8 m reach)
FOLLOW_TOLERANCE = 1e-3

MAX_RATE = 10_000.0  # Hz: far above any joint controller's rate
MAX_POINTS = 2_000_000  # per arm: about 5.5 hours at 100 Hz


@dataclass(frozen=True)
class Trajectory:
    """Every arm's joints at the times ``time`` (K,): ``q``, ``qd``, ``qdd`` arm -> (K, 2)."""

    time: np.ndarray
    q: dict[str, np.ndarray]
    qd: dict[str, np.ndarray]
    qdd: dict[str, np.ndarray]
    rate: float
    carriage: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # a row plan: the carriage's (x, v, a) at ``time``


def _times(duration: float, rate: float) -> np.ndarray:
    n = int(math.floor(duration * rate + 1e-9))
    t = np.arange(n + 1) / rate
    if t[-1] < duration - 1e-9:
        t = np.append(t, duration)  # the final pose is always a point
    return t


def check_rate(rate: float, duration: float) -> None:
    """Raise ``ValueError`` (with the reason) for a rate no export can use."""
    if not (isinstance(rate, (int, float)) and math.isfinite(rate) and 0 < rate <= MAX_RATE):
        raise ValueError(f"expected a rate in (0, {MAX_RATE:g}] Hz, found {rate!r}")
    n = duration * rate + 1
    if n > MAX_POINTS:
        raise ValueError(f"expected at most {MAX_POINTS} points per arm, found {n:.0f} ({duration:.1f} s at {rate:g} Hz)")


def trajectory(plan: Plan, rate: float) -> Trajectory:
    """Positions, velocities and accelerations of every arm at ``rate`` Hz, from t = 0 to the
    plan's end (its final pose always included); see the module docstring for the derivatives."""
    from scipy.interpolate import CubicSpline

    check_rate(rate, plan.duration)
    t = _times(plan.duration, rate)
    q, qd, qdd = {}, {}, {}
    for arm, samples in plan.q.items():
        samples = np.asarray(samples, float)
        if plan.time.size < 2:  # a plan of one instant: the arm stands still
            q[arm], qd[arm], qdd[arm] = np.repeat(samples[:1], t.size, axis=0), np.zeros((t.size, 2)), np.zeros((t.size, 2))
            continue
        rest = ((1, np.zeros(2)), (1, np.zeros(2)))
        spline = CubicSpline(plan.time, samples, axis=0, bc_type=rest)
        q[arm], qd[arm], qdd[arm] = spline(t), _flushed(spline(t, 1)), _flushed(spline(t, 2))
    carriage = None
    if plan.gantry_x is not None:  # a row: the carriage is one more (prismatic) axis, derived the same way
        x = np.asarray(plan.gantry_x, float)
        if plan.time.size < 2:
            carriage = (np.full(t.size, x[0]), np.zeros(t.size), np.zeros(t.size))
        else:
            cs = CubicSpline(plan.time, x, bc_type=((1, 0.0), (1, 0.0)))
            carriage = (cs(t), _flushed(cs(t, 1)), _flushed(cs(t, 2)))
    return Trajectory(t, q, qd, qdd, float(rate), carriage)


def follow_error(plan: Plan, traj: Trajectory) -> tuple[float, str | None, float]:
    """How far a controller following the exported points departs from the plan: cubic between
    points with their velocities (as a ROS joint trajectory controller does), against the plan's
    own samples. Returns ``(largest error in rad, its arm, its time)``; ``(0, None, 0)`` for a
    plan of one instant. At a rate too low for the motion (0.3 Hz: an export whose two points
    were both home) the points say little of what the plan does."""
    from scipy.interpolate import CubicHermiteSpline

    worst, arm_at, t_at = 0.0, None, 0.0
    if plan.time.size < 2 or traj.time.size < 2:
        return worst, arm_at, t_at
    for arm, samples in plan.q.items():
        follow = CubicHermiteSpline(traj.time, traj.q[arm], traj.qd[arm], axis=0)(plan.time)
        err = np.abs(follow - np.asarray(samples, float)).max(axis=1)
        k = int(np.argmax(err))
        if err[k] > worst:
            worst, arm_at, t_at = float(err[k]), arm, float(plan.time[k])
    return worst, arm_at, t_at


def _flushed(v: np.ndarray, tiny: float = 1e-12) -> np.ndarray:
    """Rates whose magnitude is below ``tiny`` -- the spline's rounding at rest, down to denormals
    like -1e-258 -- as exact zeros (a controller reads a joint at rest)."""
    return np.where(np.abs(v) < tiny, 0.0, v)


_SAFE = re.compile(r"[^A-Za-z0-9_.-]+")


#: The carriage's key among a row's export names (not an arm name: an arm may be called "carriage").
CARRIAGE = object()


def export_names(plan) -> dict:
    """``{arm name (or CARRIAGE): file and joint-name stem}`` of a JSON/YAML export: a row's
    carriage first, as ``carriage``, so that an arm of that name becomes ``carriage_2`` (it took
    the carriage's file, and the carriage's trajectory was lost)."""
    return _unique(([(CARRIAGE, "carriage")] if plan.gantry_x is not None else [])
                   + [(a, _safe(a, k)) for k, a in enumerate(plan.q)])


def _safe(name, k: int) -> str:
    """A file-system and ROS-safe stem for the ``k``-th (untrusted) arm name: never empty, never hidden."""
    return _SAFE.sub("_", str(name)).strip("._") or f"arm{k}"


def _unique(pairs) -> dict:
    """``{key: base}`` made unique, case-blind, in order (``base_2``, ``base_3`` ...)."""
    out: dict = {}
    used: set[str] = set()
    for key, base in pairs:
        cand, i = base, 2
        while cand.lower() in used:
            cand, i = f"{base}_{i}", i + 1
        used.add(cand.lower())
        out[key] = cand
    return out


def safe_names(names: list[str]) -> dict[str, str]:
    """File-system and ROS-safe names for untrusted arm names (unique, never empty, never hidden)."""
    return _unique((name, _safe(name, k)) for k, name in enumerate(names))


def csv_text(traj: Trajectory) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    arms = list(traj.q)
    w.writerow(["t"] + [f"{a}_{c}" for a in arms for c in ("q1", "q2", "qd1", "qd2", "qdd1", "qdd2")]
               + (["carriage_x", "carriage_v", "carriage_a"] if traj.carriage is not None else []))
    cols = [traj.time[:, None]] + [np.hstack([traj.q[a], traj.qd[a], traj.qdd[a]]) for a in arms]
    if traj.carriage is not None:
        cols.append(np.column_stack(traj.carriage))
    for row in np.hstack(cols):
        w.writerow([f"{row[0]:.6f}"] + [f"{x:.9g}" for x in row[1:]])
    return buf.getvalue()


def joint_trajectory(traj: Trajectory, arm: str, joint_prefix: str, frame_id: str = "") -> dict:
    """One arm as a ROS 2 ``trajectory_msgs/msg/JointTrajectory`` (plain data)."""
    points = []
    for k, t in enumerate(traj.time):
        ns = int(round(float(t) * 1e9))
        points.append({
            "positions": [float(x) for x in traj.q[arm][k]],
            "velocities": [float(x) for x in traj.qd[arm][k]],
            "accelerations": [float(x) for x in traj.qdd[arm][k]],
            "effort": [],
            "time_from_start": {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000},
        })
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": frame_id},
            "joint_names": [f"{joint_prefix}_joint1", f"{joint_prefix}_joint2"], "points": points}


def carriage_trajectory(traj: Trajectory, name: str = "carriage", frame_id: str = "") -> dict:
    """A row plan's carriage as a ROS 2 ``JointTrajectory`` of one prismatic joint (m, m/s, m/s^2)."""
    x, v, a = traj.carriage
    points = []
    for k, t in enumerate(traj.time):
        ns = int(round(float(t) * 1e9))
        points.append({"positions": [float(x[k])], "velocities": [float(v[k])], "accelerations": [float(a[k])], "effort": [],
                       "time_from_start": {"sec": ns // 1_000_000_000, "nanosec": ns % 1_000_000_000}})
    return {"header": {"stamp": {"sec": 0, "nanosec": 0}, "frame_id": frame_id}, "joint_names": [f"{name}_x"], "points": points}


def export_plan(plan: Plan, rate: float, fmt: ExportFormat | str, out: str | Path) -> list[Path]:
    """Write the plan at ``rate`` Hz: ``csv`` to the file ``out``; ``json``/``yaml`` one file per
    arm (``<arm>.json``) into the folder ``out``. Each file is written whole or not at all.
    Returns the paths written."""
    fmt = ExportFormat(fmt)
    traj = trajectory(plan, rate)
    out = Path(out)
    if fmt == ExportFormat.CSV:
        out.parent.mkdir(parents=True, exist_ok=True)
        atomic_text(out, csv_text(traj))
        return [out]
    out.mkdir(parents=True, exist_ok=True)
    names = export_names(plan)
    written = []
    for arm in list(traj.q) + ([CARRIAGE] if traj.carriage is not None else []):
        msg = joint_trajectory(traj, arm, names[arm]) if arm != CARRIAGE else carriage_trajectory(traj, names[arm])
        if fmt == ExportFormat.JSON:
            text = json.dumps(msg, indent=None, separators=(",", ":"), allow_nan=False)
        else:
            import yaml

            text = yaml.dump(msg, Dumper=getattr(yaml, "CSafeDumper", yaml.SafeDumper), sort_keys=False, default_flow_style=None)
        path = out / f"{names[arm]}.{fmt.value}"
        atomic_text(path, text)
        written.append(path)
    return written
