"""Benchmark the optimal planner against the heuristic baseline.

Prints, for every shipped problem: fruit harvested / reachable, makespan (baseline and
optimal), cycle time per fruit (worst arm), the makespan lower bound and the ratio
makespan / lower bound, the solve time split into allocation (incl. the warm-start search)
/ build / solve / verify, IPOPT iterations and the plan's verified status; then the solve
time against fruit count for 3-arm rows of 10, 20, 50 and 100 fruit, so growth is visible.

Solve time is measured in-process, imports excluded: allocation + build + solve + verify
(``OptimalResult.timings``; the baseline, which the planner also computes for reference,
is not included). Each figure is the median of ``--repeat`` runs.

    python benchmarks/bench_optimal.py                 # everything
    python benchmarks/bench_optimal.py --rows           # only the row-length sweep
    python benchmarks/bench_optimal.py --problems greenhouse_row --repeat 5
    python benchmarks/bench_optimal.py --rows --sizes 10 --random 30   # + random layouts
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import coplan
from coplan.generate import row_problem
from coplan.optimal import plan_optimal
from coplan.problem import parse_problem, shipped_problems
from coplan.generate import to_yaml


def _fmt(x, nd=2, unit=""):
    return "-" if x is None else f"{x:.{nd}f}{unit}"


def run(problem, repeat: int):
    """Median timings over ``repeat`` runs; metrics of the last run."""
    runs = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        res = plan_optimal(problem)
        wall = time.perf_counter() - t0
        runs.append((res, wall))
    res = runs[-1][0]
    keys = ("allocation", "build", "solve", "verify", "total")
    med = {k: statistics.median(r.timings.get(k, 0.0) for r, _ in runs) for k in keys}
    return res, med


def table_problems(names: list[str] | None, repeat: int) -> None:
    paths = [p for p in shipped_problems() if names is None or p.stem in names]
    head = (
        f"{'problem':16s} {'fruit':>7s} {'base mk':>8s} {'opt mk':>8s} {'ratio':>6s} {'cycle':>6s} {'LB':>7s} "
        f"{'mk/LB':>6s} {'alloc':>6s} {'build':>6s} {'solve':>6s} {'verify':>6s} {'total':>6s} {'iters':>5s}  status"
    )
    print(head)
    print("-" * len(head))
    for path in paths:
        prob = coplan.load_problem(path)
        res, t = run(prob, repeat)
        m, b = res.plan.metrics, res.baseline.metrics
        lb = m.get("lower_bound")
        ratio = m["makespan"] / b["makespan"] if b.get("makespan") else None
        print(
            f"{path.stem:16s} {m['harvested']:>3d}/{m['reachable']:<3d} {_fmt(b['makespan']):>8s} {_fmt(m['makespan']):>8s} "
            f"{_fmt(ratio, 3):>6s} {_fmt(m.get('cycle_time')):>6s} {_fmt(lb):>7s} {_fmt(m.get('gap_to_lower_bound'), 3):>6s} "
            f"{t['allocation']:6.3f} {t['build']:6.3f} {t['solve']:6.3f} {t['verify']:6.3f} {t['total']:6.3f} "
            f"{res.plan.solver.get('iterations', 0):>5d}  {res.plan.status.value} (baseline {res.baseline.status.value})"
        )


def table_rows(sizes: list[int], repeat: int) -> None:
    head = f"{'fruit':>5s} {'arms':>4s} {'windows':>7s} {'makespan':>8s} {'mk/LB':>6s} {'total s':>8s} {'s/fruit':>7s} {'iters':>5s}  status"
    print(head)
    print("-" * len(head))
    for n in sizes:
        d = row_problem(3, n, seed=7, reachable_only=True, name=f"row-{n}")
        prob = parse_problem(to_yaml(d), f"row-{n}")
        res, t = run(prob, repeat)
        m = res.plan.metrics
        print(
            f"{n:>5d} {len(prob.arms):>4d} {res.plan.solver.get('windows', 0):>7d} {_fmt(m['makespan']):>8s} "
            f"{_fmt(m.get('gap_to_lower_bound'), 3):>6s} {t['total']:8.2f} {t['total'] / n:7.3f} "
            f"{res.plan.solver.get('iterations', 0):>5d}  {res.plan.status.value}"
        )


def table_random(n: int, time_limit: float) -> None:
    """Random layouts the planner was not tuned for (``coplan.generate.random_problem``)."""
    from coplan.generate import random_problem
    from coplan.optimal import OptimalOptions
    from coplan.verify import verify

    head = (f"{'seed':>4s} {'arms':>4s} {'fruit':>7s} {'base mk':>8s} {'opt mk':>8s} {'ratio':>6s} {'total s':>8s}  "
            f"{'status':9s} windows (timing of each)")
    print(head)
    print("-" * len(head))
    ok, ratios, times = 0, [], []
    for seed in range(n):
        prob = parse_problem(to_yaml(random_problem(seed)), f"random-{seed}")
        res = plan_optimal(prob, options=OptimalOptions(time_limit=time_limit))
        m, b = res.plan.metrics, res.baseline.metrics
        success = res.plan.status.value == "success"
        if success:
            assert verify(prob, res.plan).passed  # a success is always an independently verified plan
            ok += 1
            ratios.append(m["makespan"] / b["makespan"])
        times.append(res.timings["total"])
        stages = res.plan.solver.get("window_timing") or []
        print(f"{seed:>4d} {len(prob.arms):>4d} {m['harvested']:>3d}/{m['reachable']:<3d} {_fmt(b.get('makespan')):>8s} "
              f"{_fmt(m.get('makespan')):>8s} {_fmt(m['makespan'] / b['makespan'] if b.get('makespan') else None, 3):>6s} "
              f"{res.timings['total']:8.1f}  {res.plan.status.value:9s} {len(stages)} ({', '.join(stages)})")
    print(f"success (IPOPT converged and verified, every reachable fruit): {ok}/{n}; "
          f"median makespan ratio to the baseline {statistics.median(ratios) if ratios else float('nan'):.3f}; "
          f"median total {statistics.median(times):.1f} s, max {max(times):.1f} s")


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", nargs="*", help="shipped problem names (default: all)")
    ap.add_argument("--rows", action="store_true", help="only the row-length sweep")
    ap.add_argument("--sizes", nargs="*", type=int, default=[10, 20, 50, 100])
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--random", type=int, default=0, metavar="N", help="also random layouts, seeds 0..N-1 (one run each)")
    ap.add_argument("--random-time-limit", type=float, default=120.0, help="time limit per random layout (s)")
    args = ap.parse_args(argv)
    print(f"coplan {coplan.__version__}, python {sys.version.split()[0]}")
    if not args.rows:
        print("\nShipped problems (times in s, median of", args.repeat, "runs)")
        table_problems(args.problems or None, args.repeat)
    if args.rows or not args.problems:
        print("\nRow length sweep: 3 arms 2 m apart, fruit uniform along the row (times: median of", args.repeat, "runs)")
        table_rows(args.sizes, max(1, min(args.repeat, 2)))
    if args.random:
        print(f"\nRandom layouts (2-5 arms, spacing, links, limits, fruit all drawn from the seed), time limit {args.random_time_limit:g} s")
        table_random(args.random, args.random_time_limit)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
