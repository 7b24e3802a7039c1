"""``coplan.plausible``: the documented path of the plausible range of every problem field
(README: ``coplan.plausible.BOUNDS``).

Only a re-export: the code is in :mod:`coplan.problem.plausible`. Nothing inside coplan
imports this module.
"""

from .problem.plausible import (
    BOUNDS,
    BYTES_PER_CARRIAGE_SAMPLE,
    BYTES_PER_SAMPLE,
    MAX_PLAN_ANGLE,
    MAX_PLAN_COORD,
    MAX_PLAN_SECONDS,
    SAMPLE_RATE,
    Bound,
    DurationBound,
    duration_issues,
    field_issues,
    max_plan_seconds,
    plan_seconds_limit,
    move_times,
    plan_duration_bound,
)

__all__ = ["Bound", "BOUNDS", "MAX_PLAN_ANGLE", "MAX_PLAN_COORD", "MAX_PLAN_SECONDS", "BYTES_PER_SAMPLE", "BYTES_PER_CARRIAGE_SAMPLE", "SAMPLE_RATE", "max_plan_seconds", "plan_seconds_limit", "DurationBound",
           "move_times", "field_issues", "plan_duration_bound", "duration_issues"]
