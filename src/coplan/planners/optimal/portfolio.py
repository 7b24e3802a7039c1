"""The search on several cores: a portfolio of seeded searches in parallel processes.

Entry point: :func:`search_portfolio`. Worker ``w`` runs :func:`coplan.planners.optimal.search.improve`
from the same start, anchor, bound and budget with the move generator seeded ``seed + w``, so
worker 0 is exactly the one-worker search and the others explore elsewhere; each spends the
whole work budget (N workers on N cores take about the wall time of one and search N times as
much). Every new best of every worker reaches the caller as it is found (``on_improve``: the
planner verifies it and offers it to its incumbent), so a plan improves while the search runs.

The result does not depend on which worker finished first: the winner is the least makespan,
then the least total work, then the lowest worker index, among the workers' final bests; its
state (for the refinement) and every worker's local bests (in worker order) come with it. With
work budgets only, the same input, options and number of workers give the same plan on any
machine; a ``deadline`` makes it depend on the clock, as for one worker.

Processes are forked where the platform allows (Linux: nothing to re-import, the problem and
the start are inherited) and spawned elsewhere (each worker then imports coplan first).
"""

from __future__ import annotations

import queue as _queue
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, replace

from ...problem.model import Problem
from ...workers import default_workers, mp_context, quiet_child
from ..coordinated.candidate import Coordinated
from .search import SearchOptions, SearchStats, StopReason, improve

__all__ = ["PortfolioResult", "search_portfolio", "default_workers", "Alongside", "AlongsideFailed"]

_TICK_EVERY = 0.5  # s between a worker's progress messages


@dataclass
class PortfolioResult:
    """The winner's best and statistics (its ``local_bests``: every worker's, in worker order),
    and one summary per worker (seed, makespan, evaluations, what stopped it)."""

    best: Coordinated
    stats: SearchStats
    workers: list[dict]


def _worker(w: int, problem: Problem, start: Coordinated, bound: float, margin: float, opts: SearchOptions,
            seconds: float | None, anchor, out) -> None:
    """Worker ``w``: one seeded search; every new best, throttled progress, and its end go to ``out``."""
    quiet_child()  # (terminated once done, it printed the command line's KeyboardInterrupt from multiprocessing's exit)
    deadline = None if seconds is None else _time.perf_counter() + seconds
    last = [0.0]

    def on_improve(c: Coordinated) -> None:
        out.put(("improve", w, c))

    def tick(share: float) -> None:
        now = _time.perf_counter()
        if now - last[0] >= _TICK_EVERY:
            last[0] = now
            out.put(("tick", w, share))

    try:
        best, stats = improve(problem, start, bound, margin, opts, on_improve, deadline, {}, anchor, None, tick)
        out.put(("done", w, (best, stats)))
    except KeyboardInterrupt:
        out.put(("done", w, None))
    except Exception as e:  # noqa: BLE001 -- reported to the parent, which keeps the other workers' results
        out.put(("error", w, f"{type(e).__name__}: {e}"))


