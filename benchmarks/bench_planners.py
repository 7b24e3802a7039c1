"""The three planners side by side: lower bound, heuristic, coordinated, optimal -- one run.

Prints (and with ``--out`` writes as Markdown) every figure the README quotes:

1. **Problems**: every shipped problem and three long rows (``row_problem(5, 25 | 100, seed=11)``,
   ``row_problem(3, 100, seed=11)``, reachable fruit only). Per planner the makespan and the
   solve time (in-process, imports excluded; the optimal planner's time includes its own
   coordinated stage); for the optimal planner also the time to its first verified plan and
   of its last improvement, makespan / lower bound, whether it is proven optimal, and what
   stopped it. Every plan is checked again here with ``coplan.verify.verify``: a plan that
   does not pass is marked ``UNSAFE`` in the table, whatever its planner said.
2. **Random layouts**: ``coplan.generate.random_problem(0..N-1)`` and ``cell_problem(0..M-1)``
   (a second, harder distribution: gaps 1.0-2.6 m), coordinated and optimal planners at their
   default settings, run in ``--workers`` processes: verified success among layouts with
   reachable fruit, failures, "never slower than coordinated" (tolerance 1 ms), and the median
   makespan improvement over the coordinated plan on the interference-heavy ones (least gap
   between neighbouring bases <= 1.6 m), beside the most any planner could gain there (the
   median of 1 - lower bound / coordinated makespan over the layouts the coordinated plan
   harvests completely: the bound is proven, no plan is shorter). ``--fast`` prints that
   ceiling for the coordinated planner alone.

Every budget is work, not seconds, so the makespans do not depend on the machine or its load;
the times do (2-core machine; the random layouts run two at a time).

    python benchmarks/bench_planners.py --out benchmarks/results.md
    python benchmarks/bench_planners.py --quick           # shipped problems only, no random layouts
    python benchmarks/bench_planners.py --random-only --rows benchmarks/rows.jsonl   # resumable sweep
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

import numpy as np

import coplan
from coplan.allocate import bound_details
from coplan.generate import cell_problem, random_problem, row_problem, to_yaml
from coplan.problem import load_problem, parse_problem, shipped_problems
from coplan.allocate.screen import screened
from coplan.verify import verify
from run_header import run_header, src_commit

TOL = 1e-3  # s: "never slower" and "proven optimal" tolerance


def _fmt(x, nd=2, unit=""):
    return "-" if x is None else f"{x:.{nd}f}{unit}"


def _problems(quick: bool):
    out = [(p.stem, load_problem(p)) for p in shipped_problems()]
    if not quick:
        for arms, n in ((5, 25), (5, 100), (3, 100)):
            name = f"row_problem({arms}, {n}, seed=11)"
            out.append((name, parse_problem(to_yaml(row_problem(arms, n, seed=11, reachable_only=True)), name)))
    return out


def _run(problem, planner: str) -> dict:
    t0 = time.perf_counter()
    res = coplan.solve(problem, planner=planner)
    wall = time.perf_counter() - t0
    plan = res.plan
    again = verify(problem, plan)  # independently, whatever the planner reported
    m = plan.metrics
    return {
        "makespan": m.get("makespan"), "harvested": m.get("harvested"), "reachable": m.get("reachable"),
        "status": plan.status.value, "verified": bool(again.passed), "seconds": wall,
        "first": m.get("time_to_first_verified"), "last": m.get("time_of_last_improvement"),
        "optimality": m.get("optimality"), "stopped_by": plan.solver.get("stopped_by"),
        "coordinated": m.get("coordinated_makespan"),
        "incumbents": plan.solver.get("incumbents") or [],
    }


def _at(run: dict, t: float, bound: float) -> float | None:
    """The optimal planner's incumbent makespan / bound at ``t`` s of its own clock (from the
    incumbent history in plan.json), None when it had none yet."""
    had = [h["makespan"] for h in run["incumbents"] if h["t"] <= t]
    return had[-1] / bound if had and bound else None


def table_problems(quick: bool) -> list[str]:
    head = ("| problem | fruit | lower bound | heuristic | coordinated | optimal | optimal / bound | vs coordinated "
            "| first verified | last improvement | optimal / bound at 10 s | stopped by |")
    lines = [head, "|" + "---|" * (head.count("|") - 1)]
    print("\n".join(lines), flush=True)  # (the rows stream as they finish: under their header)
    for name, prob in _problems(quick):
        lb = bound_details(prob)
        try:
            r = {k: _run(prob, k) for k in ("heuristic", "coordinated", "optimal")}
        except Exception as e:  # noqa: BLE001 -- one problem's failure is its row, not the end of the run
            lines.append(f"| {name} | failed: {type(e).__name__}: {e} |" + " |" * (head.count("|") - 3))
            print(lines[-1], flush=True)
            continue

        def cell(k):
            x = r[k]
            tag = "" if x["verified"] else " UNSAFE"
            return f"{_fmt(x['makespan'])} s ({_fmt(x['seconds'])} s){tag}"

        o, c = r["optimal"], r["coordinated"]
        ratio = o["makespan"] / lb.value if lb.value else None
        proven = " **proven optimal**" if o["optimality"] == "proven" else ""
        lines.append(
            f"| {name} | {o['harvested']}/{o['reachable']} | {_fmt(lb.value, 3)} s | {cell('heuristic')} | {cell('coordinated')} "
            f"| {cell('optimal')} | {_fmt(ratio, 4)}{proven} | {_fmt(o['makespan'] / c['makespan'] if c['makespan'] else None, 3)} "
            f"| {_fmt(o['first'])} s | {_fmt(o['last'])} s | {_fmt(_at(o, 10.0, lb.value), 4)} | {o['stopped_by']} |")
        print(lines[-1], flush=True)
    return lines


def _harvestable(prob) -> int:
    """Fruit some unlocked arm can pick and carry to its bin (the static screen's count)."""
    return int(screened(prob).reach.any(axis=0).sum())


def _layout(args) -> dict:
    kind, seed, planners = args
    d = random_problem(seed) if kind == "random" else cell_problem(seed)
    prob = parse_problem(to_yaml(d), f"{kind}-{seed}")
    xs = sorted(a.base[0] for a in prob.arms)
    gap = min(np.diff(xs)) if len(xs) > 1 else np.inf
    row = {"kind": kind, "seed": seed, "arms": len(prob.arms), "fruit": len(prob.fruits),
           "reachable": len(prob.reachable_ids()), "harvestable": _harvestable(prob), "gap": float(gap)}
    for planner in planners:
        t0 = time.perf_counter()
        try:
            res = coplan.solve(prob, planner=planner)
        except Exception as e:  # noqa: BLE001 -- a crash is a row of the table, not the end of the sweep
            row[planner] = {"status": "error", "error": f"{type(e).__name__}: {e}"}
            continue
        ok = verify(prob, res.plan).passed
        row[planner] = {"status": res.plan.status.value, "verified": bool(ok), "makespan": res.plan.metrics.get("makespan"),
                        "harvested": res.plan.metrics.get("harvested"), "seconds": time.perf_counter() - t0,
                        "lower_bound": res.plan.metrics.get("lower_bound")}
    return row


def _done_rows(path: str | None, commit: str) -> dict:
    """Rows already finished by an earlier run of the same commit (``--rows``): resume, lose nothing."""
    if not path or not Path(path).exists():
        return {}
    done = {}
    for line in Path(path).read_text().splitlines():
        if line.strip():
            r = json.loads(line)
            if r.get("commit") == commit:
                done[(r["kind"], r["seed"])] = r
    return done


def table_random(n_random: int, n_cells: int, workers: int, rows_file: str | None = None,
                 summary_only: bool = False, commit: str | None = None) -> list[str]:
    commit = commit or src_commit()
    jobs = [(k, s) for s in range(max(n_random, n_cells)) for k, n in (("random", n_random), ("cell", n_cells)) if s < n]
    # interleaved, so that a sweep stopped part-way covers both distributions
    done = _done_rows(rows_file, commit) if "dirty" not in commit else {}
    rows = [done[j] for j in jobs if j in done]
    if rows:
        print(f"  {len(rows)} layouts already done by an earlier run of {commit} ({rows_file})", flush=True)
    todo = [] if summary_only else [j for j in jobs if j not in done]
    with ProcessPoolExecutor(max_workers=workers) as ex:  # each layout's row printed as it finishes
        for fut in as_completed([ex.submit(_layout, (*job, ("coordinated", "optimal"))) for job in todo]):
            r = fut.result()
            r["commit"] = commit
            rows.append(r)
            if rows_file:
                with open(rows_file, "a") as fh:
                    fh.write(json.dumps(r) + "\n")
            c, o = r["coordinated"], r["optimal"]
            print(f"  {r['kind']}-{r['seed']}: {r['arms']} arms, {r['reachable']} reachable, gap {r['gap']:.2f} m; "
                  f"coordinated {c.get('status')} {_fmt(c.get('makespan'))}; optimal {o.get('status')} "
                  f"{_fmt(o.get('makespan'))} ({_fmt(o.get('seconds'), 1)} s)", flush=True)
    rows.sort(key=lambda r: (r["kind"], r["seed"]))
    out = []
    for kind, label in (("random", "random_problem"), ("cell", "cell_problem"), (None, "all")):
        mine = [r for r in rows if kind is None or r["kind"] == kind]
        if not mine:
            continue
        for r in mine:  # rows from before the column: the screen is cheap and deterministic
            if "harvestable" not in r:
                d = random_problem(r["seed"]) if r["kind"] == "random" else cell_problem(r["seed"])
                r["harvestable"] = _harvestable(parse_problem(to_yaml(d), f"{r['kind']}-{r['seed']}"))
        with_fruit = [r for r in mine if r["reachable"]]
        # complete: verified, and every fruit the screen proves harvestable was harvested
        complete = sum(r["optimal"].get("verified") and (r["optimal"].get("harvested") or 0) >= r["harvestable"]
                       for r in with_fruit)
        succ = {p: sum(r[p].get("status") == "success" and r[p].get("verified") for r in with_fruit) for p in ("coordinated", "optimal")}
        partial = sum(r["optimal"].get("status") == "partial" and r["optimal"].get("verified") for r in with_fruit)
        failed = [f"{r['kind']}-{r['seed']}" for r in with_fruit if r["optimal"].get("status") in ("failed", "error", "unsafe", "unverified")]
        worse = [f"{r['kind']}-{r['seed']}" for r in mine
                 if r["coordinated"].get("verified") and r["optimal"].get("makespan") is not None
                 and r["optimal"]["makespan"] > r["coordinated"]["makespan"] + TOL]
        lost = [f"{r['kind']}-{r['seed']}" for r in mine
                if r["coordinated"].get("verified") and r["coordinated"].get("status") == "success"
                and r["optimal"].get("status") != "success"]
        tight = [r for r in with_fruit if r["gap"] <= 1.6 and r["coordinated"].get("makespan") and r["optimal"].get("makespan")]
        gain = [1 - r["optimal"]["makespan"] / r["coordinated"]["makespan"] for r in tight]
        ceiling = _ceiling(tight)
        lbr = [r["optimal"]["makespan"] / r["optimal"]["lower_bound"] for r in with_fruit
               if r["optimal"].get("makespan") and r["optimal"].get("lower_bound")]
        secs = [r["optimal"]["seconds"] for r in mine if "seconds" in r["optimal"]]
        out.append(
            f"| {label} | {len(mine)} ({len(with_fruit)} with reachable fruit) | {succ['optimal']}/{len(with_fruit)} "
            f"({100 * succ['optimal'] / max(1, len(with_fruit)):.1f} %), partial {partial} | {succ['coordinated']}/{len(with_fruit)} "
            f"| {complete}/{len(with_fruit)} ({100 * complete / max(1, len(with_fruit)):.1f} %) "
            f"| {len(failed)} {'(' + ', '.join(failed[:6]) + ')' if failed else ''} | {len(worse)} | {len(lost)} "
            f"| {len(tight)}: {_fmt(100 * statistics.median(gain) if gain else None, 1)} % "
            f"(at most {_fmt(100 * statistics.median(ceiling) if ceiling else None, 1)} %) "
            f"| {_fmt(statistics.median(lbr) if lbr else None, 3)} | {_fmt(statistics.median(secs) if secs else None, 1)} s, "
            f"max {_fmt(max(secs) if secs else None, 1)} s |")
        print(out[-1], flush=True)
    head = ["| layouts | count | optimal: verified success | coordinated: verified success "
            "| optimal: verified, every harvestable fruit harvested | optimal failed/unsafe "
            "| slower than coordinated | success lost vs coordinated | gap <= 1.6 m: median gain over coordinated "
            "(at most: median of 1 - bound / coordinated) "
            "| median makespan / bound | optimal solve time: median, max |",
            "|---|---|---|---|---|---|---|---|---|---|---|"]
    return head + out


def _ceiling(rows: list[dict]) -> list[float]:
    """Per layout, the most any planner can gain over the coordinated plan: 1 - lower bound /
    coordinated makespan (the bound is proven: no plan is shorter)."""
    return [1 - r["coordinated"]["lower_bound"] / r["coordinated"]["makespan"] for r in rows
            if r["coordinated"].get("status") == "success" and r["coordinated"].get("lower_bound")
            and r["coordinated"].get("makespan")]


def table_fast(n_random: int, n_cells: int, workers: int) -> list[str]:
    """The coordinated planner alone on the random layouts (seconds per layout, not a minute).

    The optimal planner's first incumbent is exactly this plan (``plan_optimal`` calls
    ``plan_coordinated`` with the same options and keeps a plan only if it is verified and
    harvests at least as much), so its verified success rate is at least the one measured here."""
    jobs = [(k, s, ("coordinated",)) for s in range(max(n_random, n_cells))
            for k, n in (("random", n_random), ("cell", n_cells)) if s < n]
    rows = []
    with ProcessPoolExecutor(max_workers=workers) as ex:
        for fut in as_completed([ex.submit(_layout, job) for job in jobs]):
            r = fut.result()
            rows.append(r)
            c = r["coordinated"]
            print(f"  {r['kind']}-{r['seed']}: {r['arms']} arms, {r['reachable']} reachable, {r['harvestable']} harvestable, "
                  f"gap {r['gap']:.2f} m; coordinated {c.get('status')} verified={c.get('verified')} "
                  f"{_fmt(c.get('makespan'))} s ({_fmt(c.get('seconds'), 2)} s)", flush=True)
    rows.sort(key=lambda r: (r["kind"], r["seed"]))
    out = ["| layouts | count | with reachable fruit | verified success | verified partial: every harvestable fruit "
           "harvested | verified partial: harvestable fruit left | failed / unsafe / error "
           "| gap <= 1.6 m: median makespan / bound (most any planner can gain) | solve time: median, max |",
           "|---|---|---|---|---|---|---|---|---|"]
    for kind, label in (("random", "random_problem"), ("cell", "cell_problem"), (None, "all")):
        mine = [r for r in rows if kind is None or r["kind"] == kind]
        if not mine:
            continue
        fruit = [r for r in mine if r["reachable"]]
        c = [(r, r["coordinated"]) for r in fruit]
        succ = sum(x.get("status") == "success" and x.get("verified") for _, x in c)
        part_ok = [f"{r['kind']}-{r['seed']}" for r, x in c if x.get("status") == "partial" and x.get("verified")
                   and (x.get("harvested") or 0) >= r["harvestable"]]
        part_left = [f"{r['kind']}-{r['seed']}" for r, x in c if x.get("status") == "partial" and x.get("verified")
                     and (x.get("harvested") or 0) < r["harvestable"]]
        bad = [f"{r['kind']}-{r['seed']} ({x.get('status')}{': ' + x['error'] if x.get('error') else ''})" for r, x in c
               if x.get("status") not in ("success", "partial") or not x.get("verified")]
        secs = [x["seconds"] for _, x in c if "seconds" in x]
        tight = [r for r in fruit if r["gap"] <= 1.6 and r["coordinated"].get("status") == "success"
                 and r["coordinated"].get("makespan") and r["coordinated"].get("lower_bound")]
        ratio = [r["coordinated"]["makespan"] / r["coordinated"]["lower_bound"] for r in tight]
        ceiling = _ceiling(tight)
        out.append(f"| {label} | {len(mine)} | {len(fruit)} | {succ}/{len(fruit)} ({100 * succ / max(1, len(fruit)):.1f} %) "
                   f"| {len(part_ok)} {'(' + ', '.join(part_ok) + ')' if part_ok else ''} "
                   f"| {len(part_left)} {'(' + ', '.join(part_left) + ')' if part_left else ''} "
                   f"| {len(bad)} {'(' + ', '.join(bad) + ')' if bad else ''} "
                   f"| {len(tight)}: {_fmt(statistics.median(ratio) if ratio else None, 3)} "
                   f"({_fmt(100 * statistics.median(ceiling) if ceiling else None, 1)} %) "
                   f"| {_fmt(statistics.median(secs) if secs else None, 2)} s, {_fmt(max(secs) if secs else None, 2)} s |")
        print(out[-1], flush=True)
    return out


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="shipped problems only, no rows, no random layouts")
    ap.add_argument("--random", type=int, default=100, metavar="N", help="random_problem seeds 0..N-1")
    ap.add_argument("--cells", type=int, default=100, metavar="M", help="cell_problem seeds 0..M-1")
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--random-only", action="store_true", help="skip the problem table, run the random layouts only")
    ap.add_argument("--rows", metavar="FILE", help="append each random layout's row to this JSON-lines file and skip "
                    "rows an earlier run of the same (clean) commit already finished")
    ap.add_argument("--summary-only", action="store_true", help="with --rows: summarise the rows already in the file "
                    "(of --commit, default this one), run nothing")
    ap.add_argument("--commit", help="with --summary-only: the code (git tree of src/, as in the rows) to summarise")
    ap.add_argument("--fast", action="store_true", help="random layouts with the coordinated planner only (a lower bound "
                    "on the optimal planner's success rate: its first incumbent is this plan)")
    ap.add_argument("--out", help="also write the tables as Markdown to this file")
    args = ap.parse_args(argv)
    head = run_header()
    print(head, flush=True)
    t0 = time.perf_counter()
    parts = [f"<!-- {head}: python benchmarks/bench_planners.py {' '.join(argv or sys.argv[1:])} -->", "",
             "Makespan (solve time); every plan checked again with `coplan.verify.verify`.", ""]
    if not args.random_only:
        parts += table_problems(args.quick)
    if args.fast:
        parts += ["", f"Random layouts, coordinated planner ({args.workers} at a time):", ""]
        parts += table_fast(args.random, args.cells, args.workers)
    elif not args.quick and (args.random or args.cells):
        parts += ["", f"Random layouts at the default settings ({args.workers} at a time):", ""]
        parts += table_random(args.random, args.cells, args.workers, args.rows, args.summary_only, args.commit)
    parts += ["", f"Whole run: {time.perf_counter() - t0:.0f} s."]
    if args.out:
        with open(args.out, "w") as fh:
            fh.write("\n".join(parts) + "\n")
    print(parts[-1])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
