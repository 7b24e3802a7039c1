"""The mobile gantry of a row problem: the carriage that carries the arms along the row.

A problem file with a ``gantry`` section is a *row*: ``arms[].base`` and ``arms[].bin`` are
then relative to the carriage's origin (the bins ride with it) and ``fruits[].position`` is in
row (world) coordinates; the carriage moves along x, between ``start`` and ``end``, with
jerk-limited motion. Without a gantry a problem is a stationary cell, as before (a cell is a
row whose carriage never moves).

* :class:`Gantry` -- the validated section (frozen, SI units).
* :func:`parse_gantry` -- validate the section's raw data; issues with key path and line.
* :func:`cell_at` -- the stationary cell the carriage makes at position ``x``: a plain
  :class:`~coplan.problem.model.Problem` with the bases and bins where the carriage puts them
  and the fruit given, which every cell planner plans as it stands.
* :func:`carriage_extent` -- the x range of row positions some arm could reach from some
  carriage position in ``[start, end]`` (a fruit outside it is outside the rail: bad input).
"""

from __future__ import annotations

import weakref
from dataclasses import dataclass, replace
from typing import Any

import numpy as np

from ..errors import Issue
from .yamlsafe import did_you_mean, line_of, nearest_name, path_str

# (``Problem`` in the annotations below is coplan.problem.model.Problem, which imports this module)

__all__ = ["Gantry", "parse_gantry", "cell_at", "require_cell", "carriage_extent", "off_rail", "gantry_range_issues", "GANTRY_KEYS", "rail_reach", "standing_reach", "REACH_STEP", "RESOLUTION_RANGE", "top_speed_issues"]

#: The keys of a ``gantry`` section: required ones first.
GANTRY_KEYS = ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle")
_REQUIRED = GANTRY_KEYS[:5]
_EXPECT = {
    "start": "the x of the carriage origin at t = 0, in m",
    "end": "the x of the end of the row, in m (the carriage never goes past it)",
    "max_velocity": "the carriage's speed limit > 0, in m/s",
    "max_acceleration": "the carriage's acceleration limit > 0, in m/s^2",
    "max_jerk": "the carriage's jerk limit > 0, in m/s^3",
    "settle": "a settling time >= 0, in s (the carriage's rest after a stop before an arm may pick)",
}
#: The plausible range of each number (what a greenhouse gantry can be), for clear errors.
BOUNDS = {
    "start": (-10_000.0, 10_000.0),
    "end": (-10_000.0, 10_000.0),
    "max_velocity": (1e-3, 10.0),
    "max_acceleration": (1e-3, 100.0),
    "max_jerk": (1e-3, 10_000.0),
    "settle": (0.0, 60.0),
}


@dataclass(frozen=True)
class Gantry:
    """The carriage of a row: its travel ``[start, end]`` (m) and its limits (SI units).

    ``settle`` (s): how long the carriage stays at rest after a move before an arm may pick
    (vibration dies out); 0 by default."""

    start: float
    end: float
    max_velocity: float
    max_acceleration: float
    max_jerk: float
    settle: float = 0.0

    @property
    def length(self) -> float:
        """The row's length, m (the carriage's travel)."""
        return self.end - self.start


def _number(v: Any) -> float | None:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return None
    return float(v)


def _kind(v: Any) -> str:
    if v is None:
        return "nothing"
    names = {bool: "boolean", int: "number", float: "number", str: "string", list: "list", dict: "mapping"}
    return f"{names.get(type(v), type(v).__name__)} {v!r}"


