"""The course's baseline planner, made time-aware.

Entry point: :func:`plan_heuristic`. For each arm, for each of its fruit in order: a cubic
joint-space move current -> fruit, hold ``pick_dwell``, cubic move -> bin, hold
``place_dwell``, cubic move -> home. Each cubic lasts the shortest time that keeps it inside
the arm's velocity and acceleration limits (jerk is not limited: the cubic's acceleration
jumps at both ends, as taught). All arms start at home at t = 0. It does not avoid
collisions; the verifier reports them.
"""

from __future__ import annotations

import math
import time as _time

import numpy as np

from ..errors import finite_number
from ..allocate.allocation import Allocation, AllocationMethod, allocate
from ..plan import DEFAULT_RATE, Event, EventKind, Piece, Plan, PlannerKind, PlanStatus, compute_metrics, sample_pieces
from ..problem.model import Arm, Problem
from ..kinematics.timing import cubic_eval, cubic_min_time

__all__ = ["plan_heuristic", "build_timeline", "grid"]


def _cubic_piece(arm: Arm, t0: float, q0, q1) -> Piece:
    T = cubic_min_time(np.subtract(q1, q0), arm.max_velocity, arm.max_acceleration)
    q0 = np.asarray(q0, float)
    q1 = np.asarray(q1, float)
    if T <= 0:
        return Piece(t0, t0, lambda t, q=q1: np.tile(q, (np.size(t), 1)))
    return Piece(t0, t0 + T, lambda t, a=q0, b=q1, T=T: cubic_eval(a, b, T, t))


def _hold(t0: float, dur: float, q) -> Piece:
    q = np.asarray(q, float)
    return Piece(t0, t0 + dur, lambda t, q=q: np.tile(q, (np.size(t), 1)))


def build_timeline(problem: Problem, arm: Arm, alloc: Allocation, rate: float = DEFAULT_RATE):
    """Pieces and events of one arm's heuristic schedule. Each dwell lasts a whole number of
    the plan's samples (``rate`` Hz), at least the task's: sampled, a hold of 0.3001 s between
    two arbitrary instants was on target 0.29 s, short of the dwell the verifier asks."""
    pieces: list[Piece] = []
    events: list[Event] = []
    home = np.asarray(arm.home, float)
    cur = home
    t = 0.0
    for fid in alloc.assignment[arm.name]:
        qf = alloc.fruit_q[arm.name][fid]
        qb = alloc.place_q[arm.name][fid]
        for target, kind, dwell in ((qf, EventKind.PICK, problem.task.pick_dwell), (qb, EventKind.PLACE, problem.task.place_dwell)):
            dwell = math.ceil(dwell * rate - 1e-9) / rate
            p = _cubic_piece(arm, t, cur, target)
            pieces.append(p)
            t = p.t1
            pieces.append(_hold(t, dwell, target))
            events.append(Event(arm.name, fid, kind, t, t + dwell))
            t += dwell
            cur = target
        p = _cubic_piece(arm, t, cur, home)
        pieces.append(p)
        t = p.t1
        cur = home
    return pieces, events, t


def grid(t_end: float, rate: float = DEFAULT_RATE) -> np.ndarray:
    """Uniform time grid from 0 covering ``t_end`` at ``rate`` Hz."""
    n = max(1, int(math.ceil(t_end * rate - 1e-9)))
    return np.arange(n + 1) / rate


def plan_heuristic(problem: Problem, allocation: Allocation | None = None, rate: float = DEFAULT_RATE) -> Plan:
    """Plan every arm with the course's method. The plan is ``UNVERIFIED`` until verified."""
    from ..problem.gantry import require_cell

    require_cell(problem, "plan_heuristic")
    if not finite_number(rate) or rate < DEFAULT_RATE:  # (a plan file's grid, which the verifier holds every plan to)
        raise ValueError(f"rate: expected a sample rate of at least {DEFAULT_RATE:g} Hz, found {rate!r}")
    if allocation is not None and not isinstance(allocation, Allocation):
        raise TypeError(f"allocation: expected an Allocation (coplan.allocate(problem, method)), found {type(allocation).__name__}")
    t0 = _time.perf_counter()
    alloc = allocation if allocation is not None else allocate(problem, AllocationMethod.HEURISTIC)
    timelines = {arm.name: build_timeline(problem, arm, alloc, rate) for arm in problem.arms}
    t_end = max((tl[2] for tl in timelines.values()), default=0.0)
    times = grid(t_end, rate)
    q = {arm.name: sample_pieces(timelines[arm.name][0], arm.home, times) for arm in problem.arms}
    events = sorted((e for tl in timelines.values() for e in tl[1]), key=lambda e: (e.t_start, e.arm))
    plan = Plan(
        problem=problem.name,
        planner=PlannerKind.HEURISTIC,
        status=PlanStatus.UNVERIFIED,
        time=times,
        q=q,
        events=events,
        allocation={a: list(v) for a, v in alloc.assignment.items()},
        unreachable=list(alloc.unreachable),
        solver={
            "allocation": alloc.method.value,
            "sequence": alloc.sequence.value,
            "timings": {"allocation": alloc.seconds, "plan": _time.perf_counter() - t0 - alloc.seconds if allocation is None else _time.perf_counter() - t0},
        },
    )
    plan.metrics = compute_metrics(plan, len(problem.reachable_ids()))
    plan.metrics["lower_bound"] = alloc.lower_bound
    plan.metrics["gap_to_lower_bound"] = plan.metrics["makespan"] / alloc.lower_bound if alloc.lower_bound > 0 else None
    return plan
