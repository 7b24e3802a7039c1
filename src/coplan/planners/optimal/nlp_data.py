"""The data of the joint NLP: its knot grid, separation points, the built problem, the solution
and IPOPT's statuses (built by :mod:`coplan.planners.optimal.nlp`, solved by
:mod:`coplan.planners.optimal.nlp_solve`). No CasADi here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum

import numpy as np

from ..coordinated.schedule import ArmSchedule, StepKind
from ...plan import Event, EventKind

__all__ = ["SolverStatus", "any_interrupted", "Grid", "ConstraintPoint", "WidenGoal", "NLP", "NLPSolution", "build_grid",
           "knot_events", "map_status"]


class SolverStatus(str, Enum):
    OPTIMAL = "optimal"
    ACCEPTABLE = "acceptable"
    LIMIT_REACHED = "limit_reached"
    INFEASIBLE = "infeasible"
    NUMERICAL_ERROR = "numerical_error"
    INTERRUPTED = "interrupted"

    @property
    def converged(self) -> bool:
        return self in (SolverStatus.OPTIMAL, SolverStatus.ACCEPTABLE)


def any_interrupted(report) -> bool:
    """Whether any IPOPT round in a report (a stage's, its retries' too: nested dicts and lists
    with ``status``) was stopped by Ctrl-C."""
    if isinstance(report, dict):
        return report.get("status") == SolverStatus.INTERRUPTED.value or any(any_interrupted(v) for v in report.values())
    if isinstance(report, list):
        return any(any_interrupted(v) for v in report)
    return False


_IPOPT_STATUS = {
    "Solve_Succeeded": SolverStatus.OPTIMAL,
    "Solved_To_Acceptable_Level": SolverStatus.ACCEPTABLE,
    "Feasible_Point_Found": SolverStatus.ACCEPTABLE,
    "Maximum_Iterations_Exceeded": SolverStatus.LIMIT_REACHED,
    "Maximum_CpuTime_Exceeded": SolverStatus.LIMIT_REACHED,
    "Maximum_WallTime_Exceeded": SolverStatus.LIMIT_REACHED,
    "Infeasible_Problem_Detected": SolverStatus.INFEASIBLE,
    "User_Requested_Stop": SolverStatus.INTERRUPTED,
}


def map_status(ipopt_status: str) -> SolverStatus:
    """IPOPT's return status -> coplan's :class:`SolverStatus` (anything else: numerical error)."""
    return _IPOPT_STATUS.get(ipopt_status, SolverStatus.NUMERICAL_ERROR)


# ----------------------------------------------------------------------------- grid
@dataclass(frozen=True)
class Grid:
    """Shared knot grid: warm-start knot times and, per arm, each step's knot range."""

    t: np.ndarray  # (K+1,)
    ranges: dict[str, list[tuple[int, int]]]  # arm -> per step (k0, k1)
    segment: np.ndarray  # (K,) index of the union segment (between step boundaries) of each interval

    @property
    def K(self) -> int:
        return self.t.size - 1


def build_grid(schedules: dict[str, ArmSchedule], h_target: float = 0.06, merge_tol: float = 1e-7,
               switches: bool = True) -> Grid:
    """Union of every arm's step boundaries, intervals subdivided to at most ``h_target``.

    With ``switches`` the grid also has a knot at every jerk switch of every move (each
    joint's S-curve phases), and knots closer than ``merge_tol`` are merged: constant jerk
    per interval then represents the schedules exactly, so they are a feasible point of the
    NLP (up to the separation constraints' sampling)."""
    bounds = [0.0]
    t_end = max((s.end for s in schedules.values()), default=0.0)
    for s in schedules.values():
        for st in s.steps:
            bounds += [st.t0, st.t1]
            if switches and st.kind == StepKind.MOVE and st.curve is not None:
                bounds += list(st.t0 + st.curve.switch_times())
    bounds.append(t_end)
    b = np.unique(np.round(np.asarray(bounds), 9))
    reps = [b[0]]
    for x in b[1:]:
        if x - reps[-1] > merge_tol:
            reps.append(x)
    reps = np.asarray(reps)
    knots = [reps[0]]
    segment: list[int] = []
    for i, (x0, x1) in enumerate(zip(reps[:-1], reps[1:])):
        n = max(1, int(math.ceil((x1 - x0) / h_target - 1e-9)))
        knots += list(x0 + (x1 - x0) * np.arange(1, n + 1) / n)
        segment += [i] * n
    knots = np.asarray(knots)

    def idx(x):
        return int(np.argmin(np.abs(knots - x)))

    ranges = {name: [(idx(st.t0), idx(st.t1)) for st in s.steps] for name, s in schedules.items()}
    return Grid(knots, ranges, np.asarray(segment, dtype=int))


