"""The enumerations every stage and the command line share (no heavy imports: ``coplan --help``
and ``coplan check`` load only this, the CLI framework and what they use).

Each is re-exported by the module that owns the concept (``coplan.allocate.allocation.AllocationMethod``,
``coplan.plan.PlannerKind``, ``coplan.pipeline.ExitCode``, ``coplan.verify.verdict.FclMode``, ...).
"""

from __future__ import annotations

import re
from enum import Enum, IntEnum

__all__ = ["Choice", "AllocationMethod", "SequenceRule", "PlannerKind", "PlanStatus", "EventKind", "ExitCode", "FclMode",
           "SweepBase", "SweepMode", "RowStatus", "TrackState", "ReplanCause", "ExportFormat", "SchemaKind",
           "StopRule", "GantryMode", "AssignRule", "SpeedProfile", "LIVE_PLANNER"]

#: the planner name a live run's executed plan carries (a live cell's and a live row's)
LIVE_PLANNER = "live"


class Choice(str, Enum):
    """A named choice given by a user (an option, a YAML value, an argument): a value that is
    none of the choices is refused with all of them listed, e.g. ``PlannerKind("fastest")``:
    ``planner kind: expected one of 'heuristic', 'coordinated', 'optimal'; found 'fastest'``."""

    @classmethod
    def _missing_(cls, value):
        words = re.sub(r"(?<!^)(?=[A-Z])", " ", cls.__name__).lower()
        raise ValueError(f"{words}: expected one of {', '.join(repr(m.value) for m in cls)}; found {value!r}")


class AllocationMethod(Choice):
    HEURISTIC = "heuristic"
    MAKESPAN = "makespan"


class SequenceRule(Choice):
    FILE = "file"
    SWEEP = "sweep"
    SHORTEST = "shortest"


class PlannerKind(Choice):
    HEURISTIC = "heuristic"  # the course's nearest-arm allocation + cubic splines (the baseline)
    COORDINATED = "coordinated"  # min-makespan allocation, S-curve moves, conflict-free coordination
    OPTIMAL = "optimal"  # anytime: the coordinated plan improved by search and joint optimisation


class StopRule(Choice):
    """Where a row's carriage stops (:mod:`coplan.row.stops`)."""

    OPTIMISED = "optimised"  # stops and their fruit chosen with the arms (receding segments, strides priced by the arms' cycles)
    FIXED = "fixed"  # a stop every carriage span (a camera-frame rule)
    FEWEST = "fewest"  # the fewest stops that serve every fruit (greedy stabbing)


class GantryMode(Choice):
    """How a row's carriage moves (:mod:`coplan.row`)."""

    STOP_AND_GO = "stop-and-go"  # the carriage stops; each stop is a stationary cell (the stop rule chooses where)
    CONTINUOUS = "continuous"  # the carriage keeps moving; arms pick within time windows (row.continuous)
    AUTO = "auto"  # both planned and verified; the one with more fruit, then more fruit per hour, is kept


class LiveGantryMode(Choice):
    """How a live row's carriage moves (``coplan run ROW --gantry``): one mode, decided as fruit
    come into view (no ``auto``: a live planner cannot plan both and keep the better)."""

    CONTINUOUS = "continuous"
    STOP_AND_GO = "stop-and-go"


class AssignRule(Choice):
    """How continuous mode assigns and orders fruit to arms within their windows."""

    GREEDY = "greedy"  # earliest deadline first (interval scheduling's greedy; the baseline)
    CPSAT = "cpsat"  # OR-Tools CP-SAT over optional intervals, seeded by the greedy


class SpeedProfile(Choice):
    """How continuous mode's carriage speed varies along the row (:mod:`coplan.row.cruise`)."""

    CONSTANT = "constant"  # one cruising speed for the whole row
    DENSITY = "density"  # a speed per metre of rail, slower where the fruit need more of the arms' time
    AUTO = "auto"  # both searched, each verified: the better plan kept (row.moving; twice the planning)


