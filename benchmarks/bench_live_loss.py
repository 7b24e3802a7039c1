"""Where a live stop-and-go row loses time against its offline plan -- one run.

A live row is aimed to take at most 1.10 x the row time of the offline plan (the same row planned
knowing every fruit from the start: issue 29); live stop and go takes 1.09-1.15 x
(``bench_moving.py --parts live``). This script splits that gap, on each
shipped row (seed 0), into what the camera's noise and false reports cost, what the camera's
short view costs, and what the stops chosen live cost in the arms' work:

* **row time / offline** for the live row as ``coplan run ROW --gantry stop-and-go`` runs it
  (camera 1.5 m ahead of the front arm, 10 mm noise, 5 % false and 2 % repeated reports), with
  a perfect camera (no noise, no false or repeated reports) at the same look-ahead, and with a
  perfect camera 3 m ahead (the hop may then be 1.5 m longer);
* for the perfect 1.5 m run and the offline plan: the stops, the mean hop, the seconds the
  carriage moves and stands (to the plan's end, the arms home), the **round trip**
  of each fruit where it was picked -- the time-optimal bin -> fruit -> bin cycle with both
  dwells of the arm that picked it, with the carriage where it stood
  (:func:`coplan.row.stops.round_trips`, a lower bound on that cycle, so it measures where
  the stops put the fruit relative to the arms, not how well the arms move; averaged over the
  fruit both plans picked), the **busiest arm** over the arms' mean in those round trips (summed
  over the stops: what a stop's other arms stand idle for while its busiest arm finishes) -- and
  each cycle's **excess** over that bound (place, pick, place
  of one arm with its joints never still for two samples in between: no wait in it, so what
  the execution adds).

Every row plan here is verified (the live ones against the true fruit). It prints a Markdown
table on stdout, a row per shipped row (about 90 s on a 2-core machine).

    python benchmarks/bench_live_loss.py
"""

from __future__ import annotations

import time

import numpy as np
from run_header import run_header


def _picks_at(plan, reach):
    """Per pick event: (event, arm index, grid index of the carriage at the pick's start)."""
    names = [a.name for a in reach.problem.arms]
    t, gx = np.asarray(plan.time), np.asarray(plan.gantry_x)
    out = []
    for e in plan.events:
        if e.kind.value == "pick":
            x = float(np.interp(e.t_start, t, gx))
            k = int(np.argmin(np.abs(reach.grid - x)))
            if abs(float(reach.grid[k]) - x) > 1e-9:
                raise RuntimeError(f"{e.fruit}: picked with the carriage at {x} m, off the screen's grid")
            out.append((e, names.index(e.arm), k))
    return out


def _busiest(plan, reach, trips: dict) -> float:
    """Over the plan's stops, the busiest arm's round trips against the arms' mean, summed over
    the stops (1.0: every stop's arms equally loaded; what a stop's other arms stand idle for
    while its busiest arm finishes, in round trips)."""
    load: dict[int, np.ndarray] = {}
    for e, a, k in _picks_at(plan, reach):
        load.setdefault(k, np.zeros(len(reach.problem.arms)))[a] += trips[e.fruit]
    return float(sum(v.max() for v in load.values()) / sum(v.mean() for v in load.values()))


def _trips(plan, reach) -> dict:
    """Each picked fruit's round-trip bound where it was picked (s), by fruit id."""
    from coplan.row.stops import round_trips

    out = {}
    for e, a, k in _picks_at(plan, reach):
        tr = round_trips(reach.problem, reach, [e.fruit], np.array([k]))
        if e.fruit in out or (e.fruit, k, a) not in tr:
            raise RuntimeError(f"{e.fruit}: picked twice, or by an arm the screen says cannot from there")
        out[e.fruit] = tr[(e.fruit, k, a)]
    return out


def _still(q: np.ndarray, t: np.ndarray, t0: float, t1: float) -> bool:
    """Whether joints ``q`` (T, 2) on times ``t`` stand still for two steps or more between ``t0``
    and ``t1`` (a wait: a rest-to-rest move is at rest only at its two ends)."""
    on = (t >= t0 - 1e-9) & (t <= t1 + 1e-9)
    moving = np.abs(np.diff(q[on], axis=0)).max(axis=1) > 1e-12
    return bool(np.any(~moving[1:] & ~moving[:-1])) if moving.size > 1 else False


