"""Pick and place events inferred from the motion, for plans that declare none.

A plan from another tool (or coplan's own ``plan.csv``, which holds only the joint samples)
may declare no events. :func:`infer_events` finds them the way the verifier checks declared
ones (:func:`coplan.verify.verify`): an arm *holds* on a target over a run of plan intervals
in which its tip stays within ``position_tolerance`` of the target and no point of the arm is
faster than ``still_speed`` (the same bound on the linear replay the verifier uses), for at
least the dwell less ``dwell_tolerance``. Holds are taken in time order over all arms:

* a hold on a fruit the arm can reach, while the arm holds nothing and nobody picked that
  fruit yet, is a **pick** (the earliest hold wins a fruit two arms visit); in a row (a
  ``plan.csv`` with its ``gantry_x`` column) the tip holds still in the row frame, the carriage
  at rest or moving, as the verifier checks a declared pick (:mod:`coplan.verify.hold`);
* the next hold over the arm's bin is its **place**.

Each inferred pick spans its whole hold, a place its dwell and two samples from the hold's start
(an arm may rest over its bin long after: the plan's makespan is not that rest), so the verifier then checks
each like a declared one.
Part of the verifier: it uses no planner code.
"""

from __future__ import annotations

import numpy as np

from .clearance import ArmMotion, runs
from .hold import bin_track, holds_on
from ..plan import Event, EventKind, Plan
from ..problem.model import Problem
from .verdict import VerifyOptions

__all__ = ["infer_events", "near_intervals"]


def _holds(m: ArmMotion, tip: np.ndarray, time: np.ndarray, target, min_hold: float, opts: VerifyOptions,
           row_frame: bool = False, near: np.ndarray | None = None) -> list[tuple[float, float]]:
    """``(t_start, t_end)`` of every run of intervals over which the arm holds on ``target``
    (:func:`coplan.verify.hold.holds_on`: the verifier's own test), at least ``min_hold`` long;
    ``near``: the intervals worth testing (all by default)."""
    n = np.arange(time.size - 1) if near is None else near
    if not n.size:
        return []
    on = np.zeros(time.size - 1, dtype=bool)
    on[n] = holds_on(m, tip, time, target, n, opts, row_frame)
    out = []
    for a, b in runs(on):
        t0, t1 = float(time[a]), float(time[b + 1])
        if t1 - t0 >= min_hold - 1e-9:  # (a hold of 29 samples at 10 ms is 0.28999999999999915 s)
            out.append((t0, t1))
    return out


def near_intervals(tip: np.ndarray, by_x: np.ndarray, point, radius: float) -> np.ndarray:
    """Indices ``n`` of the sample intervals ``[n, n + 1]`` with a sample of ``tip`` (T, 2)
    within ``radius`` of ``point``, sorted; ``by_x``: ``tip``'s sample indices sorted by x (one
    sort per arm, then a bisection per fruit: on a long row the tip comes near a fruit in a
    few of its hundreds of thousands of samples)."""
    x = tip[by_x, 0]
    lo = np.searchsorted(x, point[0] - radius - 1e-9, "left")  # (a hair wider: the distance below decides)
    hi = np.searchsorted(x, point[0] + radius + 1e-9, "right")
    cand = by_x[lo:hi]
    k = np.sort(cand[np.hypot(tip[cand, 0] - point[0], tip[cand, 1] - point[1]) <= radius])
    n = np.union1d(k, k - 1)
    return n[(n >= 0) & (n < tip.shape[0] - 1)]


def infer_events(problem: Problem, plan: Plan, motions: list[ArmMotion], opts: VerifyOptions | None = None) -> list[Event]:
    """Pick and place events of ``plan`` inferred from its motion (module docstring); sorted by time.

    ``motions`` are the replayed arms (:func:`coplan.verify.clearance.arm_motions`, problem order)."""
    opts = opts or VerifyOptions()
    time = np.asarray(plan.time, float)
    if time.size < 2:
        return []
    dwell_tol = plan.dt if opts.dwell_tolerance is None else opts.dwell_tolerance
    task = problem.task
    row = problem.gantry is not None  # picks in the row frame, places over the bin the carriage carries
    reach = None if row else problem.reach_matrix()
    holds: list[tuple[float, float, str, EventKind, str | None]] = []
    for ia, (arm, m) in enumerate(zip(problem.arms, motions)):
        tip = m.tips()  # (the row frame for a row: the carriage's shift included)
        still = np.flatnonzero(m.speed <= opts.still_speed)  # (a cell's holds, and every place)
        by_x = np.argsort(tip[:, 0], kind="stable") if row else None
        for j, f in enumerate(problem.fruits):
            if row:  # only where the tip comes near the fruit (a long row, many fruit)
                near = near_intervals(tip, by_x, f.position, opts.position_tolerance + 0.05)
            elif not reach[ia, j]:
                continue
            else:
                near = still
            holds += [(t0, t1, arm.name, EventKind.PICK, f.id)
                      for t0, t1 in _holds(m, tip, time, f.position, task.pick_dwell - dwell_tol, opts, row, near)]
        # a place lasts its dwell (and two samples: an arm settling within the tolerance before
        # it is still) from the hold's start: an arm may rest over its bin long after (on the
        # move, to the row's end), and the fruit was dropped once the dwell was over
        holds += [(t0, min(t1, t0 + task.place_dwell + 2.0 * plan.dt), arm.name, EventKind.PLACE, None)
                  for t0, t1 in _holds(m, tip, time, bin_track(arm.bin, plan.gantry_x if row else None),
                                       task.place_dwell - dwell_tol, opts, False, still)]
    holds.sort(key=lambda h: (h[0], h[2], h[3] != EventKind.PICK))
    holding: dict[str, str] = {}
    picked: set[str] = set()
    events: list[Event] = []
    for t0, t1, arm, kind, fid in holds:
        if kind == EventKind.PICK and arm not in holding and fid not in picked:
            holding[arm] = fid
            picked.add(fid)
            events.append(Event(arm, fid, EventKind.PICK, t0, t1))
        elif kind == EventKind.PLACE and arm in holding:
            events.append(Event(arm, holding.pop(arm), EventKind.PLACE, t0, t1))
    return events
