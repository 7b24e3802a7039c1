"""Other events for more room: the optimal planner again at a raised clearance (the ``regroup``
stage, after ``widen``; :func:`regrouped`).

The widening stage moves the arms apart at the incumbent's makespan *on the incumbent's events*
(who picks what, in which order, and the order of events across arms). Where the least room is
between two picks whose dwells overlap in time, or where a move passes a neighbour's pick at a
time the events fix, no program on those events has more room: on overlap-2x6-s28 the least
room, 20.4 mm, is two arms holding their tips on two fruit at the same instant. Another
allocation and order may keep the makespan with more room; the planner, asked for more
clearance, looks for one. So where the widened plan keeps less certified margin than the
widening's goal (twice the margin it started from, at most ``widen_goal``), the whole flow
(coordinated, retime, search, refine, widen) runs again on the problem with its clearance raised
by the shortfall, and its plan replaces the incumbent only if, checked by the verifier against
the problem's own clearance, it harvests as much, is no slower and keeps more certified margin.
Not where the arms at home (every plan's start and end) keep less than the goal, nor under a
time limit with less time left than the solve so far took.
(It may be faster: the search starts elsewhere at another clearance. Then it is an incumbent
like any other, from the ``regroup`` source.)

It costs a second solve where it runs (it never runs on a plan with its room already); its
budgets are work, like the first's, so it gives the same plan on any machine.
"""

from __future__ import annotations

import math
import time as _time
from dataclasses import replace

import numpy as np

from ...plan import PlanStatus, finalize_plan
from ...problem.model import Problem
from ...progress import Tick
from .incumbent import Source
from .judged import MARGIN_TOL, room_goal
from .nlp_data import SolverStatus
from .windows import min_clearance

__all__ = ["regrouped", "home_room", "ROOM_QUANTUM"]

#: the clearance is raised by the shortfall rounded up to this (m): a plan's room to the
#: micrometre would make the raised problem differ with the last bits of a CPU's floating point
ROOM_QUANTUM = 1e-4


def home_room(problem: Problem) -> float:
    """The least room (m) beyond the clearance between neighbours with every arm at home, where
    every plan starts and ends: no plan keeps more (inf with no neighbours)."""
    return min_clearance(problem, {a.name: np.asarray(a.home, float)[None, :] for a in problem.arms}) - problem.task.clearance


class _Inner:
    """The inner run's progress: its messages prefixed, its ticks one level down."""

    def __init__(self, say, tick):
        self.say, self.outer_tick = say, tick

    def __call__(self, message: str) -> None:
        self.say(f"regroup: {message}")

    def tick(self, t: Tick) -> None:
        self.outer_tick(replace(t, level=t.level + 1))


