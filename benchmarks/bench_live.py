"""The live cell's figures -- the targets of issue 12 ("Harvest from a live vision feed").

On greenhouse-like rows (3 arms 2 m apart, 12-30 fruit, ``coplan.generate.row_problem``, every
fruit reachable) and seeded feeds (``coplan.live.feed.make_feed``), runs the simulated cell
(``coplan.live.sim.simulate``) and prints per run and per size:

* re-planning latency (median, p95, max over every re-plan; target p95 <= 100 ms), and whether
  every executed trajectory passed ``coplan.verify.verify`` (continuity, limits, clearance, picks);
* scenario ``late``: half the fruit known at t = 0, the rest arriving over the first half of the
  run (``reveal_by`` = half the omniscient makespan), 10 mm noise: throughput loss against the
  omniscient coordinated plan (target <= 10 %);
* scenario ``noisy``: 10 mm initial noise, 1 mm close-range noise, 5 % false positives, 10 %
  duplicate detections: pick success over the reachable true fruit (target: all), false picks
  (target: none) and collisions (the verifier's).

    python benchmarks/bench_live.py [--seeds 5] [--sizes 12 20 30] [--work N | --work none] [--budget S]

Latency is wall-clock time on this machine. A re-plan tries better candidates while its work
budget lasts (``LiveOptions.work``, default 100 conflict checks: the same plans on any machine);
``--work none`` tries every candidate (higher latency); ``--budget S`` adds a clock budget
(``LiveOptions.budget``: the plans then depend on the machine's speed and load).
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from coplan.planners.coordinated import plan_coordinated
from coplan.generate import row_problem, to_yaml
from coplan.live.cell import LiveOptions
from coplan.live.feed import make_feed
from coplan.live.sim import simulate
from coplan.problem import parse_problem
from run_header import run_header

SCENARIOS = {
    "late": dict(known=0.5, sigma=0.01, false_rate=0.0, duplicate_rate=0.0),
    "noisy": dict(known=0.5, sigma=0.01, false_rate=0.05, duplicate_rate=0.1, close_sigma=0.001),
}


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--seeds", type=int, default=5, help="seeded feeds per problem size (default 5)")
    ap.add_argument("--sizes", type=int, nargs="+", default=[12, 20, 30], help="fruit per problem (default 12 20 30)")
    ap.add_argument("--work", default=str(LiveOptions.work), help="re-plan work budget in conflict checks, or 'none'")
    ap.add_argument("--budget", default="none", help="re-plan clock budget in s, or 'none' (the default)")
    args = ap.parse_args()
    print(run_header(), flush=True)
    opts = LiveOptions(work=None if args.work.lower() == "none" else int(args.work),
                       budget=None if args.budget.lower() == "none" else float(args.budget))
    print(f"{'scenario':8} {'fruit':>5} {'seed':>4} {'replans':>7} {'med ms':>7} {'p95 ms':>7} {'max ms':>7} "
          f"{'live s':>7} {'omni s':>7} {'loss %':>7} {'picked':>7} {'false':>9} {'verified':>8} {'run s':>6}")
    summary = {}
    for name, kw in SCENARIOS.items():
        for n in args.sizes:
            lat, loss, ok, success, false_picks, false_seen = [], [], [], [], 0, 0
            for seed in range(args.seeds):
                problem = parse_problem(to_yaml(row_problem(3, n, seed=seed, reachable_only=True)))
                omni = plan_coordinated(problem).plan.metrics["makespan"]
                feed = make_feed(problem, seed=seed, reveal_by=0.5 * omni, **kw)
                t0 = time.perf_counter()
                r = simulate(problem, feed, opts, seed=seed)
                wall = time.perf_counter() - t0
                m = r.run["metrics"]
                lats = [x["latency"] for x in r.run["replans"]]
                lat += lats
                loss.append(m["throughput_loss"])
                ok.append(m["verified"])
                success.append(m["pick_success_rate"])
                false_picks += m["false_picks"]
                false_seen += m["false_detections"]
                print(f"{name:8} {n:5d} {seed:4d} {len(lats):7d} {1000 * statistics.median(lats):7.1f} "
                      f"{1000 * float(np.percentile(lats, 95)):7.1f} {1000 * max(lats):7.1f} {m['makespan']:7.2f} "
                      f"{m['omniscient_makespan']:7.2f} {100 * m['throughput_loss']:7.1f} {m['harvested']:3d}/{m['reachable']:<3d} "
                      f"{m['false_picks']:3d} of {m['false_detections']:<2d} {str(m['verified']):>8} {wall:6.1f}", flush=True)
            summary[(name, n)] = (lat, loss, ok, success, false_picks, false_seen)
    print("\nper scenario and size (all seeds):")
    for (name, n), (lat, loss, ok, success, fp, fs) in summary.items():
        print(f"  {name:6} {n:3d} fruit: latency median {1000 * statistics.median(lat):.1f} ms, p95 "
              f"{1000 * float(np.percentile(lat, 95)):.1f} ms, max {1000 * max(lat):.1f} ms; throughput loss mean "
              f"{100 * statistics.mean(loss):.1f} %, worst {100 * max(loss):.1f} %; pick success min {min(success):.3f}; "
              f"false picks {fp} of {fs} false detections; verified {sum(ok)}/{len(ok)}")


if __name__ == "__main__":
    main()
