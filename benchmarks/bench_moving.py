"""Stop and go against pick on the move, on the same rows -- one run.

1. **Head to head** on the shipped 50 m rows (``problems/rows/``) and on generated 20 m rows
   (``coplan.generate.gantry_row``, seed 11) at 2, 8 and 20 fruit per metre with 3 and 6 arms:
   the stop rules fixed stride, fewest stops and optimised (the coordinated cell planner at
   every stop, the stops' cells in two worker processes: ``--workers 2``), and continuous (``--gantry continuous --workers 2``: the speed search over a
   density profile, two levels planned side by side). Per row and mode: row time (the last fruit placed), fruit per hour, share of the
   harvestable fruit harvested, row time / the row's lower bound valid for any motion (no stop
   assumed: :func:`coplan.allocate.row_bound.row_bounds`), planning time and its share of the row time,
   and the verdict of ``coplan verify`` run on the written plan file in another process. Then,
   per row, which mode wins and by how much (fruit per hour against the better of the others).
2. **Speed curve** of continuous mode on one row: fruit per hour and share harvested against
   the carriage's speed -- one constant speed every 0.05 m/s, and every full plan the density
   profile's speed search tried (each verified).
2b. **Profiles** (``--parts profiles``, not in the default run): on every head-to-head row, the
   speed search over one constant speed against the search over a density profile (the
   default), each a full plan verified (``coplan verify`` on its file too): row time, fruit per
   hour, mean speed, planning time, and which profile wins by how much -- whether shaping the
   speed to the fruit pays (issue 29: "constant per row first; per segment by density if it pays").
3. **Arms curve**: fruit per hour against the number of arms (1 to 12, 2 m apart) on one
   generated 30 m row at 12 fruit per metre, stop and go (optimised stops) and on the move, run
   as a ``coplan sweep`` (``base: gantry``) on a 2-worker Dask LocalCluster; the figure
   ``docs/arms_curve.png`` with the line a perfectly linear speed-up from one arm would follow.
4. **Live rows**, both modes: on the move (``coplan run ROW --speed V``) at the constant speed
   the speed search over constant speeds chooses offline (a live planner cannot shape its speed
   to fruit it has not seen), holding for fruit, and stop and go (``coplan run
   ROW --gantry stop-and-go``); each shipped row, a camera 1.5 m ahead, 10 mm noise, 5 % false
   and 2 % repeated reports, seeds 0-2: the share of what the offline plan in the same mode (full
   knowledge; on the move at the same speed, stop and go the optimised-stops row planner)
   harvests, row time against it, and the slowest decision against the shortest cycle.
5. **Faults**, both modes: 50 seeded live rows each (generated 12 m rows, 3 arms, 6 fruit per
   metre, seeds 0-49; on the move at 0.1 m/s), each with one arm stopping, a 3 s camera outage,
   a burst of 50 false reports and a decision 2 s late, every one through ``coplan run`` in its
   own process: collisions and limit violations in the executed plans (``coplan verify`` on the
   files), fruit missed though a working arm could still reach them, and whether every run's
   files read back whole.

Every ratio is measured in this run, on this machine. Every plan is verified.

    python benchmarks/bench_moving.py               # both parts
    python benchmarks/bench_moving.py --quick       # the generated rows at 8 fruit per metre only
    python benchmarks/bench_moving.py --arms-only   # the arms curve only
    python benchmarks/bench_moving.py --live-only   # the live rows only
    python benchmarks/bench_moving.py --faults-only # the fault runs only
    python benchmarks/bench_moving.py --parts head,live  # some of the parts, in one run
    python benchmarks/bench_moving.py --parts profiles   # constant against density speed search
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from run_header import run_header

MODES = ("fixed", "fewest", "optimised", "continuous")
#: the speed curve's words for where the carriage rests at the end (coplan.row.cruise.EndRest's values)
_REST_WORDS = {"reach": "further on", "early": "early", "rail": "the rail's end"}
WORKERS = 2  # processes of continuous mode's speed search and of the stop rules' cells (coplan solve ROW --workers 2)


def _rows(quick: bool) -> list[tuple[str, object, str]]:
    """(name, problem, its YAML text) of every benchmark row."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import load_problem, parse_problem, shipped_rows

    out = [] if quick else [(p.stem, load_problem(p), p.read_text()) for p in shipped_rows()]
    for n_arms in (3, 6):
        for density in ((8.0,) if quick else (2.0, 8.0, 20.0)):
            text = to_yaml(gantry_row(length=20.0, n_arms=n_arms, density=density, seed=11))
            out.append((f"gen {n_arms} arms {density:g}/m", parse_problem(text), text))
    return out


