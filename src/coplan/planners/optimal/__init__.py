"""The anytime optimal planner: a verified incumbent, improved by search, retiming and a joint NLP.

- :mod:`.options`: :class:`OptimalOptions` and its YAML file (``--options FILE``)
- :mod:`.planner`: :func:`plan_optimal`: coordinated -> retime -> search -> refine (-> polish), the incumbent rule
- :mod:`.search`: large-neighbourhood search with the coordinator as evaluator
- :mod:`.retime`: CP-SAT retiming (a plan's moves kept, every start chosen together)
- :mod:`.refine`: the search's neighbourhood again, each neighbour ranked by its retimed makespan
- :mod:`.nlp`, :mod:`.nlp_data`, :mod:`.nlp_solve`: the CasADi program over all arms (its knot
  grid and data), solved by IPOPT
- :mod:`.windows`: refinement rounds and receding windows around the NLP
- :mod:`.widen`: the widening stage (the same makespan, more room between neighbours, less jerk)

IPOPT's linear algebra runs on the OpenBLAS that CasADi bundles, whose kernel is pinned when
``coplan`` is imported (:mod:`coplan`'s package docstring says why and how).
"""

from .options import OptimalOptions, OptionsError, load_options, parse_options
from .planner import OptimalResult, plan_optimal

__all__ = ["OptimalOptions", "OptimalResult", "OptionsError", "load_options", "parse_options", "plan_optimal"]
