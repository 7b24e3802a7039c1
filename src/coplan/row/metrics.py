"""What a grower and an engineer judge a row plan by.

:func:`row_metrics` -> a JSON-ready dict (``plan.json``'s ``metrics.row``, the summary, ``--json``):

* **fruit per hour** over the row (harvested / row time), and per arm;
* **share harvested** of the harvestable fruit (and of all fruit), with the fruit screened out
  and the reason for each, and the arms the screen locks (``locked_arms``: arm -> why; they
  harvest nothing from any carriage position);
* **row time** (the last fruit placed), per metre of row, the **stops** and the mean time per
  stop (``mean_time_per_stop``: from the carriage's arrival to the end of the stop's last pick,
  when it may leave -- the arms place while it moves on; at the last stop the row's last place
  comes after), the **carriage moving share** and the **picking share** (some arm
  holding still on a fruit) of the row time;
* **idle share by cause** per arm: ``carriage`` (at rest while the carriage moves, or settles
  after a stop: ``gantry.settle``, when no arm may pick), ``no_fruit``
  (at rest at a stop where it has nothing within reach), ``others`` (done at a stop, at rest,
  while the other arms finish), ``coordination`` (within its work -- from its first event to its
  last, at a stop where it has fruit -- holding still for a neighbour: neither moving nor
  dwelling), ``making_way`` (moving where it has no fruit: out of a neighbour's way -- an arm the
  screen locks does only that, and then rests where it went). At rest: home, or holding still
  away from home outside its work (done over its bin, or parked out of the way). On the move, an
  arm holding still within its work while the fruit it picks next is not yet in its reach waits
  for the carriage (``carriage``), not for a neighbour. The row plan
  :func:`coplan.solve` writes has ``metrics.per_arm[arm].idle_fraction`` the sum of these (the
  cell's definition, the time after its last place and out of its moves and dwells, counted its
  move home after its last place as idle and its moves out of a neighbour's way as work: up to
  4.6 points off them);
* **ratios** to the row's lower bounds (:mod:`coplan.allocate.row_bound`), and ``overlap_seconds``: how
  long the carriage moves while some arm works (places, goes home, comes out), which the
  stop-and-go bound's model excludes;
* **on the move** (``mode`` continuous): the speed profile, the carriage's mean speed (over its
  time in motion) and top speed, how many full plans the speed search tried, how many picks had
  the carriage at rest (where it starts, or at its rest at the row's end) for their whole dwell;
* **real time**: planning time / row time, when the first stop was known and when the row's first
  motion can start (then, or later if the first cell's arms start before its cell would be
  planned: the row waits for it) and, stop by stop, whether its cell was planned before the row
  needed it, counted from that first motion -- the least slack (s; negative: late) and the
  slowest stop's planning time. On the move the first motion is the end of planning: the
  carriage's speed and every arm's cycles come from the whole speed search.
"""

from __future__ import annotations

import numpy as np

from ..kinds import GantryMode
from ..plan import EventKind, Plan
from ..problem.model import Problem

__all__ = ["row_metrics", "fruit_bounds_count"]


def _home(problem: Problem, plan: Plan, tol: float = 1e-6) -> dict[str, np.ndarray]:
    return {a.name: np.all(np.abs(plan.q[a.name] - np.asarray(a.home, float)) <= tol, axis=1) for a in problem.arms}


def _not_in_reach_yet(reach, arm: int, events, x: np.ndarray, waiting: np.ndarray, dt: float) -> np.ndarray:
    """On the move: the samples of ``waiting`` (an arm holding still within its work) at which
    the fruit it picks next is not yet within its reach from where the carriage is -- it waits
    for the carriage to bring it, not for a neighbour."""
    out = np.zeros(waiting.size, dtype=bool)
    picks = sorted((e for e in events if e.kind == EventKind.PICK), key=lambda e: e.t_start)
    grid = reach.grid
    k0 = 0
    for e in picks:
        k1 = int(round(e.t_start / dt))
        idx = np.flatnonzero(waiting[k0:k1]) + k0
        cover = reach.cover.get(e.fruit)
        if idx.size and cover is not None:
            step = grid[1] - grid[0] if grid.size > 1 else 1.0
            at = np.clip(np.rint((x[idx] - grid[0]) / step).astype(int), 0, grid.size - 1)  # (the nearest grid position)
            out[idx] = ~cover[arm][at]
        k0 = int(round(e.t_end / dt)) + 1
    return out


