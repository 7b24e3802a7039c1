"""Sweep throughput on Dask with 1 and 2 worker processes, and what a warm worker reuses.

1. **Throughput**: the same sweep (``random_problem(0..N-1)``, the coordinated planner by
   default: deterministic work, no clock limits) on a ``LocalCluster`` of 1, then 2 worker
   processes. Prints problems per minute over the whole run (cluster start included) and in
   steady state (first to last row), and the 2-worker / 1-worker ratio (target >= 1.8).
2. **Reuse across problems**: what a long-lived worker saves per problem against a fresh
   process per problem: the same problems solved (a) each in its own ``python -c`` process
   (imports, CasADi kernels, HiGHS start each time) and (b) one after another in one warm
   process (what a Dask worker does), and the import time alone. (The optimal planner's CasADi
   kernels are also built once per process: ``coplan.planners.optimal.nlp`` caches them.)

    python benchmarks/bench_sweep.py [--problems 16] [--reuse 6] [--planner coordinated]

The machine is shared with other jobs while this runs; the figures say so when printed.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from coplan.sweep.run import run_sweep
from coplan.sweep.spec import parse_sweep
from run_header import run_header


def _spec(n: int, planner: str, time_limit: float):
    return parse_sweep(f"name: bench\nbase: random\nvary:\n  seed: {{from: 0, to: {n - 1}}}\n"
                       f"planner: {planner}\ntime_limit: {time_limit}\n", "bench.yaml")


def throughput(n: int, planner: str, time_limit: float, workers: int) -> dict:
    times: list[float] = []
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        res = run_sweep(_spec(n, planner, time_limit), Path(tmp) / "out", workers=workers,
                        on_row=lambda row, o: times.append(time.perf_counter()))
        wall = time.perf_counter() - t0
    steady = (len(times) - 1) / (times[-1] - times[0]) * 60.0 if len(times) > 1 and times[-1] > times[0] else None
    return {"workers": workers, "problems": res.done, "wall_s": wall, "per_min": 60.0 * res.done / wall,
            "steady_per_min": steady, "counts": res.counts, "load": os.getloadavg()[0]}


_ONE = """
import sys, time, json
t0 = time.perf_counter()
from coplan.generate import random_problem, to_yaml
from coplan.problem import parse_problem
from coplan import solve
t1 = time.perf_counter()
p = parse_problem(to_yaml(random_problem(int(sys.argv[1]))))
r = solve(p, planner=sys.argv[2])
print(json.dumps({"imports": t1 - t0, "solve": time.perf_counter() - t1, "status": r.status.value}))
"""


def reuse(m: int, planner: str) -> dict:
    """Cold (a fresh process) and warm (this process, warmed up on another problem) solves of
    the same problems, interleaved so that a change in the machine's load hits both alike."""
    t0 = time.perf_counter()
    from coplan import solve
    from coplan.generate import random_problem, to_yaml
    from coplan.problem import parse_problem

    imp = time.perf_counter() - t0
    solve(parse_problem(to_yaml(random_problem(10_000))), planner=planner)  # warm-up, not counted
    cold, warm = [], []
    for s in range(m):
        t0 = time.perf_counter()
        p = subprocess.run([sys.executable, "-c", _ONE, str(s), planner], capture_output=True, text=True, check=True)
        doc = json.loads(p.stdout.strip().splitlines()[-1])
        doc["process"] = time.perf_counter() - t0
        cold.append(doc)
        prob = parse_problem(to_yaml(random_problem(s)))
        t0 = time.perf_counter()
        solve(prob, planner=planner)
        warm.append(time.perf_counter() - t0)
    cold_total = sum(c["process"] for c in cold)
    return {"problems": m, "cold_process_total_s": cold_total, "cold_solve_total_s": sum(c["solve"] for c in cold),
            "cold_imports_median_s": statistics.median(c["imports"] for c in cold), "warm_total_s": sum(warm),
            "warm_imports_s": imp, "gain": cold_total / sum(warm), "saved_per_problem_s": (cold_total - sum(warm)) / m}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", type=int, default=16, help="problems in the throughput sweep (0: skip)")
    ap.add_argument("--reuse", type=int, default=6, help="problems in the reuse measurement (0: skip)")
    ap.add_argument("--planner", default="coordinated")
    ap.add_argument("--time-limit", type=float, default=120.0)
    ap.add_argument("--json", type=Path, help="also write the figures to this JSON file")
    args = ap.parse_args(argv)
    print(run_header(), flush=True)
    print(f"machine: {os.cpu_count()} cores, load average {os.getloadavg()[0]:.2f} at start (shared with other jobs)")
    out: dict = {}
    if args.problems:
        runs = [throughput(args.problems, args.planner, args.time_limit, w) for w in (1, 2)]
        print("| workers | problems | wall, s | problems/min (wall) | problems/min (steady) | load avg |")
        print("|---|---|---|---|---|---|")
        for r in runs:
            print(f"| {r['workers']} | {r['problems']} | {r['wall_s']:.1f} | {r['per_min']:.1f} | {r['steady_per_min']:.1f} | {r['load']:.2f} |")
        ratio = runs[1]["per_min"] / runs[0]["per_min"]
        steady = runs[1]["steady_per_min"] / runs[0]["steady_per_min"]
        print(f"2 workers / 1 worker: {ratio:.2f}x (wall), {steady:.2f}x (steady state); target >= 1.8x")
        out.update(throughput=runs, speedup_wall=ratio, speedup_steady=steady)
    if args.reuse:
        ru = reuse(args.reuse, args.planner)
        print(f"reuse over {ru['problems']} problems ({args.planner}): a fresh process each {ru['cold_process_total_s']:.1f} s "
              f"(of which solving {ru['cold_solve_total_s']:.1f} s, imports {ru['cold_imports_median_s']:.2f} s median each); "
              f"one warm process {ru['warm_total_s']:.1f} s: {ru['gain']:.2f}x, {ru['saved_per_problem_s']:.2f} s saved per problem "
              f"(imports {ru['warm_imports_s']:.2f} s once per worker)")
        out["reuse"] = ru
    if args.json:
        args.json.write_text(json.dumps(out, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
