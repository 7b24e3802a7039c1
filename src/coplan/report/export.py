"""A plan as a joint controller takes it (``coplan export PLAN --rate HZ --format csv|json|yaml``).

:func:`trajectory` resamples every arm's joints at a chosen rate with their velocities and
accelerations; :func:`export_plan` writes them as

* ``csv``: one file, one row per time: ``t`` (s) then, per arm, ``<arm>_q1, <arm>_q2, <arm>_qd1,
  <arm>_qd2, <arm>_qdd1, <arm>_qdd2`` (rad, rad/s, rad/s^2; names quoted by the ``csv`` module),
  a row's ``carriage_x, carriage_v, carriage_a`` (m, m/s, m/s^2) last; times and positions at
  full precision (``coplan verify PROBLEM export.csv`` checks the table itself: a finite
  difference at 1 kHz magnifies a ninth digit's rounding into the jerk), the rates to 9 digits;
* ``json`` / ``yaml``: one file per arm in a folder, each a ROS 2
  ``trajectory_msgs/msg/JointTrajectory`` (``header``, ``joint_names``, ``points`` with
  ``positions``, ``velocities``, ``accelerations``, ``effort``, ``time_from_start: {sec,
  nanosec}``), loadable field for field into the message (e.g. ``rosidl_runtime_py.set_message_fields``).

Where the derivatives come from: ``plan.json`` holds positions on a uniform grid (100 Hz, step
``dt``), the samples the verifier checked: their first, second and third differences / ``dt^k``
within the velocity, acceleration and jerk limits. The export is the uniform cubic B-spline whose
control points are those samples (each end's sample repeated), differentiated exactly. Its
velocity, acceleration and jerk are at every instant weighted means of the samples' first,
second and third differences (the B-spline's derivatives are B-splines of the differences), so
**no exported value, and no finite difference of the exported positions at any rate, exceeds
what the verifier accepted** in the plan -- an interpolating spline through the samples
overshoots them (about 1 % in acceleration and 11 % in jerk at 250 Hz, measured on the
coordinated cell plan). The price: the curve passes near, not through, the samples, by at most a
sixth of a second difference (``|q[k-1] - 2 q[k] + q[k+1]| / 6``: about 2e-4 rad at a 12 rad/s^2
limit; :func:`follow_error` reports how far a controller would depart from the plan), and,
symmetric about each sample, it starts moving one step before the plan does. So the export is
the plan **delayed by one step** (:attr:`Trajectory.delay`, 10 ms at 100 Hz), every arm and the
carriage alike (their relative timing, which clearance depends on, unchanged): it starts at t = 0
exactly at rest, ends exactly at rest two steps after the plan's duration, and stands exactly
still wherever the plan holds a pose for four samples or more (a dwell), but for a step at each
end of the hold (a 0.5 s dwell: 0.48 s exactly still). The grid is uniform at
the rate asked for, its last point the first at or after the end.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..kinds import ExportFormat
from ..plan import Plan, PlanStatus
from ..output import atomic_texts

__all__ = ["ExportFormat", "Trajectory", "trajectory", "export_plan", "follow_error", "limit_excess", "export_events", "events_path", "smoothing_error", "FOLLOW_TOLERANCE",
           "restored", "restored_samples", "FILE_RESOLUTION",
           "MAX_POINTS", "MAX_RATE"]

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
    delay: float = 0.0  # s: the export at ``t`` is the plan at ``t - delay`` (module docstring)


def _times(duration: float, rate: float) -> np.ndarray:
    """A uniform grid at ``rate`` from 0 to the first point at or after ``duration``."""
    n = int(math.ceil(duration * rate - 1e-9))
    return np.arange(n + 1) / rate


def _smoothed(samples: np.ndarray, dt: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The uniform cubic B-spline over ``samples`` (N, ...) at plan step ``dt``, delayed by one
    step (module docstring), and its first two derivatives, at times ``t`` (K,): (K, ...) each.
    Exactly at rest at and before 0 and from ``(N + 1) dt`` on."""
    from scipy.interpolate import BSpline

    n = samples.shape[0]
    ctrl = np.concatenate([samples[:1], samples[:1], samples, samples[-1:], samples[-1:]])  # (N + 4, ...)
    knots = (np.arange(n + 8) - 3.0) * dt  # control point i centred at (i - 1) dt: the first sample at one step
    spline = BSpline(knots, ctrl, 3, extrapolate=False)
    u = np.clip(t, 0.0, (n + 1) * dt)
    out = [spline(u, nu) for nu in (0, 1, 2)]
    first, last = t <= 0.0, t >= (n + 1) * dt  # (at and past the clips: the end poses exactly, at rest)
    out[0][first], out[0][last] = samples[0], samples[-1]
    for d in out[1:]:
        d[first | last] = 0.0
    return out[0], out[1], out[2]