def parse_gantry(data: Any, lines: dict, issues: list[Issue]) -> Gantry | None:
    """The :class:`Gantry` of a ``gantry`` section, or None after appending every issue
    (key path ``gantry.<key>``, its line, what was expected and what was found)."""
    if not isinstance(data, dict):
        issues.append(Issue("gantry", f"expected a mapping with keys {', '.join(_REQUIRED)}, found {_kind(data)}",
                            line_of(lines, ("gantry",))))
        return None
    ok = True
    values: dict[str, float] = {}
    for k in data:
        if k not in GANTRY_KEYS:
            issues.append(Issue(path_str(("gantry", k)), f"expected one of {', '.join(GANTRY_KEYS)}, found unknown key {k!r}{did_you_mean(k, GANTRY_KEYS)}",
                                line_of(lines, ("gantry", k))))
            ok = False
    meant = {nearest_name(k, GANTRY_KEYS) for k in data if k not in GANTRY_KEYS}  # (a mis-spelt key: said once, with its 'did you mean')
    for k in GANTRY_KEYS:
        loc = ("gantry", k)
        if k not in data:
            if k in _REQUIRED and k not in meant:
                issues.append(Issue(path_str(loc), f"expected {_EXPECT[k]}, found nothing (required field)", line_of(lines, ("gantry",))))
                ok = False
            continue
        v = _number(data[k])
        if v is None or v != v or v in (float("inf"), float("-inf")):
            issues.append(Issue(path_str(loc), f"expected {_EXPECT[k]}, found {_kind(data[k])}", line_of(lines, loc)))
            ok = False
            continue
        lo, hi = BOUNDS[k]
        if k.startswith("max_") and v <= 0:
            issues.append(Issue(path_str(loc), f"expected {_EXPECT[k]}, found {v:g}", line_of(lines, loc)))
            ok = False
        elif not lo <= v <= hi:
            issues.append(Issue(path_str(loc), f"expected {_EXPECT[k]} within the plausible range [{lo:g}, {hi:g}], found {v:g}",
                                line_of(lines, loc)))
            ok = False
        values[k] = v
    if "start" in values and "end" in values and not values["start"] < values["end"]:  # (beside any other issue)
        issues.append(Issue("gantry.end", f"expected the end of the row past its start ({values['start']:g} m), "
                                          f"found {values['end']:g}", line_of(lines, ("gantry", "end"))))
        ok = False
    return Gantry(**values) if ok else None


def carriage_extent(problem: "Problem") -> tuple[float, float]:
    """Row x that some arm reaches from some carriage position in ``[start, end]`` (the rail's
    reach); a fruit outside is on no stretch of this row."""
    g = problem.gantry
    lo = min(a.base[0] - a.reach for a in problem.arms)
    hi = max(a.base[0] + a.reach for a in problem.arms)
    return g.start + lo, g.end + hi


def off_rail(problem: "Problem", fruits=None) -> list[tuple[int, str]]:
    """``(index, message)`` of each fruit of ``fruits`` (default: the problem's) outside
    :func:`carriage_extent`: on no stretch of this row, so bad input."""
    g = problem.gantry
    lo, hi = carriage_extent(problem)
    return [(j, f"expected a fruit on this row: x within [{lo:g}, {hi:g}] m, what some arm reaches from the rail "
                f"[{g.start:g}, {g.end:g}] m; found x = {f.position[0]:g}")
            for j, f in enumerate(problem.fruits if fruits is None else fruits) if not lo <= f.position[0] <= hi]


def gantry_range_issues(g: Gantry) -> list[tuple[tuple, str]]:
    """``(key path, message)`` for each number of a :class:`Gantry` built or changed in Python
    outside its plausible range (:data:`BOUNDS`), as a file's section is refused for it."""
    out = []
    for k in GANTRY_KEYS:
        lo, hi = BOUNDS[k]
        v = getattr(g, k)
        if not lo <= v <= hi:
            out.append((("gantry", k), f"expected {_EXPECT[k]} within the plausible range [{lo:g}, {hi:g}], found {v:g}"))
    return out


REACH_STEP = 0.01  # m between the carriage positions :func:`rail_reach` tries
#: The spacings of candidate carriage positions a row may be screened and bounded on, m (as
#: ``--resolution``): a 200 m row of 2,000 fruit and 6 arms screens 240 MB at 0.01; beyond 0.5 a
#: fruit's window of rail (often under a metre) has no position.
RESOLUTION_RANGE = (0.01, 0.5)
_RAIL_REACH: "weakref.WeakKeyDictionary" = weakref.WeakKeyDictionary()


def rail_reach(problem: "Problem") -> np.ndarray:
    """(A, F) bool: arm ``a`` can pick fruit ``f`` (IK inside its joint limits, ``reach_margin``
    kept) from some carriage position on the rail, tried every :data:`REACH_STEP` m from
    ``start`` to ``end`` (computed once per problem: problems are immutable). What a row's
    :meth:`Problem.reach_matrix` is, and the verifier's reachable fruit."""
    hit = _RAIL_REACH.get(problem)
    if hit is None:
        hit = _RAIL_REACH[problem] = _rail_reach(problem)
    return hit.copy()


