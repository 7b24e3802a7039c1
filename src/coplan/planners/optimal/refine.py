"""Refinement: the search's neighbourhood again, every candidate ranked by its *retimed* makespan.

Entry point: :func:`refine`. The search (:func:`coplan.planners.optimal.search.improve`) ranks
candidates by the coordinator's leg-by-leg makespan. Retiming the same moves
(:func:`coplan.planners.optimal.retime.retime`, every start chosen together) can lower it, by
different amounts for different candidates: on dense_overlap the search's best, 15.445 s,
retimes to 15.261 s, while one of its neighbours, 15.351 s as coordinated, retimes to 14.977 s.
So this stage goes on from the search's best state with the search's own moves
(:class:`coplan.planners.optimal.search.Neighbourhood`) and ranks each neighbour by its retimed
makespan:

* a neighbour is proposed from the current state, mostly around the arm that places last;
* it is skipped when its decoupled estimate cannot beat the best, when it cannot be
  coordinated, or when its coordinated makespan exceeds the current state's by more than
  ``slack``;
* otherwise it is retimed, and becomes the current state when faster, or when slower with
  probability exp(-worse / ``temperature``) (annealing at a fixed temperature);
* a new best is offered (``offer``: the caller verifies it); one the caller refuses is
  dropped: it becomes neither the best nor the current state;
* after ``patience`` retimings without improving on the best of the start in use (or 500
  proposals without one worth retiming) it goes on from the next start: the other local bests
  the search left (its fresh starts' bests,
  :attr:`coplan.planners.optimal.search.SearchStats.local_bests`), lowest decoupled estimate
  first. The search's starts end in different places: with seeds 1 and 4 on dense_overlap
  its best is 15.796 s, an allocation whose critical arm never waits (its decoupled estimate
  is 15.796 s too), so no retiming or single move beats it, while the start from the lower
  bound's allocation, 16.609 s as the search left it, refines to 15.08 s. When every start is
  used, it goes on from the best changed by ``kick`` random moves (an iterated local search)
  until the budget is spent.

Budget: ``retimes`` CP-SAT runs, each with a deterministic limit; the moves come from the neighbourhood's seeded generator, so the same input gives the
same plan anywhere. The forbidden start offsets of move pairs are shared by every retiming
(most moves repeat from one neighbour to the next), so later retimings cost a fraction of the
first. It stops at once when the best meets the lower bound.
"""

from __future__ import annotations

import time as _time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..coordinated.candidate import Coordinated
from ...problem.model import Problem
from .retime import retime, retimed_candidate
from .search import Neighbourhood, State, StopReason
from ...ties import TIE, quantised

__all__ = ["RefineOptions", "RefineStats", "refine"]


@dataclass(frozen=True)
class RefineOptions:
    """Budget and rules of :func:`refine`.

    retimes : CP-SAT retimings (the budget; the starts' own included)
    patience : after this many retimings without improving on the best of the start in use,
        go on from the next start
    kick : when every start is used, go on from the best changed by this many random moves
    slack : retime a neighbour only when its coordinated makespan is at most this much (s)
        above the current retimed one (retiming rarely gains more)
    temperature : accept a slower neighbour with probability exp(-(its retimed makespan -
        current) / temperature) (s); the best is kept whatever is accepted
    work : each retiming's deterministic time limit (CP-SAT)
    tolerance : a makespan this close to the lower bound (s) is optimal
    """

    retimes: int = 100
    patience: int = 30
    kick: int = 3
    slack: float = 0.6
    temperature: float = 0.05
    work: float = 5.0
    tolerance: float = 1e-3


@dataclass
class RefineStats:
    retimes: int = 0
    proposals: int = 0
    evaluations: int = 0  # neighbours coordinated
    pruned: int = 0  # skipped: the estimate cannot beat the best
    beyond_slack: int = 0  # skipped: coordinated more than ``slack`` above the current state
    failed: int = 0  # not coordinated, not retimed, or refused by the caller
    improvements: int = 0
    starts: int = 0  # local bests refined from (the search's best first)
    kicks: int = 0  # starts from the best changed by random moves, once every start was used
    start_makespan: float | None = None  # the start's retimed makespan (its own when not retimed)
    stop: StopReason = StopReason.BUDGET

    def summary(self) -> dict:
        return {"retimes": self.retimes, "proposals": self.proposals, "evaluations": self.evaluations,
                "pruned_by_bound": self.pruned, "beyond_slack": self.beyond_slack, "failed": self.failed,
                "improvements": self.improvements, "starts": self.starts, "kicks": self.kicks, "start_makespan": self.start_makespan,
                "stopped_by": self.stop.value}