def _span(plan: Plan) -> tuple[float, float]:
    """``(the export's delay, its length in s)``: the plan one step later, at rest two steps after its end."""
    delay = 0.0 if plan.time.size < 2 else float(plan.dt)
    return delay, plan.duration + 2.0 * delay


def check_rate(rate: float, plan: Plan) -> None:
    """Raise ``ValueError`` (with the reason) for a rate no export of ``plan`` can use: not a
    rate, or more than :data:`MAX_POINTS` points per arm (the export's own count: its grid runs
    two plan steps past the plan's end)."""
    if not (isinstance(rate, (int, float)) and not isinstance(rate, bool) and math.isfinite(rate) and 0 < rate <= MAX_RATE):
        raise ValueError(f"expected a rate in (0, {MAX_RATE:g}] Hz, found {rate!r}")
    length = _span(plan)[1]
    n = int(math.ceil(length * rate - 1e-9)) + 1  # (the size of _times(length, rate))
    if n > MAX_POINTS:
        raise ValueError(f"expected at most {MAX_POINTS} points per arm, found {n} ({length:.1f} s at {rate:g} Hz)")


def trajectory(plan: Plan, rate: float) -> Trajectory:
    """Positions, velocities and accelerations of every arm at ``rate`` Hz on a uniform grid from
    t = 0, the plan delayed by one step and at rest at both ends (module docstring)."""
    check_rate(rate, plan)
    one = plan.time.size < 2  # a plan of one instant: everything stands still
    delay, length = _span(plan)
    t = _times(length, rate)
    q, qd, qdd = {}, {}, {}
    for arm, samples in plan.q.items():
        samples = np.asarray(samples, float)
        if one:
            q[arm], qd[arm], qdd[arm] = np.repeat(samples[:1], t.size, axis=0), np.zeros((t.size, 2)), np.zeros((t.size, 2))
            continue
        p, v, a = _smoothed(samples, plan.dt, t)
        q[arm], qd[arm], qdd[arm] = p, _flushed(v), _flushed(a)
    carriage = None
    if plan.gantry_x is not None:  # a row: the carriage is one more (prismatic) axis, derived the same way
        x = np.asarray(plan.gantry_x, float)
        if one:
            carriage = (np.full(t.size, x[0]), np.zeros(t.size), np.zeros(t.size))
        else:
            p, v, a = _smoothed(x, plan.dt, t)
            carriage = (p, _flushed(v), _flushed(a))
    return Trajectory(t, q, qd, qdd, float(rate), carriage, delay)


#: The resolution of a plan file's samples (plan.json and plan.csv keep 1e-7 rad, 1e-7 m).
FILE_RESOLUTION = 1e-7
_STENCILS = {1: np.array([-1.0, 1.0]), 2: np.array([1.0, -2.0, 1.0]), 3: np.array([-1.0, 3.0, -3.0, 1.0])}


