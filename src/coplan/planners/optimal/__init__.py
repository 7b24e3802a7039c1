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

IPOPT's linear algebra runs on the OpenBLAS that CasADi bundles, which picks its kernels for the
CPU at load time; unless the caller chose otherwise, it is pinned here (before CasADi loads) to
the generic x86-64 kernel on one thread, so that IPOPT takes the same steps on any x86-64 machine
and the widened plan does not depend on the CPU (the speed is the same on these small programs).
"""

import os as _os
import platform as _platform

if _platform.machine() in ("x86_64", "AMD64"):
    _os.environ.setdefault("OPENBLAS_CORETYPE", "Prescott")
_os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from .options import OptimalOptions, OptionsError, load_options, parse_options
from .planner import OptimalResult, plan_optimal

__all__ = ["OptimalOptions", "OptimalResult", "OptionsError", "load_options", "parse_options", "plan_optimal"]
