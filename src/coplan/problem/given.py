"""A problem as the entry points take it: a :class:`~coplan.problem.model.Problem`, a mapping
(as :mod:`coplan.generate` makes them) or a file's path or a shipped name.

* :func:`as_problem` -- any of those as a Problem, each caller refusing anything else in its
  own words (``coplan.verify``, ``coplan.report.rows.compare_rows``, ``run_live_row``; ``coplan.solve``
  with ``load_problem``'s).
* :func:`problem_from_mapping` -- a mapping checked as a file is, its issues named by key path.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Mapping
from dataclasses import replace
from typing import Any

from ..errors import Issue, ProblemError
from .generate import UnwritableValue, to_yaml
from .load import load_problem, parse_problem
from .model import Problem

__all__ = ["as_problem", "problem_from_mapping"]


def as_problem(problem, refused: Callable[[Any], str] | None = None) -> Problem:
    """``problem`` as a :class:`~coplan.problem.model.Problem`, taken as :func:`coplan.solve` takes
    it: a Problem as it is, a mapping checked as a file (:func:`problem_from_mapping`), a path or a
    shipped name read (:func:`coplan.problem.load.load_problem`); anything else
    ``TypeError(refused(problem))`` -- each entry point that takes a problem says what it takes in
    its own words -- or, with no ``refused``, :func:`~coplan.problem.load.load_problem`'s own
    refusal (``coplan.solve``'s)."""
    if isinstance(problem, Problem):
        return problem
    if isinstance(problem, Mapping):
        return problem_from_mapping(problem)
    if refused is None or isinstance(problem, (str, os.PathLike)):
        return load_problem(problem)
    raise TypeError(refused(problem))


def problem_from_mapping(data: Mapping[str, Any]) -> Problem:
    """A problem given as a mapping (as :mod:`coplan.generate` makes them), checked as a file is
    -- its issues named by key path only: the lines are those of a YAML text the caller never saw
    (``coplan.solve`` and ``coplan.verify`` take one)."""
    if not data:  # (it said "found an empty file")
        raise ProblemError([Issue("", "expected a mapping with keys name, arms, fruits, task; found an empty mapping")],
                           "a problem given as a mapping")
    try:
        text = to_yaml(dict(data))
    except UnwritableValue as e:  # (a TypeError with no key path)
        raise ProblemError([Issue(e.path, f"expected a number, string, boolean, null, list or mapping, found {e.found}")],
                           "a problem given as a mapping") from None
    try:
        return parse_problem(text, "a problem given as a mapping")
    except ProblemError as e:
        raise ProblemError([replace(i, line=None) for i in e.issues], e.source) from None