def restored_samples(values: np.ndarray, dt: float, limits: tuple[float, float, float], resolution: float = FILE_RESOLUTION,
                     room: float = 1e-7) -> np.ndarray | None:
    """Samples ``values`` (N,) of one joint (or the carriage), rounded to ``resolution``, moved
    within that rounding (at most half a step each) so that their first, second and third
    differences / ``dt^k`` keep ``limits`` (velocity, acceleration, jerk) to ``room`` (relative);
    None where no such samples are found. The full-precision samples the rounding came from are
    such samples; rounded, a plan that runs at its limits comes out over them in its differences
    (8 x half a step in a third difference: 0.4 rad/s^3 at 100 Hz, 0.3 % of a 120 rad/s^3 limit),
    and so would its export. An LP (HiGHS) over the samples near a difference over its limit
    (within ``k`` samples, then 30, then all), each pose held for three samples or more kept."""
    from scipy import sparse
    from scipy.optimize import linprog

    r = np.asarray(values, float)
    n = r.size
    caps = {k: limits[k - 1] * dt**k * (1.0 + room) for k in (1, 2, 3)}
    bad = np.zeros(n, bool)
    for k in (1, 2, 3):
        over = np.flatnonzero(np.abs(np.diff(r, n=k)) > caps[k])
        for m in range(k + 1):
            bad[over + m] = True
    if not bad.any():
        return r
    held = np.r_[False, r[1:] == r[:-1]] & np.r_[r[:-1] == r[1:], False]  # (a pose held: its inner samples stay)
    for grow in (10, 30, n):
        free = bad.copy()
        for g in range(1, min(grow, n - 1) + 1):
            free[g:] |= bad[:-g]
            free[:-g] |= bad[g:]
        free &= ~held
        idx = np.flatnonzero(free)
        col = np.full(n, -1)
        col[idx] = np.arange(idx.size)
        rows, cols, vals, ub, lb = [], [], [], [], []
        count = 0
        for k in (1, 2, 3):
            starts = np.unique(np.clip((idx[:, None] - np.arange(k + 1)[None, :]).ravel(), 0, n - 1 - k))
            if starts.size == 0:
                continue
            window = starts[:, None] + np.arange(k + 1)[None, :]  # (S, k + 1) samples of each difference
            const = r[window] @ _STENCILS[k]
            c = col[window]
            at = np.nonzero(c >= 0)
            rows.append(count + at[0])
            cols.append(c[at])
            vals.append(_STENCILS[k][at[1]])
            ub.append((caps[k] - const) / resolution)  # (in steps of the rounding: HiGHS's tolerances are absolute)
            lb.append((-caps[k] - const) / resolution)
            count += starts.size
        a = sparse.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(count, idx.size))
        res = linprog(np.zeros(idx.size), A_ub=sparse.vstack([a, -a]).tocsr(),
                      b_ub=np.concatenate(ub + [-b for b in lb]), bounds=(-0.5, 0.5), method="highs")
        if res.status == 0:
            x = r.copy()
            x[idx] += res.x * resolution
            return x
        if grow >= n:
            break
    return None


def restored(plan: Plan, problem) -> tuple[Plan, bool]:
    """``plan`` with every arm's joints and the carriage restored within their file rounding to
    keep ``problem``'s limits (:func:`restored_samples`) where they are rounded (a plan.json read
    without its plan.npz); ``(plan, whether every series is within its limits now)``. Its motion
    is not the file's to the last digit: export it, do not verify it in place of the file."""
    from dataclasses import replace

    from ..plan import on_lattice

    if plan.time.size < 4 or not all(on_lattice(q) for q in plan.q.values()):
        return plan, True
    ok = True
    arms = {a.name: a for a in problem.arms}
    q = {}
    for name, samples in plan.q.items():
        samples = np.asarray(samples, float)
        arm = arms.get(name)
        if arm is None:
            q[name] = samples
            continue
        cols = []
        for j in range(2):
            x = restored_samples(samples[:, j], plan.dt, (arm.max_velocity[j], arm.max_acceleration[j], arm.max_jerk[j]))
            ok &= x is not None
            cols.append(samples[:, j] if x is None else x)
        q[name] = np.column_stack(cols)
    gx = plan.gantry_x
    if gx is not None and problem.gantry is not None and on_lattice(gx):
        g = problem.gantry
        x = restored_samples(np.asarray(gx, float), plan.dt, (g.max_velocity, g.max_acceleration, g.max_jerk))
        ok &= x is not None
        gx = gx if x is None else x
    return replace(plan, q=q, gantry_x=gx), ok


