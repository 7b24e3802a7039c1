"""Whole rows on a mobile gantry: the stop rules side by side, and planning at scale -- one run.

1. **Stop rules** on the shipped 50 m rows (``problems/rows/``): fixed stride, fewest stops and
   optimised, each planned with the coordinated cell planner at every stop (the stops' cells in
   two worker processes beside the stop rule: ``coplan solve ROW --workers 2``) and verified in the
   row frame. Per rule: stops, row time (the last fruit placed), fruit per hour, share of the
   harvestable fruit harvested, row time / the lower bound for any plan and for stop-and-go,
   how long the carriage moved while an arm worked (placing, going home, coming out: what the
   stop-by-stop bound's model excludes), planning time and its share of the row time, when the
   first stop was known, and whether
   every stop's cell was planned before the carriage needed it. Then the optimised rule's
   fruit per hour against the better of the two baselines, and each row's bounds: the plain
   stop-by-stop one (one move, best-position work) and the priced one (stops and positions).
2. **Scale**: rows of 25, 50, 100 and 200 m, 6 arms, 10.5 fruit per metre (``gantry_row``), the
   optimised rule, each in a fresh process: planning time and its share of the row time,
   planning time per metre, peak memory (the maximum resident set of the planning process and
   of its largest worker), and the plan file
   written, read back and checked by ``coplan verify`` in another process (its wall time).

Every ratio is measured in this run, on this machine. Every plan is verified.

    python benchmarks/bench_rows.py                 # both parts
    python benchmarks/bench_rows.py --rules-only    # the stop rules only
    python benchmarks/bench_rows.py --rules-only --pace-prices 2,3,4,5   # and the optimised rule with each
                                                    # pace price (StopWindow.pace_price, coplan solve --pace-price)
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from run_header import run_header

WORKERS = 2  # processes the stops' cells are planned in beside the stop rule (coplan solve ROW --workers 2)

def _rules(files: list[Path], paces: list[float] = ()) -> list[str]:
    from coplan.kinds import StopRule
    from coplan.problem import load_problem
    from coplan.allocate.row_bound import row_bounds
    from coplan.row.metrics import row_metrics
    from coplan.row.plan import RowOptions, plan_row
    from coplan.row.stops import StopWindow

    out = ["| row | fruit | stop rule | stops | row time | fruit / h | harvested | / bound (any plan) | / bound (stop by stop, no overlap) "
           "| moves overlapping work | planning | planning / row time | first motion | kept ahead (least slack) | verified |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    gains, bounds = [], []
    for f in files:
        prob = load_problem(f)
        b = row_bounds(prob)
        bounds.append(f"{f.stem}: any plan {b.any_plan:.1f} s; stop by stop {b.stop_and_go:.1f} s -- one move and the busiest "
                      f"arm's best-position work {b.moves + b.work:.1f} s, stops and positions priced together {b.priced:.1f} s "
                      f"({b.priced_stops} stops in its witness); all computed in {b.seconds:.2f} s")
        print(bounds[-1], flush=True)
        per = {}
        for rule, pace in [(StopRule.FIXED, 0.0), (StopRule.FEWEST, 0.0), (StopRule.OPTIMISED, 0.0)] + [
                (StopRule.OPTIMISED, p) for p in paces]:
            res = plan_row(prob, RowOptions(stops=rule, workers=WORKERS, window=StopWindow(pace_price=pace)))
            m = row_metrics(prob, res, b)
            per[(rule, pace)] = m
            name = rule.value + (f", pace {pace:g} s" if pace else "")
            out.append(f"| {f.stem} | {len(prob.fruits)} | {name} | {m['stops']} | {m['row_time']:.1f} s | "
                       f"{m['fruit_per_hour']:.0f} | {100 * m['share_harvested']:.1f} % | {m['ratio_any_plan_bound']:.3f} | "
                       f"{m['ratio_stop_and_go_bound']:.3f} | {m['overlap_seconds']:.1f} s | {m['planning_time']:.2f} s | "
                       f"{100 * m['planning_over_row_time']:.2f} % | {m['first_motion_seconds']:.2f} s | "
                       f"{'yes' if m['kept_ahead'] else 'no'} ({m['least_slack_seconds']:.1f} s) | "
                       f"{'yes' if res.verification.passed else 'NO'} |")
            print(out[-1], flush=True)
        base = max(per[(StopRule.FIXED, 0.0)]["fruit_per_hour"], per[(StopRule.FEWEST, 0.0)]["fruit_per_hour"])
        for pace in [0.0] + list(paces):
            mo = per[(StopRule.OPTIMISED, pace)]
            gains.append((f.stem, pace, mo["fruit_per_hour"] / base - 1.0, mo["stops"], per[(StopRule.FIXED, 0.0)]["stops"]))
    out.append("")
    out += [f"{name}: optimised{f' (pace {p:g} s)' if p else ''} {100 * g:+.1f} % fruit per hour against the better "
            f"baseline; {s} stops (fixed stride {sf}){'' if g >= 0.10 and s <= sf else ' -- not both targets'}"
            for name, p, g, s, sf in gains]
    out += [""] + bounds
    return out


_CHILD = r"""
import json, resource, sys, time
from pathlib import Path
from coplan.generate import gantry_row, to_yaml
from coplan.problem import parse_problem
from coplan.pipeline import solve
from coplan.row.plan import RowOptions
length = float(sys.argv[1]); out = Path(sys.argv[2])
text = to_yaml(gantry_row(length=length, n_arms=6, density=10.5, seed=11))
(out / "row.yaml").write_text(text)
prob = parse_problem(text, str(out / "row.yaml"))
t = time.perf_counter()
res = solve(prob, out_dir=out / "run", options=RowOptions(workers=int(sys.argv[3])))
m = res.plan.metrics["row"]
print(json.dumps({"fruit": len(prob.fruits), "harvested": m["harvested"], "harvestable": m["harvestable"],
                  "row_time": m["row_time"], "planning": m["planning_time"], "first": m["first_motion_seconds"],
                  "kept_ahead": m["kept_ahead"], "slack": m["least_slack_seconds"], "verified": bool(res.verification.passed),
                  "ratio": m["ratio_any_plan_bound"], "wall": time.perf_counter() - t,
                  "peak_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0,
                  "worker_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024.0,
                  "plan_mb": (out / "run" / "plan.json").stat().st_size / 2**20}))
