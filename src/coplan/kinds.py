"""The enumerations every stage and the command line share (no heavy imports: ``coplan --help``
and ``coplan check`` load only this, the CLI framework and what they use).

Each is re-exported by the module that owns the concept (``coplan.allocation.AllocationMethod``,
``coplan.plan.PlannerKind``, ``coplan.pipeline.ExitCode``, ``coplan.verdict.FclMode``, ...).
"""

from __future__ import annotations

from enum import Enum, IntEnum

__all__ = ["AllocationMethod", "SequenceRule", "PlannerKind", "PlanStatus", "EventKind", "ExitCode", "FclMode"]


class AllocationMethod(str, Enum):
    HEURISTIC = "heuristic"
    MAKESPAN = "makespan"


class SequenceRule(str, Enum):
    FILE = "file"
    SWEEP = "sweep"
    SHORTEST = "shortest"


class PlannerKind(str, Enum):
    HEURISTIC = "heuristic"  # the course's nearest-arm allocation + cubic splines (the baseline)
    COORDINATED = "coordinated"  # min-makespan allocation, S-curve moves, conflict-free coordination
    OPTIMAL = "optimal"  # anytime: the coordinated plan improved by search and joint optimisation


class PlanStatus(str, Enum):
    """Overall verdict of a plan. Only ``SUCCESS`` means verified and complete."""

    SUCCESS = "success"  # every reachable fruit harvested, verification passed
    PARTIAL = "partial"  # verified safe, but not every reachable fruit harvested
    UNSAFE = "unsafe"  # verification found violations (collisions, limits, missed picks)
    UNVERIFIED = "unverified"  # not yet verified
    INFEASIBLE = "infeasible"  # nothing could be planned
    FAILED = "failed"  # the solver failed; the plan is the best it had
    INTERRUPTED = "interrupted"  # stopped by the user; the plan is the best it had


class EventKind(str, Enum):
    PICK = "pick"
    PLACE = "place"


class ExitCode(IntEnum):
    """Process exit codes of the ``coplan`` command (documented in the README)."""

    OK = 0  # verified success
    INTERNAL = 1  # a bug: unexpected internal error
    USAGE = 2  # bad command-line usage
    BAD_INPUT = 3  # a problem or plan file is invalid
    INFEASIBLE = 4  # nothing could be planned (no reachable fruit, solver proved infeasible)
    PARTIAL = 5  # verified safe but not every reachable fruit harvested
    UNSAFE = 6  # verification failed (collisions, limits, missed picks)
    SOLVER_FAILED = 7  # solver hit a limit or a numerical error; best iterate kept
    IO_ERROR = 8  # a file could not be written or read (disk full, permissions); the path is named
    INTERRUPTED = 130  # Ctrl-C; what there was is saved
    TERMINATED = 143  # SIGTERM (e.g. a job scheduler's stop): handled like Ctrl-C, what there was is saved


class FclMode(str, Enum):
    OFF = "off"  # no cross-check (inner loops only; never for a final verdict)
    CRITICAL = "critical"  # closest instants, interval worst points, seeded random instants
    FULL = "full"  # every sample the verifier evaluated, every pair (slow: ~0.1 ms per link pair)