def limit_excess(traj: Trajectory, problem) -> dict[str, tuple[float, str]]:
    """``{velocity|acceleration|jerk: (ratio, arm)}``: the largest finite difference of the
    exported positions (first, second and third, over the export's step) against the problem's
    joint limits -- what ``coplan verify`` of the export measures -- and whose (1 or less:
    within the limit)."""
    worst: dict[str, tuple[float, str]] = {}
    dt = 1.0 / traj.rate
    limits = {a.name: (a.max_velocity, a.max_acceleration, a.max_jerk) for a in problem.arms}
    for arm, q in traj.q.items():
        if arm not in limits or q.shape[0] < 4:
            continue
        for k, (what, lim) in enumerate(zip(("velocity", "acceleration", "jerk"), limits[arm]), start=1):
            r = float((np.abs(np.diff(q, n=k, axis=0)) / dt**k / np.asarray(lim, float)).max())
            if r > worst.get(what, (0.0, ""))[0]:
                worst[what] = (r, arm)
    return worst


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
        follow = CubicHermiteSpline(traj.time, traj.q[arm], traj.qd[arm], axis=0)(plan.time + traj.delay)
        err = np.abs(follow - np.asarray(samples, float)).max(axis=1)
        k = int(np.argmax(err))
        if err[k] > worst:
            worst, arm_at, t_at = float(err[k]), arm, float(plan.time[k])
    return worst, arm_at, t_at


def smoothing_error(plan: Plan) -> tuple[float, str | None, float]:
    """How far the export's curve passes from the plan's samples whatever the rate: the uniform
    cubic B-spline's value at a sample is ``(q[k-1] + 4 q[k] + q[k+1]) / 6``, a sixth of the second
    difference from it. Returns ``(largest in rad, its arm, its time)``; a part of
    :func:`follow_error` that no rate removes (a plan that accelerates hard for its sampling)."""
    worst, arm_at, t_at = 0.0, None, 0.0
    for arm, samples in plan.q.items():
        q = np.asarray(samples, float)
        if q.shape[0] < 3:
            continue
        err = np.abs(q[:-2] - 2.0 * q[1:-1] + q[2:]).max(axis=1) / 6.0
        k = int(np.argmax(err))
        if err[k] > worst:
            worst, arm_at, t_at = float(err[k]), arm, float(plan.time[k + 1])
    return worst, arm_at, t_at


def _flushed(v: np.ndarray, tiny: float = 1e-12) -> np.ndarray:
    """Rates whose magnitude is below ``tiny`` -- the spline's rounding at rest, down to denormals
    like -1e-258 -- as exact zeros (a controller reads a joint at rest)."""
    return np.where(np.abs(v) < tiny, 0.0, v)


_SAFE = re.compile(r"[^A-Za-z0-9_.-]+")


#: The carriage's key among a row's export names (not an arm name: an arm may be called "carriage").
CARRIAGE = object()
EVENTS = object()  # the events file's stem in a JSON/YAML export's folder


def export_names(plan) -> dict:
    """``{arm name (or CARRIAGE): file and joint-name stem}`` of a JSON/YAML export: a row's
    carriage first, as ``carriage``, so that an arm of that name becomes ``carriage_2`` (it took
    the carriage's file, and the carriage's trajectory was lost); ``EVENTS``, the picks and
    places, last: ``events``, or ``events_2`` beside an arm of that name (which keeps its own)."""
    return _unique(([(CARRIAGE, "carriage")] if plan.gantry_x is not None else [])
                   + [(a, _safe(a, k)) for k, a in enumerate(plan.q)] + [(EVENTS, "events")])


#: names Windows keeps for devices, whatever follows the dot (CON.json is the console there)
_DEVICES = {"con", "prn", "aux", "nul"} | {f"{d}{i}" for d in ("com", "lpt") for i in range(1, 10)}


