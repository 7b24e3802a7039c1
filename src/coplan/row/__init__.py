"""The row stage: a mobile gantry's carriage along a greenhouse row, stop by stop or on the move.

* :mod:`coplan.row.reach` -- :func:`row_reach`: from which carriage positions each arm harvests each fruit.
* :mod:`coplan.row.stops` -- the stop rules (optimised, fixed stride, fewest stops).
* :mod:`coplan.row.plan` -- :func:`plan_row`: stops, each stop's cell, one verified row plan.
* :mod:`coplan.row.continuous` -- :func:`plan_moving`: pick on the move (the carriage never stops;
  :mod:`~coplan.row.cruise` its motion and the pick windows, :mod:`~coplan.row.track` the tip held
  over a moving fruit, :mod:`~coplan.row.booking` cycles booked clear of the neighbours,
  :mod:`~coplan.row.assign` CP-SAT's assignment and order), the speed searched.
* :mod:`coplan.row.bound` -- the row's lower bounds.
* :mod:`coplan.row.metrics` -- fruit per hour, share harvested, idle by cause, real-time figures.
"""

_SUBMODULES = ("assign", "booking", "bound", "continuous", "cruise", "live", "liverun", "livestops", "metrics", "plan",
               "reach", "sensing", "stops", "stranded", "track")


def __getattr__(name: str):
    # the submodules the docs name (``coplan.row.continuous.plan_moving``), reachable after ``import coplan``
    if name in _SUBMODULES:
        import importlib

        return importlib.import_module(f".{name}", __name__)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
