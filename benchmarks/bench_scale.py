"""Time to quality at scale: long rows and many arms, every core -- one run.

Rows ``coplan.generate.row_problem(arms, fruit, seed=5, reachable_only=True)`` (the lesson's
arms 2 m apart, fruit uniform along the row): 5 x 100, 5 x 200, 10 x 300 and 12 x 600. Each
is solved by the whole ``coplan solve`` command in a fresh process, as a user runs it:

1. **Clock limits** (10 s on 5 x 100, 30 s on 5 x 200 and 10 x 300, 60 s on 12 x 600), with 1
   and with 2 workers: the first verified plan counted from the command's launch (imports,
   loading and the heuristic baseline included), the makespan / the lower bound at the limit,
   when the incumbent first came within 1.05, 1.02 and 1.01 x the bound (``metrics.time_to_ratio``,
   from the planner's start), the whole command's wall time and its peak memory (the largest
   resident set of the command or any of its worker processes).
2. **The default budget** (work, not seconds) on 5 x 100 and 5 x 200 against the heuristic
   planner's command on the same row: the wall time more than the heuristic's.
3. **Planning cost per fruit**, 25 to 600 fruit: the first verified plan in process, imports
   already made, not profiled.
4. **Where the coordinated stage spends its time** (in process, profiled): allocation and
   bound MILPs, elbow-branch choice, leg-by-leg coordination, the taking-turns fallback,
   verification.

Every plan is verified by the command (exit code 0 only when it is) and every fruit picked.
Every ratio is measured in this run, on this machine.

    python benchmarks/bench_scale.py
    python benchmarks/bench_scale.py --quick    # 5 x 100 and 5 x 200 only
"""

from __future__ import annotations

import argparse
import json
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from run_header import run_header

ROWS = [(5, 100, 10.0), (5, 200, 30.0), (10, 300, 30.0), (12, 600, 60.0)]
DEFAULT_ROWS = [(5, 100), (5, 200)]


def _row_file(folder: Path, arms: int, fruit: int) -> Path:
    from coplan.generate import row_problem, to_yaml

    path = folder / f"row_{arms}x{fruit}.yaml"
    if not path.exists():
        path.write_text(to_yaml(row_problem(arms, fruit, seed=5, reachable_only=True)))
    return path


def _child(argv: list[str]) -> None:
    """Run ``coplan`` in this process, then report the peak memory of it and its workers."""
    from coplan.cli import app

    code = 0
    try:
        app(argv)
    except SystemExit as e:
        code = int(e.code or 0)
    except Exception as e:  # noqa: BLE001 -- the exit code tells the parent
        print(f"error: {e}", file=sys.stderr)
        code = 1
    own = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    kids = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
    Path(os.environ["COPLAN_BENCH_RSS"]).write_text(json.dumps({"self_kb": own, "children_kb": kids, "code": code}))
    sys.exit(code)


def _command(args: list[str], tmp: Path) -> dict:
    """``coplan ARGS`` in a fresh process: launch time, wall time, peak memory, exit code."""
    rss = tmp / "rss.json"
    env = dict(os.environ, COPLAN_BENCH_RSS=str(rss), MPLBACKEND="Agg")
    launched = time.time()
    t = time.perf_counter()
    p = subprocess.run([sys.executable, __file__, "--child", *args], env=env, capture_output=True, text=True)
    wall = time.perf_counter() - t
    mem = json.loads(rss.read_text()) if rss.exists() else {"self_kb": 0, "children_kb": 0}
    return {"launched": launched, "wall": wall, "code": p.returncode, "stderr": p.stderr[-2000:],
            "peak_mb": max(mem["self_kb"], mem["children_kb"]) / 1024}


