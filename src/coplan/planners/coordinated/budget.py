"""The coordinator's work caps: how many conflict checks one run may spend on a problem."""

from __future__ import annotations

from ...problem.model import Problem

__all__ = ["CHECKS_PER_FRUIT", "attempt_checks"]

CHECKS_PER_FRUIT = 8  # a run books about 3-5 conflict checks per fruit (measured on rows of 100-300 fruit)


def attempt_checks(problem: Problem, at_least: int, per_fruit: int = CHECKS_PER_FRUIT) -> int:
    """The work cap of one coordinator run on ``problem``: ``at_least`` (the option), or
    ``per_fruit`` checks per fruit on a longer row -- a fixed cap would make every run on a few
    hundred fruit fail for want of checks, however easy the row."""
    return max(int(at_least), int(per_fruit) * len(problem.fruits))
