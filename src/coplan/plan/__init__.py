"""Plans: the joint trajectories of every arm on one uniform time grid, with events.

A :class:`Plan` is what every planner returns and what ``plan.json`` holds
(format ``coplan.plan/1``). Between two samples the joints move linearly (the replay
contract: that is what :meth:`Plan.sample` does and what the verifier certifies).

The plan itself and what is computed from it are in :mod:`coplan.plan.model`; reading a plan
file (checked, every problem named by its key path) in :mod:`coplan.plan.files`.
"""

from .files import exact_samples, load_plan, plan_from_dict, time_grid_issues
from .model import (DEFAULT_RATE, MAX_PLAN_ANGLE, MAX_PLAN_BYTES, MAX_PLAN_COORD, PLAN_FORMAT, Event, EventKind, Piece,
                    Plan, PlannerKind, PlanStatus, checked_status, compute_metrics, fit_issue, finalize_plan, finer_grid, grid_step, jerk_figures,
                    jsonable, motion_digest, on_lattice, sample_pieces)

__all__ = [
    "PLAN_FORMAT",
    "DEFAULT_RATE",
    "finer_grid",
    "on_lattice",
    "jsonable",
    "exact_samples",
    "PlannerKind",
    "PlanStatus",
    "EventKind",
    "Event",
    "Piece",
    "Plan",
    "sample_pieces",
    "compute_metrics",
    "jerk_figures",
    "checked_status",
    "fit_issue",
    "motion_digest",
    "finalize_plan",
    "load_plan",
    "plan_from_dict",
    "time_grid_issues",
    "grid_step",
    "MAX_PLAN_BYTES",
    "MAX_PLAN_ANGLE",
    "MAX_PLAN_COORD",
]
