"""``coplan.optimal``: the documented path of the optimal planner's options (README:
``from coplan.optimal import OptimalOptions``).

Only a re-export: the code is in :mod:`coplan.planners.optimal` (options in
:mod:`coplan.planners.optimal.options`, the planner in :mod:`coplan.planners.optimal.planner`).
Nothing inside coplan imports this module.
"""

from .planners.optimal import OptimalOptions, OptimalResult, OptionsError, load_options, parse_options, plan_optimal

__all__ = ["OptimalOptions", "OptimalResult", "OptionsError", "load_options", "parse_options", "plan_optimal"]
