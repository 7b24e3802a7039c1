"""Where the carriage stops, and which fruit each stop harvests: three rules.

* ``fixed`` (:func:`fixed_stops`) -- a stop every *carriage span* (the median width of row
  over which a fruit stays in the arms' reach), the first one as far along as still serves the
  first fruit; fruit no stride stop serves get extra stops (fewest-stops rule on them). The
  analogue of a camera-frame rule: advance by what the cell sees.
* ``fewest`` (:func:`fewest_stops`) -- the fewest stops that serve every fruit: greedy
  interval stabbing (at the last position that still serves the fruit whose window closes
  first), exact for fruit whose serving positions are intervals.
* ``optimised`` (:func:`optimised_stops`) -- a MILP (HiGHS) over a receding window of the rail:
  which candidate positions to stop at and which arm harvests which fruit there, minimising
  the window's time: each stop's cell time (at least every arm's bin -> fruit -> bin round
  trips and dwells at that position, time-optimal moves, plus its way out and home) plus the
  carriage's cost per stop (its braking and starting, beyond cruising). A fruit whose serving
  positions go on past the window may wait for a later window at the price of its cheapest
  round trip. The window's first stops are kept, and the next window starts there.

Each rule returns :class:`Stop` objects in carriage order; which arm takes which fruit at a
stop is the cell planner's to decide (the MILP's arm choice only prices the stop).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..kinematics.timing import scurve_time, scurve_times
from ..problem.model import Problem
from ..ties import quantised
from .reach import RowReach

__all__ = ["Stop", "fixed_stops", "fewest_stops", "optimised_stops", "carriage_span", "round_trips", "StopWindow"]


@dataclass(frozen=True)
class Stop:
    """A carriage stop: its grid index ``k``, position ``x`` (m) and the fruit it harvests."""

    k: int
    x: float
    fruit: tuple[str, ...]


def carriage_span(reach: RowReach) -> float:
    """The median width of row (m) over which a fruit stays within the arms' reach."""
    widths = [(b - a + 1) * reach.resolution for a, b in (reach.span(f) for f in reach.cover)]
    return float(np.median(widths)) if widths else reach.resolution


def _stops_from(reach: RowReach, ks: list[int], fruit: list[str]) -> list[Stop]:
    """Stops at grid indices ``ks`` (sorted), each fruit to the first one that serves it."""
    owner: dict[int, list[str]] = {k: [] for k in ks}
    for f in fruit:
        cov = reach.cover[f].any(axis=0)
        k = next((k for k in ks if cov[k]), None)
        if k is not None:
            owner[k].append(f)
    order = {f.id: i for i, f in enumerate(reach.problem.fruits)}
    return [Stop(k, float(reach.grid[k]), tuple(sorted(owner[k], key=order.__getitem__))) for k in ks if owner[k]]


def fewest_stops(reach: RowReach, fruit: list[str] | None = None) -> list[Stop]:
    """The fewest stops serving every fruit (greedy stabbing, see the module docstring)."""
    todo = list(reach.cover) if fruit is None else [f for f in fruit if f in reach.cover]
    cov = {f: reach.cover[f].any(axis=0) for f in todo}
    first_end = {}
    for f, c in cov.items():  # the end of the first run of serving positions
        k = int(np.argmax(c))
        run = np.flatnonzero(~c[k:])
        first_end[f] = k + (int(run[0]) - 1 if run.size else c.size - 1 - k)
    left = sorted(todo, key=lambda f: (first_end[f], f))
    ks: list[int] = []
    done: set[str] = set()
    for f in left:
        if f in done:
            continue
        k = first_end[f]
        ks.append(k)
        done |= {g for g in left if cov[g][k]}
    return _stops_from(reach, sorted(set(ks)), todo)


def fixed_stops(reach: RowReach, stride: float | None = None) -> list[Stop]:
    """A stop every ``stride`` m (default :func:`carriage_span`), see the module docstring."""
    if not reach.cover:
        return []
    stride = carriage_span(reach) if stride is None else stride
    step = max(1, int(round(stride / reach.resolution)))
    ends = [reach.span(f)[1] for f in reach.cover]
    k0 = min(ends)
    last = max(reach.span(f)[0] for f in reach.cover)
    ks = list(range(k0, max(last, k0) + step, step))
    ks = [k for k in ks if k < reach.grid.size]
    served = {f for f in reach.cover if reach.cover[f].any(axis=0)[ks].any()}
    extra = fewest_stops(reach, [f for f in reach.cover if f not in served])
    return _stops_from(reach, sorted(set(ks) | {s.k for s in extra}), list(reach.cover))


