"""Stage 2, allocation: which arm picks which fruit, in which order, with which elbow branch.

- :mod:`.screen`: static feasibility from what never moves (locked arms, unharvestable fruit)
- :mod:`.allocation`: :func:`allocate` (the course's heuristic score or the min-makespan
  MILP) and the lower bound (:func:`bound_details`) with its own assignment
- :mod:`.row_bound`: a row's lower bounds (:func:`row_bounds`: for any motion and for stop and
  go), from :mod:`.row_cycles` (:func:`cycle_bounds`: each fruit's cheapest harvest cycle per
  arm over carriage positions) and :mod:`.stop_bound` (stops and positions priced together)

``coplan.allocate`` names this package and the stage's entry function at once: calling the
package calls :func:`allocate` (``coplan.allocate(problem, "makespan")``). Python binds the name
to the package whenever anything imports it -- a solve does -- so a documented call became
"'module' object is not callable" after one.
"""

import sys as _sys
import types as _types

from .allocation import Allocation, LowerBound, allocate, bound_allocation, bound_details, lower_bound
from .row_bound import RowBounds, cycle_bounds, row_bounds
from .screen import Screen, screened

__all__ = ["Allocation", "LowerBound", "allocate", "bound_allocation", "bound_details", "lower_bound", "RowBounds",
           "cycle_bounds", "row_bounds", "Screen", "screened"]


class _Stage(_types.ModuleType):
    """This package, callable as its entry function (module docstring)."""

    def __call__(self, *args, **kwargs) -> Allocation:
        return allocate(*args, **kwargs)


_sys.modules[__name__].__class__ = _Stage
