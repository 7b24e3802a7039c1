"""Stage 1, the problem: a YAML file read safely, checked completely, as a frozen :class:`Problem`.

- :mod:`.model`: the immutable ``Problem`` (``Arm``, ``Fruit``, ``Task``), checked however it is made
- :mod:`.load`: :func:`load_problem` (a file), :func:`parse_problem` (text), ``file_record`` (the
  file a problem came from, for a plan to name it), the shipped problems
- :mod:`.yamlsafe`: safe YAML (no tags, anchors or aliases; size caps; key path -> line)
- :mod:`.plausible`: the documented plausible range of every field (``BOUNDS``) and the
  longest plan coplan writes
- :mod:`.generate`: generated rows and random layouts (sweeps, tests)
- :mod:`.poses`: home poses apart, homes in their limits, bins reachable, one fruit per position
- :mod:`.gantry`: a row's mobile gantry (``Gantry``, ``cell_at``: the cell at a carriage position)
- :mod:`.spec`: the raw schema of a problem file (pydantic validators and models)
"""

from .model import Arm, Fruit, Problem, Task
from .given import problem_from_mapping
from .load import default_problem_path, load_problem, parse_problem, shipped_problems, shipped_rows

__all__ = ["Arm", "Fruit", "Problem", "Task", "default_problem_path", "load_problem", "parse_problem", "problem_from_mapping",
           "shipped_problems", "shipped_rows"]