class PlanStatus(Choice):
    """Overall verdict of a plan. Only ``SUCCESS`` means verified and complete."""

    SUCCESS = "success"  # every reachable fruit harvested, verification passed
    PARTIAL = "partial"  # verified safe, but not every reachable fruit harvested
    UNSAFE = "unsafe"  # verification found violations (collisions, limits, missed picks)
    UNVERIFIED = "unverified"  # not yet verified
    INFEASIBLE = "infeasible"  # nothing could be planned
    FAILED = "failed"  # the solver failed; the plan is the best it had
    INTERRUPTED = "interrupted"  # stopped by the user; the plan is the best it had


class EventKind(Choice):
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
    INCOMPLETE = 9  # a sweep's problems without a result (workers died on every attempt, scheduler gone): run again
    INTERRUPTED = 130  # Ctrl-C; what there was is saved
    TERMINATED = 143  # SIGTERM (e.g. a job scheduler's stop): handled like Ctrl-C, what there was is saved


class FclMode(Choice):
    OFF = "off"  # no cross-check (inner loops only; never for a final verdict)
    CRITICAL = "critical"  # closest instants, interval worst points, seeded random instants
    FULL = "full"  # every sample the verifier evaluated, every pair (slow: ~0.1 ms per link pair)


class SweepBase(Choice):
    """What a design sweep's problems are made from (``coplan.sweep.spec``)."""

    ROW = "row"  # coplan.generate.row_problem: a straight row of identical arms
    OVERLAP = "overlap"  # coplan.generate.overlap_problem: every fruit in a shared zone
    RANDOM = "random"  # coplan.generate.random_problem(seed)
    CELL = "cell"  # coplan.generate.cell_problem(seed)
    FILES = "files"  # problem files: a file, a folder or a glob
    GANTRY = "gantry"  # coplan.generate.gantry_row: a row harvested from a mobile gantry (stop and go or on the move)


class SweepMode(Choice):
    GRID = "grid"  # every combination of the varied values
    RANDOM = "random"  # ``samples`` combinations drawn with the sweep's seed


class RowStatus(Choice):
    """Status of one row of a sweep table: a plan's status, or why there is no plan."""

    SUCCESS = "success"
    PARTIAL = "partial"
    UNSAFE = "unsafe"
    UNVERIFIED = "unverified"
    INFEASIBLE = "infeasible"
    FAILED = "failed"
    INTERRUPTED = "interrupted"
    BAD_INPUT = "bad input"  # the problem (file or generated) is invalid
    ERROR = "error"  # an internal error while solving (the message says which)
    TIMEOUT = "timeout"  # the hard per-task time limit stopped the worker
    LOST = "lost"  # the worker died on every attempt (crash, out of memory)


class TrackState(Choice):
    """What the live planner (:mod:`coplan.live`) knows of one believed fruit (merged detections)."""

    PENDING = "pending"  # detected, not (yet) in the plan
    PLANNED = "planned"  # in the plan, not yet committed
    COMMITTED = "committed"  # its pick is in motion the arms are committed to
    DROPPED = "dropped"  # nothing found there at close range (a false or duplicate detection)
    UNREACHABLE = "unreachable"  # no arm can harvest it where it was measured


class ReplanCause(Choice):
    DETECTIONS = "detections"  # new detections arrived
    CLOSE_RANGE = "close-range"  # a refined measurement at close range
    IDLE = "idle"  # retry: the plan ended with detected fruit left over


class ExportFormat(Choice):
    """``coplan export --format``: what a joint controller is handed (:mod:`coplan.report.export`)."""

    CSV = "csv"  # one file, a row per time, every arm's q, qd, qdd
    JSON = "json"  # per arm a ROS 2 trajectory_msgs/JointTrajectory
    YAML = "yaml"  # the same as YAML


class SchemaKind(Choice):
    """``coplan schema``: the file formats coplan ships a JSON Schema for (:mod:`coplan.schemas`)."""

    PROBLEM = "problem"
    PLAN = "plan"
    FEED = "feed"
