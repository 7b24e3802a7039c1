"""The widening stage's runs, judged: :func:`widened` runs the widening program
(:func:`coplan.planners.optimal.widen.widen`) on the incumbent's schedules -- again with every
knot time held, from the plan's own schedules, or held more loosely, where the first leaves
less room than the goal -- and keeps a candidate only when the independent verifier passes it,
it harvests as much, is no slower and its certified margin is no smaller (:func:`_judged`).
Called by :func:`coplan.planners.optimal.stages.widen`."""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import partial

import time as _time
from dataclasses import replace

from ...plan import finalize_plan
from ...problem.model import Problem
from .incumbent import Incumbent
from .nlp_data import any_interrupted
from .options import OptimalOptions

__all__ = ["widened", "room_goal", "MARGIN_TOL"]

_RETRY_ITERATIONS = 30  # fewer widening iterations left than this: no second program
_LOOSE_TRACK = 1.0  # the last retry's hold on the start's poses (WidenOptions.track: 10)


def widened(problem: Problem, inc: Incumbent, opts: OptimalOptions, deadline: float | None, say,
            proven: bool = False, share: Callable[[float], None] | None = None) -> dict:
    """The widening stage on the incumbent's schedules; the widened plan replaces the incumbent
    when it is verified, harvests as much, is no slower and its certified margin is no smaller.
    Where the program with free timing leaves less certified room than the goal (twice the
    margin, at most ``widen_goal``) or no candidate, the program with every knot time held is
    solved on the iterations left (``retry`` in the report; not when the first call solved it
    already) and the better candidate kept. The
    programs start from the eased schedules (:func:`coplan.planners.optimal.ease.ease`: each
    arm's rest spread over its moves); should they give nothing to keep, the program is solved
    once more from the incumbent's own (``uneased`` in the report). Where the room kept is still
    less than the goal, once more with every knot time held and a lighter hold on the start's
    poses (``loose``).
    A plan with ``widen_goal`` of margin already is only smoothed (its room held, widened up to
    ``widen_cap``), and left as it is when the search proved it optimal (``proven``): such a
    solve is short (greenhouse_row's 0.07 s), and a program would be most of it.
    ``share(s)``: told the share of the stage's IPOPT iterations spent as each solve ends (the
    progress bar's). Returns the stage's report (plan.json ``solver.widen``)."""
    from .widen import WidenOptions, widen

    used = [0]

    def spent(n: int) -> None:
        used[0] += n
        if share is not None:
            share(min(1.0, used[0] / max(opts.widen_iterations, 1)))

    widen_schedules = partial(widen, spent=spent)

    wopts = WidenOptions(cap=opts.widen_cap, iterations=opts.widen_iterations, max_knots=opts.widen_knots,
                         h_target=opts.h_target, ease=opts.widen_ease)
    before = inc.plan
    margin0 = before.verification["margin"]
    jerk0 = {a: v.get("rms_jerk") for a, v in before.metrics.get("per_arm", {}).items()}
    if not problem.neighbour_pairs():
        return {"status": "skipped", "accepted": False, "margin_before": None, "makespan_before": inc.makespan,
                "rms_jerk_before": jerk0, "reason": "no two arms can touch: nothing to widen"}
    if margin0 >= opts.widen_goal and proven:
        return {"status": "skipped", "accepted": False, "margin_before": margin0, "makespan_before": inc.makespan,
                "rms_jerk_before": jerk0,
                "reason": f"the plan keeps {1000 * margin0:.1f} mm beyond the clearance already "
                          f"(widen_goal is {1000 * opts.widen_goal:.0f} mm) and is proven optimal: not smoothed"}
    res = widen_schedules(problem, inc.candidate.alloc, inc.candidate.schedules, inc.makespan, wopts, deadline, say)
    info = dict(res.info)
    info.update(accepted=False, margin_before=margin0, makespan_before=inc.makespan, rms_jerk_before=jerk0)
    best = _judged(problem, inc, res, info, say)
    # past widen_knots: no retry on these schedules fits (the same knots); the plan's own, uneased,
    # may (easing moves event starts: crossing_paths 220 knots uneased, 222 eased)
    too_long = bool(info.get("too_long"))
    if too_long and not ((info.get("ease") or {}).get("arms") and info.get("knots_uneased", math.inf) <= opts.widen_knots):
        return info

    def in_time() -> bool:  # (and not stopped by Ctrl-C: IPOPT's own handler stopped its program only)
        return (deadline is None or _time.perf_counter() < deadline) and not any_interrupted(info)

    def left() -> int:  # IPOPT iterations the stage has left
        return opts.widen_iterations - info.get("iterations", 0)
    # free timing settled on less room than the goal (a local optimum) or on a plan the
    # verifier refuses: the same program with every knot time held, on the iterations left
    # (overlap-3x9-s25: free timing 10.7 mm certified, refused; held 84.1 mm)
    # (not when the first call solved that program already -- free timing did not settle -- it
    # would start from the same point and take the same steps, on fewer iterations)
    want = room_goal(margin0, opts.widen_goal)
    free = any(r["timing"] == "free" for r in info.get("rounds", ()))
    held = any(r["timing"] == "held" for r in info.get("rounds", ()))
    if (free and not held and not too_long and left() >= _RETRY_ITERATIONS and "room_note" not in info and in_time()
            and (best is None or best[2] < want)):
        say(f"widen: free timing {'left less room than the goal' if best is not None else 'gave no plan to keep'}; "
            "solving again with every knot time held")
        best = _again(problem, inc, replace(wopts, h_bounds=(1.0, 1.0), iterations=left()), "retry", info, best,
                      widen_schedules, deadline, say)
    if best is None and (info.get("ease") or {}).get("arms") and in_time():
        # the program from the eased schedules gave nothing to keep: once more from the plan's own
        say("widen: nothing to keep from the eased schedules; solving again from the plan's own")
        best = _again(problem, inc, replace(wopts, ease=False), "uneased", info, best, widen_schedules, deadline, say)
    if ((best is None or best[2] < want) and not too_long and "room_note" not in info and wopts.track > _LOOSE_TRACK
            and left() >= _RETRY_ITERATIONS and in_time()):
        # still less room than the goal: a local optimum of a program held close to the start's
        # poses; once more, held more loosely, every knot time held (overlap-2x6-s22: 31.5 ->
        # 34.7 mm, the goal 32.6; free timing held loosely gave 31.7)
        say("widen: less room than the goal; solving again held more loosely to the start's poses")
        best = _again(problem, inc, replace(wopts, track=_LOOSE_TRACK, h_bounds=(1.0, 1.0), iterations=left()), "loose",
                      info, best, widen_schedules, deadline, say)
    if best is None:  # (the reason said each attempt's: it gave the first program's alone)
        tried = [f"{k}: {info[k]['reason']}" for k in ("retry", "uneased", "loose") if (info.get(k) or {}).get("reason")]
        if tried and info.get("reason"):
            info["reason"] = "; ".join([info["reason"]] + tried)
        return info
    plan, ver, margin = best
    inc.replace(plan, ver, "widening")
    info["accepted"] = True
    info.pop("reason", None)
    say(f"widen: certified margin {1000 * margin0:.1f} -> {1000 * margin:.1f} mm at {plan.metrics['makespan']:.4f} s")
    return info


