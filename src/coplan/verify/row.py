"""The verifier's row frame: what a plan on a mobile gantry must also satisfy.

A row plan (``plan.gantry_x``: the carriage's x on the plan's own time grid) is checked in
the row's (world) frame: the bases are where the carriage puts them, ``base + (x(t), 0)``.

* **carriage** -- at rest at ``gantry.start`` at t = 0 and at rest at the end of the plan;
  always within ``[start, end]``; velocity, acceleration and jerk within the gantry's limits
  (forward, second and third differences of the samples, with the joints' tolerances: see
  :mod:`coplan.verify.verifier`); no pick's dwell within ``gantry.settle`` s of the carriage
  coming to rest after a move (two samples' tolerance: a move's last micrometres may round to
  rest a sample early).
* **clearance** -- as for a cell, in the row frame (:class:`~coplan.verify.clearance.ArmMotion`
  with the carriage's shift); between samples the certificate adds the carriages' relative
  speed to the arms' own point speeds: zero for arms on one carriage, which move together.
* **picks** -- the tip within tolerance of the fruit *in row coordinates* and still there for the
  dwell: its speed in the row frame, the carriage's included, below ``still_speed``, bounded on
  the linear replay (joints and carriage linear between samples) by the mean row-frame tip
  velocity over each interval plus the most the arm's own tip velocity can turn within it. A
  pick may happen with the carriage at rest (stop and go) or moving, the joints carrying the tip
  along with the fruit (on the move).
* **places** -- over the arm's bin, which rides with the carriage: checked in the carriage's frame.
* **reach** -- which fruit some arm could pick from some carriage position on the rail (joint
  limits, the annulus less ``task.reach_margin``), on a 1 cm grid of positions: the fruit a
  complete plan harvests. Computed here, independently of the planners' screen.

Nothing here comes from :mod:`coplan.row` or the planners.
"""

from __future__ import annotations

import numpy as np

from ..errors import Issue, PlanFileError
from ..plan import EventKind, Plan, grid_step
from ..problem.model import Problem
from .clearance import runs
from .verdict import Verification, Violation, ViolationKind, blurred_by_rounding, rounding_allowance, rounding_words

__all__ = ["check_row_inputs", "check_carriage", "row_reachable_ids", "plan_source"]


def plan_source(plan: Plan) -> str:
    """How a plan's problems name it: by the problem it says it is of (a plan.csv names none)."""
    from ..plancsv import EXPORT_PLANNER

    if plan.problem:
        return f"plan for problem {plan.problem!r}"
    return ("coplan export table" if plan.planner_name == EXPORT_PLANNER else "plan.csv replay") + " (it names no problem)"


def check_row_inputs(problem: Problem, plan: Plan) -> None:
    """A row problem needs a row plan (and a cell problem a cell plan)."""
    n = np.asarray(plan.time).size
    if problem.gantry is not None and plan.gantry_x is None:
        raise PlanFileError([Issue("gantry", "expected a row plan (gantry.x: the carriage's position at every time; in a "
                                             "plan.csv, the column gantry_x after t), found a plan without a carriage; "
                                             "the problem has a gantry")], plan_source(plan))
    if problem.gantry is None and plan.gantry_x is not None:
        raise PlanFileError([Issue("gantry", "expected a plan of a stationary cell, found a row plan (gantry.x); the problem "
                                             "has no gantry")], plan_source(plan))
    if plan.gantry_x is not None and (np.shape(plan.gantry_x) != (n,) or not np.all(np.isfinite(plan.gantry_x))):
        raise PlanFileError([Issue("gantry.x", f"expected {n} finite positions, found shape {np.shape(plan.gantry_x)}")],
                            plan_source(plan))


