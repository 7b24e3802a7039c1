"""Which arm picks which fruit, and in which order, within the pick windows: OR-Tools CP-SAT.

One optional interval per fruit and window (an arm, a run of carriage positions serving it): its
pick starts inside the window, and the interval covers the whole cycle around it -- the move
from the bin, the pick, the move back and the place, each move priced at its rest-to-rest
time-optimal duration at the window's middle (the moves' share of the limits:
:data:`coplan.row.track.LIMIT_SHARE`). An arm's intervals never overlap; a fruit is picked at
most once. Objective: the most fruit, then the earliest end of the last cycle. The greedy's
bookings are the hint, so CP-SAT starts from the baseline.

The geometry between neighbours is not in the model: its order goes back to
:func:`coplan.row.policy.run_policy`, which books each arm's fruit in that order, each cycle
clear of the neighbours (later if it must), and leaves to the greedy whatever no longer fits.
Single-threaded with a deterministic work limit: the same plan on any machine.
"""

from __future__ import annotations

import math

import numpy as np

from ..kinematics.arm import ik_one
from ..kinematics.timing import move_lower_bound
from ..plan import EventKind
from ..problem.model import Problem
from .booking import Booker
from .cruise import Cruise
from .reach import RowReach
from .track import LIMIT_SHARE

__all__ = ["build_order_model", "cpsat_order", "CPSAT_WORK"]

_UNIT = 100  # model time units per second (10 ms)
#: CP-SAT's deterministic work limit (its "deterministic seconds"; the same on any machine). Its
#: gains come from booking its first orders, not from a long search: 0.1 kept the same plans as
#: 0.5 where it won (sparse_row 123.55 s, a 6-arm 8 per metre row 101.06 s, course_row's level
#: 0.667), in a third to a half of the time.
CPSAT_WORK = 0.1
#: ... in full up to this many intervals, beyond in proportion to the square of the ratio (a
#: larger model's deterministic second costs more wall-clock time: six_arm_row's 2,347 intervals
#: took 3.3 s for 0.17 of them, and its search never bettered the greedy's hint).
CPSAT_SIZE = 800


def _move_estimate(problem: Problem, booker: Booker, cruise: Cruise, fid: str, w) -> float | None:
    """Seconds of the move between the bin and ``fid`` (either way: rest to rest, the same bound)
    for arm ``w.arm`` at the window's middle; None when no branch serves it there."""
    arm = problem.arms[w.arm]
    hi = w.hi if math.isfinite(w.hi) else w.lo + 1.0
    t = 0.5 * (w.lo + hi)
    xy = booker.fruit_xy[fid]
    c = cruise.state_one(t)[0]
    brs = booker.branches(w.arm, fid, c, c)
    if not brs:
        return None
    lim = [np.asarray(x, float) * LIMIT_SHARE for x in (arm.max_velocity, arm.max_acceleration, arm.max_jerk)]
    qb = booker.bin_q[w.arm]
    best = None
    for b in brs:
        qf = ik_one(xy[0] - c, xy[1], arm.links, arm.base, arm.joint_limits, b)  # :func:`track` at t
        if not (math.isfinite(qf[0]) and math.isfinite(qf[1])):
            continue
        d = move_lower_bound(qb, qf, *lim)
        if best is None or d < best:
            best = d
    return best


def _calibration(problem: Problem, greedy: Booker, events, cruise: Cruise) -> float:
    """How much longer the greedy's real moves took than the model's estimates (median of its
    cycles, at least 1): the moves arrive on a moving fruit, wait for neighbours, and come back
    from wherever the pick ended."""
    index = {a.name: i for i, a in enumerate(problem.arms)}
    picks = {(e.arm, e.fruit): e for e in events if e.kind == EventKind.PICK}
    ratios = []
    for e in events:
        if e.kind != EventKind.PLACE or (e.arm, e.fruit) not in picks:
            continue
        pk = picks[(e.arm, e.fruit)]
        i = index[e.arm]
        w = next((w for w in greedy.windows[e.fruit] if w.arm == i and w.lo - 1e-9 <= pk.t_start <= w.hi + 1e-9), None)
        move = None if w is None else _move_estimate(problem, greedy, cruise, e.fruit, w)
        if move:
            ratios.append((e.t_start - pk.t_end) / move)
    return max(1.0, float(np.median(ratios))) if ratios else 1.0


def _hint_room(events, index: dict[str, int]) -> dict[tuple[str, int], tuple[int, int]]:
    """For each cycle the greedy booked, ``(fruit, arm) -> (approach, return)`` in model units:
    the time from the arm's previous place's end to the pick, and from the pick's end to the
    place. Intervals no longer than these nest inside the greedy's real cycles, which never
    overlap on one arm, so the greedy's bookings are a feasible start for CP-SAT."""
    picks = {(e.arm, e.fruit): e for e in events if e.kind == EventKind.PICK}
    places = sorted((e for e in events if e.kind == EventKind.PLACE and (e.arm, e.fruit) in picks),
                    key=lambda e: (e.arm, e.t_start))
    out = {}
    prev_end: dict[str, float] = {}
    for e in places:
        pk = picks[(e.arm, e.fruit)]
        app = int(math.floor((pk.t_start - prev_end.get(e.arm, 0.0)) * _UNIT + 1e-6))
        ret = int(math.floor((e.t_start - pk.t_end) * _UNIT + 1e-6))
        out[(e.fruit, index[e.arm])] = (max(app, 0), max(ret, 0))
        prev_end[e.arm] = e.t_end
    return out


