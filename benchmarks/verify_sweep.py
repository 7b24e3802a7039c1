"""Check a sweep run with ``--keep-plans`` the way ``coplan verify`` would: every row whose status
is success has its saved plan (``plans/<key>.json``, rounded as written) verified again,
independently of the run, against its problem (``plans/<key>.yaml``, else the sweep file's
problem of that key). Prints the counts the 1,000-random-layout target asks for: rows called
success whose plan fails verification (target 0), and success among problems with reachable
fruit (target >= 99.5 %), with every failure's seed and cause.

    python benchmarks/verify_sweep.py OUT_DIR [--offset N] [--limit N]
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from coplan.plan import load_plan
from coplan.problem import parse_problem
from coplan.sweep.report import counts_as_with_fruit
from coplan.sweep.spec import load_sweep
from coplan.sweep.table import read_rows
from coplan.verify import verify
from run_header import run_header


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("out", type=Path)
    ap.add_argument("--limit", type=int, default=None, help="verify at most this many plans")
    ap.add_argument("--offset", type=int, default=0, help="skip the first N successful rows (checked in an earlier call)")
    args = ap.parse_args(argv)
    print(run_header(), flush=True)
    rows = read_rows(args.out)
    meta = json.loads((args.out / "sweep.json").read_text())
    texts = {}
    if meta.get("source"):
        spec = load_sweep(meta["source"])
        texts = {it.key: it.problem_text for it in spec.items(meta.get("planner"), meta.get("time_limit"))}
    ok = [r for r in rows if r["status"] == "success"]
    checked, failed, missing = 0, [], 0
    for r in ok[args.offset:][: args.limit]:
        plan_path = args.out / "plans" / f"{r['key']}.json"
        yaml_path = plan_path.with_suffix(".yaml")
        text = yaml_path.read_text() if yaml_path.exists() else texts.get(r["key"])
        if not plan_path.exists() or text is None:
            missing += 1
            continue
        ver = verify(parse_problem(text, str(yaml_path)), load_plan(plan_path))
        checked += 1
        if not ver.passed:
            failed.append((r["seed"], r["key"], ver.summary().get("violation_kinds")))
    with_fruit = [r for r in rows if counts_as_with_fruit(r)]
    succ = [r for r in with_fruit if r["status"] == "success"]
    print(f"{len(rows)} rows; {len(ok)} success; {checked} saved plans verified again, {missing} without a saved plan")
    print(f"success rows whose plan fails verification: {len(failed)}" + "".join(f"\n  seed {s} ({k}): {v}" for s, k, v in failed))
    if with_fruit:
        print(f"success among problems with reachable fruit: {len(succ)}/{len(with_fruit)} ({100 * len(succ) / len(with_fruit):.2f} %)")
    for r in rows:
        if r["status"] != "success":
            print(f"  not success: seed {r['seed']} ({r['key']}): {r['status']} / {r['exit_class']}: {' '.join((r['message'] or '').split())[:300]}")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