def _plan(prob, mode: str):
    from coplan.kinds import StopRule
    from coplan.row.moving import plan_moving
    from coplan.row.plan import RowOptions, plan_row

    if mode == "continuous":
        from coplan.row.continuous import MovingOptions

        return plan_moving(prob, MovingOptions(workers=WORKERS))  # the speed search on both cores
    return plan_row(prob, RowOptions(stops=StopRule(mode), workers=WORKERS))  # the stops' cells on both cores


def _cli_verify(text: str, plan, folder: Path) -> bool:
    """``coplan verify`` on the written problem and plan file, in another process."""
    folder.mkdir(parents=True, exist_ok=True)
    pfile = folder / "problem.yaml"
    pfile.write_text(text)
    files = plan.save(folder, "plan")
    r = subprocess.run([sys.executable, "-m", "coplan.cli", "verify", str(pfile), str(files["json"])],
                       capture_output=True, text=True)
    return r.returncode == 0




def head_to_head(quick: bool) -> None:
    from coplan.allocate.row_bound import row_bounds
    from coplan.row.metrics import row_metrics

    print("| row | fruit | mode | row time | fruit / h | harvested | / bound (any motion) | planning | planning / row time | "
          "mean speed | coplan verify |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    wins = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, prob, text in _rows(quick):
            b = row_bounds(prob)
            per = {}
            for mode in MODES:
                res = _plan(prob, mode)
                m = row_metrics(prob, res, b)
                ok = res.verification.passed and _cli_verify(text, res.plan, Path(tmp) / name.replace(" ", "_") / mode)
                per[mode] = (m, ok)
                speed = f"{m['mean_speed']:.3f} m/s" if mode == "continuous" else "-"
                print(f"| {name} | {len(prob.fruits)} | {mode} | {m['row_time']:.1f} s | {m['fruit_per_hour']:.0f} | "
                      f"{100 * (m['share_harvested'] or 0):.1f} % | {m['ratio_any_plan_bound']:.3f} | {m['planning_time']:.2f} s | "
                      f"{100 * m['planning_over_row_time']:.2f} % | {speed} | {'yes' if ok else 'NO'} |", flush=True)
            complete = {k: v for k, v in per.items() if v[1] and (v[0]["share_harvested"] or 0) >= 1.0 - 1e-9}
            pool = complete or per
            best = max(pool, key=lambda k: pool[k][0]["fruit_per_hour"])
            others = [pool[k][0]["fruit_per_hour"] for k in pool if k != best]
            gain = 100 * (pool[best][0]["fruit_per_hour"] / max(others) - 1) if others else 0.0
            sg = max((pool[k][0]["fruit_per_hour"] for k in pool if k != "continuous"), default=None)
            cont = pool.get("continuous")
            vs = (f"; continuous {100 * (cont[0]['fruit_per_hour'] / sg - 1):+.1f} % against the best stop rule"
                  if cont and sg else "")
            wins.append(f"- {name}: {best} wins, {gain:+.1f} % fruit per hour against the next mode; "
                        f"{pool[best][0]['ratio_any_plan_bound']:.3f} x the bound for any motion{vs}")
    print()
    print("\n".join(wins))


def profiles(quick: bool) -> None:
    """Part 2b (module docstring): the speed search over a constant speed against a density profile."""
    from coplan.allocate.row_bound import row_bounds
    from coplan.kinds import SpeedProfile
    from coplan.row.continuous import MovingOptions
    from coplan.row.metrics import row_metrics
    from coplan.row.moving import plan_moving

    print("| row | fruit | profile | row time | fruit / h | harvested | / bound (any motion) | mean speed | planning | "
          "planning / row time | coplan verify |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    lines = []
    with tempfile.TemporaryDirectory() as tmp:
        for name, prob, text in _rows(quick):
            b = row_bounds(prob)
            per = {}
            for prof in (SpeedProfile.CONSTANT, SpeedProfile.DENSITY):
                res = plan_moving(prob, MovingOptions(profile=prof, workers=WORKERS))
                m = row_metrics(prob, res, b)
                ok = res.verification.passed and _cli_verify(text, res.plan, Path(tmp) / name.replace(" ", "_") / prof.value)
                per[prof.value] = (m, ok)
                print(f"| {name} | {len(prob.fruits)} | {prof.value} | {m['row_time']:.1f} s | {m['fruit_per_hour']:.0f} | "
                      f"{100 * (m['share_harvested'] or 0):.1f} % | {m['ratio_any_plan_bound']:.3f} | {m['mean_speed']:.3f} m/s | "
                      f"{m['planning_time']:.2f} s | {100 * m['planning_over_row_time']:.2f} % | {'yes' if ok else 'NO'} |", flush=True)
            c, d = per["constant"][0], per["density"][0]
            whole = [k for k, (m, ok) in per.items() if ok and (m["share_harvested"] or 0) >= 1.0 - 1e-9]
            if len(whole) == 2:
                best, other = (("constant", c), ("density", d)) if c["fruit_per_hour"] > d["fruit_per_hour"] else (("density", d), ("constant", c))
                lines.append(f"- {name}: {best[0]} wins, {100 * (best[1]['fruit_per_hour'] / other[1]['fruit_per_hour'] - 1):+.1f} % "
                             f"fruit per hour; both searches {c['planning_time'] + d['planning_time']:.1f} s = "
                             f"{100 * (c['planning_time'] + d['planning_time']) / best[1]['row_time']:.2f} % of the better row time")
            else:
                lines.append(f"- {name}: complete and verified: {', '.join(whole) or 'neither'}")
    print()
    print("\n".join(lines))


def speed_curve(name: str = "sparse_row") -> None:
    from coplan.kinds import SpeedProfile
    from coplan.problem import load_problem, shipped_rows
    from coplan.row.continuous import MovingOptions
    from coplan.row.moving import plan_moving, speed_search

    prob = load_problem(next(p for p in shipped_rows() if p.stem == name))
    t = time.perf_counter()
    _, grid = speed_search(prob, MovingOptions(profile=SpeedProfile.CONSTANT, workers=WORKERS),
                           levels=[0.05 * k for k in range(1, 11)])
    res = plan_moving(prob, MovingOptions(workers=WORKERS))
    took = time.perf_counter() - t
    print(f"\nSpeed curve of {name} on the move ({took:.1f} s): one constant speed for the row, every 0.05 m/s, then the "
          f"speed search over a density profile ({len(res.info['speed_curve'])} full plans); every plan verified:\n")
    print("| profile | pace | mean speed | fruit / h | harvested | row time | slowed where missed | order | rest at the end | verified |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    rows = [("constant", p.to_dict()) for p in grid] + [("density", p) for p in res.info["speed_curve"]]
    for prof, p in sorted(rows, key=lambda r: (r[0], r[1]["mean_speed"])):
        pace = "-" if prof == "constant" else f"{p['level']:.3f}"
        print(f"| {prof} | {pace} | {p['mean_speed']:.3f} m/s | {p['fruit_per_hour']:.0f} | {100 * p['share_harvested']:.1f} % | "
              f"{p['row_time']:.1f} s | {'yes' if p['refined'] else 'no'} | {p['assign']} | "
              f"{_REST_WORDS.get(p.get('end_rest'), 'further on')} | {'yes' if p['verified'] else 'NO'} |")
    best_c = max((p.to_dict() for p in grid if p.complete), key=lambda p: p["fruit_per_hour"], default=None)
    print(f"\nchosen (density): pace {res.info['level']:.3f}, {res.info['mean_speed']:.3f} m/s on average, "
          f"{res.plan.metrics['harvested']} fruit in {res.plan.metrics['makespan']:.1f} s"
          + (f"; the best constant speed harvesting every fruit: {best_c['mean_speed']:.3f} m/s, {best_c['row_time']:.1f} s"
             if best_c else ""))


ARMS_SWEEP = """name: arms-curve
base: gantry
fixed: {length: 30.0, density: 12.0, seed: 5, spacing: 2.0}
vary:
  n_arms: {from: 1, to: 12}
  gantry: [stop-and-go, continuous]
planner: coordinated
time_limit: 900
"""


def arms_curve(figure: Path) -> None:
    import pyarrow.parquet as pq

    with tempfile.TemporaryDirectory() as tmp:
        spec = Path(tmp) / "arms.yaml"
        spec.write_text(ARMS_SWEEP)
        t = time.perf_counter()
        r = subprocess.run([sys.executable, "-m", "coplan.cli", "sweep", str(spec), "--workers", "2", "-o", str(Path(tmp) / "out")],
                           capture_output=True, text=True)
        took = time.perf_counter() - t
        if r.returncode != 0:
            print(r.stdout[-2000:], r.stderr[-2000:])
            raise SystemExit(f"coplan sweep failed ({r.returncode})")
        rows = pq.read_table(Path(tmp) / "out" / "results.parquet").to_pylist()
    print(f"\nArms curve (coplan sweep on a 2-worker Dask LocalCluster, {len(rows)} rows in {took:.0f} s; a 30 m row, "
          f"12 fruit per metre, seed 5):\n")
    print("| arms | fruit | mode | fruit / h | per arm | x one arm | harvested | / bound (any motion) | verified |")
    print("|---|---|---|---|---|---|---|---|---|")
    rows.sort(key=lambda r: (r["gantry"], r["n_arms"]))
    one = {r["gantry"]: r["fruit_per_hour"] for r in rows if r["n_arms"] == 1}
    for r in rows:
        fph = r["fruit_per_hour"] or 0.0
        print(f"| {r['n_arms']} | {r['n_fruits']} | {r['gantry']} | {fph:.0f} | {fph / r['n_arms']:.0f} | "
              f"{fph / one[r['gantry']]:.2f} | {100 * (r['share_harvested'] or 0):.1f} % | {r['ratio'] or float('nan'):.3f} | "
              f"{'yes' if r['verified'] else 'NO'} |")
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.4, 4.0), dpi=110)
    for mode, style in (("stop-and-go", "o-"), ("continuous", "s-")):
        pts = [(r["n_arms"], r["fruit_per_hour"]) for r in rows if r["gantry"] == mode]
        ax.plot(*zip(*pts), style, label=mode)
    n = sorted({r["n_arms"] for r in rows})
    best_one = max(one.values())
    ax.plot(n, [best_one * k for k in n], ":", color="grey", label="linear from one arm")
    ax.set_xlabel("arms on the carriage (2 m apart)")
    ax.set_ylabel("fruit per hour")
    ax.set_title("30 m row, 12 fruit/m: fruit per hour against arms")
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(figure)
    print(f"\nwrote {figure}")


def live_rows(seeds=(0, 1, 2)) -> None:
    from coplan.problem import load_problem, shipped_rows
    from coplan.row.live import LiveRowOptions, run_live_row

    from coplan.kinds import GantryMode
    from coplan.row.moving import live_speed

    print("\nLive rows (camera 1.5 m ahead, 10 mm noise, 5 % false and 2 % repeated reports; the offline plan in the "
          "same mode knows every fruit: on the move at the same constant speed, stop and go the optimised-stops row "
          "planner):\n")
    print("| row | mode | seed | harvested | of the offline plan's | row time / offline | stops (holds) | slowest decision | "
          "shortest cycle | probes | verified |")
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for path in shipped_rows():
        prob = load_problem(path)
        # a live planner cannot shape its speed to fruit it has not seen: the row runs at one speed,
        # the one the speed search over constant speeds chooses offline (every fruit harvested)
        t = time.perf_counter()
        v, best = live_speed(prob, workers=WORKERS)  # (rounded down to the mm/s: no faster than the speed found)
        print(f"| {path.stem} | (constant speed search: {v:.3f} m/s, {best.plan.metrics['harvested']} fruit, "
              f"{time.perf_counter() - t:.1f} s) | | | | | | | | | |", flush=True)
        for mode in (GantryMode.CONTINUOUS, GantryMode.STOP_AND_GO):
            for seed in seeds:
                r = run_live_row(prob, LiveRowOptions(speed=v, seed=seed, mode=mode))
                m = r.metrics
                label = f"on the move {v:.3f} m/s" if mode == GantryMode.CONTINUOUS else "stop and go"
                stops = m["stops"] if m["stops"] is not None else f"({m['holds_for_fruit']}, {m['hold_seconds']:.1f} s)"
                print(f"| {path.stem} | {label} | {seed} | {m['harvested']} | {100 * m['of_offline']:.1f} % | "
                      f"{m['row_time_ratio']:.3f} | {stops} | "
                      f"{1000 * m['decision_max_seconds']:.1f} ms | {m['shortest_cycle_seconds']:.2f} s | "
                      f"{m['probes']} | {'yes' if m['verified'] else 'NO'} |", flush=True)


def faults(n: int = 50) -> None:
    for mode in ("continuous", "stop-and-go"):
        fault_runs(mode, n)


def fault_runs(mode: str, n: int) -> None:
    import json

    from coplan.generate import gantry_row, to_yaml

    how = ["--speed", "0.1"] if mode == "continuous" else ["--gantry", "stop-and-go"]

    bad_files, unsafe, missed, harvested, offline, took, holds, waits, nothing = 0, 0, [], 0, 0, [], [], 0, 0
    ratios, changed = [], 0
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(n):
            path = Path(tmp) / f"row{seed}.yaml"
            path.write_text(to_yaml(gantry_row(length=12.0, n_arms=3, density=6.0, seed=seed)))
            out = Path(tmp) / f"run{seed}"
            t = time.perf_counter()
            subprocess.run([sys.executable, "-m", "coplan.cli", "run", str(path), *how, "--seed", str(seed),
                            "--arm-stop", "--camera-dark", "3", "--false-burst", "50", "--late-replan", "2", "-o", str(out),
                            "--json"], capture_output=True, text=True)
            took.append(time.perf_counter() - t)
            try:
                doc = json.loads((out / "run.json").read_text())
                json.loads((out / "plan.json").read_text())
                json.loads((out / "verification.json").read_text())
            except (OSError, ValueError):
                bad_files += 1
                continue
            v = subprocess.run([sys.executable, "-m", "coplan.cli", "verify", str(path), str(out / "plan.json")],
                               capture_output=True, text=True)
            unsafe += v.returncode not in (0, 5)  # 5: verified safe, not every fruit harvested (an arm stopped)
            m = doc["metrics"]
            missed.append(len(m["missed_reachable_by_a_working_arm"]))
            harvested += m["harvested"]
            offline += m["offline_harvested"]
            dark = m["faults"].get("camera_dark", {})
            if "hold_seconds" in dark and (mode == "continuous" or dark["hold_seconds"] > 0):  # (stop and go logs 0 where none)
                holds.append(dark["hold_seconds"])
            waits += "carriage_waits_at" in dark
            nothing += m["grasps_on_nothing"]
            ratios += [m["row_time_ratio"]] if m.get("row_time_ratio") else []
            changed += "hop_changed_at" in m["faults"].get("arm_stop", {})
    print(f"\nFaults over {n} seeded live rows, {'on the move at 0.1 m/s' if mode == 'continuous' else 'stop and go'} "
          f"(12 m, 3 arms, 6 fruit/m; one arm stops, a 3 s camera outage, "
          f"50 false reports at once, a decision 2 s late; each a coplan run in its own process, median {np.median(took):.1f} s):\n")
    print(f"- executed plans coplan verify refuses (collisions, limits, picks off their fruit): {unsafe} of {n - bad_files}")
    print(f"- runs whose files did not read back whole: {bad_files} of {n}")
    print(f"- fruit harvested: {harvested}, {100 * harvested / max(offline, 1):.1f} % of what the fault-free offline plans harvest")
    print(f"- fruit missed though a working arm could still reach them (the true fruit, from a carriage position not yet "
          f"passed when it was reported{' -- at rest: one it could still brake to --' if mode != 'continuous' else ''}: "
          f"before the arm stopped by any arm, after it by a working arm with a pick pose clear of the stopped one): "
          f"{sum(missed)} in total, in {sum(1 for x in missed if x)} of {len(missed)} runs (at most {max(missed, default=0)} in one)")
    print(f"- row time: median {np.median(ratios) if ratios else float('nan'):.2f} x the fault-free offline plan's "
          f"(range {min(ratios, default=float('nan')):.2f}-{max(ratios, default=float('nan')):.2f})"
          + (f"; a hop changed under way by the arm's stop in {changed} runs" if mode != "continuous" else ""))
    what = "the carriage held" if mode == "continuous" else "the machine stood still waiting for the camera"
    print(f"- camera outage: {what} in {len(holds)} runs (median {np.median(holds) if holds else 0:.2f} s), "
          f"waited at a stop for the camera in {waits}; grasps that closed on nothing (close-range error > 5 mm): {nothing}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="the generated rows at 8 fruit per metre only, no curves")
    ap.add_argument("--arms-only", action="store_true", help="the arms curve only")
    ap.add_argument("--live-only", action="store_true", help="the live rows only (at 0.1 m/s)")
    ap.add_argument("--faults-only", action="store_true", help="the fault runs only")
    ap.add_argument("--parts", default=None, help="a comma list of parts to run, of: head, speed, arms, live, faults, "
                                                  "profiles (the last only when asked for) "
                                                  "(e.g. head,live: what a change to the stop rules' plans moves)")
    ap.add_argument("--figure", type=Path, default=Path(__file__).resolve().parent.parent / "docs" / "arms_curve.png",
                    help="where the arms curve's figure goes (default docs/arms_curve.png)")
    args = ap.parse_args()
    print(run_header(), flush=True)
    t = time.perf_counter()
    only = args.arms_only or args.live_only or args.faults_only
    parts = {"head", "speed", "arms", "live", "faults"}
    if args.parts is not None:
        asked = {p.strip() for p in args.parts.split(",") if p.strip()}
        if not asked or asked - parts - {"profiles"}:
            ap.error(f"--parts: expected a comma list of {', '.join(sorted(parts | {'profiles'}))}, found {args.parts!r}")
        parts = asked
    if not only and "head" in parts:
        head_to_head(args.quick)
    if args.parts is not None and "profiles" in parts:  # (its own part: not in the default run)
        profiles(args.quick)
    if not args.quick and not only and "speed" in parts:
        speed_curve()
    if not args.quick and (not only or args.arms_only) and "arms" in parts:
        arms_curve(args.figure)
    if not args.quick and (not only or args.live_only) and "live" in parts:
        live_rows()
    if not args.quick and (not only or args.faults_only) and "faults" in parts:
        faults()
    print(f"\n(one run, {time.perf_counter() - t:.0f} s)")


if __name__ == "__main__":
    main()