def _check_inputs(problem, result, bounds) -> None:
    """TypeError / ValueError before any figure: a result that is not a row planner's, a problem
    that is not its (another row's fruit gave 'harvested 34 of 34' for a row of 30), bounds of
    another kind."""
    from ..allocate.row_bound import RowBounds
    from .plan import RowResult

    if not isinstance(result, RowResult):
        hint = (" (coplan.solve's result carries them already: result.plan.metrics['row'])"
                if hasattr(result, "plan") and hasattr(result, "files") else "")
        raise TypeError(f"result: expected a RowResult (coplan.row.plan_row / plan_moving){hint}, found "
                        f"{type(result).__name__}")
    if not isinstance(problem, Problem) or problem.gantry is None:
        raise ValueError(f"problem: expected the row the result was planned for (a Problem with a gantry), found "
                         f"{getattr(problem, 'name', type(problem).__name__)!r}" + ("" if isinstance(problem, Problem) else
                                                                                   f" ({type(problem).__name__})"))
    mine = result.reach.problem
    if problem is not mine and (problem.name != mine.name or [f.id for f in problem.fruits] != [f.id for f in mine.fruits]
                                or problem.digest != mine.digest):
        raise ValueError(f"problem: expected the row the result was planned for, {mine.name!r}, found {problem.name!r}"
                         + (" (the same name, other fruit or text)" if problem.name == mine.name else ""))
    if bounds is not None and not isinstance(bounds, RowBounds):
        raise TypeError(f"bounds: expected RowBounds (coplan.allocate.row_bound.row_bounds(problem)) or None, found "
                        f"{type(bounds).__name__}")
    if bounds is not None and bounds.problem is not None and bounds.problem != problem.name:  # (the ratios came out wrong)
        raise ValueError(f"bounds: expected the bounds of {problem.name!r} (row_bounds(problem)), found those of "
                         f"{bounds.problem!r}")