def _rail_reach(problem: "Problem") -> np.ndarray:
    g = problem.gantry
    cs = np.arange(g.start, g.end + REACH_STEP / 2, REACH_STEP)
    m = problem.task.reach_margin
    if not problem.fruits:
        return np.zeros((len(problem.arms), 0), dtype=bool)
    fx = np.array([f.position[0] for f in problem.fruits], float)
    fy = np.array([f.position[1] for f in problem.fruits], float)
    ok = np.zeros((len(problem.arms), fx.size), dtype=bool)
    for i, arm in enumerate(problem.arms):  # every fruit and the carriage positions near it at once, arm by arm
        # each fruit's candidate positions (a sorted grid: an index range, one position to spare
        # each side), then the exact test on those only: memory in the pairs, not fruit x rail
        lo = np.maximum(np.searchsorted(cs, fx - arm.base[0] - arm.reach) - 1, 0)
        hi = np.minimum(np.searchsorted(cs, fx - arm.base[0] + arm.reach, side="right") + 1, cs.size)
        n = np.maximum(hi - lo, 0)
        if not n.any():
            continue
        rows = np.repeat(np.arange(fx.size), n)
        cols = lo[rows] + (np.arange(rows.size) - np.repeat(np.cumsum(n) - n, n))
        near = np.abs(fx[rows] - cs[cols] - arm.base[0]) <= arm.reach
        rows, cols = rows[near], cols[near]
        for a in range(0, rows.size, 200_000):  # (in chunks: a long dense row has millions of pairs)
            r, c = rows[a:a + 200_000], cols[a:a + 200_000]
            hit = arm.ik(np.c_[fx[r] - cs[c], fy[r]], m)[1].any(axis=-1)
            ok[i, r[hit]] = True
    return ok


def standing_reach(problem: "Problem") -> np.ndarray:
    """(A, F) bool: what each arm reaches where it stands -- a cell's ``reach_matrix``, a row's with
    the carriage at 0 (its ``reach_matrix`` is the whole rail's, :func:`rail_reach`): the reach the
    cell stages (the screen, the course's allocation) take of a problem they are given."""
    return (problem if problem.gantry is None else cell_at(problem, 0.0)).reach_matrix()


def cell_at(problem: "Problem", x: float, fruit_ids=None, name: str | None = None) -> "Problem":
    """The stationary cell the carriage makes at ``x``: bases and bins shifted by ``(x, 0)``,
    the fruit ``fruit_ids`` (all when None) in row coordinates, no gantry. Every cell planner,
    the screen and the verifier take it as it stands."""
    arms = tuple(replace(a, base=(a.base[0] + x, a.base[1]), bin=(a.bin[0] + x, a.bin[1])) for a in problem.arms)
    if fruit_ids is None:
        fruits = problem.fruits
    else:
        keep = set(fruit_ids)
        fruits = tuple(f for f in problem.fruits if f.id in keep)
    return replace(problem, arms=arms, fruits=fruits, gantry=None, name=name or f"{problem.name}@{x:.3f}",
                   source=None, digest=None)


def require_cell(problem, what: str) -> None:
    """ValueError where ``problem`` is a row (it has a gantry) but ``what`` works on a stationary
    cell: said before any work (a coordinated plan of a row failed its verification, an
    allocation of a row read its carriage as standing at 0 and left fruit 'unreachable')."""
    if getattr(problem, "gantry", None) is not None:
        raise ValueError(f"{what}: {problem.name!r} is a row (it has a gantry): plan it with coplan.solve, or "
                         f"coplan.row.plan_row / plan_moving; {what} works on a stationary cell (the cell at carriage "
                         f"position x: coplan.problem.gantry.cell_at(problem, x))")


def top_speed_issues(name: str, speed, when: str) -> list:
    """A cruising speed (m/s) above any gantry's (:data:`BOUNDS` ``max_velocity``) as an issue at
    ``name``, for an options class built in Python (1e9 was taken until the row was planned or
    run, ``when``: the row's own ``gantry.max_velocity`` is checked then); empty otherwise."""
    top = BOUNDS["max_velocity"][1]
    if isinstance(speed, (int, float)) and not isinstance(speed, bool) and speed > top:
        return [Issue(name, f"expected a cruising speed of at most {top:g} m/s (the fastest a gantry may be; the row's "
                            f"own gantry.max_velocity is checked when {when}), found {speed:g}")]
    return []
