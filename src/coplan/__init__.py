"""coplan: coordinated, collision-free, jerk-limited motion planning for several planar 2R arms.

Pipeline: ``problem -> allocate -> plan -> verify -> report``. The quickest way in::

    import coplan
    result = coplan.solve("problems/greenhouse_row.yaml")   # optimal planner, verified
    result.plan.metrics["makespan"], result.status
"""

import os as _os
import platform as _platform

# IPOPT's linear algebra (the optimal planner's programs) runs on the OpenBLAS CasADi bundles,
# which picks its kernels at load time -- for the CPU, or as OPENBLAS_CORETYPE says. Another
# kernel rounds otherwise, IPOPT takes other steps, and the widened plan differs, or is not
# found (crossing_paths under OPENBLAS_CORETYPE=Haswell, which a machine's environment set: the
# program did not converge). So the generic x86-64 kernel on one thread is pinned here, before
# anything of coplan loads CasADi, whatever the environment says: the same plan on any machine
# (the speed is the same on these small programs). COPLAN_OPENBLAS_CORETYPE=native keeps the
# environment's choice (plans may then depend on the CPU).
if _os.environ.get("COPLAN_OPENBLAS_CORETYPE", "") != "native":
    if _platform.machine() in ("x86_64", "AMD64"):
        _os.environ["OPENBLAS_CORETYPE"] = "Prescott"
    _os.environ["OPENBLAS_NUM_THREADS"] = "1"

from .kinds import AllocationMethod, EventKind, ExitCode, PlannerKind, PlanStatus, SequenceRule  # noqa: E402

# the rest is imported on first use (PEP 562), so `import coplan` and `coplan --help` stay quick
_LAZY = {
    "Allocation": "allocate.allocation",
    "CoplanError": "errors", "InputError": "errors", "PlanFileError": "errors", "ProblemError": "errors",
    "Plan": "plan", "load_plan": "plan",
    "SolveResult": "pipeline", "solve": "pipeline",
    "Arm": "problem.model", "Fruit": "problem.model", "Problem": "problem.model", "Task": "problem.model", "default_problem_path": "problem.load",
    "load_problem": "problem.load", "parse_problem": "problem.load", "shipped_problems": "problem.load",
    "view": "viz.viewer",
}


# documented submodules, reachable as attributes before anything imported them (``coplan.generate.row_problem``)
# (``allocate`` is a package callable as its entry function: coplan.allocate(problem, "makespan"))
_SUBMODULES = ("allocate", "generate", "optimal", "plausible", "report", "row", "sweep", "verify")


def __getattr__(name: str):
    if name in _SUBMODULES:
        import importlib

        return importlib.import_module(f".{name}", __name__)
    if name in _LAZY:
        import importlib

        value = getattr(importlib.import_module(f".{_LAZY[name]}", __name__), name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():  # (tab completion: the lazy names too)
    return sorted(set(globals()) | set(_LAZY) | set(_SUBMODULES))


__version__ = "0.1.0"

__all__ = [
    "Allocation",
    "AllocationMethod",
    "Arm",
    "CoplanError",
    "EventKind",
    "ExitCode",
    "Fruit",
    "InputError",
    "Plan",
    "PlanFileError",
    "PlanStatus",
    "PlannerKind",
    "Problem",
    "ProblemError",
    "SequenceRule",
    "SolveResult",
    "Task",
    "allocate",
    "default_problem_path",
    "load_plan",
    "load_problem",
    "parse_problem",
    "shipped_problems",
    "solve",
    "view",
]