# --------------------------------------------------------------------------- the optimised rule
def round_trips(problem: Problem, reach: RowReach, fruit: list[str], ks: np.ndarray) -> dict:
    """``(fruit, k, arm index) -> s``: the time-optimal bin -> fruit -> bin round trip with both
    dwells, for every arm serving the fruit at grid index ``k`` in ``ks`` (best IK branches).
    Per-joint S-curve times (no motion is faster): a lower bound on that fruit's cycle."""
    dw = problem.task.pick_dwell + problem.task.place_dwell
    out: dict = {}
    kset = np.zeros(reach.grid.size, dtype=bool)
    kset[ks] = True
    for a, arm in enumerate(problem.arms):
        qb, vb = arm.ik(np.asarray(arm.bin, float), 0.0)
        bins = qb[vb]
        if bins.size == 0:
            continue
        trip, keys = [], []
        for f in fruit:
            on = np.flatnonzero(reach.cover[f][a] & kset)
            if on.size == 0:
                continue
            fx, fy = problem.fruit(f).position
            pts = np.c_[fx - reach.grid[on] - 0.0, np.full(on.size, fy)]
            q, valid = arm.ik(pts, problem.task.reach_margin)  # (n, 2, 2)
            keys += [(f, int(k), a) for k in on]
            trip.append((q, valid))
        if not keys:
            continue
        q = np.concatenate([t[0] for t in trip])
        valid = np.concatenate([t[1] for t in trip])
        best = np.full(len(keys), np.inf)
        for b in range(2):
            legs = np.stack([_lb(arm, qq, q[:, b]) for qq in bins])  # (bins, n)
            t = 2.0 * legs.min(axis=0)
            best = np.where(valid[:, b], np.minimum(best, t), best)
        for key, t in zip(keys, best):
            if np.isfinite(t):
                out[key] = float(t) + dw
    return out


