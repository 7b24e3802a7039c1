"""``coplan.generate``: the documented path of the problem generators (README:
``coplan.generate`` makes rows and random layouts: ``row_problem``, ``random_problem``,
``cell_problem``, ``gantry_row`` (a row on a mobile gantry), ``to_yaml`` (of a mapping or a
``Problem``), ``problem_dict``).

Only a re-export: the code is in :mod:`coplan.problem.generate`. Nothing inside coplan
imports this module.
"""

from .problem.generate import (
    LESSON_DEFAULTS,
    LESSON_GANTRY,
    LESSON_TASK,
    cell_problem,
    gantry_row,
    overlap_problem,
    problem_dict,
    random_problem,
    row_problem,
    to_yaml,
)

__all__ = ["row_problem", "overlap_problem", "random_problem", "cell_problem", "gantry_row", "to_yaml", "problem_dict", "LESSON_DEFAULTS",
           "LESSON_TASK", "LESSON_GANTRY"]
