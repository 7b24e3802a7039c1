"""The widening stage's figures -- the targets of issue 30 ("the same makespan with the widest
clearance margin and the gentlest motion").

For every shipped cell problem and ``--layouts`` interference-heavy random layouts
(``coplan.generate.overlap_problem``: 2-3 lesson arms 1.3-1.6 m apart, every fruit in a zone two
neighbours share), one default ``coplan solve`` (optimal planner, widening on), the plan written
and verified again from its file as ``coplan verify`` does; from the widening stage's report in
plan.json (``solver.widen``):

* makespan before and after (the incumbent the stage started from, and the plan returned), and
  whether the optimality proof survived;
* certified margin (least certified clearance less the required) before and after;
* RMS jerk (mean over the arms) before and after;
* the time the stage added, against the rest of the same solve;
* where the widened plan kept less room than the widening's goal, the regroup stage (the planner
  again at a clearance raised by the shortfall: other events, ``solver.regroup``): whether its
  plan was kept, and its time.

Then the makespan against the clearance asked for (the problem's, +10, +25, +50, +100 mm) on
crossing_paths and dense_overlap, every plan verified (``coplan compare --clearance-sweep``).

Last (``--live``), a proxy for the live cell, which re-plans in 50 ms with the coordinator and so
cannot run a widening program of 1-5 s: on seeded live runs of the same layouts (10 and 20 mm
vision noise, every fruit detected late or early, ``coplan.live.sim.simulate`` trying every candidate),
the close-range corrections accepted and refused -- refused because the corrected approach is not
clear of the neighbours -- when the live planner keeps the default 15 mm of planning room, and
when it keeps 50 mm (the room the widening stage gives offline plans).

    python benchmarks/bench_widen.py [--layouts 30] [--no-sweep] [--live N]

One run on one machine: every ratio is against a figure measured in the same run.
"""

from __future__ import annotations

import argparse
import statistics
import tempfile
import time
from pathlib import Path

import numpy as np

from coplan.generate import overlap_problem, to_yaml
from coplan.pipeline import solve
from coplan.plan import load_plan
from coplan.problem import load_problem, parse_problem, shipped_problems
from coplan.report.clearance import EXTRAS_MM, clearance_cost
from coplan.verify import verify
from run_header import run_header


def layouts(n: int):
    """``n`` interference-heavy layouts: 2 or 3 arms, 1.3-1.6 m apart, 3 fruit per arm in shared zones."""
    out = []
    for seed in range(n):
        arms = 2 + seed % 2
        spacing = 1.3 + 0.3 * ((seed * 7) % 10) / 9
        d = overlap_problem(n_arms=arms, n_fruits=3 * arms, spacing=round(spacing, 3), seed=100 + seed,
                            name=f"overlap-{arms}x{3 * arms}-s{seed}")
        out.append(parse_problem(to_yaml(d), d["name"]))
    return out


def run(problem, folder: Path) -> dict:
    t = time.perf_counter()
    res = solve(problem, out_dir=folder)
    wall = time.perf_counter() - t
    plan = load_plan(folder / "plan.json")  # as `coplan verify` reads it
    ver = verify(problem, plan)
    m = res.plan.metrics
    w = res.plan.solver.get("widen") or {}
    timings = res.plan.solver.get("timings") or {}
    added = timings.get("widen", 0.0)
    rg = res.plan.solver.get("regroup") or {}
    regroup_s = timings.get("regroup", 0.0)
    mean = lambda d: float(np.mean([v for v in (d or {}).values() if v is not None])) if d else None  # noqa: E731
    jerk_after = mean({a: v.get("rms_jerk") for a, v in m.get("per_arm", {}).items()})
    jerk_before = mean(w.get("rms_jerk_before")) if w else jerk_after
    margin_after = ver.margin if ver.pairs else None
    margin_before = w.get("margin_before", margin_after)
    return {
        "problem": problem.name, "arms": len(problem.arms), "fruit": len(problem.fruits),
        "makespan_before": w.get("makespan_before", m["makespan"]), "makespan": m["makespan"],
        "optimality": m.get("optimality"), "margin_before": margin_before, "margin": margin_after,
        "jerk_before": jerk_before, "jerk": jerk_after, "widen_s": added, "regroup_s": regroup_s,
        "rest_s": timings.get("total", wall) - added - regroup_s,
        "wall": wall, "verified": bool(ver.passed), "accepted": bool(w.get("accepted")),
        "regrouped": bool(rg.get("accepted")),
        "note": ("widened" if w.get("accepted") else (w.get("reason") or w.get("status") or "no neighbours"))
        + (f" ({w['room_note']})" if w.get("room_note") else "") + _regroup_note(rg),
    }