def _lb(arm, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Per-joint time-optimal rest-to-rest time from ``q0`` (2,) to each of ``q1`` (n, 2)."""
    d = np.abs(np.nan_to_num(q1) - q0[None, :])
    return np.maximum(*(scurve_times(d[:, i], arm.max_velocity[i], arm.max_acceleration[i], arm.max_jerk[i]) for i in range(2)))


def stop_cost(problem: Problem) -> float:
    """What a stop costs the carriage beyond cruising past it, s: braking to rest and starting
    again (the rest-to-rest S-curve over a long move, less the same distance at full speed)."""
    g = problem.gantry
    d = 10.0 * max(g.max_velocity ** 2 / g.max_acceleration, g.max_velocity * g.max_acceleration / g.max_jerk, 1.0)
    return scurve_time(d, g.max_velocity, g.max_acceleration, g.max_jerk) - d / g.max_velocity + g.settle


def arm_overheads(problem: Problem) -> list[float]:
    """Per arm, what a stop adds beyond its round trips: leaving home and coming back to it
    (the time-optimal home -> bin move, twice: a lower-bound estimate)."""
    out = []
    for arm in problem.arms:
        qb, vb = arm.ik(np.asarray(arm.bin, float), 0.0)
        home = np.asarray(arm.home, float)
        t = min((float(_lb(arm, home, qb[b][None, :])[0]) for b in range(2) if vb[b]), default=0.0)
        out.append(2.0 * t)
    return out


@dataclass(frozen=True)
class StopWindow:
    """The receding window of the optimised rule: ``length`` m of rail per MILP, ``keep`` m of
    it committed (then the next window starts at the last stop kept), candidate positions every
    ``step`` grid points, and CP-SAT's deterministic time limit per window (``work``)."""

    length: float = 12.0
    keep: float = 6.0
    step: int = 4
    work: float = 0.5  # CP-SAT's deterministic time limit per window


def optimised_stops(problem: Problem, reach: RowReach, window: StopWindow | None = None, on_stop=None) -> tuple[list[Stop], dict]:
    """The optimised rule over the whole row, window by window (see the module docstring).

    ``on_stop(stop)`` is called with every stop as soon as its window commits it (a caller
    plans it while the next window is solved). Returns the stops and the MILP's report."""
    w = window or StopWindow()
    res = reach.resolution
    todo = [f for f in reach.harvestable()]
    spans = {f: reach.span(f) for f in todo}
    pos = 0  # grid index the carriage has reached
    stops: list[Stop] = []
    info = {"windows": 0, "milp_seconds": [], "status": [], "binaries": []}
    tau = stop_cost(problem)
    over = arm_overheads(problem)
    while todo:
        lo = max(pos, min(spans[f][0] for f in todo))
        hi = lo + int(round(w.length / res))
        keep_to = lo + int(round(w.keep / res))
        inside = [f for f in todo if spans[f][0] <= hi]
        cand = np.arange(lo, min(hi, reach.grid.size - 1) + 1, w.step)
        # a fruit's last serving position, if inside the window, must be a candidate: no fruit is lost
        must = sorted({spans[f][1] for f in inside if spans[f][1] <= hi})
        cand = np.unique(np.concatenate([cand, np.asarray(must, int)])).astype(int)
        hint = [s for s in fewest_stops(reach, inside) if s.k <= hi]
        cand = np.unique(np.concatenate([cand, np.asarray([s.k for s in hint], int)])).astype(int)
        chosen, status, secs, nbin = _solve_window(problem, reach, inside, cand, hi, tau, over, w, hint)
        info["windows"] += 1
        info["milp_seconds"].append(secs)
        info["status"].append(status)
        info["binaries"].append(nbin)
        committed = [s for s in chosen if s.k <= keep_to] or chosen[:1]
        if not committed:  # nothing chosen (every fruit may wait): the fewest-stops rule for the first
            committed = fewest_stops(reach, inside)[:1]
        for s in committed:
            stops.append(s)
            if on_stop is not None:
                on_stop(s)
        done = {f for s in committed for f in s.fruit}
        todo = [f for f in todo if f not in done]
        pos = committed[-1].k + 1
        late = [f for f in todo if spans[f][1] < pos]  # passed without being served: a stop of its own
        for s in fewest_stops(reach, late):
            stops.append(s)
            if on_stop is not None:
                on_stop(s)
        todo = [f for f in todo if f not in set(late)]
    stops.sort(key=lambda s: s.k)
    return stops, info


def _solve_window(problem, reach, fruit, cand, hi, tau, over, w, hint=None):
    """One window's model, solved by CP-SAT (single-threaded, deterministic time limit
    ``w.work``), from ``hint`` (stops) when given. Returns (stops chosen, status, seconds, booleans)."""
    import time

    from ortools.sat.python import cp_model

    t0 = time.perf_counter()
    cost = round_trips(problem, reach, fruit, cand)
    A = len(problem.arms)
    ms = lambda v: int(math.floor(1000.0 * float(quantised(v)) + 1e-6))  # whole ms (rounded down)
    m = cp_model.CpModel()
    spans = {f: reach.span(f) for f in fruit}
    x = {key: m.NewBoolVar("") for key in sorted(cost)}
    y = {int(k): m.NewBoolVar("") for k in cand}
    u = {(int(k), a): m.NewBoolVar("") for k in cand for a in range(A)}
    horizon = sum(ms(v) for v in cost.values()) + A * sum(ms(o) for o in over) + 1
    T = {int(k): m.NewIntVar(0, horizon, "") for k in cand}
    wait = {f: m.NewBoolVar("") for f in fruit if spans[f][1] > hi}
    cheapest: dict[str, float] = {}
    for (f, k, a), v in cost.items():
        cheapest[f] = min(cheapest.get(f, math.inf), v)
    by_fruit: dict[str, list] = {}
    load: dict[tuple[int, int], list] = {}
    for (f, k, a), var in x.items():
        by_fruit.setdefault(f, []).append(var)
        load.setdefault((k, a), []).append((var, ms(cost[(f, k, a)])))
        m.AddImplication(var, u[(k, a)])
    for f in fruit:
        vs = by_fruit.get(f, []) + ([wait[f]] if f in wait else [])
        if vs:
            m.AddExactlyOne(vs)
    for (k, a), items in load.items():
        m.AddImplication(u[(k, a)], y[k])
        m.Add(T[k] >= sum(c * v for v, c in items) + ms(over[a]) * u[(k, a)])
    m.Minimize(sum(T.values()) + ms(tau) * sum(y.values()) + sum(ms(cheapest.get(f, 0.0)) * v for f, v in wait.items()))
    if hint:  # a complete feasible solution: each fruit at its hint stop, on its cheapest arm there
        on = {s.k for s in hint if s.k in y}
        pick = {}
        for s in hint:
            if s.k not in on:
                continue
            for f in s.fruit:
                arms = [(cost[(f, s.k, a)], a) for a in range(A) if (f, s.k, a) in cost]
                if arms and f not in pick:
                    pick[f] = (s.k, min(arms)[1])
        loads: dict[tuple[int, int], int] = {}
        for key, var in x.items():
            chosen = pick.get(key[0]) == (key[1], key[2])
            m.AddHint(var, chosen)
            if chosen:
                loads[(key[1], key[2])] = loads.get((key[1], key[2]), 0) + ms(cost[key])
        for (k, a), var in u.items():
            m.AddHint(var, (k, a) in loads)
        for k, var in y.items():
            m.AddHint(var, k in on and any((k, a) in loads for a in range(A)))
            m.AddHint(T[k], max((loads[(k, a)] + ms(over[a]) for a in range(A) if (k, a) in loads), default=0))
        for f, var in wait.items():
            m.AddHint(var, f not in pick)
    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1  # single-threaded and a deterministic limit: the same stops anywhere
    solver.parameters.max_deterministic_time = w.work
    solver.parameters.random_seed = 0
    solver.parameters.catch_sigint_signal = False
    st = solver.Solve(m)
    secs = time.perf_counter() - t0
    nb = len(x) + len(y) + len(u) + len(wait)
    if st not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return [], solver.StatusName(st).lower(), secs, nb
    at: dict[int, list[str]] = {}
    for (f, k, a), var in x.items():
        if solver.Value(var):
            at.setdefault(k, []).append(f)
    order = {f.id: i for i, f in enumerate(problem.fruits)}
    stops = [Stop(k, float(reach.grid[k]), tuple(sorted(fs, key=order.__getitem__))) for k, fs in sorted(at.items())]
    return stops, solver.StatusName(st).lower(), secs, nb
