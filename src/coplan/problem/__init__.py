"""Stage 1, the problem: a YAML file read safely, checked completely, as a frozen :class:`Problem`.

- :mod:`.model`: the ``Problem`` (``Arm``, ``Fruit``, ``Task``), :func:`load_problem`,
  :func:`parse_problem`, the shipped problems
- :mod:`.yamlsafe`: safe YAML (no tags, anchors or aliases; size caps; key path -> line)
- :mod:`.plausible`: the documented plausible range of every field (``BOUNDS``) and the
  longest plan coplan writes
- :mod:`.generate`: generated rows and random layouts (sweeps, tests)
"""

from .model import (
    Arm,
    Fruit,
    Problem,
    Task,
    default_problem_path,
    load_problem,
    parse_problem,
    shipped_problems,
)

__all__ = ["Arm", "Fruit", "Problem", "Task", "default_problem_path", "load_problem", "parse_problem", "shipped_problems"]