def build_order_model(problem: Problem, greedy: Booker, cruise: Cruise, events=None):
    """The CP-SAT model of :func:`cpsat_order` (module docstring), hinted with the greedy's
    bookings: ``(model, items, calibration)``, ``items`` one ``(fruit, arm, on, pick, end,
    hinted pick time or None)`` per fruit and window; empty when no window prices."""
    from ortools.sat.python import cp_model

    events = greedy.events if events is None else events
    # both dwells as the booker holds them (whole samples), in model units: no longer than in the
    # greedy's cycles, so that its bookings stay a feasible hint
    dwells = int(math.ceil((greedy.n_pick + greedy.n_place) / greedy.rate * _UNIT - 1e-6))
    scale = _calibration(problem, greedy, events, cruise)
    horizon_s = max((e.t_end for e in events), default=cruise.duration) + 60.0
    H = int(math.ceil(horizon_s * _UNIT))
    m = cp_model.CpModel()
    per_arm: dict[int, list] = {i: [] for i in range(len(problem.arms))}
    per_fruit: dict[str, list] = {}
    items = []
    index = {a.name: i for i, a in enumerate(problem.arms)}
    room = _hint_room(events, index)
    booked = {(e.fruit, index[e.arm]): e.t_start for e in events if e.kind == EventKind.PICK}
    for fid, ws in greedy.windows.items():
        for w in ws:
            move = _move_estimate(problem, greedy, cruise, fid, w)
            if move is None:
                continue
            app = ret = int(math.ceil(move * scale * _UNIT))
            t = booked.get((fid, w.arm))
            mine = t is not None and w.lo - 1e-9 <= t <= w.hi + 1e-9  # the window the greedy picked it in
            if mine:  # the greedy's own cycle: no longer than it took (the hint is feasible)
                app, ret = min(app, room[(fid, w.arm)][0]), min(ret, room[(fid, w.arm)][1])
            lo = max(app, int(math.ceil(w.lo * _UNIT)))
            hi = min(H, int(math.floor(w.hi * _UNIT)) if math.isfinite(w.hi) else H)
            if hi < lo:
                continue
            on = m.NewBoolVar("")
            p = m.NewIntVar(lo, hi, "")
            dur = app + dwells + ret
            s = m.NewIntVar(lo - app, hi - app, "")
            e = m.NewIntVar(lo - app + dur, hi - app + dur, "")
            m.Add(s == p - app)
            iv = m.NewOptionalIntervalVar(s, dur, e, on, "")
            per_arm[w.arm].append(iv)
            per_fruit.setdefault(fid, []).append(on)
            items.append((fid, w.arm, on, p, e, t if mine else None))
    if not items:
        return m, items, scale
    for ivs in per_arm.values():
        m.AddNoOverlap(ivs)
    for ons in per_fruit.values():
        m.AddAtMostOne(ons)
    last = m.NewIntVar(0, H + 10 * _UNIT * 60, "")
    for _, _, on, _, e, _ in items:
        m.Add(last >= e).OnlyEnforceIf(on)
    count = sum(on for _, _, on, _, _, _ in items)
    m.Maximize(count * (H + 10 * _UNIT * 60 + 1) - last)
    for _, _, on, p, _, t in items:
        m.AddHint(on, t is not None)
        if t is not None:
            m.AddHint(p, int(round(t * _UNIT)))
    return m, items, scale


def cpsat_order(problem: Problem, greedy: Booker, reach: RowReach, cruise: Cruise,
                work: float = CPSAT_WORK, events=None) -> tuple[dict[int, list[str]] | None, dict]:
    """Each arm's fruit in CP-SAT's order (module docstring), or None; and a report.

    ``greedy``: a booker on this carriage motion (its windows, elbow branches and bin poses);
    ``events``: the greedy's booked events, the hint (None: ``greedy.events``; a booking made
    elsewhere on the same motion, e.g. the speed search's plan at this level)."""
    from ortools.sat.python import cp_model

    m, items, scale = build_order_model(problem, greedy, cruise, events)
    if not items:
        return None, {"status": "EMPTY"}
    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1  # single-threaded and a deterministic limit: the same plan anywhere
    # the same work on a larger model buys less search: the budget shrinks with the model, so a
    # long dense row's reordering stays a fraction of its planning (deterministic, any machine)
    solver.parameters.max_deterministic_time = work * min(1.0, CPSAT_SIZE / len(items)) ** 2
    solver.parameters.random_seed = 0
    solver.parameters.linearization_level = 0  # no LP: on these interval models it costs more than it finds
    solver.parameters.catch_sigint_signal = False
    status = solver.Solve(m)
    name = solver.StatusName(status)
    report = {"status": name, "intervals": len(items), "work": work, "calibration": scale}
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return None, report
    chosen: dict[int, list[tuple[int, str]]] = {i: [] for i in range(len(problem.arms))}
    for fid, a, on, p, _, _ in items:
        if solver.Value(on):
            chosen[a].append((solver.Value(p), fid))
    report["fruit"] = int(sum(len(v) for v in chosen.values()))
    return {a: [f for _, f in sorted(v)] for a, v in chosen.items()}, report