def _safe(name, k: int) -> str:
    """A file-system and ROS-safe stem for the ``k``-th (untrusted) arm name: never empty, never
    hidden, never a Windows device name (``CON`` -> ``CON_``)."""
    stem = _SAFE.sub("_", str(name)).strip("._") or f"arm{k}"
    head, dot, tail = stem.partition(".")  # (NUL.anything is the device too: the mark goes before the first dot)
    return f"{head}_{dot}{tail}" if head.lower() in _DEVICES else stem


def _unique(pairs) -> dict:
    """``{key: base}`` made unique, case-blind (``base_2``, ``base_3`` ...): a row's carriage and
    every name that is safe as it is keep theirs first, the rest in order
    (arms "a b" and "a_b": "a b" took a_b.json and the arm named a_b became a_b_2)."""
    pairs = list(pairs)
    # (the events file last: an arm named events keeps its file, and the events take events_2)
    first = [k for k, (key, base) in enumerate(pairs) if key is CARRIAGE or (key is not EVENTS and base == key)]
    chosen: dict[int, str] = {}
    used: set[str] = set()
    for k in first + [k for k in range(len(pairs)) if k not in first]:
        base = pairs[k][1]
        cand, i = base, 2
        while cand.lower() in used:
            cand, i = f"{base}_{i}", i + 1
        used.add(cand.lower())
        chosen[k] = cand
    return {key: chosen[k] for k, (key, _) in enumerate(pairs)}


def safe_names(names: list[str]) -> dict[str, str]:
    """File-system and ROS-safe names for untrusted arm names (unique, never empty, never hidden)."""
    return _unique((name, _safe(name, k)) for k, name in enumerate(names))


def export_events(plan: Plan, traj: Trajectory) -> list[dict]:
    """The plan's picks and places on the export's clock (each time + ``traj.delay``: the export is
    the plan one step later), in time order: ``{arm, fruit, kind, t_start, t_end}`` -- when the
    gripper closes and opens, without rebuilding them from plan.json's clock."""
    return [{"arm": e.arm, "fruit": e.fruit, "kind": e.kind.value, "t_start": round(e.t_start + traj.delay, 9),
             "t_end": round(e.t_end + traj.delay, 9)} for e in sorted(plan.events, key=lambda e: (e.t_start, e.arm))]


def events_path(out: Path) -> Path:
    """Where a CSV export's events go: ``<name>.events.csv`` beside it."""
    return out.with_name(out.stem + ".events.csv")


def events_csv(events: list[dict]) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    w.writerow(["arm", "fruit", "kind", "t_start", "t_end"])
    for e in events:
        w.writerow([e["arm"], e["fruit"], e["kind"], repr(e["t_start"]), repr(e["t_end"])])
    return buf.getvalue()


def csv_text(traj: Trajectory) -> str:
    buf = io.StringIO()
    w = csv.writer(buf, lineterminator="\n")
    arms = list(traj.q)
    w.writerow(["t"] + [f"{a}_{c}" for a in arms for c in ("q1", "q2", "qd1", "qd2", "qdd1", "qdd2")]
               + (["carriage_x", "carriage_v", "carriage_a"] if traj.carriage is not None else []))
    cols = [traj.time[:, None]] + [np.hstack([traj.q[a], traj.qd[a], traj.qdd[a]]) for a in arms]
    if traj.carriage is not None:
        cols.append(np.column_stack(traj.carriage))
    exact = np.zeros(1 + 6 * len(arms) + (3 if traj.carriage is not None else 0), dtype=bool)
    exact[0] = True
    for i in range(len(arms)):
        exact[1 + 6 * i: 3 + 6 * i] = True  # positions as stored (shortest exact text): verifiable at any rate
    if traj.carriage is not None:
        exact[-3] = True
    for row in np.hstack(cols):
        w.writerow([repr(float(x)) if e else f"{x:.9g}" for x, e in zip(row, exact)])
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


