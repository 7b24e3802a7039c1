"""The optimal planner's incumbent: the best verified plan so far, and how it is reported.

:class:`Incumbent` keeps a plan only if the independent verifier passed it, it harvests at least
as much as the one it replaces and it is faster (:meth:`Incumbent.offer`); the widening stage,
which keeps the makespan, replaces it through :meth:`Incumbent.replace` under its own rule.
:func:`time_to_ratio` reads the incumbent history; :func:`stop_message` says why the planner
stopped and where its plan came from.
"""

from __future__ import annotations

import time as _time
from time import time as _epoch  # the wall clock, for callers outside (not a budget)

import numpy as np

from ...kinds import Choice
from ...plan import Plan, PlanStatus, finalize_plan
from ...problem.model import Problem
from ..coordinated.planner import Coordinated
from .search_setup import StopReason

__all__ = ["Incumbent", "Source", "time_to_ratio", "stop_message"]


class Source(Choice):
    """The stage an incumbent's makespan came from (plan.json's ``solver.incumbent_from`` and
    each history entry's ``source``)."""

    COORDINATED = "coordinated"
    RETIME = "retime"
    SEARCH = "search"
    REFINE = "refine"
    NLP = "joint NLP"
    NLP_UNVERIFIED = "joint NLP (unverified)"  # the joint NLP's best iterate, kept where nothing was verified
    REGROUP = "regroup"

    @property
    def words(self) -> str:
        return {Source.COORDINATED: "the coordinated plan", Source.RETIME: "the retiming", Source.SEARCH: "the search",
                Source.REFINE: "the refinement", Source.NLP: "the joint NLP", Source.NLP_UNVERIFIED: "the joint NLP, unverified",
                Source.REGROUP: "the regroup stage, planned at a raised clearance"}[self]


class Incumbent:
    """The best verified plan so far (see the module docstring for the acceptance rule)."""

    def __init__(self, problem: Problem, t_start: float, say):
        self.problem, self.t_start, self.say = problem, t_start, say
        self.n_reach = len(problem.reachable_ids())
        self.plan: Plan | None = None
        self.verification = None
        self.candidate: Coordinated | None = None
        self.source: Source | None = None
        self.first_at = None
        self.first_wall = None  # the wall clock (s since the epoch) at the first verified plan
        self.improved_at = None
        self.history: list[dict] = []
        self.moved_by: str | None = None  # the stage that moved the incumbent's plan at its makespan (widen)

    @property
    def makespan(self) -> float:
        return self.plan.metrics["makespan"] if self.plan is not None else np.inf

    def offer(self, plan: Plan, verification, source: Source, candidate: Coordinated | None = None,
              ties: bool = False) -> bool:
        """Keep ``plan`` if verified and it harvests more, or as much and faster (with ``ties``: or
        as fast, so that a parallel search's winner replaces an equal best that happened to arrive
        first). A plan that harvests more is kept even if slower: fruit come first."""
        plan = finalize_plan(plan, verification, self.n_reach)
        if plan.status not in (PlanStatus.SUCCESS, PlanStatus.PARTIAL):
            return False
        equal = False  # as much, as fast: kept only with ``ties``, and quietly (not an improvement)
        if self.plan is not None:
            got, have = plan.metrics["harvested"], self.plan.metrics["harvested"]
            mk = plan.metrics["makespan"]
            equal = got == have and mk >= self.makespan - 1e-9
            if got < have or (equal and not (ties and mk <= self.makespan + 1e-9)):
                return False
        self.plan, self.verification, self.source = plan, verification, Source(source)
        self.candidate = candidate if candidate is not None else self.candidate
        self.moved_by = None  # (a plan of its own: no stage has moved it yet)
        if equal:
            return True
        now = _time.perf_counter() - self.t_start
        if self.first_at is None:
            self.first_at, self.first_wall = now, _epoch()
        self.improved_at = now
        self.history.append({"t": now, "makespan": self.makespan, "source": self.source.value})
        lb = plan.metrics.get("lower_bound") or 0.0
        gap = f", {max(self.makespan / lb - 1, 0.0):.2%} over the lower bound {lb:.3f} s" if lb else ""
        self.say(f"incumbent {self.makespan:.3f} s ({self.source.value}){gap}")
        return True

    def replace(self, plan: Plan, verification, stage: str, candidate: Coordinated | None = None) -> None:
        """Put ``plan`` (verified, checked by the caller: as fast, as much) in place of the
        incumbent's plan; its source stays (the stage that found the makespan), and its
        schedules unless ``candidate`` gives the plan's own (the regroup stage's: other events).
        It is moved by ``stage``, which ``moved_by`` and :func:`stop_message` name: the written
        plan is that one."""
        self.plan, self.verification = plan, verification
        self.candidate = candidate if candidate is not None else self.candidate
        self.moved_by = stage  # (not in the history: no makespan came of it, and its readers group by source)


def time_to_ratio(history: list[dict], bound: float | None, ratios=(1.05, 1.02, 1.01)) -> dict[str, float | None]:
    """When (s after the planner started) the incumbent first came within each ratio of the
    lower bound (from the incumbent history); None where it never did."""
    out: dict[str, float | None] = {}
    for r in ratios:
        hit = next((h["t"] for h in history if bound and h["makespan"] <= r * bound + 1e-9), None)
        out[f"{r:.2f}"] = hit
    return out


def stop_message(inc: Incumbent, stop: StopReason) -> str:
    """Why the planner stopped, and which stage its plan came from."""
    if inc.n_reach == 0:  # (it said no verified plan was found, of a problem with nothing to plan)
        # (a problem with no fruit at all was said to have none in reach: a sweep's row read as a layout fault)
        return ("nothing to plan: the problem has no fruit (every arm stays at home)" if not inc.problem.fruits else
                "nothing to plan: no arm reaches any fruit (every arm stays at home)")
    if inc.source is None or inc.source == Source.NLP_UNVERIFIED:
        return "no verified plan was found; the best the solver had is kept"
    words = {
        StopReason.PROVEN_OPTIMAL: "the plan meets the lower bound: proven optimal",
        StopReason.BUDGET: "the work budget is spent",
        StopReason.STALLED: "the search stopped improving",
        StopReason.EXHAUSTED: "every allocation, order and elbow branch was tried",
        StopReason.TIME_LIMIT: "the time limit was reached; the verified incumbent is returned",
        StopReason.INTERRUPTED: "interrupted; the verified incumbent is saved",
    }
    moved = f", then moved by the {inc.moved_by} stage at its makespan" if inc.moved_by else ""
    return f"{words[stop]} (incumbent from {inc.source.words}{moved})"