def _solve(row: Path, out: Path, tmp: Path, *extra: str) -> dict:
    r = _command(["solve", str(row), "-o", str(out), "--json", *extra], tmp)
    if not (out / "plan.json").exists():  # the command died (killed, out of memory): say so, go on
        raise RuntimeError(f"coplan solve {' '.join(extra)} wrote no plan (exit {r['code']}): {r['stderr'][-300:]}")
    plan = json.loads((out / "plan.json").read_text())
    m, s = plan["metrics"], plan["solver"]
    first = s.get("first_verified_wall_time")
    ver = plan.get("verification") or {}
    return r | {"makespan": m["makespan"], "bound": m.get("lower_bound"), "harvested": m.get("harvested"),
                "verified": bool(ver.get("passed")), "first": None if first is None else first - r["launched"],
                "to": m.get("time_to_ratio") or {}, "status": plan.get("status"),
                "search": s.get("search") or {}}


def _fmt(x, nd=2, unit=""):
    return "-" if x is None else f"{x:.{nd}f}{unit}"


def _limits(rows, folder: Path, tmp: Path) -> list[str]:
    lines = ["| row | fruit | lower bound | workers | limit | first verified plan (whole command) | makespan / bound "
             "| to 1.05 x | to 1.02 x | to 1.01 x | whole command | peak memory | verified, every fruit |",
             "|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    pairs = {}
    for arms, fruit, limit in rows:
        row = _row_file(folder, arms, fruit)
        for w in (1, 2):
            try:
                r = _solve(row, tmp / f"out_{arms}x{fruit}_w{w}", tmp, "--time-limit", str(limit), "--workers", str(w))
            except RuntimeError as e:
                lines.append(f"| {arms} x {fruit} | {fruit} | - | {w} | {limit:g} s | FAILED: {e} |")
                print(lines[-1], flush=True)
                pairs[(arms, fruit, w)] = {"to": {}}
                continue
            pairs[(arms, fruit, w)] = r
            to = r["to"]
            ok = r["verified"] and r["harvested"] == fruit and r["code"] == 0
            lines.append(f"| {arms} x {fruit} | {fruit} | {r['bound']:.2f} s | {w} | {limit:g} s | {_fmt(r['first'], 2, ' s')} "
                         f"| {r['makespan'] / r['bound']:.4f} | {_fmt(to.get('1.05'), 1, ' s')} | {_fmt(to.get('1.02'), 1, ' s')} "
                         f"| {_fmt(to.get('1.01'), 1, ' s')} | {r['wall']:.1f} s | {r['peak_mb']:.0f} MB | {'yes' if ok else 'NO'} |")
            print(lines[-1], flush=True)
    lines.append("")
    for arms, fruit, _ in rows:
        a, b = pairs[(arms, fruit, 1)], pairs[(arms, fruit, 2)]
        t1, t2 = a["to"].get("1.02"), b["to"].get("1.02")
        speed = f"{t1 / t2:.2f} x sooner with 2" if t1 and t2 else "not reached by both"
        lines.append(f"- {arms} x {fruit}: time to 1.02 x the bound, 1 worker {_fmt(t1, 1, ' s')}, 2 workers "
                     f"{_fmt(t2, 1, ' s')}: {speed}")
        print(lines[-1], flush=True)
    return lines


def _defaults(rows, folder: Path, tmp: Path) -> list[str]:
    lines = ["", "| row | heuristic command | optimal command, default budget | more than the heuristic | makespan / bound | verified |",
             "|---|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    for arms, fruit in rows:
        row = _row_file(folder, arms, fruit)
        h = _command(["solve", str(row), "-o", str(tmp / f"h_{arms}x{fruit}"), "--planner", "heuristic", "--json"], tmp)
        r = _solve(row, tmp / f"d_{arms}x{fruit}", tmp)
        ok = r["verified"] and r["harvested"] == fruit and r["code"] == 0
        lines.append(f"| {arms} x {fruit} | {h['wall']:.1f} s | {r['wall']:.1f} s | {r['wall'] - h['wall']:.1f} s "
                     f"| {r['makespan'] / r['bound']:.4f} | {'yes' if ok else 'NO'} |")
        print(lines[-1], flush=True)
    return lines


def _per_fruit(sizes, folder: Path) -> list[str]:
    """Planning cost per fruit: the optimal planner's first verified plan, in this process with
    its imports already made (a small row planned first), not profiled: what a sweep or a live
    re-plan pays per problem once coplan is loaded."""
    from coplan.generate import row_problem, to_yaml
    from coplan.planners.optimal import OptimalOptions, plan_optimal
    from coplan.problem import load_problem, parse_problem

    small = parse_problem(to_yaml(row_problem(2, 6, seed=1, reachable_only=True)), "warm-up")
    plan_optimal(small, options=OptimalOptions(time_limit=0.01))  # imports made, caches warm
    lines = ["", "| row | fruit | first verified plan (in process) | per fruit | verified, every fruit |", "|---|---|---|---|---|"]
    print("\n".join(lines), flush=True)
    per = []
    for arms, fruit in sizes:
        res = plan_optimal(load_problem(_row_file(folder, arms, fruit)), options=OptimalOptions(time_limit=0.01))
        first = res.plan.metrics.get("time_to_first_verified")
        ok = bool(res.verification and res.verification.passed) and res.plan.metrics.get("harvested") == fruit
        per.append(1e3 * first / fruit)
        lines.append(f"| {arms} x {fruit} | {fruit} | {first:.3f} s | {per[-1]:.1f} ms | {'yes' if ok else 'NO'} |")
        print(lines[-1], flush=True)
    lines.append(f"- per fruit from {min(per):.1f} to {max(per):.1f} ms: the largest {max(per) / min(per):.2f} x the least")
    print(lines[-1], flush=True)
    return lines


def _split(sizes, folder: Path) -> list[str]:
    """The coordinated stage, profiled in process: where its time goes, and per fruit."""
    import cProfile
    import pstats

    from coplan.planners.coordinated import CoordinatedOptions, plan_coordinated
    from coplan.problem import load_problem

    parts = {"bound and allocation MILPs": ("allocation.py", "_minmax_milp"),
             "elbow branches": ("routing.py", "choose_branches"),
             "leg-by-leg coordination": ("coordinate.py", "coordinate"),
             "taking turns (fallback)": ("planner.py", "_fallback"),
             "verification": ("verifier.py", "verify")}
    lines = ["", "| row | fruit | coordinated stage | per fruit | its first candidate | first candidate per fruit | "
             + " | ".join(parts) + " |", "|---|---|---|---|---|---|" + "---|" * len(parts)]
    print("\n".join(lines), flush=True)
    for arms, fruit in sizes:
        problem = load_problem(_row_file(folder, arms, fruit))
        first = []
        t0 = time.perf_counter()
        pr = cProfile.Profile()
        pr.enable()
        plan_coordinated(problem, "makespan", CoordinatedOptions(), None, {},
                         on_feasible=lambda c: first.append(time.perf_counter() - t0))
        pr.disable()
        total = time.perf_counter() - t0
        st = pstats.Stats(pr).stats
        cum = {name: sum(v[3] for (f, _, fn), v in st.items() if f.endswith(file) and fn == func)
               for name, (file, func) in parts.items()}
        lines.append(f"| {arms} x {fruit} | {fruit} | {total:.2f} s | {1e3 * total / fruit:.1f} ms | "
                     f"{_fmt(first[0] if first else None, 2, ' s')} | {_fmt(1e3 * first[0] / fruit if first else None, 1, ' ms')} | "
                     + " | ".join(f"{100 * cum[n] / total:.0f} %" for n in parts) + " |")
        print(lines[-1], flush=True)
    lines.append("(profiled: the times include cProfile's overhead; the shares are what matters)")
    return lines


def main() -> None:
    if len(sys.argv) > 1 and sys.argv[1] == "--child":
        return _child(sys.argv[2:])
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="5 x 100 and 5 x 200 only")
    args = ap.parse_args()
    print(run_header(), flush=True)
    rows = ROWS[:2] if args.quick else ROWS
    t_all = time.perf_counter()
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        folder = tmp / "rows"
        folder.mkdir()
        print(f"{os.cpu_count()} cores here\n")
        lines = _limits(rows, folder, tmp)
        lines += _defaults(DEFAULT_ROWS, folder, tmp)
        sizes = [(5, 25), (5, 50)] + [(a, f) for a, f, _ in rows]
        lines += _per_fruit(sizes, folder)
        lines += _split(sizes, folder)
    print(f"\nWhole run: {time.perf_counter() - t_all:.0f} s.")


if __name__ == "__main__":
    main()