def _again(problem: Problem, inc: Incumbent, wopts, key: str, info: dict, best, widen_schedules, deadline, say):
    """One more widening program (``wopts``) on the incumbent's schedules, judged; its report
    under ``info[key]``, its rounds, iterations and time added to the stage's. Returns the
    better of ``best`` and its candidate (more certified margin), ``info`` updated to it."""
    res = widen_schedules(problem, inc.candidate.alloc, inc.candidate.schedules, inc.makespan, wopts, deadline, say)
    again = dict(res.info)
    other = _judged(problem, inc, res, again, say)
    info[key] = {k: again.get(k) for k in ("status", "iterations", "room", "dense_room", "verified", "margin", "reason")}
    info["rounds"] = info.get("rounds", []) + again.get("rounds", [])
    info["iterations"] = info.get("iterations", 0) + again.get("iterations", 0)
    info["wall_seconds"] = info.get("wall_seconds", 0.0) + again.get("wall_seconds", 0.0)
    if other is None or (best is not None and other[2] <= best[2]):
        return best
    info.update({k: again[k] for k in ("status", "room", "dense_room", "points", "verified", "margin", "makespan", "rms_jerk")
                 if k in again})
    return other


#: certified margins equal to the micrometre are no smaller: a held pose's certified clearance
#: moves by 1e-8 m with the float noise of the motion around it (overlap-2x6-s28: 20.445996 ->
#: 20.445976 mm, the same poses at the least room)
MARGIN_TOL = 1e-6


def room_goal(margin0: float, widen_goal: float) -> float:
    """The room (m) the widening aims for from a certified margin of ``margin0``: twice it, at
    most ``widen_goal`` (the regroup stage plans again where the widened plan falls short)."""
    return min(2.0 * margin0, widen_goal)


def _judged(problem: Problem, inc: Incumbent, res, info: dict, say):
    """The widening's candidate judged against the incumbent: ``(plan, verification, certified
    margin)`` when it is verified, harvests as much, is no slower and keeps no less margin; else
    None, with the reason in ``info`` (updated in place with what the verifier found)."""
    from ...verify.verifier import verify

    before, margin0 = inc.plan, inc.plan.verification["margin"]
    if res.plan is None:
        say(f"widen: {info.get('reason', info['status'])}; kept the incumbent")
        return None
    ver = verify(problem, res.plan)
    plan = finalize_plan(res.plan, ver, inc.n_reach)
    if "lower_bound" in before.metrics:
        plan.metrics["lower_bound"] = before.metrics["lower_bound"]
    margin = ver.margin if ver.passed else None
    info.update(verified=bool(ver.passed), margin=margin, makespan=plan.metrics["makespan"],
                rms_jerk={a: v.get("rms_jerk") for a, v in plan.metrics.get("per_arm", {}).items()})
    why = None
    if not ver.passed:
        why = f"refused by the verifier ({len(ver.violations)} violation{'s' * (len(ver.violations) != 1)})"
    elif plan.metrics["harvested"] < before.metrics["harvested"]:
        why = "it harvests less"
    elif plan.metrics["makespan"] > inc.makespan + 1e-9:
        why = f"slower ({plan.metrics['makespan']:.4f} s against {inc.makespan:.4f} s)"
    elif margin < margin0 - MARGIN_TOL:
        why = f"its certified margin {1000 * margin:.1f} mm is smaller than {1000 * margin0:.1f} mm"
    if why is not None:
        say(f"widen: {why}; kept the incumbent")
        info["reason"] = why
        return None
    return plan, ver, margin
