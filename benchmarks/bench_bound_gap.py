"""Where a stop-and-go row plan's time goes against the stop-by-stop lower bound: the carriage's
moves, where the stops are, and the cycles at them (issue "Harvest a whole greenhouse row": row
time <= 1.10 x that bound).

Per shipped row, the default stop-and-go plan (optimised stops, coordinated cells) beside the
bound (:func:`coplan.allocate.stop_bound.stops_bound`) split into its two parts:

* ``moves``: the bound's carriage moves; the plan's time with the carriage moving and no arm
  working (its moving time less the moves that overlap work);
* ``work``: the bound's work, each fruit charged the least weighted cycle bound of the arms that
  reach it (the bound's weights per cell and arm, their weighted mean: a stop lasts at least
  that) at the cheapest cell on its side of the bound's stops; the plan's stop time (row time
  less its pure moving), and the same weighted cycle bounds charged where the plan really
  picked each fruit (:func:`coplan.allocate.row_cycles.cell_cycles` at the carriage's cell at
  the pick, by the arm that picked it), and at the best of the bound's own stops.

``stops' positions`` (the plan's cycle bounds where it picked less the bound's work) is what
where the stops are costs: each fruit's cycle bound where it was picked against where the bound
charges it. ``the rest`` (stop time less those cycle bounds) is the cycles longer than their
bounds and the arms waiting at a stop: the columns after it give the arms' mean time done at a
stop while the others finish (imbalance, ``metrics.row.idle_share[arm].others``) and holding
still for a neighbour (``coordination``), each its share of the row time.

    python benchmarks/bench_bound_gap.py
"""

from __future__ import annotations

import argparse

import numpy as np

import coplan
from coplan.allocate.row_cycles import cell_cycles
from coplan.allocate.stop_bound import STEP, stops_bound
from coplan.problem import load_problem
from run_header import run_header

ROWS = ("course_row", "dense_row", "six_arm_row", "sparse_row")


def _charges(problem, plan, cells: list[int], weights: np.ndarray) -> tuple[float, float]:
    """``(at the plan's picks, at the best of ``cells``)``: the sum over the fruit the plan picks
    of the picking arm's cycle bound at the carriage's cell at the pick, weighted by the bound's
    weight for that arm and cell (``weights`` (cells, arms that harvest): a stop lasts at least
    its arms' cycles so weighted), and the sum over the same fruit of the least weighted cycle
    bound over arms and ``cells``, s."""
    cc = cell_cycles(problem, STEP)
    arms = [a for a in range(len(cc.cost)) if cc.cost[a] is not None]
    index = {f.id: i for i, f in enumerate(problem.fruits)}
    names = {a.name: i for i, a in enumerate(problem.arms)}
    bands = {a: cc.band(a) for a in arms}
    col = {a: k for k, a in enumerate(arms)}  # (each arm's column of ``weights``)
    t, x = np.asarray(plan.time), np.asarray(plan.gantry_x)
    at_picks, picked = 0.0, []
    for e in plan.events:
        if e.kind != coplan.EventKind.PICK:
            continue
        a, f = names[e.arm], index[e.fruit]
        band, cost = bands[a]
        cell = int(np.searchsorted(cc.hi, np.interp(e.t_start, t, x)))
        at_picks += weights[cell, col[a]] * float(np.where(band[f] == cell, cost[f], np.inf).min())
        picked.append(f)
    best = np.full(len(picked), np.inf)
    for k, (band, cost) in enumerate(bands.values()):
        for c in cells:
            best = np.minimum(best, weights[c, k] * np.where(band[picked] == c, cost[picked], np.inf).min(axis=1))
    return at_picks, float(best.sum())


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rows", default=",".join(ROWS), help="shipped rows, comma-separated")
    args = ap.parse_args(argv)
    print(run_header(), flush=True)
    print("| row | row time | bound | / bound | bound: moves | plan: moving, no arm working | bound: work | plan: stop time "
          "| plan's cycle bounds where it picked | at the best of the bound's stops | stops' positions | the rest "
          "| of it, arms done waiting for others | holding for a neighbour | verified |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for name in args.rows.split(","):
        problem = load_problem(name)
        res = coplan.solve(problem)
        row = res.plan.metrics["row"]
        sb = stops_bound(problem)
        moving = row["carriage_moving_share"] * row["row_time"] - row["overlap_seconds"]
        stop_time = row["row_time"] - moving
        cells = [int(round((s - problem.gantry.start) / STEP)) for s in sb.stops]
        at_picks, at_bound_stops = _charges(problem, res.plan, cells, sb.weights)
        idle = row["idle_share"].values()
        others = row["row_time"] * float(np.mean([i["others"] for i in idle]))
        holding = row["row_time"] * float(np.mean([i["coordination"] for i in idle]))
        print(f"| {name} | {row['row_time']:.1f} s | {sb.value:.1f} s | {row['row_time'] / sb.value:.3f} | {sb.moves:.1f} s "
              f"| {moving:.1f} s | {sb.work:.1f} s | {stop_time:.1f} s | {at_picks:.1f} s | {at_bound_stops:.1f} s "
              f"| +{at_picks - sb.work:.1f} s | +{stop_time - at_picks:.1f} s | {others:.1f} s | {holding:.1f} s | {'yes' if res.verification.passed else 'NO'} |",
              flush=True)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