def regrouped(run) -> dict:
    """The ``regroup`` stage on ``run`` (:class:`coplan.planners.optimal.stages.Run`, after its
    widening stage): its report (plan.json ``solver.regroup``), the incumbent replaced in place
    when the plan found at the raised clearance is kept (module docstring)."""
    from ...verify.verifier import verify

    problem, opts, inc = run.problem, run.opts, run.inc
    w = run.reports.get("widen") or {}
    margin0 = w.get("margin_before")
    why = ("the option regroup is false" if not opts.regroup else
           "the widening stage did not run" if not opts.widen or w.get("status") == "skipped" or margin0 is None else
           "the run was interrupted first" if run.interrupted else
           "no planner to run again" if run.again is None else
           "no verified plan" if inc.plan is None or not inc.verification or not inc.verification.passed else None)
    if why is not None:
        return {"status": "skipped", "accepted": False, "reason": why}
    margin = float(inc.verification.margin)
    want = room_goal(margin0, opts.widen_goal)
    if margin >= want - MARGIN_TOL:
        return {"status": "skipped", "accepted": False, "margin": margin,
                "reason": f"the plan keeps {1000 * margin:.1f} mm, the widening's goal ({1000 * want:.1f} mm)"}
    home = home_room(problem)
    if home < want:  # (every plan starts and ends there)
        return {"status": "skipped", "accepted": False, "margin": margin,
                "reason": f"the arms at home keep {1000 * home:.1f} mm beyond the clearance: no plan keeps the "
                          f"widening's goal ({1000 * want:.1f} mm)"}
    if not run.in_time():
        return {"status": "skipped", "accepted": False, "reason": "the time limit came before the regroup stage"}
    now = _time.perf_counter()
    if run.deadline is not None and run.deadline - now < now - run.t_start:
        return {"status": "skipped", "accepted": False,
                "reason": f"the time limit leaves {run.deadline - now:.1f} s, less than the solve so far took "
                          f"({now - run.t_start:.1f} s): a second solve needs about as long"}
    # raised by the shortfall: a plan there keeps the goal once widened as much as this one was.
    # (Not past the incumbent's own least room, which would rule its events out: on s28 with a
    # short search, 16.5 mm instead of 13.5 found no plan to keep, the shortfall a faster one.)
    raise_by = math.ceil((want - margin) / ROOM_QUANTUM - 1e-9) * ROOM_QUANTUM
    clearance = round(problem.task.clearance + raise_by, 6)
    raised = replace(problem, task=replace(problem.task, clearance=clearance), digest=None)
    run.say(f"regroup: the widened plan keeps {1000 * margin:.1f} mm (goal {1000 * want:.1f} mm); "
            f"planning again at a clearance of {1000 * clearance:.1f} mm for other events")
    run.stage("regroup")
    left = None if run.deadline is None else max(run.deadline - _time.perf_counter(), 1e-3)
    t0 = _time.perf_counter()
    inner = run.again(raised, run.allocation, replace(opts, regroup=False, time_limit=left), _Inner(run.say, run.tick))
    info = {"status": "ran", "accepted": False, "margin_before": margin, "goal": want, "clearance": clearance,
            "makespan_before": inc.makespan, "wall_seconds": _time.perf_counter() - t0}
    if inner.error:
        info["reason"] = f"the run at the raised clearance stopped: {inner.error}"
        return info
    ver = verify(problem, inner.plan)  # at the problem's own clearance
    plan = finalize_plan(inner.plan, ver, run.n_reach)
    if "lower_bound" in inc.plan.metrics:  # (the problem's bound, not the raised one's)
        plan.metrics["lower_bound"] = inc.plan.metrics["lower_bound"]
    got = ver.margin if ver.passed else None
    info.update(verified=bool(ver.passed), makespan=plan.metrics["makespan"], margin=got,
                stages=(inner.plan.solver or {}).get("stages"))
    if inner.solver_status == SolverStatus.INTERRUPTED:  # (Ctrl-C: the whole run stops, the incumbent kept)
        run.interrupted = True
        info.update(status="interrupted", reason="interrupted (Ctrl-C)")
        return info
    why = ("refused by the verifier" if not ver.passed else
           f"its status is {plan.status.value}" if plan.status not in (PlanStatus.SUCCESS, PlanStatus.PARTIAL) else
           "it has no schedules (the joint NLP's last resort)" if inner.candidate is None else
           "it harvests less" if plan.metrics["harvested"] < inc.plan.metrics["harvested"] else
           f"slower ({plan.metrics['makespan']:.4f} s against {inc.makespan:.4f} s)"
           if plan.metrics["makespan"] > inc.makespan + 1e-9 else
           f"no more room ({1000 * got:.1f} mm against {1000 * margin:.1f} mm)" if got <= margin + MARGIN_TOL else None)
    if why is not None:
        info["reason"] = why
        run.say(f"regroup: {why}; kept the incumbent")
        return info
    if plan.metrics["makespan"] < inc.makespan - 1e-9 or plan.metrics["harvested"] > inc.plan.metrics["harvested"]:
        # faster (or more fruit) too: an improvement like any other, its own plan
        if not inc.offer(plan, ver, Source.REGROUP, inner.candidate):
            info["reason"] = "the incumbent refused it"
            return info
    else:
        inc.replace(plan, ver, "regroup", inner.candidate)
    info["accepted"] = True
    run.say(f"regroup: other events keep {plan.metrics['makespan']:.4f} s with {1000 * got:.1f} mm "
            f"(was {1000 * margin:.1f} mm)")
    return info
