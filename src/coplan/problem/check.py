"""The checks every :class:`coplan.problem.model.Problem` passes however it was made: read from a
file (which checks much more, with line numbers), built in Python, or changed with
``dataclasses.replace``. A NaN link radius must not reach a planner, nor the verifier, whose
distances it would make infinitely clear.

Entry point: :func:`built_issues` -> the :class:`coplan.errors.Issue` list (key path, what was
expected, what was found); the problem raises :class:`coplan.errors.ProblemError` with them.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from ..errors import Issue, finite_number
from .gantry import Gantry
from .spec import kind_of

__all__ = ["built_issues"]

_ARM_PAIRS = (("base", "[x, y] in m", None), ("bin", "[x, y] in m", None), ("home", "[t1, t2] in rad", None),
              ("links", "[l1, l2]: two link lengths > 0 in m", "pos"),
              ("max_velocity", "two joint speeds > 0 in rad/s", "pos"),
              ("max_acceleration", "two joint accelerations > 0 in rad/s^2", "pos"),
              ("max_jerk", "two joint jerks > 0 in rad/s^3", "pos"))
_TASK = ("pick_dwell", "place_dwell", "clearance", "reach_margin", "singularity_threshold")
_GANTRY = ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle")


def _kind(v: Any) -> str:
    """:func:`kind_of` in Python's words: a problem built in Python holds tuples, not YAML lists."""
    return "tuple " + kind_of(v).split(" ", 1)[1] if isinstance(v, tuple) else kind_of(v)


def _num(v: Any, sign: str | None) -> bool:
    return finite_number(v) and (sign is None or (v > 0 if sign == "pos" else v >= 0))


def _words(sign: str | None) -> str:
    return {"pos": "a finite number > 0", "nonneg": "a finite number >= 0"}.get(sign, "a finite number")


def _pair(v: Any, path: str, what: str, sign: str | None, out: list[Issue]) -> None:
    if not isinstance(v, (tuple, list)) or len(v) != 2 or not all(_num(u, sign) for u in v):
        out.append(Issue(path, f"expected {what}, found {_kind(v)}"))


def _names(items: Iterable, attr: str, where: str, out: list[Issue]) -> None:
    seen: dict[str, int] = {}
    for i, it in enumerate(items):
        name = getattr(it, attr, None)
        if not isinstance(name, str) or not name.strip():  # (as a file's: blank is empty)
            out.append(Issue(f"{where}[{i}].{attr}", f"expected a non-empty string, found {_kind(name)}"))
        elif name != name.strip():  # (a file's are stripped: ' left ' beside 'left' was planned as a second arm)
            out.append(Issue(f"{where}[{i}].{attr}", f"expected {'an' if attr[0] in 'aeiou' else 'a'} {attr} with no spaces around it (a problem file's are "
                                                     f"stripped: {name.strip()!r}), found {name!r}"))
        elif name in seen:
            out.append(Issue(f"{where}[{i}].{attr}", f"expected a unique {attr}, found {name!r} again ({where}[{seen[name]}])"))
        else:
            seen[name] = i


def built_issues(problem) -> list[Issue]:
    """Every way ``problem`` is not a problem coplan can plan: arms, fruit, task and gantry of the
    right kinds, finite, positive where a length or a limit, joint limits in order, names unique."""
    out: list[Issue] = []
    if not isinstance(problem.name, str) or not problem.name.strip():  # (a file's is refused empty too)
        out.append(Issue("name", f"expected a non-empty string, found {_kind(problem.name)}"))
    arms, fruits = problem.arms, problem.fruits
    if not isinstance(arms, tuple) or not arms:
        return out + [Issue("arms", f"expected a non-empty tuple of Arm, found {_kind(arms)}")]
    if not isinstance(fruits, tuple):
        return out + [Issue("fruits", f"expected a tuple of Fruit, found {_kind(fruits)}")]
    # (a mapping for an Arm or a Fruit: "'dict' object has no attribute 'link_radius'" from below)
    arm_keys = ("name", "link_radius", "joint_limits") + tuple(f for f, _, _ in _ARM_PAIRS)
    odd = [Issue(f"arms[{i}]", f"expected an Arm (coplan.problem.model.Arm; coplan.solve takes a whole problem as a "
                               f"mapping), found {_kind(a)}") for i, a in enumerate(arms) if not all(hasattr(a, k) for k in arm_keys)]
    odd += [Issue(f"fruits[{i}]", f"expected a Fruit (coplan.problem.model.Fruit), found {_kind(f)}")
            for i, f in enumerate(fruits) if not (hasattr(f, "id") and hasattr(f, "position"))]
    if odd:
        return out + odd
    _names(arms, "name", "arms", out)
    for i, a in enumerate(arms):
        for f, what, sign in _ARM_PAIRS:
            _pair(getattr(a, f, None), f"arms[{i}].{f}", what, sign, out)
        if not _num(getattr(a, "link_radius", None), "pos"):
            out.append(Issue(f"arms[{i}].link_radius", f"expected a capsule radius > 0 in m, found {_kind(a.link_radius)}"))
        lim = getattr(a, "joint_limits", None)
        if (not isinstance(lim, (tuple, list)) or len(lim) != 2
                or not all(isinstance(p, (tuple, list)) and len(p) == 2 and all(_num(u, None) for u in p) and p[0] < p[1]
                           for p in lim)):
            out.append(Issue(f"arms[{i}].joint_limits", f"expected [[t1_min, t1_max], [t2_min, t2_max]] in rad, each min < max, "
                                                        f"found {_kind(lim)}"))
    _names(fruits, "id", "fruits", out)
    for i, f in enumerate(fruits):
        p = getattr(f, "position", None)
        if not (isinstance(p, (tuple, list)) and len(p) == 2 and _num(p[0], None) and _num(p[1], None)):
            out.append(Issue(f"fruits[{i}].position", f"expected [x, y] in m, two finite numbers, found {_kind(p)}"))
    if not all(hasattr(problem.task, k) for k in _TASK):  # (Task is coplan.problem.model's, which imports this module)
        out.append(Issue("task", f"expected a Task ({', '.join(_TASK)}), found {_kind(problem.task)}"))
    for k in _TASK if not out or out[-1].path != "task" else ():
        v = getattr(problem.task, k, None)
        if not _num(v, "nonneg"):
            out.append(Issue(f"task.{k}", f"expected {_words('nonneg')}, found {_kind(v)}"))
    g = problem.gantry
    if g is not None and not isinstance(g, Gantry):
        out.append(Issue("gantry", f"expected a Gantry (coplan.problem.gantry.Gantry) or None, found {_kind(g)}"))
    elif g is not None:
        for k in _GANTRY:
            v = getattr(g, k, None)
            sign = "pos" if k.startswith("max_") else "nonneg" if k == "settle" else None
            if not _num(v, sign):
                out.append(Issue(f"gantry.{k}", f"expected {_words(sign)}, found {_kind(v)}"))
        if _num(g.start, None) and _num(g.end, None) and not g.start < g.end:
            out.append(Issue("gantry.end", f"expected the end of the row past its start ({g.start:g} m), found {g.end:g}"))
    return out
