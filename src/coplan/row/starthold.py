"""How long a row's carriage first rests where it starts, on the move: fruit the start serves
that a carriage ramping up at once would pass before an arm could pick them.

* :func:`start_hold` -- offline (:mod:`coplan.row.moving`), for the fruit the speed
  search's first plans left out that only the start serves;
* :func:`reports_start_hold` -- live (:mod:`coplan.row.live`), for the camera's reports before
  the carriage moves.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..problem.model import Fruit, Problem
from ..allocate.row_cycles import cycle_bounds
from .cruise import Cruise
from .reach import RowReach, row_reach
from .sensing import RowReport, report_times

__all__ = ["start_hold", "reports_start_hold"]


def start_hold(problem: Problem, reach: RowReach, fruit, cost: np.ndarray | None = None) -> float:
    """How long the carriage rests where it starts so that the arms can pick ``fruit`` -- fruit
    only the start serves, which a carriage that ramps up from rest at once leaves no time to be
    picked in. Each fruit's cheapest cycle
    (:func:`coplan.allocate.row_cycles.cycle_bounds`, on an arm that serves it from the start; ``cost``:
    those bounds where the caller has them) plus a second for the arm's way out and the grid,
    each arm's summed; the busiest arm's total."""
    cost = cycle_bounds(problem, limits=False)[0] if cost is None else cost
    col = {f.id: k for k, f in enumerate(problem.fruits)}
    load = np.zeros(len(problem.arms))
    for fid in fruit:
        arms = np.flatnonzero(reach.cover[fid][:, 0])  # the arms that serve it from the start
        if arms.size == 0:
            continue
        c = cost[arms, col[fid]]
        a = int(arms[np.argmin(np.where(np.isfinite(c), c + load[arms], np.inf))])
        load[a] += (float(cost[a, col[fid]]) if np.isfinite(cost[a, col[fid]]) else 0.0) + 1.0
    return float(load.max(initial=0.0))


def reports_start_hold(problem: Problem, reports: list[RowReport], cruise: Cruise) -> float:
    """The rest where the carriage starts (:func:`start_hold`) for the
    reports the camera makes before it moves that the start position serves and the carriage,
    ramping up at once (``cruise``), would pass before an arm could get there: a fruit every arm
    that serves it from the start loses from reach (the end of its first run of serving
    positions) sooner than its cheapest way out (half its cycle bound, less the dwells), the pick
    dwell and a second for the grid. Only the start serving it is the extreme case; a fruit
    0.18 m inside the reach at the start was passed at 0.3 m/s while the offline plan rested for
    it. 0 if none."""
    times = report_times(reports, cruise)
    at_start = [r.id for r in reports if times.get(r.id, math.inf) <= 0.0]
    if not at_start:
        return 0.0
    # (the reports made before the carriage moves, alone: each fruit's screen and cycle bounds
    # are its own, and the whole row's cost more -- 0.18 against 0.11 s a run on dense_row)
    first = set(at_start)
    seen = replace(problem, fruits=tuple(Fruit(r.id, r.position) for r in reports if r.id in first),
                   name=f"{problem.name} (as seen)", source=None, digest=None)
    reach = row_reach(seen, fruit_ids=at_start)
    cost = cycle_bounds(seen, limits=False)[0]
    col = {f.id: k for k, f in enumerate(seen.fruits)}
    task = problem.task

    def passed(f: str) -> bool:
        for a in np.flatnonzero(reach.cover[f][:, 0]):
            if not np.isfinite(cost[a, col[f]]):
                continue
            ks = reach.cover[f][a]
            last = int(np.argmin(ks)) - 1 if not ks.all() else ks.size - 1  # the first run of serving positions
            way_out = 0.5 * (float(cost[a, col[f]]) - task.pick_dwell - task.place_dwell)
            if float(cruise.time_at(reach.grid[last])[0]) >= way_out + task.pick_dwell + 1.0:
                return False  # this arm has time to pick it with the carriage under way
        return True

    held = [f for f in at_start if f in reach.cover and reach.cover[f][:, 0].any() and passed(f)]
    return start_hold(seen, reach, held, cost) if held else 0.0