def row_metrics(problem: Problem, result, bounds=None) -> dict:
    """The figures a planned row is judged by, as ``plan.metrics['row']`` holds them: fruit per
    hour (the row's and each arm's), the share harvested and what was screened out (with reasons),
    row time and time per metre, stops and mean time per stop, the carriage's moving and picking
    shares, each arm's idle share by cause, the ratios to ``bounds`` (a
    :class:`~coplan.allocate.row_bound.RowBounds`; None: no ratios), planning time and its share of
    the row time, first motion and the least slack ahead of the carriage (the module docstring says
    how each is counted). ``result``: a :class:`coplan.row.plan.RowResult` (stop and go or on the move)."""
    _check_inputs(problem, result, bounds)
    plan: Plan = result.plan
    g = problem.gantry
    m = plan.metrics
    span = float(m.get("makespan") or 0.0)
    harvested = int(m.get("harvested") or 0)
    harvestable = len(result.reach.cover)
    per_h = 3600.0 / span if span > 0 else 0.0
    t = plan.time
    n = t.size
    dt = plan.dt
    upto = t <= span + 1e-9
    x = np.asarray(plan.gantry_x, float)
    moves = np.abs(np.diff(x)) > 1e-9  # (N - 1,) the carriage moves over [t_i, t_i+1]
    moving = np.zeros(n, dtype=bool)  # (N,) a sample at either end of such an interval
    moving[1:] |= moves
    moving[:-1] |= moves
    # the shares of the row time: over the sample intervals (a stretch of m samples lasts m - 1
    # intervals; counting samples made a row on the move 100.03 % moving)
    in_row = t[1:] <= span + 1e-9
    picking = np.zeros(max(n - 1, 0), dtype=bool)
    for e in plan.events:
        if e.kind == EventKind.PICK:
            picking[int(round(e.t_start / dt)):int(round(e.t_end / dt))] = True
    home = _home(problem, plan)
    stop_of = np.full(n, -1)
    settling = np.zeros(n, dtype=bool)  # (N,) the carriage at rest at a stop, its settle not over: no arm may pick
    for sp in result.stops if g.settle > 0 else ():
        settling[int(round(sp.arrive / dt)):int(round((sp.arrive + g.settle) / dt))] = True
    settling &= ~moving
    for i, sp in enumerate(result.stops):
        a0, a1 = int(round(sp.start / dt)), int(round(sp.start / dt)) + sp.plan.time.size
        stop_of[a0:min(a1, n)] = i
    idle = _idle_by_cause(problem, result, home, moving, settling, stop_of, upto, x)
    away = np.zeros(n, dtype=bool)  # some arm away from home
    for a in problem.arms:
        away |= ~home[a.name]
    counts = {a.name: sum(1 for e in plan.events if e.arm == a.name and e.kind == EventKind.PLACE) for a in problem.arms}
    stands = [sp.depart - sp.arrive for sp in result.stops]
    planning = float(result.timings.get("planning", 0.0))
    first = result.info.get("first_stop_seconds")
    motion = first  # the row's first motion: the carriage's first move, once the first stop is known ...
    if first is not None and result.stops:  # ... or later: the row waits for the first cell its arms need
        opening = min(sp.start for sp in result.stops)
        motion = max(first, max(sp.ready - sp.start for sp in result.stops if sp.start <= opening + 1e-9))
    slack = [motion + sp.start - sp.ready for sp in result.stops] if motion is not None else []
    out = {
        "fruit": len(problem.fruits),
        "harvestable": harvestable,
        "harvested": harvested,
        "share_harvested": harvested / harvestable if harvestable else None,
        "share_of_all_fruit": harvested / len(problem.fruits) if problem.fruits else None,
        "screened_out": dict(result.reach.reasons),
        "locked_arms": dict(result.reach.locked),
        "row_time": span,
        "row_length": g.length,
        "time_per_metre": span / g.length,
        "fruit_per_hour": harvested * per_h,
        "fruit_per_hour_per_arm": {k: v * per_h for k, v in counts.items()},
        "stops": len(result.stops),
        "stop_positions": [round(sp.stop.x, 4) for sp in result.stops],
        "mean_time_per_stop": float(np.mean(stands)) if stands else None,  # (None: no stop, on the move)
        "carriage_moving_share": float((moves & in_row).sum() * dt / span) if span > 0 else 0.0,
        "picking_share": float((picking & in_row).sum() * dt / span) if span > 0 else 0.0,
        # the carriage moving while an arm works (away from home at either end of the interval)
        "overlap_seconds": float((moves & (away[:-1] | away[1:]) & in_row).sum() * dt),
        "idle_share": idle,
        "planning_time": planning,
        "planning_over_row_time": planning / span if span > 0 else None,
        "first_stop_seconds": first,
        "first_motion_seconds": motion,
        "slowest_stop_seconds": max((sp.seconds for sp in result.stops), default=None),
        "least_slack_seconds": min(slack) if slack else None,
        "kept_ahead": min(slack) >= 0.0 if slack else None,  # (None: no stop to keep ahead of)
    }
    out["mode"] = result.info.get("mode", GantryMode.STOP_AND_GO.value)
    if out["mode"] == GantryMode.CONTINUOUS:  # no stops: the carriage's speeds instead, and no stop to keep ahead of
        out.update(_on_the_move(result, moving, x, planning))
    if bounds is not None:
        out["lower_bound"] = bounds.to_dict()
        # (no ratio for a row that harvested nothing: an interrupted row before its first stop)
        # (nor for a partial harvest: the bounds count every fruit an arm reaches from some carriage
        # position, so 78 of 93 fruit read "0.941" against them; the summary and a sweep said no ratio)
        whole = (out.get("harvested") or 0) >= fruit_bounds_count(out)
        out["ratio_any_plan_bound"] = span / bounds.any_plan if whole and bounds.any_plan > 0 and span > 0 else None
        # (only for a plan that picks at rest: on the move it bounds nothing -- plan.json gave 1.065 where
        # compare.json and the summary gave none)
        out["ratio_stop_and_go_bound"] = (span / bounds.stop_and_go if whole and bounds.stop_and_go > 0 and span > 0
                                          and out["mode"] != GantryMode.CONTINUOUS else None)
    else:  # (no bounds -- an interruption came first: no ratio, the keys there as for a partial row)
        out.update(lower_bound=None, ratio_any_plan_bound=None, ratio_stop_and_go_bound=None)
    return out


