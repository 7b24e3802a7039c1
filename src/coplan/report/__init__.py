"""Stage 5, reports and exports of solved plans.

- :mod:`.comparison`: ``coplan compare``: planners side by side on one problem or a folder
- :mod:`.export`: a plan resampled for a joint controller (CSV, ROS 2 JointTrajectory)
"""

from .comparison import Comparison, compare
from .export import export_plan, trajectory

__all__ = ["Comparison", "compare", "export_plan", "trajectory"]