def _excess(plan, trips: dict) -> np.ndarray:
    """Per cycle from the bin with no wait in it (place, pick, place of one arm, its joints never
    still for two steps between them): its time beyond the fruit's round trip -- what the
    execution adds."""
    by: dict[str, list] = {}
    for e in sorted(plan.events, key=lambda e: e.t_start):
        by.setdefault(e.arm, []).append(e)
    t = np.asarray(plan.time)
    out = []
    for arm, es in by.items():
        q = np.asarray(plan.q[arm])
        for e0, e1, e2 in zip(es, es[1:], es[2:]):
            if ((e0.kind.value, e1.kind.value, e2.kind.value) != ("place", "pick", "place") or e1.fruit != e2.fruit
                    or _still(q, t, e0.t_end, e1.t_start) or _still(q, t, e1.t_end, e2.t_start)):
                continue
            out.append(e2.t_end - e0.t_end - trips[e1.fruit])
    return np.asarray(out)


def _moving(plan) -> tuple[float, float]:
    """Seconds the carriage moves and stands in the plan (to its last sample)."""
    t, gx = np.asarray(plan.time), np.asarray(plan.gantry_x)
    moving = float(np.sum(np.diff(t)[np.abs(np.diff(gx)) > 1e-12]))
    return moving, float(t[-1] - t[0]) - moving


def _hops(xs: list[float]) -> float:
    return float(np.mean(np.diff(xs))) if len(xs) > 1 else float("nan")


def main() -> None:
    from coplan.kinds import GantryMode
    from coplan.problem import load_problem, shipped_rows
    from coplan.row.live import LiveRowOptions, run_live_row
    from coplan.row.reach import row_reach

    print(run_header(), flush=True)
    t_all = time.perf_counter()
    perfect = dict(sigma=0.0, false_rate=0.0, duplicate_rate=0.0)
    print("\nLive stop and go against its offline plan (seed 0; row time / the offline plan's):\n")
    print("| row | as run (1.5 m, noisy) | perfect camera, 1.5 m | perfect camera, 3 m | stops live / offline | "
          "mean hop live / offline (m) | carriage moving live / offline (s) | carriage standing live / offline (s) | round trip live / offline (s per fruit) | busiest arm / mean live / offline | cycle excess live / offline, median "
          "(mean, cycles) (s) | verified |")
    print("|---|---|---|---|---|---|---|---|---|---|---|---|")
    for path in shipped_rows():
        prob = load_problem(path)
        reach = row_reach(prob)
        runs = {}
        for key, kw in (("run", {}), ("perfect", perfect), ("perfect3", perfect | {"look_ahead": 3.0})):
            runs[key] = run_live_row(prob, LiveRowOptions(mode=GantryMode.STOP_AND_GO, seed=0, **kw))
        live, off = runs["perfect"].plan, runs["perfect"].offline.plan
        t_live, t_off = _trips(live, reach), _trips(off, reach)
        e_live, e_off = _excess(live, t_live), _excess(off, t_off)
        (mv_live, st_live), (mv_off, st_off) = _moving(live), _moving(off)
        both = sorted(set(t_live) & set(t_off))  # (the round trips of the fruit both plans picked)
        m_live, m_off = np.mean([t_live[f] for f in both]), np.mean([t_off[f] for f in both])
        x_live = [s["x"] for s in live.solver["row"]["stops"]]
        x_off = [sp.stop.x for sp in runs["perfect"].offline.stops]
        ok = all(r.metrics["verified"] for r in runs.values()) and runs["perfect"].offline.verification.passed
        print(f"| {path.stem} | {runs['run'].metrics['row_time_ratio']:.3f} | {runs['perfect'].metrics['row_time_ratio']:.3f} | "
              f"{runs['perfect3'].metrics['row_time_ratio']:.3f} | {len(x_live)} / {len(x_off)} | "
              f"{_hops(x_live):.2f} / {_hops(x_off):.2f} | {mv_live:.1f} / {mv_off:.1f} | {st_live:.1f} / {st_off:.1f} | "
              f"{m_live:.3f} / {m_off:.3f} ({m_live / m_off - 1:+.1%}) | "
              f"{_busiest(live, reach, t_live):.3f} / {_busiest(off, reach, t_off):.3f} | "
              f"{np.median(e_live):.3f} ({np.mean(e_live):.3f}, {e_live.size}) / {np.median(e_off):.3f} "
              f"({np.mean(e_off):.3f}, {e_off.size}) | "
              f"{'yes' if ok else 'NO'} |", flush=True)
    print(f"\n(one run, {time.perf_counter() - t_all:.0f} s)")


if __name__ == "__main__":
    import argparse

    # (no options: --help ran the whole benchmark)
    argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter).parse_args()
    main()