def check_carriage(problem: Problem, plan: Plan, opts, ver: Verification) -> None:
    """The carriage's start, travel range, rest at the end and limits (module docstring)."""
    g = problem.gantry
    x = np.asarray(plan.gantry_x, float)
    t = np.asarray(plan.time, float)
    tol = opts.carriage_tolerance
    if abs(x[0] - g.start) > tol:
        ver.violations.append(Violation(ViolationKind.CARRIAGE, ("carriage",), 0.0, abs(x[0] - g.start), float(x[0]),
                                        g.start, message=f"the carriage starts at x = {x[0]:.4f} m, not at gantry.start"))
    out = np.maximum(g.start - x, x - g.end)
    for a, b in runs(out > tol):
        w = a + int(np.argmax(out[a:b + 1]))
        ver.violations.append(Violation(ViolationKind.CARRIAGE, ("carriage",), float(t[w]), float(out[w]), float(x[w]),
                                        g.end if x[w] > g.end else g.start, float(t[a]), float(t[b]),
                                        message=f"the carriage at x = {x[w]:.4f} m, off the rail [{g.start:g}, {g.end:g}]"))
    if t.size < 2:
        return
    dt = grid_step(t)
    _check_settle(problem, plan, x, t, dt, ver)
    pad = np.concatenate([np.repeat(x[:1], 3), x, np.repeat(x[-1:], 3)])  # at rest before and after the plan
    tp = (np.arange(pad.size) - 3) * dt
    res = 1e-7  # plan.json rounds positions to 1e-7 m
    for k, (what, limit) in enumerate((("velocity", g.max_velocity), ("acceleration", g.max_acceleration),
                                       ("jerk", g.max_jerk)), start=1):
        diff = np.abs(np.diff(pad, n=k)) / dt ** k
        centre = np.clip(0.5 * (tp[:-k] + tp[k:]), 0.0, t[-1])
        allow = rounding_allowance(x, res, dt, k)
        bound = limit * (1.0 + opts.rel_tolerance) + allow
        ver.peaks.setdefault("carriage", {})[what] = float(diff.max() / limit) if diff.size else 0.0
        blurred = blurred_by_rounding(diff, limit, opts.rel_tolerance, allow, dt)
        if blurred is not None:  # (finer than 100 Hz, on the 1e-7 lattice: over the limit by no more than rounding)
            w = int(np.argmax(np.where(blurred, diff, -np.inf)))
            ver.violations.append(Violation(ViolationKind.CARRIAGE, ("carriage",), float(centre[w]), float(diff[w] - limit),
                                            float(diff[w]), float(limit), message=(
                                                f"carriage {what} not checkable: {diff[w] / limit:.2f} x its limit, but "
                                                + rounding_words("positions", "m", res, dt, allow, limit, what))))
        for a, b in runs(diff > bound):
            w = a + int(np.argmax(diff[a:b + 1]))
            ver.violations.append(Violation(ViolationKind.CARRIAGE, ("carriage",), float(centre[w]), float(diff[w] - limit),
                                            float(diff[w]), float(limit), float(centre[a]), float(centre[b]),
                                            message=f"carriage {what} at {diff[w] / limit:.2f} x its limit"))


def _check_settle(problem: Problem, plan: Plan, x: np.ndarray, t: np.ndarray, dt: float, ver: Verification) -> None:
    """No pick's dwell within ``gantry.settle`` s of the carriage coming to rest after a move."""
    settle = problem.gantry.settle
    if settle <= 0:
        return
    moved = np.abs(np.diff(x)) > 1e-9  # between samples i and i + 1
    rest_at = t[1:-1][moved[:-1] & ~moved[1:]] if moved.size > 1 else np.zeros(0)  # the first sample at rest after a move
    for e in plan.events:
        if e.kind != EventKind.PICK or rest_at.size == 0:
            continue
        k = int(np.searchsorted(rest_at, e.t_end + 1e-9, side="right")) - 1  # the last rest that began before the dwell ended
        if k < 0:
            continue
        since = e.t_start - float(rest_at[k])
        if since < settle - 2.0 * dt - 1e-9:
            ver.violations.append(Violation(ViolationKind.CARRIAGE, (e.arm, "carriage"), float(e.t_start), settle - since,
                                            since, settle, message=(
                                                f"{e.arm} picks {e.fruit} at t = {e.t_start:.2f} s, {max(since, 0.0):.2f} s after the "
                                                f"carriage came to rest (at {float(rest_at[k]):.2f} s); gantry.settle is {settle:g} s")))


def row_reachable_ids(problem: Problem) -> list[str]:
    """Fruit some arm can pick from some carriage position on the rail (module docstring): a row's
    :meth:`Problem.reachable_ids` (:func:`coplan.problem.gantry.rail_reach`, on a 1 cm grid)."""
    return problem.reachable_ids()

