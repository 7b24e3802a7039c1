"""Layouts shared by several test modules (imported as ``from layouts import ...``)."""

from __future__ import annotations

import numpy as np

from coplan.errors import ProblemError
from coplan.generate import random_problem, to_yaml
from coplan.problem import Problem, parse_problem


def squeezed(seed: int, n_fruits: int, name: str | None = None) -> Problem | None:
    """random_problem(seed) squeezed to bases 0.9-1.4 m apart (about half its arms lock);
    None when the squeeze puts a home pose too close to a neighbour's (invalid input)."""
    d = random_problem(seed, n_fruits=n_fruits)
    sp = float(np.random.default_rng(1000 + seed).uniform(0.9, 1.4))
    n = len(d["arms"])
    for i, a in enumerate(d["arms"]):
        x = round((i - (n - 1) / 2) * sp, 4)
        a["base"], a["bin"] = [x, 0.0], [x, a["bin"][1]]
    for f in d["fruits"]:
        f["position"][0] = round(f["position"][0] * sp / 1.8, 4)
    try:
        return parse_problem(to_yaml(d), name)
    except ProblemError:
        return None
