"""Stage 2, allocation: which arm picks which fruit, in which order, with which elbow branch.

- :mod:`.screen`: static feasibility from what never moves (locked arms, unharvestable fruit)
- :mod:`.allocation`: :func:`allocate` (the course's heuristic score or the min-makespan
  MILP) and the lower bound (:func:`bound_details`) with its own assignment
"""

from .allocation import Allocation, LowerBound, allocate, bound_allocation, bound_details, lower_bound
from .screen import Screen, screened

__all__ = ["Allocation", "LowerBound", "allocate", "bound_allocation", "bound_details", "lower_bound", "Screen",
           "screened"]
