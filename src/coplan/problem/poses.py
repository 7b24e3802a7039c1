"""What a problem's poses and positions must satisfy beyond each field's own value: home poses at
least the clearance apart, each home inside its joint limits and each bin reachable, one fruit
per position. A file is refused for these at its lines (:mod:`coplan.problem.load`); a
problem built or changed in Python is held to them when it is built or planned.

Entry points: :func:`home_issues`, :func:`position_issues`, :func:`pose_issues` -> lists of
:class:`coplan.errors.Issue` (key path, what was expected, what was found).
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import Issue
from ..kinematics import arm as kin
from ..kinematics.geometry import segment_distance
from .yamlsafe import line_of, path_str

# (``Problem``, ``Arm``, ``Fruit`` and ``Task`` in the annotations below are coplan.problem.model's,
# which imports this module, as coplan.problem.load does)

__all__ = ["COINCIDENT", "coincident", "position_issues", "copy_issues", "home_issues", "home_pair_issues", "pose_issues"]


#: Two fruit closer than this (m) are one position (a copy, or a copy nudged by a rounding).
COINCIDENT = 1e-6


def coincident(positions) -> list[tuple[int, int]]:
    """``(a, b)`` index pairs, ``a < b``, of positions within :data:`COINCIDENT` of each other
    (each later one once, with the first it repeats)."""
    pts = np.asarray(positions, float).reshape(-1, 2)
    if pts.shape[0] < 2:
        return []
    from scipy.spatial import cKDTree

    first: dict[int, int] = {}
    for a, b in sorted(cKDTree(pts).query_pairs(COINCIDENT, p=2.0)):
        first.setdefault(b, a)
    return sorted((a, b) for b, a in first.items())


def position_issues(problem: Problem) -> list[Issue]:
    """Two fruit at one position, as a file is refused for them (a problem built or changed in
    Python is held to this when it is planned: :func:`coplan.solve`; the live planners' problems
    of camera reports, which may coincide, are not)."""
    return copy_issues(list(problem.fruits), list(range(len(problem.fruits))), {})


def copy_issues(fruits: list[Fruit], where: list[int], lines: dict) -> list[Issue]:
    """One issue per fruit within :data:`COINCIDENT` of an earlier one; ``where``: each fruit's
    index in ``fruits:`` (a file's skips the entries refused before), ``lines`` its lines."""
    out = []
    for a, b in coincident([f.position for f in fruits]):
        loc = ("fruits", where[b], "position")
        out.append(Issue(path_str(loc), f"expected one fruit per position, found {list(fruits[b].position)} again (also "
                                        f"fruits[{where[a]}] {fruits[a].id!r}, within {COINCIDENT * 1e6:g} um): a fruit is "
                                        f"picked once; remove the copy", line_of(lines, loc)))
    return out


def home_issues(problem: Problem) -> list[Issue]:
    """Home poses closer than the clearance, as a file is refused for them (a problem built or
    changed in Python is held to this when it is planned: :func:`coplan.solve`)."""
    origins = {i: {"home": ("arms", i, "home")} for i in range(len(problem.arms))}
    return home_pair_issues(list(enumerate(problem.arms)), origins, problem.task, {})


def home_pair_issues(arms: list[tuple[int, Arm]], origins: dict, task: Task, lines: dict) -> list[Issue]:
    """Home poses must already respect the clearance: one issue per pair that does not."""
    out = []
    for x in range(len(arms)):
        for y in range(x + 1, len(arms)):
            (i, a), (k, b) = arms[x], arms[y]
            pa = kin.fk_points(np.array(a.home), a.links, a.base)
            pb = kin.fk_points(np.array(b.home), b.links, b.base)
            dmin = min(
                float(segment_distance(pa[s], pa[s + 1], pb[u], pb[u + 1])) for s in range(2) for u in range(2)
            ) - a.link_radius - b.link_radius
            if dmin < task.clearance:
                home_from = "" if origins[k]["home"][0] == "arms" else " (home from defaults.home)"
                out.append(
                    Issue(
                        path_str(("arms", k, "home")),
                        f"expected home poses at least the clearance {task.clearance} m apart, found arms "
                        f"{a.name!r} (arms[{i}]) and {b.name!r} (arms[{k}]) "
                        + (f"{dmin:.4f} m apart" if dmin >= 0 else f"overlapping by {-dmin:.4f} m")
                        + f" at home{home_from}"
                        + (f" (their bases {math.dist(a.base, b.base):.3f} m apart)"
                           if math.dist(a.base, b.base) < a.link_radius + b.link_radius + task.clearance else ""),
                        line_of(lines, origins[k]["home"]) if home_from == "" else line_of(lines, ("arms", k)),
                    )
                )
    return out


def pose_issues(problem: Problem) -> list[Issue]:
    """A problem built or changed in Python, checked as a file's arms are: each home inside its
    joint limits, each bin reachable (a file's problem has passed these before it is built:
    nothing is found twice). Home poses closer than the clearance are not refused here: the
    screen's tests build them on purpose, and a plan from there fails verification at t = 0."""
    out = []
    for i, a in enumerate(problem.arms):
        for j in range(2):
            lo, hi = a.joint_limits[j]
            if not lo <= a.home[j] <= hi:
                out.append(Issue(f"arms[{i}].home[{j}]", f"expected a home angle inside the joint limits [{lo}, {hi}] "
                                                         f"(arms[{i}].joint_limits[{j}]), found {a.home[j]}"))
        if not a.can_reach(a.bin):
            out.append(Issue(f"arms[{i}].bin", f"expected a bin its arm {a.name!r} can reach (IK inside joint limits), found "
                                               f"{list(a.bin)} {a.reach_words(a.bin)}"))
    return out
