"""coplan: coordinated, collision-free, jerk-limited motion planning for several planar 2R arms.

Pipeline: ``problem -> allocate -> plan -> verify -> report``. The quickest way in::

    import coplan
    result = coplan.solve("problems/greenhouse_row.yaml")   # optimal planner, verified
    result.plan.metrics["makespan"], result.status
"""

from .allocation import Allocation, AllocationMethod, SequenceRule, allocate
from .errors import CoplanError, InputError, PlanFileError, ProblemError
from .plan import EventKind, Plan, PlannerKind, PlanStatus, load_plan
from .pipeline import ExitCode, SolveResult, solve
from .problem import Arm, Fruit, Problem, Task, default_problem_path, load_problem, parse_problem, shipped_problems

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
]
