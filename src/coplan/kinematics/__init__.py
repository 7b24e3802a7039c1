"""The arms' geometry and motion laws, pure NumPy (no planner, no problem file).

- :mod:`.arm`: 2R forward/inverse kinematics (and one point's, in plain floats), Jacobian
  (and, for one pose in plain floats, its entries and their rate), manipulability (``fk`` and ``jacobian`` also on CasADi
  symbols), the box an arm sweeps over a box of joint angles (``sweep_box``)
- :mod:`.geometry`: exact 2-D segment and capsule distances, the planners' one implementation
  (the verifier keeps its own, :mod:`coplan.verify.clearance`)
- :mod:`.timing`: per-joint time-optimal jerk-limited S-curves (:class:`SCurve`), the course's cubic
"""

from .arm import (
    dls_velocity,
    fk,
    fk_points,
    ik,
    ik_one,
    in_workspace,
    jacobian,
    jacobian_entries,
    jacobian_rate_entries,
    manipulability,
    max_point_speed,
    project_to_workspace,
    singularity_proximity,
    sweep_box,
    wrap_angle,
)
from .geometry import capsule_distance, segment_distance, segment_distance_xy
from .timing import SCurve, cubic_eval, cubic_min_time, move_lower_bound, scurve_time

__all__ = [
    "fk", "fk_points", "ik", "ik_one", "jacobian", "jacobian_entries", "jacobian_rate_entries", "manipulability",
    "singularity_proximity", "in_workspace", "project_to_workspace", "dls_velocity", "max_point_speed", "sweep_box",
    "wrap_angle",
    "segment_distance", "segment_distance_xy", "capsule_distance",
    "SCurve", "cubic_eval", "cubic_min_time", "move_lower_bound", "scurve_time",
]
