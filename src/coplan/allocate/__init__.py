"""Stage 2, allocation: which arm picks which fruit, in which order, with which elbow branch.

- :mod:`.screen`: static feasibility from what never moves (locked arms, unharvestable fruit)
- :mod:`.allocation`: :func:`allocate` (the course's heuristic score or the min-makespan
  MILP) and the lower bound (:func:`bound_details`) with its own assignment
- :mod:`.row_bound`: a row's lower bounds (:func:`row_bounds`: for any motion and for stop and
  go; :func:`cycle_bounds`: each fruit's cheapest harvest cycle per arm and carriage position)
"""

from .allocation import Allocation, LowerBound, allocate, bound_allocation, bound_details, lower_bound
from .row_bound import RowBounds, cycle_bounds, row_bounds
from .screen import Screen, screened

__all__ = ["Allocation", "LowerBound", "allocate", "bound_allocation", "bound_details", "lower_bound", "RowBounds",
           "cycle_bounds", "row_bounds", "Screen", "screened"]