def search_portfolio(problem: Problem, start: Coordinated, bound: float, margin: float, options: SearchOptions,
                     workers: int, on_improve: Callable[[Coordinated], None] | None = None,
                     deadline: float | None = None, anchor=None,
                     tick: Callable[[float], None] | None = None) -> PortfolioResult:
    """``workers`` seeded searches in parallel processes (see the module docstring).

    ``on_improve`` receives each worker's new bests as they arrive (arrival order depends on
    the machine; the returned winner does not). ``tick`` receives the least share of the
    budget spent over the workers still running. A worker that fails is reported in its
    summary and the others' results are kept; when every worker fails, the start is returned.
    """
    if workers < 1:
        raise ValueError(f"expected workers >= 1, found {workers}")
    ctx = mp_context()
    out = ctx.Queue()
    seconds = None if deadline is None else max(0.0, deadline - _time.perf_counter())
    procs = []
    for w in range(workers):
        p = ctx.Process(target=_worker, args=(w, problem, start, bound, margin, replace(options, seed=options.seed + w),
                                              seconds, anchor, out), daemon=True)
        p.start()
        procs.append(p)
    results: dict[int, tuple | None] = {}
    errors: dict[int, str] = {}
    shares = [0.0] * workers
    try:
        while len(results) + len(errors) < workers:
            try:
                kind, w, payload = out.get(timeout=1.0)
            except _queue.Empty:
                dead = [w for w, p in enumerate(procs) if not p.is_alive() and w not in results and w not in errors]
                for w in dead:  # ended without a word (killed): what it sent before is kept
                    errors[w] = f"the worker process ended (exit code {procs[w].exitcode})"
                continue
            if kind == "improve":
                if on_improve is not None:
                    on_improve(payload)
            elif kind == "tick":
                shares[w] = payload
                if tick is not None:
                    tick(min(s for v, s in enumerate(shares) if v not in results))
            elif kind == "done":
                results[w] = payload
                shares[w] = 1.0
            else:
                errors[w] = payload
    finally:
        for p in procs:
            if p.is_alive():
                p.terminate()
            p.join(timeout=5.0)
        out.close()
    summaries = []
    finished = []
    for w in range(workers):
        r = results.get(w)
        if r is None:
            summaries.append({"worker": w, "seed": options.seed + w, "error": errors.get(w, "interrupted")})
            continue
        best, stats = r
        finished.append((best.makespan, best.total, w))
        summaries.append({"worker": w, "seed": options.seed + w, "makespan": best.makespan,
                          "evaluations": stats.evaluations, "checks": stats.checks, "stop": stats.stop.value})
    if not finished:
        stats = SearchStats()
        stats.stop = StopReason.INTERRUPTED if len(errors) < workers else StopReason.BUDGET  # (all failed: their errors are in the summaries)
        return PortfolioResult(start, stats, summaries)
    win = min(finished, key=lambda x: (round(x[0], 9), round(x[1], 9), x[2]))[2]  # (makespan, work, index): no arrival order
    best, stats = results[win]
    if best.makespan > start.makespan - 1e-9 and best.total >= start.total - 1e-9:
        best = start  # no worker beat the start (the copy that came back is the start itself)
    stats.local_bests = [lb for w in range(workers) if results.get(w) for lb in results[w][1].local_bests]
    return PortfolioResult(best, stats, summaries)


# ----------------------------------------------------------------------------- the coordinated stage alongside
def _coordinated_worker(problem: Problem, allocation, options, out) -> None:
    from ..coordinated.planner import plan_coordinated

    quiet_child()  # (terminated once it has sent its result, as the search's workers are)

    try:
        out.put(("done", plan_coordinated(problem, allocation, options, None, {})))
    except KeyboardInterrupt:
        out.put(("error", "interrupted"))
    except Exception as e:  # noqa: BLE001 -- reported to the parent, which keeps its own first candidate
        out.put(("error", f"{type(e).__name__}: {e}"))


class AlongsideFailed(RuntimeError):
    """The coordinated planner's other process (:class:`Alongside`) failed or ended without a word."""


class Alongside:
    """The coordinated planner (every candidate) in another process, while the caller does
    something else with the first one (the optimal planner retimes it); :meth:`result` waits
    for it. The same input and options give the same result as in this process."""

    def __init__(self, problem: Problem, allocation, options) -> None:
        ctx = mp_context()
        self._out = ctx.Queue()
        self._proc = ctx.Process(target=_coordinated_worker, args=(problem, allocation, options, self._out), daemon=True)
        self._proc.start()

    def result(self):
        """The other process's :class:`~coplan.planners.coordinated.planner.CoordinatedResult`;
        :class:`AlongsideFailed` saying why when it failed or ended without a word."""
        while True:
            try:
                kind, payload = self._out.get(timeout=1.0)
            except _queue.Empty:
                if not self._proc.is_alive():
                    raise AlongsideFailed(f"the coordinated planner's process ended (exit code {self._proc.exitcode})") from None
                continue
            if kind == "done":
                return payload
            raise AlongsideFailed(payload)

    def close(self) -> None:
        if self._proc.is_alive():
            self._proc.terminate()
        self._proc.join(timeout=5.0)
        self._out.close()