"""


def _scale(lengths: list[float]) -> list[str]:
    out = ["| row | fruit | planning | row time | planning / row time | planning per metre | first motion "
           "| kept ahead | peak memory (largest worker) | plan.json | coplan verify (read back) | verified |",
           "|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for L in lengths:
        with tempfile.TemporaryDirectory() as d:
            r = subprocess.run([sys.executable, "-c", _CHILD, str(L), d, str(WORKERS)], capture_output=True, text=True)
            if r.returncode != 0:
                out.append(f"| {L:g} m | failed: {r.stderr.strip().splitlines()[-1] if r.stderr else r.returncode} |")
                print(out[-1], flush=True)
                continue
            m = json.loads(r.stdout.strip().splitlines()[-1])
            t = time.perf_counter()
            v = subprocess.run([sys.executable, "-m", "coplan.cli", "verify", str(Path(d) / "row.yaml"),
                                str(Path(d) / "run" / "plan.json")], capture_output=True, text=True)
            tv = time.perf_counter() - t
            out.append(f"| {L:g} m, 6 arms | {m['fruit']} | {m['planning']:.1f} s | {m['row_time']:.0f} s | "
                       f"{100 * m['planning'] / m['row_time']:.2f} % | {m['planning'] / L:.3f} s/m | {m['first']:.2f} s | "
                       f"{'yes' if m['kept_ahead'] else 'no'} ({m['slack']:.1f} s) | {m['peak_mb']:.0f} MB ({m['worker_mb']:.0f} MB) | "
                       f"{m['plan_mb']:.1f} MB | {tv:.1f} s, exit {v.returncode} | {'yes' if m['verified'] else 'NO'} |")
            print(out[-1], flush=True)
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rules-only", action="store_true", help="the stop rules on the shipped rows only (about 1 minute)")
    ap.add_argument("--scale-only", action="store_true", help="the rows at scale only (6 arms, 10.5 fruit per metre)")
    ap.add_argument("--pace-prices", default="", help="also the optimised rule with each of these pace prices, s, "
                                                      "comma-separated (StopWindow.pace_price)")
    ap.add_argument("--lengths", default="25,50,100,200", help="the rows at scale, m, comma-separated (default 25,50,100,200)")
    args = ap.parse_args()
    print(run_header(), flush=True)
    from coplan.problem import shipped_rows

    t0 = time.perf_counter()
    lines = []
    if not args.scale_only:
        lines += _rules(shipped_rows(), [float(x) for x in args.pace_prices.split(",") if x.strip()]) + [""]
    if not args.rules_only:
        lines += _scale([float(x) for x in args.lengths.split(",")])
    print("\n" + "\n".join(lines))
    print(f"\nWhole run: {time.perf_counter() - t0:.0f} s.")


if __name__ == "__main__":
    main()