@dataclass(frozen=True)
class ConstraintPoint:
    """A separation constraint: at knot ``k`` + ``tau`` of its interval, arms ``ia``/``ib``, links ``s``/``u``."""

    k: int
    tau: float
    ia: int
    ib: int
    s: int
    u: int


def knot_events(schedules: dict[str, ArmSchedule], grid: Grid, t_knots: np.ndarray, upto: int | None = None) -> list[Event]:
    """The picks and places of ``schedules`` at the knot times ``t_knots`` of a solution on
    ``grid`` (each step keeps its knot range; steps ending after knot ``upto`` are left out)."""
    upto = grid.K if upto is None else upto
    kinds = {StepKind.PICK: EventKind.PICK, StepKind.PLACE: EventKind.PLACE}
    out = []
    for n, sch in schedules.items():
        for st, (k0, k1) in zip(sch.steps, grid.ranges[n]):
            if st.kind in kinds and k1 <= upto:
                out.append(Event(n, st.fruit, kinds[st.kind], float(t_knots[k0]), float(t_knots[k1])))
    return sorted(out, key=lambda e: (e.t_start, e.arm))


@dataclass(frozen=True)
class WidenGoal:
    """The widening objective of :func:`coplan.planners.optimal.nlp.build_nlp`: every
    separation row keeps ``clearance + S`` with ``S`` a variable in ``[floor, cap]`` (m); no
    arm places after ``makespan`` and the plan ends by ``end`` (s); the objective is
    ``-weight * S`` plus the jerk integral ``sum_k h_k |u_k / jmax|^2`` (``weight`` 0: the jerk
    alone, with ``S >= floor`` holding the room already won). ``free_idle``: an arm with no
    work rests at home at the start and the end only, and may move between (aside)."""

    makespan: float
    end: float
    floor: float
    cap: float
    guess: float
    weight: float
    free_idle: bool = False


# ----------------------------------------------------------------------------- NLP
@dataclass
class NLP:
    """A built NLP: CasADi solver plus bounds, warm start and the variable layout."""

    problem: dict  # {"x", "f", "g"} CasADi SX expressions
    options: dict  # nlpsol options (IPOPT)
    x0: np.ndarray
    lbx: np.ndarray
    ubx: np.ndarray
    lbg: np.ndarray
    ubg: np.ndarray
    layout: dict
    scales: dict
    grid: Grid
    points: list[ConstraintPoint]
    build_seconds: float
    n_vars: int
    n_cons: int


@dataclass
class NLPSolution:
    status: SolverStatus
    ipopt_status: str
    iterations: int
    t: np.ndarray  # (K+1,) knot times
    X: dict[str, np.ndarray]  # arm -> (6, K+1)
    U: dict[str, np.ndarray]  # arm -> (2, K)
    objective: float
    solve_seconds: float
    max_violation: float
    x: np.ndarray = field(repr=False, default=None)

    def sample(self, times) -> dict[str, np.ndarray]:
        """Exact joint positions at ``times`` (N,) -> arm -> (N, 2)."""
        times = np.clip(np.asarray(times, float), 0.0, self.t[-1])
        k = np.clip(np.searchsorted(self.t, times, side="right") - 1, 0, self.t.size - 2)
        tau = times - self.t[k]
        out = {}
        for a, X in self.X.items():
            U = self.U[a]
            q = X[0:2, k] + X[2:4, k] * tau + X[4:6, k] * tau**2 / 2 + U[:, k] * tau**3 / 6
            out[a] = q.T
        return out
