"""Where a live row stops (:func:`coplan.row.live.run_live_row`, stop and go), from the fruit the
camera has reported so far: what each stop harvests and what it leaves to the next
(:func:`stop_share`), the next-to-last stop once the camera can see to the rail's end from it
(:func:`next_to_last`), and the last stop (:func:`last_stop`). Priced as the optimised rule
prices its stops (:mod:`coplan.row.stops`: time-optimal round trips, the stops' busiest arms,
the carriage's moves)."""

from __future__ import annotations

import numpy as np

from ..problem.model import Problem
from .reach import RowReach
from .stops import TripCosts, arm_overheads, arrival_time, price_stops, quantised_trips, round_trips

__all__ = ["stop_share", "next_to_last", "last_stop", "dark_hold"]


def dark_hold(plan, dark: tuple[float, float]) -> float:
    """Seconds of the camera's outage (``dark``: its start and length) in which the whole machine
    stood still -- the carriage at rest, every arm at rest and none dwelling at a pick or a place
    -- waiting for what the camera could not see: the outage's cost stop and go
    (``hold_seconds``, as on the move), from the executed ``plan``'s samples."""
    t = plan.time
    if t.size < 2:
        return 0.0
    dt = plan.dt
    still = np.abs(np.diff(plan.gantry_x)) < 1e-9
    for arm in plan.q:  # (no arm moving or dwelling: Plan.busy, as each arm's busy time counts it)
        still &= ~plan.busy(arm)
    mid = 0.5 * (t[:-1] + t[1:])  # each step between two samples
    d0, d1 = dark[0], dark[0] + dark[1]
    return round(float(np.count_nonzero(still & (mid >= d0) & (mid < d1))) * dt, 3)


def stop_share(problem: Problem, reach, windows: dict, todo: list[str], k: int, k_plan: int, stopped: set[int],
               inset: int = 0):
    """What the stop at grid index ``k`` harvests, and each working arm's fruit there in row
    order, against the next stop the camera allows now (``k_plan``; ``todo``: the fruit reported
    and not taken). Every fruit no carriage position from ``k_plan`` on serves (it would be
    passed) is harvested here; a fruit both stops serve goes where it lengthens the two stops
    together least (each stop as long as its busiest arm, by time-optimal bin -> fruit -> bin
    round trips; fewest options first), then to this stop, then to the cheaper round trip; the
    fruit only the next one serves load it from the start. The next stop is priced as at least
    as long as this one (its fruit beyond the camera's view are not reported yet, and the row's
    density does not change much in one hop): a fruit goes to the next stop's rear arm where
    this stop has no arm with time to spare for it, rather than lengthen this stop -- the
    imbalance that made stop and go 1.13-1.31 x the offline plan's row time on the benchmark
    rows. Where both have time to spare this stop takes it: the next stop's arms get the fruit
    the camera has not reported yet (taking it here rather than where its round trip is
    cheaper: live course_row 1.097-1.115 x the offline plan over seeds 0-5, was 1.106-1.119;
    six_arm_row 1.072-1.115, was 1.099-1.135; sparse_row 1.112-1.149, was 1.101-1.148;
    dense_row within 0.003). A fruit is left to the next stop only if
    it stays in reach ``inset`` grid steps beyond it (the margin the next stop keeps from a
    fruit's last chance: the hop is not shortened for it). Returns (order, kept fruit)."""
    here = [f for f, ws in windows.items() if any(w.arm not in stopped for w in ws)]
    allowed = {f: {w.arm for w in windows[f]} - stopped for f in here}
    now: dict[str, list[tuple[float, int]]] = {}
    for (f, _, a), c in quantised_trips(round_trips(problem, reach, here, np.array([k])) if here else {}).items():
        if a in allowed[f]:
            now.setdefault(f, []).append((c, a))
    later: dict[str, list[tuple[float, int]]] = {}
    if k_plan > k:
        for (f, _, a), c in quantised_trips(round_trips(problem, reach, [f for f in todo if f in reach.cover], np.array([k_plan]))).items():
            if a not in stopped:
                later.setdefault(f, []).append((c, a))
    working = [a for a in range(len(problem.arms)) if a not in stopped]
    last = {f: int(np.flatnonzero(reach.cover[f][working].any(axis=0))[-1]) - inset for f in now}
    load = {0: [0.0] * len(problem.arms), 1: [0.0] * len(problem.arms)}  # this stop, the next
    order: dict[int, list[str]] = {}

    def put(f: str, o: list[tuple[float, int, int]]) -> None:
        def cost(c: float, a: int, s: int) -> tuple:
            top = max(load[s]) if s == 0 else max(max(load[0]), max(load[1]))  # (the next: as long as this one, at least)
            grown = max(top, load[s][a] + c) - top
            return grown, s, c, a
        _, s, c, a = min(cost(*x) for x in o)
        load[s][a] += c
        if s == 0:
            order.setdefault(a, []).append(f)

    for f, o in sorted(later.items(), key=lambda it: (len(it[1]), it[0])):
        if f not in now:
            put(f, [(c, a, 1) for c, a in o])
    both = sorted(now, key=lambda f: (last[f] >= k_plan > k and f in later, len(now[f]) + len(later.get(f, [])), f))
    for f in both:
        o = [(c, a, 0) for c, a in now[f]]
        if last[f] >= k_plan > k:
            o += [(c, a, 1) for c, a in later.get(f, [])]
        put(f, o)
    x = {f.id: f.position[0] for f in problem.fruits}
    keep = {f for fs in order.values() for f in fs} | (set(windows) - set(here))  # (a stopped arm's: not booked)
    return {a: sorted(fs, key=lambda f: (x[f], f)) for a, fs in order.items()}, keep


