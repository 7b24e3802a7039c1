"""Stage 3, planning: an allocation becomes joint trajectories (a :class:`coplan.plan.Plan`).

- :mod:`.heuristic`: the course's baseline (cubic joint splines, time-scaled)
- :mod:`.coordinated`: the fast planner: time-optimal S-curve schedules coordinated leg by
  leg, conflict-free by construction (``plan_coordinated``)
- :mod:`.optimal`: the anytime planner: the coordinated plan improved by search, CP-SAT
  retiming and refinement, and (``polish``, or as the last resort) a joint CasADi/IPOPT
  program (``plan_optimal``; import it from :mod:`coplan.planners.optimal`, which loads CasADi)

Every planner's plan is verified by :mod:`coplan.verify` before it is called a success.
"""

from .coordinated import CoordinatedOptions, plan_coordinated
from .heuristic import plan_heuristic

__all__ = ["CoordinatedOptions", "plan_coordinated", "plan_heuristic"]