def refine(
    problem: Problem,
    hood: Neighbourhood,
    state: State,
    start: Coordinated,
    bound: float,
    margin: float,
    options: RefineOptions | None = None,
    offer: Callable[[Coordinated], bool] | None = None,
    deadline: float | None = None,
    tables: dict | None = None,
    memo: dict | None = None,
    more: Sequence[tuple[Coordinated, State]] = (),
    tick: Callable[[float], None] | None = None,
) -> tuple[Coordinated, RefineStats]:
    """Refine ``start`` (whose state in ``hood`` is ``state``) by retimed local search (see the
    module docstring), then, each time ``patience`` retimings bring no new best of the start
    in use, each of ``more`` (other local bests, e.g. ``SearchStats.local_bests``) in turn,
    lowest decoupled estimate first (the most room for coordination), then fastest.
    ``offer`` is called with every new best (retimed schedules) and says whether it passed the
    caller's check (the planner verifies it; a refused one is dropped), the refinement keeping
    its own best; ``tick`` receives the share of the budget (retimings) spent, before each;
    ``tables``/``memo``: S-curve tables and forbidden offsets shared with other retimings.
    Returns the best candidate (``start`` when nothing beat it) and the statistics; Ctrl-C ends
    it with what it has."""
    opts = options or RefineOptions()
    st = RefineStats()
    memo = {} if memo is None else memo
    tables = {} if tables is None else tables
    offer = offer or (lambda c: True)
    hood.hold(hood.opts.fixed_assignment)
    starts, seen = [(start, state)], {state}
    for c, s in sorted(more, key=lambda x: (float(quantised(hood.estimate(x[1]))), float(quantised(x[0].makespan)))):
        if s not in seen:
            starts.append((c, s))
            seen.add(s)

    def retimed(c: Coordinated) -> Coordinated | None:
        st.retimes += 1
        if tick is not None:
            tick(st.retimes / max(1, opts.retimes))
        r = retime(problem, c.schedules, margin, work=opts.work, tables=tables, memo=memo, deadline=deadline)
        if r.schedules is None:
            return None
        return retimed_candidate(c, r)

    best, s_best = start, state

    def better(c: Coordinated, s: State) -> bool:
        """Whether ``c`` (state ``s``) is a new best the caller keeps (``best`` updated)."""
        nonlocal best, s_best
        if c.makespan >= best.makespan - 1e-9:
            return False
        if not offer(c):
            st.failed += 1
            return False
        best, s_best = c, s
        st.improvements += 1
        return True

    try:
        k, since = -1, opts.patience  # the start in use; retimings since it last improved on its own best
        cur = s_cur = None
        own = np.inf  # this start's best (retimed) makespan
        tried = 0  # proposals since the last retiming
        while True:
            if best.makespan <= bound + opts.tolerance:
                st.stop = StopReason.PROVEN_OPTIMAL
                break
            if st.retimes >= opts.retimes:
                st.stop = StopReason.BUDGET
                break
            if deadline is not None and _time.perf_counter() > deadline:
                st.stop = StopReason.TIME_LIMIT
                break
            if st.proposals >= 50 * opts.retimes:
                st.stop = StopReason.STALLED
                break
            if since >= opts.patience or tried >= 500:  # the next start
                k += 1
                if k < len(starts):
                    cur, s_cur = starts[k]
                    st.starts += 1
                else:  # every start used: the best, kicked by a few random moves
                    if opts.kick <= 0 or st.kicks >= 20 * (st.improvements + 1):
                        st.stop = StopReason.STALLED  # no kicks, or kicks that lead nowhere
                        break
                    s_cur = s_best
                    for _ in range(opts.kick):
                        mv = hood.propose(s_cur, int(hood.rng.integers(len(s_cur.assign))))
                        s_cur = mv[1] if mv is not None else s_cur
                    kicked = hood.evaluate(s_cur) if s_cur != s_best else None
                    st.kicks += 1
                    st.evaluations += s_cur != s_best
                    if kicked is None:  # kick again
                        st.proposals += 1
                        continue
                    cur = kicked
                got = retimed(cur)
                if got is not None and got.makespan < cur.makespan - 1e-9:
                    if got.makespan >= best.makespan - 1e-9 or better(got, s_cur):
                        cur = got
                if k == 0:
                    st.start_makespan = cur.makespan
                own = cur.makespan
                since = tried = 0
                continue
            st.proposals += 1
            tried += 1
            mv = hood.propose(s_cur, hood.critical(cur))
            if mv is None or mv[1] in seen:
                continue
            s_new = mv[1]
            seen.add(s_new)
            if hood.estimate(s_new) > best.makespan - opts.tolerance:
                st.pruned += 1
                continue
            st.evaluations += 1
            cand = hood.evaluate(s_new)
            if cand is None:
                st.failed += 1
                continue
            if cand.makespan > cur.makespan + opts.slack:
                st.beyond_slack += 1
                continue
            got = retimed(cand)
            tried, since = 0, since + 1
            if got is None or cand.makespan < got.makespan - TIE:  # the coordinator's own timing is better
                got = cand
            if got.makespan < best.makespan - 1e-9 and not better(got, s_new):
                continue
            if got.makespan < own - 1e-9:
                own, since = got.makespan, 0
            worse = got.makespan - cur.makespan
            if worse < -1e-9 or (opts.temperature > 0 and hood.rng.random() < np.exp(-max(worse, 0.0) / opts.temperature)):
                cur, s_cur = got, s_new
    except KeyboardInterrupt:
        st.stop = StopReason.INTERRUPTED
    return best, st
