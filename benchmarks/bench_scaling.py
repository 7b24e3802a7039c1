"""How planning cost grows with the length of a row: more fruit, more arms -- one run.

Rows from ``coplan.generate.row_problem(arms, fruit, seed=11, reachable_only=True)``: first five
arms with 25-200 fruit, then 20 fruit per arm with 2-10 arms. For each, in-process and imports
excluded (2-core machine, one row at a time):

* the coordinated planner's solve time, and that time per fruit;
* one coordinator run on its plan (``coordinate`` from scratch, the optimal planner's
  evaluator), per fruit;
* the optimal planner at its default work budget: solve time, coordinator runs, time per run
  and per run per fruit (the search's budget is work, so the number of runs it buys falls as
  each run gets longer), makespan / lower bound.

"Linear" means the per-fruit columns stay flat as the rows grow.

    python benchmarks/bench_scaling.py
    python benchmarks/bench_scaling.py --quick     # up to 100 fruit, no optimal planner
"""

from __future__ import annotations

import argparse
import time

import coplan
from coplan.generate import row_problem, to_yaml
from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated
from coplan.planners.coordinated.coordinate import coordinate
from coplan.planners.coordinated.schedule import decoupled_schedules
from coplan.problem import parse_problem
from run_header import run_header

ROWS = [(5, 25), (5, 50), (5, 100), (5, 200), (2, 40), (4, 80), (6, 120), (8, 160), (10, 200)]


def _row(arms: int, fruit: int):
    return parse_problem(to_yaml(row_problem(arms, fruit, seed=11, reachable_only=True)))


def measure(arms: int, fruit: int, optimal: bool) -> dict:
    problem = _row(arms, fruit)
    n = len(problem.fruits)
    t0 = time.perf_counter()
    co = plan_coordinated(problem, "makespan", CoordinatedOptions(), None, {})
    t_coord = time.perf_counter() - t0
    cand = co.candidate
    t0 = time.perf_counter()
    coordinate(problem, decoupled_schedules(problem, cand.alloc), CoordinatedOptions().margin,
               priority=list(cand.order) or None)
    t_run = time.perf_counter() - t0
    row = {"arms": arms, "fruit": n, "coordinated_s": t_coord, "coordinated_ms_per_fruit": 1e3 * t_coord / n,
           "run_ms_per_fruit": 1e3 * t_run / n, "bound": co.plan.metrics.get("lower_bound"),
           "coordinated": cand.makespan}
    if optimal:
        t0 = time.perf_counter()
        res = coplan.solve(problem, planner="optimal")
        t_opt = time.perf_counter() - t0
        search = res.plan.solver.get("search") or {}
        evals = search.get("evaluations") or 0
        t_search = (res.plan.solver.get("timings") or {}).get("search") or 0.0
        row |= {"optimal": res.plan.metrics["makespan"], "optimal_s": t_opt, "evaluations": evals,
                "ms_per_eval": 1e3 * t_search / evals if evals else None,
                "ms_per_eval_per_fruit": 1e3 * t_search / evals / n if evals else None}
    return row


def _f(x, nd=2):
    return "-" if x is None else f"{x:.{nd}f}"


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="rows up to 100 fruit, coordinated planner only")
    args = ap.parse_args(argv)
    print(run_header(), flush=True)
    rows = [r for r in ROWS if not args.quick or r[1] <= 100]
    print("| arms | fruit | lower bound | coordinated (solve s) | coordinated ms / fruit | one coordinator run ms / fruit "
          "| optimal (solve s) | optimal / bound | coordinator runs | ms / run | ms / run / fruit |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    t_all = time.perf_counter()
    for arms, fruit in rows:
        r = measure(arms, fruit, not args.quick)
        opt = (f"{r['optimal']:.2f} s ({r['optimal_s']:.1f} s)", _f(r["optimal"] / r["bound"], 4), str(r["evaluations"]),
               _f(r["ms_per_eval"], 0), _f(r["ms_per_eval_per_fruit"], 2)) if "optimal" in r else ("-",) * 5
        print(f"| {r['arms']} | {r['fruit']} | {r['bound']:.2f} s | {r['coordinated']:.2f} s ({r['coordinated_s']:.2f} s) "
              f"| {r['coordinated_ms_per_fruit']:.1f} | {r['run_ms_per_fruit']:.2f} | " + " | ".join(opt) + " |", flush=True)
    print(f"Whole run: {time.perf_counter() - t_all:.0f} s.")


if __name__ == "__main__":
    main()