def _idle_by_cause(problem: Problem, result, home: dict, moving: np.ndarray, settling: np.ndarray, stop_of: np.ndarray,
                   upto: np.ndarray, x: np.ndarray) -> dict[str, dict[str, float]]:
    """Each arm's idle shares of the row time by cause (:func:`row_metrics`): ``home`` (arm ->
    (N,) at rest at home), ``moving`` / ``settling`` (N,) the carriage's, ``stop_of`` (N,) the
    stop each sample belongs to (-1: none), ``upto`` (N,) within the row time, ``x`` (N,) the
    carriage's position."""
    plan: Plan = result.plan
    n, dt = plan.time.size, plan.dt
    span = float(plan.metrics.get("makespan") or 0.0)
    idle: dict[str, dict[str, float]] = {}
    for ai, a in enumerate(problem.arms):
        q = plan.q[a.name]
        still = np.r_[np.all(np.abs(np.diff(q, axis=0)) <= 1e-9, axis=1), True]
        dwelling = np.zeros(n, dtype=bool)
        for e in plan.events:
            if e.arm == a.name:
                dwelling[int(round(e.t_start / dt)):int(round(e.t_end / dt)) + 1] = True
        has = {i for i, sp in enumerate(result.stops) if sp.plan.allocation.get(a.name)}
        if result.stops:
            at_stop_without = np.isin(stop_of, [i for i in range(len(result.stops)) if i not in has])
        else:  # on the move: an arm without a fruit in the whole row
            at_stop_without = np.full(n, not plan.allocation.get(a.name))
        # within its work: from its first event to its last (an arm with none: nowhere); holding
        # still away from home outside it -- done, or parked where it has nothing to do (an arm the
        # screen locks) -- is resting, as at home, not waiting for a neighbour
        within = np.zeros(n, dtype=bool)
        mine = [e for e in plan.events if e.arm == a.name]
        if mine:
            within[int(round(min(e.t_start for e in mine) / dt)):int(round(max(e.t_end for e in mine) / dt)) + 1] = True
        held = ~home[a.name] & still & ~dwelling
        h = (home[a.name] | (held & (~within | at_stop_without))) & upto
        waiting = held & within & ~at_stop_without & upto
        early = _not_in_reach_yet(result.reach, ai, mine, x, waiting, dt) if not result.stops else np.zeros(n, dtype=bool)
        causes = {
            "carriage": (h & (moving | settling)) | early,
            "no_fruit": h & ~moving & ~settling & at_stop_without,
            "others": h & ~moving & ~settling & ~at_stop_without,
            "coordination": waiting & ~early,
            "making_way": ~home[a.name] & ~still & at_stop_without & upto,
        }
        idle[a.name] = {k: float(v.sum() / upto.sum()) if span > 0 else 0.0 for k, v in causes.items()}  # (shares of the samples)
    return idle


def _on_the_move(result, moving: np.ndarray, x: np.ndarray, planning: float) -> dict:
    """The figures of a row on the move that replace its stops' (:func:`row_metrics`): picks with
    the carriage at rest, the speed profile and its speeds, the plans the speed search tried."""
    plan: Plan = result.plan
    t, dt, n = plan.time, plan.dt, plan.time.size
    # picks whose whole dwell has the carriage at rest (where it starts, held, or at its rest at the end)
    at_rest = sum(1 for e in plan.events if e.kind == EventKind.PICK
                  and not moving[int(round(e.t_start / dt)):int(round(e.t_end / dt)) + 1].any())
    # the top speed the carriage reaches (the profile's may be more than a short rail lets it reach:
    # "top 0.181 m/s" on a 1 mm rail)
    reached = float(np.max(np.abs(np.diff(x) / np.diff(t)))) if n > 1 else 0.0
    top = result.info.get("top_speed")
    return {"picks_at_rest": at_rest, "profile": result.info.get("profile"), "mean_speed": result.info.get("mean_speed"),
            "top_speed": min(top, reached) if top is not None else reached,
            "plans_tried": len(result.info.get("speed_curve") or []),
            "kept_ahead": None, "least_slack_seconds": None, "first_motion_seconds": planning}


#: a row's first motion later than this share of its row time is said beside its figures (fruit
#: per hour leaves that wait out): :func:`late_start`
LATE_START_SHARE = 0.05


def late_start(first_motion: float | None, row_time: float | None) -> bool:
    """Whether a row's first motion (s after its planning began) comes later than
    :data:`LATE_START_SHARE` of its row time: a wait its summary and comparison say."""
    return first_motion is not None and bool(row_time) and row_time > 0 and first_motion > LATE_START_SHARE * row_time


def fruit_bounds_count(row: dict) -> int:
    """How many fruit the row's lower bounds count, from a plan's ``metrics.row`` (``row``): every
    fruit an arm reaches from some carriage position, those the screen's candidate stops miss
    included -- at least the harvestable ones. A plan that harvested fewer has no ratio to them."""
    return max(row.get("harvestable") or 0, (row.get("lower_bound") or {}).get("fruit") or 0)
