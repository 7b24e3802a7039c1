"""Pick and place events inferred from the motion, for plans that declare none.

A plan from another tool (or coplan's own ``plan.csv``, which holds only the joint samples)
may declare no events. :func:`infer_events` finds them the way the verifier checks declared
ones (:func:`coplan.verify.verify`): an arm *holds* on a target over a run of plan intervals
in which its tip stays within ``position_tolerance`` of the target and no point of the arm is
faster than ``still_speed`` (the same bound on the linear replay the verifier uses), for at
least the dwell less ``dwell_tolerance``. Holds are taken in time order over all arms:

* a hold on a fruit the arm can reach, while the arm holds nothing and nobody picked that
  fruit yet, is a **pick** (the earliest hold wins a fruit two arms visit);
* the next hold over the arm's bin is its **place**.

Each inferred event spans its whole hold, so the verifier then checks it like a declared one.
Part of the verifier: it uses no planner code.
"""

from __future__ import annotations

import numpy as np

from ..kinematics import arm as kin
from .clearance import ArmMotion, runs
from ..plan import Event, EventKind, Plan
from ..problem.model import Problem
from .verdict import VerifyOptions

__all__ = ["infer_events"]


def _holds(m: ArmMotion, tip: np.ndarray, time: np.ndarray, still: np.ndarray, target, min_hold: float,
           opts: VerifyOptions) -> list[tuple[float, float]]:
    """``(t_start, t_end)`` of every run of intervals with the tip on ``target`` and the arm still."""
    idx = np.flatnonzero(still)
    if not idx.size:
        return []
    dt = time[1] - time[0]
    pos = np.asarray(target, float)
    d0 = np.hypot(*(tip[idx] - pos).T)
    d1 = np.hypot(*(tip[idx + 1] - pos).T)
    # the tip stays within (d0 + d1 + V dt) / 2 of the target over the whole interval
    on = np.zeros(still.size, dtype=bool)
    on[idx] = (d0 + d1 + m.speed[idx] * dt) / 2 <= opts.position_tolerance
    out = []
    for a, b in runs(on):
        t0, t1 = float(time[a]), float(time[b + 1])
        if t1 - t0 >= min_hold:
            out.append((t0, t1))
    return out


def infer_events(problem: Problem, plan: Plan, motions: list[ArmMotion], opts: VerifyOptions | None = None) -> list[Event]:
    """Pick and place events of ``plan`` inferred from its motion (module docstring); sorted by time.

    ``motions`` are the replayed arms (:func:`coplan.verify.clearance.arm_motions`, problem order)."""
    opts = opts or VerifyOptions()
    time = np.asarray(plan.time, float)
    if time.size < 2:
        return []
    dwell_tol = plan.dt if opts.dwell_tolerance is None else opts.dwell_tolerance
    task = problem.task
    reach = problem.reach_matrix()
    holds: list[tuple[float, float, str, EventKind, str | None]] = []
    for ia, (arm, m) in enumerate(zip(problem.arms, motions)):
        tip = kin.fk(m.q, m.links, m.base)[1]
        still = m.speed <= opts.still_speed
        for j, f in enumerate(problem.fruits):
            if reach[ia, j]:
                holds += [(t0, t1, arm.name, EventKind.PICK, f.id)
                          for t0, t1 in _holds(m, tip, time, still, f.position, task.pick_dwell - dwell_tol, opts)]
        holds += [(t0, t1, arm.name, EventKind.PLACE, None)
                  for t0, t1 in _holds(m, tip, time, still, arm.bin, task.place_dwell - dwell_tol, opts)]
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
