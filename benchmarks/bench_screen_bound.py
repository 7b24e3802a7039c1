"""How long the static feasibility screen and the tight lower bound take, and how fast the
command line starts -- the figures of the issue "Know what cannot be done, and prove what is best".

Prints, for the shipped problems and long generated rows (5 arms x 100 fruit and more): the
screen's time, the bound's time (HiGHS MILP with the first fruit modelled exactly), the bound
and whether HiGHS proved it; then ``coplan --help`` and ``coplan check`` start-up next to a
bare ``python -c pass`` measured in the same run (median of ``--repeat`` runs each).

    python benchmarks/bench_screen_bound.py
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import time
from pathlib import Path

from coplan.allocate import bound_details
from coplan.generate import row_problem, to_yaml
from coplan.problem import load_problem, parse_problem, shipped_problems
from coplan.allocate.screen import screen
from run_header import run_header


def _median_time(fn, repeat: int) -> float:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        out.append(time.perf_counter() - t0)
    return statistics.median(out)


def _median_process(cmd: list[str], repeat: int) -> float:
    out = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        subprocess.run(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, check=False)
        out.append(time.perf_counter() - t0)
    return statistics.median(out)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeat", type=int, default=5)
    args = ap.parse_args(argv)
    print(run_header(), flush=True)
    probs = [(p.stem, load_problem(p)) for p in shipped_problems()]
    for arms, n in ((5, 100), (5, 200), (3, 100)):
        name = f"row_problem({arms}, {n}, seed=11)"
        probs.append((name, parse_problem(to_yaml(row_problem(arms, n, seed=11, reachable_only=True)), name)))
    print("| problem | arms | fruit | screen | bound | screen + bound | bound value | proven |")
    print("|---|---|---|---|---|---|---|---|")
    for name, p in probs:
        screen(p), bound_details(p)  # warm-up: imports, HiGHS start
        ts = _median_time(lambda: screen(p), args.repeat)
        tb = _median_time(lambda: bound_details(p), args.repeat)
        bd = bound_details(p)
        print(f"| {name} | {len(p.arms)} | {len(p.fruits)} | {ts * 1e3:.1f} ms | {tb * 1e3:.1f} ms | {(ts + tb) * 1e3:.1f} ms "
              f"| {bd.value:.3f} s | {'yes' if bd.proven else 'no'} |")
    exe = Path(sys.executable)
    coplan = exe.with_name("coplan")
    bare = _median_process([str(exe), "-c", "pass"], args.repeat)
    helped = _median_process([str(coplan), "--help"], args.repeat)
    check = _median_process([str(coplan), "check"], args.repeat)
    print(f"\nstart-up (median of {args.repeat}): python -c pass {bare:.3f} s; coplan --help {helped:.3f} s "
          f"(+{helped - bare:.3f} s); coplan check (default problem, with the bound and the verified baseline) {check:.3f} s")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
