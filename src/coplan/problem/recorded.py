"""The problem a plan was planned on, found from what the plan records: one rule for the
commands that take a plan alone (``coplan plot/view/export/verify PLAN``) and for
``coplan.view(plan)`` in Python.

:func:`recorded_problem`: the problem file the plan records (``problem_file``: its path and the
sha256 of its text), if it is still there and unchanged; else -- the plan records no file, or the
file is gone -- the shipped problem or row of the plan's name, if its text is the recorded one
(when there is a record). Anything else is a :class:`~coplan.errors.PlanFileError` saying why and
what to give instead (``remedy``), never another problem of the same name in silence; nor, in
silence, a recorded file that bears a shipped problem's name but is another text (``note``).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from ..errors import Issue, PlanFileError
from ..kinds import Choice
from .load import load_problem, shipped_problems, shipped_rows
from .model import Problem

__all__ = ["ProblemSource", "PlanProblem", "recorded_problem"]


class ProblemSource(Choice):
    """Where :func:`recorded_problem` found a plan's problem."""

    RECORDED = "recorded"  # the file the plan records, unchanged
    SHIPPED = "shipped"  # the shipped problem of the plan's name (no file recorded, or it is gone)


@dataclass(frozen=True)
class PlanProblem:
    """A plan's problem, where it was found, and a sentence a caller shows (``note``, as a
    warning or on the console) when it is the shipped one, or a recorded file that bears a shipped
    problem's name but is another text."""

    problem: Problem
    source: ProblemSource
    note: str = ""


def recorded_problem(name: str | None, record: dict | None, remedy: str) -> PlanProblem:
    """The problem of a plan named ``name`` (its ``problem``; None or '' for a plan.csv) that
    records ``record`` (its ``problem_file``: ``{"path", "sha256"}``, or None). ``remedy``: what
    the user should give instead, ending each error's message ("give its YAML file with
    --problem FILE"). Raises :class:`PlanFileError` (one issue) when the recorded file has
    changed since, when the plan names no problem or one that is not shipped, or when the
    recorded file is gone and the shipped problem of that name is another text."""
    if record is not None and Path(record["path"]).is_file():
        problem = load_problem(record["path"])
        if problem.digest != record["sha256"]:
            raise PlanFileError([Issue("problem_file", f"it was planned from {record['path']}, which has changed since "
                                                       f"(its sha256 differs): {remedy} to use it anyway")])
        return PlanProblem(problem, ProblemSource.RECORDED, _not_shipped(problem, record["path"]))
    if not name:
        raise PlanFileError([Issue("problem", f"it does not name its problem (a plan.csv does not): {remedy}")])
    problem = _shipped_named(name)
    gone = f"it was planned from {record['path']}, which is gone" if record is not None else ""
    if problem is None:
        names = ", ".join(load_problem(p).name for p in shipped_problems() + shipped_rows())  # (an error: once)
        raise PlanFileError([Issue("problem", f"{gone + ', and ' if gone else ''}it is a plan of problem {name!r}, "
                                              f"which is not a shipped problem ({names}): {remedy}")])
    if record is not None and problem.digest != record["sha256"]:
        raise PlanFileError([Issue("problem_file", f"{gone}; the shipped problem {problem.name!r} is another text (its "
                                                   f"sha256 differs): {remedy}")])
    note = (f"the plan records no problem file{' that still exists' if record is not None else ''}: taken to be the "
            f"shipped problem {problem.name!r} ({problem.source or ''}); if it was planned on a changed problem, "
            f"{remedy}")
    return PlanProblem(problem, ProblemSource.SHIPPED, note)


SHIPPED_NAME_LINE = re.compile(r"^name:\s*(\S+)\s*$", re.MULTILINE)  # (a shipped file's name line: one plain word)


def _shipped_named(name: str) -> Problem | None:
    """The shipped problem or row named ``name``, or None: found by each file's name line first
    (loading every shipped problem took 0.25-0.6 s on each plot, view, export or verify of a plan)."""
    named = [s for s in shipped_problems() + shipped_rows()
             if (m := SHIPPED_NAME_LINE.search(Path(s).read_text(encoding="utf-8"))) and m.group(1) == name]
    return next((q for q in (load_problem(s) for s in named) if q.name == name), None)


def _not_shipped(problem: Problem, path: str) -> str:
    """A note where the recorded file at ``path`` names a shipped problem but is another text: a
    plan verified or exported against it is held to that file's limits and fruit, not the shipped
    problem's (a copy of crossing_paths with its limits raised certified a plan twice as fast as
    "crossing-paths ... passed", no word of which file); '' otherwise."""
    shipped = shipped_problems() + shipped_rows()
    if any(Path(path).resolve() == Path(s).resolve() for s in shipped):
        return ""
    twin = _shipped_named(problem.name)
    if twin is None or twin.digest == problem.digest:
        return ""
    return (f"its problem is taken from {path}, the file the plan records, which bears the name of the shipped "
            f"problem {problem.name!r} ({twin.source}) but is another text (its limits, fruit or arms may differ)")
