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


# f1 sits 0.1 m above b's base: only a reaches it, and a's tip there is within the clearance
# of b's shoulder whatever pose b takes -- no plan can pick it
IMPOSSIBLE = """
name: impossible
defaults:
  links: [1.0, 0.8]
  link_radius: 0.04
  joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]]
  max_velocity: [3.0, 4.0]
  max_acceleration: [8.0, 12.0]
  max_jerk: [80.0, 120.0]
  home: [1.5708, 0.5]
arms:
  - {name: a, base: [0.0, 0.0], bin: [0.0, -0.5]}
  - {name: b, base: [1.0, 0.0], bin: [1.0, -0.5]}
fruits:
  - {id: f1, position: [1.0, 0.1]}
task: {pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}
"""


def course_arms_row(end: float, fruits: dict[str, tuple[float, float]], name: str = "course-arms-row") -> str:
    """The course's three arms (bases -2, 0, 2 m on the carriage, bins 0.5 m below) on a rail
    from 0 to ``end`` m, with ``fruits`` (id -> row position): a row's YAML text."""
    rows = "\n".join(f"  - {{id: {k}, position: [{x}, {y}]}}" for k, (x, y) in fruits.items())
    return f"""name: {name}
defaults: {{links: [1.0, 0.8], link_radius: 0.04, joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]],
           max_velocity: [3.0, 4.0], max_acceleration: [8.0, 12.0], max_jerk: [80.0, 120.0], home: [1.0472, 0.7854]}}
arms:
  - {{name: arm1, base: [-2.0, 0.0], bin: [-2.0, -0.5]}}
  - {{name: arm2, base: [0.0, 0.0], bin: [0.0, -0.5]}}
  - {{name: arm3, base: [2.0, 0.0], bin: [2.0, -0.5]}}
fruits:
{rows}
task: {{pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}}
gantry: {{start: 0.0, end: {end}, max_velocity: 0.5, max_acceleration: 0.5, max_jerk: 5.0}}
"""