def export_plan(plan: Plan | str | Path, rate: float, fmt: ExportFormat | str, out: str | Path, traj: Trajectory | None = None,
                replaces: list[Path] | tuple = (), before=None) -> list[Path]:
    """Write the plan at ``rate`` Hz: ``csv`` to the file ``out`` (and its picks and places, on the
    export's clock, to ``<out>.events.csv`` beside it); ``json``/``yaml`` one file per arm
    (``<arm>.json``) and ``events.json`` into the folder ``out``. Each file is written whole or not at all.
    ``traj``: :func:`trajectory` ``(plan, rate)`` when the caller has it already. Returns the
    paths written; the files go into place together (:func:`coplan.output.atomic_texts`: a Ctrl-C
    or a full disk leaves the files there were, not some of each), and each of ``replaces`` (an
    earlier export's files this one does not overwrite) is removed with them; ``before()`` is called
    just before they are (what it raises leaves every file as it was). ``plan`` may be a
    plan file's path (read with :func:`coplan.plan.load_plan`).
    It writes what it is given: ``coplan export`` verifies the plan against its problem first
    (:func:`coplan.verify.verify` does it here); a plan without events (a plan.csv) gives an empty
    events file unless its events are inferred first (:func:`coplan.verify.infer.infer_events`)."""
    if isinstance(plan, (str, os.PathLike)):  # (a path raised "'str' object has no attribute 'time'")
        from ..plan import load_plan

        plan = load_plan(plan)
    elif not isinstance(plan, Plan):
        raise TypeError(f"plan: expected a Plan or a plan file's path, found {type(plan).__name__}")
    fmt = ExportFormat(fmt)
    if plan.status == PlanStatus.UNSAFE or plan.changed_since_verified():  # (the CLI refuses it; a script wrote it without a word)
        import warnings

        why = ("the verifier refused it (unsafe)" if plan.status == PlanStatus.UNSAFE else
               "its motion changed after it was verified")
        warnings.warn(f"export_plan: writing the plan of {plan.problem!r} ({plan.planner_name}) though {why}: not a "
                      f"trajectory to send to a robot (coplan export refuses it)", UserWarning, stacklevel=2)
    if traj is not None and abs(traj.rate - rate) > 1e-9 * max(1.0, rate):  # (it wrote at the trajectory's 50 Hz, asked 100)
        raise ValueError(f"traj: expected trajectory(plan, {rate:g}) at the rate asked, found one at {traj.rate:g} Hz")
    traj = trajectory(plan, rate) if traj is None else traj
    out = Path(out)
    events = export_events(plan, traj)
    if fmt == ExportFormat.CSV:
        out.parent.mkdir(parents=True, exist_ok=True)
        atomic_texts([(out, csv_text(traj)), (events_path(out), events_csv(events))], replaces, before)
        return [out, events_path(out)]
    if out.suffix.lower() in (".json", ".yaml", ".yml", ".csv") and not out.is_dir():
        # (json and yaml write a folder of files: "ex.json" made a folder of that name)
        raise ValueError(f"out: expected a folder for {fmt.value} (one file per arm and events.{fmt.value}), found the "
                         f"file name {str(out)!r}; give a folder (e.g. {str(out.with_suffix(''))!r})")
    out.mkdir(parents=True, exist_ok=True)
    names = export_names(plan)
    written = []
    for arm in [EVENTS] + list(traj.q) + ([CARRIAGE] if traj.carriage is not None else []):
        msg = ({"events": events} if arm is EVENTS else
               joint_trajectory(traj, arm, names[arm]) if arm is not CARRIAGE else carriage_trajectory(traj, names[arm]))
        if fmt == ExportFormat.JSON:
            text = json.dumps(msg, indent=None, separators=(",", ":"), allow_nan=False)
        else:
            import yaml

            text = yaml.dump(msg, Dumper=getattr(yaml, "CSafeDumper", yaml.SafeDumper), sort_keys=False, default_flow_style=None)
        written.append((out / f"{names[arm]}.{fmt.value}", text))
    atomic_texts(written, replaces, before)  # (whole or not at all: the files of one export, never two plans')
    return [p for p, _ in written]