def next_to_last(problem: Problem, reach: RowReach, fruit: list[str], k: int, ks, x_from: float) -> int | None:
    """Of the grid indices ``ks`` (beyond ``k``), the next stop that with the stop at ``k``
    serves every fruit in ``fruit`` in the least estimated time (:func:`price_stops`'s balance
    and estimate over the two stops, the carriage's moves from ``x_from``); None if no index
    in ``ks`` serves them all with ``k``. The row's last two stops, once the next may be one
    from which the camera sees to the rail's end."""
    ks = sorted(set(int(kk) for kk in ks))
    if not fruit or not ks:
        return None
    cost = TripCosts(problem, reach, fruit)
    cost.add([k] + ks)
    over = arm_overheads(problem)
    best = None
    for kk in ks:
        t, _, taken = price_stops(problem, reach, cost, fruit, [k, kk], over, x_from, max(over))
        if len(taken) == len(fruit) and (best is None or t < best[0] - 1e-9):
            best = (t, kk)
    return None if best is None else best[1]


def last_stop(problem: Problem, reach: RowReach, fruit: list[str], ks, arms: list[int], x_from: float) -> int | None:
    """Of the grid indices ``ks``, the one stop that serves every fruit in ``fruit`` with the
    arms ``arms`` in the least estimated time -- the carriage's move from ``x_from`` and the
    stop's busiest arm, the fruit balanced as :func:`price_stops` balances them (fewest options
    first, each where it lengthens the busiest arm least, then where its round trip is
    cheapest); None if no index in ``ks`` serves them all. A row's end: the stop the rest of the
    row needs, nearer than the farthest one where the arms beyond the last fruit would idle."""
    ks = np.asarray(sorted(set(int(k) for k in ks)), int)
    if not fruit or ks.size == 0:
        return None
    use = set(arms)
    by: dict[int, dict[str, list[tuple[float, int]]]] = {}
    for (f, k, a), t in quantised_trips(round_trips(problem, reach, fruit, ks)).items():
        if a in use:
            by.setdefault(k, {}).setdefault(f, []).append((t, a))
    best = None
    for k in ks.tolist():
        opts = by.get(k, {})
        if len(opts) < len(fruit):
            continue
        load = dict.fromkeys(use, 0.0)
        for f in sorted(opts, key=lambda f: (len(opts[f]), f)):
            top = max(load.values())
            _, c, a = min((max(top, load[a] + c) - top, c, a) for c, a in opts[f])
            load[a] += c
        est = max(load.values()) + arrival_time(problem.gantry, x_from, float(reach.grid[k]))
        if best is None or est < best[0] - 1e-9:
            best = (est, k)
    return None if best is None else best[1]