def _regroup_note(rg: dict) -> str:
    """What the regroup stage did, where it ran."""
    if rg.get("status") in (None, "skipped"):
        return ""
    at = f"at {1000 * rg['clearance']:.1f} mm"
    if rg.get("accepted"):
        return f"; regrouped {at}: {1000 * rg['margin_before']:.1f} -> {1000 * rg['margin']:.1f} mm, {rg['makespan']:.4f} s"
    return f"; regroup {at} not kept: {rg.get('reason')}"


def mm(x):
    return "-" if x is None or not np.isfinite(x) else f"{1000 * x:.1f}"


def table(rows: list[dict]) -> None:
    print("| problem | arms x fruit | makespan before -> after (s) | optimality | certified margin before -> after (mm) "
          "| RMS jerk before -> after (rad/s^3) | widening (s) / rest of the solve (s) | regroup (s) | verified | stage |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        jb, ja = r["jerk_before"], r["jerk"]
        print(f"| {r['problem']} | {r['arms']} x {r['fruit']} | {r['makespan_before']:.4f} -> {r['makespan']:.4f} | "
              f"{r['optimality']} | {mm(r['margin_before'])} -> {mm(r['margin'])} | {jb:.1f} -> {ja:.1f} "
              f"({100 * (ja / jb - 1):+.0f} %) | {r['widen_s']:.2f} / {r['rest_s']:.2f} "
              f"({100 * r['widen_s'] / max(r['rest_s'], 1e-9):.0f} %) | {r['regroup_s']:.2f} | "
              f"{'yes' if r['verified'] else 'NO'} | {r['note']} |")


def verdicts(rows: list[dict], label: str) -> None:
    held = all(r["makespan"] - r["makespan_before"] <= 1e-3 for r in rows)
    shorter = [r["makespan_before"] - r["makespan"] for r in rows if r["makespan"] < r["makespan_before"] - 1e-3]
    room = [r for r in rows if r["margin_before"] is not None and np.isfinite(r["margin_before"])]
    ok = [r for r in room if r["margin"] >= min(2 * r["margin_before"], 0.05) - 1e-9 or r["margin"] >= 0.05]
    ratios = [r["jerk"] / r["jerk_before"] for r in rows if r["jerk_before"]]
    widened = [r["jerk"] / r["jerk_before"] for r in rows if r["accepted"]]
    print(f"\n{label}: makespan no longer (within 1 ms) on every problem: {held}"
          + (f" ({len(shorter)} shorter by more than 1 ms, by at most {1000 * max(shorter):.1f} ms)" if shorter else "")
          + "; certified margin doubled or >= 50 mm on "
          f"{len(ok)} of {len(room)}; median RMS jerk ratio {statistics.median(ratios):.3f} over all"
          + (f", {statistics.median(widened):.3f} over the {len(widened)} widened" if widened else "")
          + f"; every plan verified: {all(r['verified'] for r in rows)}; the stage added at most "
          f"{max(100 * r['widen_s'] / max(r['rest_s'], 1e-9) for r in rows):.0f} % "
          f"({max(r['widen_s'] for r in rows):.2f} s); regroup ran on {sum(r['regroup_s'] > 0 for r in rows)} "
          f"({sum(r['regroup_s'] for r in rows):.1f} s in all), kept on {sum(r['regrouped'] for r in rows)}")


def live_proxy(n: int) -> None:
    """Close-range corrections accepted / refused (not clear of the neighbours / otherwise) in
    seeded live runs, with 15 mm and 50 mm of planning room (see the module docstring)."""
    from coplan.live.cell import LiveOptions
    from coplan.live.feed import make_feed
    from coplan.live.sim import simulate

    print("\n## Live cell (proxy): close-range corrections with 15 mm and 50 mm of planning room\n")
    print("| vision noise | planning room | runs | corrections accepted | refused: not clear of a neighbour "
          "| refused: other | fruit harvested / true | collisions (verifier) |")
    print("|---|---|---|---|---|---|---|---|")
    probs = layouts(n)
    for sigma in (0.010, 0.020):
        for room in (0.015, 0.050):
            acc = clear = other = picked = true = bad = 0
            for k, prob in enumerate(probs):
                feed = make_feed(prob, known=0.5, sigma=sigma, seed=k)
                run = simulate(prob, feed, LiveOptions(margin=room, work=None), seed=k)
                for r in run.cell.replans:
                    if r.corrected:
                        acc += 1
                    elif "planned again:" in r.note:
                        clear += "not clear of the neighbours" in r.note
                        other += "not clear of the neighbours" not in r.note
                picked += run.plan.metrics.get("harvested", 0)
                true += len(prob.fruits)
                bad += int(not run.verification.passed)
            print(f"| {1000 * sigma:.0f} mm | {1000 * room:.0f} mm | {len(probs)} | {acc} | {clear} | {other} | "
                  f"{picked} / {true} | {bad} runs failed verification |")


def sweeps(tmp: Path) -> None:
    """The makespan against the clearance asked for, crossing_paths and dense_overlap (optimal)."""
    for stem in ("crossing_paths", "dense_overlap"):
        path = next(p for p in shipped_problems() if p.stem == stem)
        cost = clearance_cost(path, tmp / f"sweep-{stem}", EXTRAS_MM, "optimal", figures=False)
        print(f"\n## {cost.problem}: makespan against the clearance asked for (optimal planner)\n")
        print("| clearance (m) | makespan (s) | x the problem's | certified margin (mm) | the plan planned for | "
              "that level's own plan (s) | harvested | verified |")
        print("|---|---|---|---|---|---|---|---|")
        for r in cost.rows:
            if r.get("error"):
                print(f"| {r['clearance']:.3f} | impossible: {r['error']} | - | - | - | - | - | - |")
                continue
            ratio = "-" if r.get("ratio") is None else f"{r['ratio']:.3f}"
            mine = r["plan_from_mm"] == r["extra_mm"]
            print(f"| {r['clearance']:.3f} (+{r['extra_mm']:g} mm) | {r['makespan']:.3f} | {ratio} | "
                  f"{r['margin_mm']:.1f} | {'this level' if mine else '+%g mm' % r['plan_from_mm']} | "
                  f"{r['planned_makespan']:.3f} | {r['harvested']}/{r['reachable']} | {'yes' if r['verified'] else 'NO'} |")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0].replace("\n", " ")
                                 + " The whole run takes about 20 minutes on 2 cores (--sweep-only: 7).")
    ap.add_argument("--layouts", type=int, default=30, help="interference-heavy random layouts (default 30)")
    ap.add_argument("--no-sweep", action="store_true", help="without the makespan-against-clearance tables")
    ap.add_argument("--sweep-only", action="store_true", help="the makespan-against-clearance tables only")
    ap.add_argument("--live", type=int, default=0, help="live proxy runs per setting (0: none)")
    args = ap.parse_args()
    print(run_header(), flush=True)
    t0 = time.perf_counter()
    if args.sweep_only:
        with tempfile.TemporaryDirectory() as tmp:
            sweeps(Path(tmp))
        print(f"\n(one run, {time.perf_counter() - t0:.0f} s)")
        return
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        shipped = [load_problem(p) for p in shipped_problems()]
        shipped = [p for p in shipped if p.gantry is None]
        rows = [run(p, tmp / p.name) for p in shipped]
        print("## Shipped problems (default solve)\n")
        table(rows)
        verdicts(rows, "shipped")
        lay = [run(p, tmp / p.name) for p in layouts(args.layouts)]
        print(f"\n## {len(lay)} interference-heavy random layouts (default solve)\n")
        table(lay)
        verdicts(lay, "layouts")
        both = [r["jerk"] / r["jerk_before"] for r in rows + lay if r["jerk_before"]]
        print(f"\nall {len(both)} problems (shipped and layouts): median RMS jerk ratio {statistics.median(both):.3f}")
        if not args.no_sweep:
            sweeps(tmp)
    if args.live:
        live_proxy(args.live)
    print(f"\n(one run, {time.perf_counter() - t0:.0f} s)")


if __name__ == "__main__":
    main()
