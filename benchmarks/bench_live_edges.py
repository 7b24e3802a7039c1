"""Live stop and go where the shipped rows do not go -- one run.

Two kinds of generated row (``coplan.generate.gantry_row``), each run live stop and go as
``coplan run ROW --gantry stop-and-go`` runs it (camera 1.5 m ahead of the front arm, 10 mm
noise, 5 % false and 2 % repeated reports, live seed 0) and compared with its offline plan (the
optimised-stops row planner, every fruit known):

* **arms close together**: 12 m rows, three arms 1.2 m apart (the shipped rows' are 2 m), 3.6
  fruit per metre, row seeds 0-3. A live stop's arms book direct moves, and a neighbour can be
  in the way of every one to some fruit; what a stop's booking leaves of its share is planned
  there as a cell (:func:`coplan.row.stopcell.book_cell`; *cell picks*), decided at the stop's
  arrival, its first motion once the stop's booked motion is over (*its lead*: the time the
  decision has; *kept ahead*: every cycle decided within the shortest cycle and every cell
  within its lead);
* **arms closer still**: 6 m rows, three arms 1 m apart, 8 fruit per metre, row seeds 0-3,
  where the screen locks the two rear arms (their bins out of reach past a neighbour: *locked*)
  and the front arm harvests alone; a hop is capped by the rear arm that harvests;
* **short rows**: 1, 2 and 3 m, three arms 2 m apart, 6 fruit per metre, row seeds 0-2 (live
  seed = row seed): the camera sees the whole row from the start, and the live row stops once,
  where :func:`coplan.row.livestops.last_stop` says.

Every plan is verified (the live ones against the true fruit). It prints a Markdown table on
stdout (about 2 minutes on a 2-core machine).

    python benchmarks/bench_live_edges.py
"""

from __future__ import annotations

import time

from run_header import run_header


def _rows():
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem

    for seed in range(4):
        yield ("arms 1.2 m apart", 12.0, seed, 0,
               parse_problem(to_yaml(gantry_row(length=12.0, n_arms=3, density=3.6, spacing=1.2, seed=seed))))
    for seed in range(4):
        yield ("arms 1 m apart", 6.0, seed, 0,
               parse_problem(to_yaml(gantry_row(length=6.0, n_arms=3, density=8.0, spacing=1.0, seed=seed))))
    for length in (1.0, 2.0, 3.0):
        for seed in range(3):
            yield ("short row", length, seed, seed, parse_problem(to_yaml(gantry_row(length=length, density=6.0, seed=seed))))


def main() -> None:
    from coplan.kinds import GantryMode
    from coplan.plan import EventKind
    from coplan.problem.gantry import cell_at
    from coplan.row.live import LiveRowOptions, run_live_row
    from coplan.row.reach import locked_arms

    print(run_header(), flush=True)
    t0 = time.perf_counter()
    print("| row | length | row seed | fruit | locked | offline plan harvests | live harvests of those | row time / offline | "
          "stops live (offline) | cell picks | slowest decision | slowest cell (its lead) | kept ahead | verified |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|---|---|")
    for kind, length, seed, live_seed, problem in _rows():
        res = run_live_row(problem, LiveRowOptions(mode=GantryMode.STOP_AND_GO, seed=live_seed))
        ref = {e.fruit for e in res.offline.plan.events if e.kind == EventKind.PLACE}
        got = {e.fruit for e in res.plan.events if e.kind == EventKind.PLACE}
        stops = res.plan.solver["row"]["stops"]
        ok = res.verification.passed and res.offline.plan.verification is not None and res.offline.plan.verification.get("passed")
        cells = res.metrics["cell_decisions"]
        slow = max(cells, key=lambda d: d["seconds"], default=None)
        cell = "-" if slow is None else f"{slow['seconds'] * 1000:.0f} ms ({slow['lead_seconds']:.1f} s)"
        locked = ", ".join(sorted(locked_arms(cell_at(problem, 0.0, ())))) or "-"
        print(f"| {kind} | {length:g} m | {seed} | {len(problem.fruits)} | {locked} | {len(ref)} | {len(ref & got)} | "
              f"{res.metrics['row_time_ratio']:.3f} | {len(stops)} ({len(res.offline.stops)}) | "
              f"{sum(s['cell_picks'] for s in stops)} | {res.metrics['decision_max_seconds'] * 1000:.0f} ms | {cell} | "
              f"{'yes' if res.metrics['kept_ahead'] else 'no'} | {'yes' if ok else 'NO'} |",
              flush=True)
    print(f"\n(one run, {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    import argparse

    # (no options: --help ran the whole benchmark)
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    main()
