"""The immutable problem: :class:`Problem` (its :class:`Arm`, :class:`Fruit`, :class:`Task` and,
on a row, its :class:`~coplan.problem.gantry.Gantry`), validated however it is made.

Reading one from a file or text -- with every issue's key path and line -- is
:mod:`coplan.problem.load` (:func:`~coplan.problem.load.load_problem`,
:func:`~coplan.problem.load.parse_problem`); a problem built or changed in Python is checked
here, by its ``__post_init__``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..kinematics import arm as kin
from ..errors import ProblemError
from .check import built_issues
from .gantry import Gantry, rail_reach
from .poses import pose_issues

__all__ = ["Arm", "Fruit", "Task", "Problem", "MAX_ARMS", "MAX_FRUITS", "require_problem"]

MAX_ARMS = 64
MAX_FRUITS = 20_000


# --------------------------------------------------------------------------- data objects
@dataclass(frozen=True)
class Arm:
    """One 2R arm, fully specified (defaults already applied). SI units."""

    name: str
    base: tuple[float, float]
    bin: tuple[float, float]
    links: tuple[float, float]
    link_radius: float
    joint_limits: tuple[tuple[float, float], tuple[float, float]]
    max_velocity: tuple[float, float]
    max_acceleration: tuple[float, float]
    max_jerk: tuple[float, float]
    home: tuple[float, float]

    def __post_init__(self) -> None:
        for f in ("base", "bin", "links", "joint_limits", "max_velocity", "max_acceleration", "max_jerk", "home"):
            object.__setattr__(self, f, _as_tuples(getattr(self, f)))

    @property
    def reach(self) -> float:
        return self.links[0] + self.links[1]

    @property
    def inner_radius(self) -> float:
        return abs(self.links[0] - self.links[1])

    @property
    def limits(self) -> np.ndarray:
        """Joint limits as a (2, 2) array ``[[min1, max1], [min2, max2]]``."""
        return np.array(self.joint_limits, dtype=float)

    def ik(self, point, margin: float = 0.0):
        """IK of a world point, both branches, inside joint limits and the annulus shrunk by ``margin``.

        Returns ``q`` (..., 2, 2) with NaN where invalid and ``valid`` (..., 2).
        """
        q, valid = kin.ik(point, self.links, self.base, self.limits)
        if margin > 0:
            inside = kin.in_workspace(point, self.links, self.base, margin)
            valid = valid & inside[..., None]
            q = np.where(valid[..., None], q, np.nan)
        return q, valid

    def can_reach(self, point, margin: float = 0.0) -> bool:
        return bool(np.any(self.ik(point, margin)[1]))

    def radii(self) -> tuple[float, float]:
        """The least and greatest distance from the base the tip reaches within the elbow's
        joint limits, m (``[inner_radius, reach]`` when the elbow may fold and stretch fully)."""
        l1, l2 = self.links
        lo, hi = self.joint_limits[1]

        def has(a: float) -> bool:  # an angle a + 2 pi k within [lo, hi]
            return math.floor((hi - a) / (2.0 * math.pi)) >= math.ceil((lo - a) / (2.0 * math.pi))

        c = (math.cos(lo), math.cos(hi))  # (limits past +-pi: cos(min(|q2|, pi)) called 3.4 rad fully folded)
        c_lo, c_hi = (-1.0 if has(math.pi) else min(c)), (1.0 if has(0.0) else max(c))

        def r(cq: float) -> float:
            return math.sqrt(max(l1 * l1 + l2 * l2 + 2.0 * l1 * l2 * cq, 0.0))
        return r(c_lo), r(c_hi)

    def reach_words(self, point) -> str:
        """Why ``point`` is out of this arm's reach, for a message: its distance from the base
        against the radii the elbow's limits allow, or the shoulder's limits."""
        d = math.dist(self.base, point)
        lo, hi = self.radii()
        limited = abs(lo - self.inner_radius) > 1e-9 or abs(hi - self.reach) > 1e-9
        span = f"[{lo:.3f}, {hi:.3f}] m" + (f" (the elbow's joint limits {list(self.joint_limits[1])} rad)" if limited else "")
        if lo - 1e-9 <= d <= hi + 1e-9:
            return (f"at {d:.3f} m from the base, within the reachable radii {span}, but in a direction the "
                    f"shoulder's joint limits {list(self.joint_limits[0])} rad (with the elbow's) do not reach")
        return f"at {d:.3f} m from the base; the reachable radii are {span}"


def _as_tuples(v: Any) -> Any:
    """A list or array of numbers (or of pairs) as tuples, as a file's are: a list in a frozen,
    hashable problem made it unhashable (a TypeError deep in the planner). Anything else as it is,
    for :func:`coplan.problem.check.built_issues` to name."""
    if isinstance(v, np.ndarray) and v.ndim in (1, 2):
        v = v.tolist()
    if isinstance(v, list):
        return tuple(_as_tuples(u) for u in v)
    if isinstance(v, tuple):
        return tuple(_as_tuples(u) if isinstance(u, (list, tuple, np.ndarray)) else u for u in v)
    return v


@dataclass(frozen=True)
class Fruit:
    id: str
    position: tuple[float, float]

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _as_tuples(self.position))


@dataclass(frozen=True)
class Task:
    """The task's settings (SI units): ``pick_dwell`` and ``place_dwell`` (s) the tip holds still
    on the fruit and over the bin; ``clearance`` (m) between neighbouring arms' links, beyond
    their radii; ``reach_margin`` (m) kept inside each arm's annulus of reach;
    ``singularity_threshold``: manipulability (|det J|) below which a pose is reported near-singular."""

    pick_dwell: float
    place_dwell: float
    clearance: float
    reach_margin: float = 0.01
    singularity_threshold: float = 0.05


@dataclass(frozen=True)
class Problem:
    """A validated, immutable harvesting problem. A variant is a new one:
    ``dataclasses.replace(problem, task=dataclasses.replace(problem.task, clearance=0.1))``,
    checked as it is made (:class:`~coplan.errors.ProblemError`)."""

    name: str
    arms: tuple[Arm, ...]
    fruits: tuple[Fruit, ...]
    task: Task
    description: str = ""
    source: str | None = field(default=None, compare=False)
    digest: str | None = field(default=None, compare=False)  # sha256 of the YAML text it was read from
    gantry: Gantry | None = None  # a row: bases and bins relative to the carriage, fruit in row coordinates

    def __post_init__(self) -> None:
        for key in ("arms", "fruits"):  # (a list of Arm or Fruit was refused where a list of numbers was taken)
            if isinstance(getattr(self, key), list):
                object.__setattr__(self, key, tuple(getattr(self, key)))
        # however it was made (a file checks much more, with lines): finite, positive where it must be
        issues = built_issues(self)
        if not issues:  # what a file's arms are checked for beyond their numbers
            issues = pose_issues(self)
        if issues:  # (a file's own checks came first: these are a problem built or changed in Python)
            raise ProblemError(issues, f"{self.source}, as changed in Python" if self.source else "a problem built in Python")

    def __repr__(self) -> str:  # (the fruit are the bulk: 2.4k characters for 26 fruit in a notebook cell)
        arms = ", ".join(a.name for a in self.arms[:8]) + (", ..." if len(self.arms) > 8 else "")
        where = "" if self.gantry is None else f", row {self.gantry.start:g}-{self.gantry.end:g} m"
        return (f"Problem(name={self.name!r}, arms={len(self.arms)} [{arms}], fruits={len(self.fruits)}{where}, "
                f"clearance={self.task.clearance:g} m{f', source={self.source!r}' if self.source else ''})")

    def arm(self, name: str) -> Arm:
        """The arm named ``name`` (KeyError naming the arms there are)."""
        for a in self.arms:
            if a.name == name:
                return a
        raise KeyError(f"no arm named {name!r}; arms are {[a.name for a in self.arms]}")

    def fruit(self, fid: str) -> Fruit:
        """The fruit of id ``fid`` (KeyError if none)."""
        for f in self.fruits:
            if f.id == fid:
                return f
        raise KeyError(f"no fruit with id {fid!r}")

    @property
    def fruit_positions(self) -> np.ndarray:
        """(F, 2) array of fruit positions in file order."""
        return np.array([f.position for f in self.fruits], dtype=float).reshape(-1, 2)

    def reach_matrix(self) -> np.ndarray:
        """(A, F) bool: arm a can reach fruit f (IK inside joint limits, ``reach_margin`` kept);
        on a row, from some carriage position on its rail (:func:`coplan.problem.gantry.rail_reach`:
        with the carriage at 0 alone, sparse_row's arms reached 5 of its 93 fruit)."""
        if self.gantry is not None:
            return rail_reach(self)
        pts = self.fruit_positions
        return np.array([a.ik(pts, self.task.reach_margin)[1].any(axis=-1) for a in self.arms]).reshape(
            len(self.arms), len(self.fruits)
        )

    def unreachable(self) -> list[str]:
        """Ids of fruit that no arm can reach (left out of every plan)."""
        m = self.reach_matrix()
        return [f.id for j, f in enumerate(self.fruits) if not m[:, j].any()]

    def reachable_ids(self) -> list[str]:
        """Ids of the fruit some arm can reach (its tip on the fruit within its joint limits), in
        the problem's order."""
        m = self.reach_matrix()
        return [f.id for j, f in enumerate(self.fruits) if m[:, j].any()]

    def neighbour_pairs(self) -> list[tuple[int, int]]:
        """Index pairs of arms whose swept discs (reach + radius + clearance) can touch."""
        out = []
        for i, a in enumerate(self.arms):
            for j in range(i + 1, len(self.arms)):
                b = self.arms[j]
                d = math.dist(a.base, b.base)
                if d < a.reach + b.reach + a.link_radius + b.link_radius + self.task.clearance:
                    out.append((i, j))
        return out


def require_problem(problem, what: str) -> None:
    """TypeError where an entry point that takes a :class:`Problem` (``what``) is given anything
    else: a name, a path or a mapping, which :func:`coplan.solve` reads (here a name raised
    "'str' object has no attribute 'gantry'", or "cannot create weak reference to 'str' object")."""
    if not isinstance(problem, Problem):
        raise TypeError(f"{what}: expected a Problem (coplan.problem.load_problem reads a file or a shipped name; "
                        f"coplan.solve also takes a name, a path or a mapping), found {type(problem).__name__} "
                        f"{str(problem)[:60]!r}")
