"""Every arm starts at its home pose and ends there (the problem's ``home``: "joint angles at
start and end").

* An arm that does not *start* at home is a violation (``home``): the plan begins with a jump
  that nothing planned or checked -- the controller would have to bring the arm to the plan's
  first pose itself.
* An arm that does not *end* at home is a warning (``not_home``), as a fruit left unharvested
  is: the plan stays within the motion verified, but the arm is left out, in its neighbours'
  way for whatever runs next, which starts from home. The warning says so, with the pose. Where
  the plan declares the arm stopped by a fault (a live run's ``solver.live.faults.arm_stop``:
  ``{"arm": name, "t": s}``, an obstacle where it rests), the warning names the fault.

Used by :func:`coplan.verify.verify`.
"""

from __future__ import annotations

import math

import numpy as np

from ..plan import Plan
from ..problem.model import Problem
from .clearance import ArmMotion
from .verdict import Finding, Verification, Violation, ViolationKind, WarningKind

__all__ = ["declared_halts", "check_home"]


def declared_halts(plan: Plan) -> dict[str, float]:
    """``{arm: t}`` of the arms the plan declares stopped by a fault (module docstring); a
    declaration that is not an arm name and a finite time is no declaration."""
    solver = plan.solver if isinstance(plan.solver, dict) else {}
    live = solver.get("live") if isinstance(solver.get("live"), dict) else {}
    faults = live.get("faults") if isinstance(live.get("faults"), dict) else {}
    stop = faults.get("arm_stop")
    if (isinstance(stop, dict) and isinstance(stop.get("arm"), str) and isinstance(stop.get("t"), (int, float))
            and not isinstance(stop.get("t"), bool) and math.isfinite(stop["t"])):
        return {stop["arm"]: float(stop["t"])}
    return {}


def _pose(q) -> str:
    return "[" + ", ".join(f"{float(v):.4f}" for v in q) + "]"


def check_home(problem: Problem, plan: Plan, motions: list[ArmMotion], time: np.ndarray, tolerance: float,
               ver: Verification) -> None:
    """A HOME violation for each arm whose first pose misses its home by more than ``tolerance``
    rad on some joint; a NOT_HOME warning for each whose last pose does (module docstring)."""
    halts = declared_halts(plan)
    end = float(time[-1]) if time.size else 0.0
    for arm, m in zip(problem.arms, motions):
        home = np.asarray(arm.home, float)
        off = float(np.max(np.abs(m.q[0] - home)))
        if off > tolerance:
            ver.violations.append(Violation(
                ViolationKind.HOME, (arm.name,), 0.0, off, off, tolerance, 0.0, 0.0,
                message=f"starts at {_pose(m.q[0])} rad, {off:.4f} rad from its home {_pose(home)}"))
        off = float(np.max(np.abs(m.q[-1] - home)))
        if off > tolerance:
            why = (f"the plan declares it stopped by a fault at t = {halts[arm.name]:.2f} s (solver.live.faults.arm_stop)"
                   if arm.name in halts else "left out, in its neighbours' way for whatever starts from home next")
            ver.warnings.append(Finding(
                WarningKind.NOT_HOME, (arm.name,), end, off, tolerance, end, end,
                message=f"ends at {_pose(m.q[-1])} rad, {off:.4f} rad from its home {_pose(home)}: {why}"))
