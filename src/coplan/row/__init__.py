"""The row stage: a mobile gantry's carriage along a greenhouse row, stop by stop or on the move.

* :mod:`coplan.row.reach` -- :func:`row_reach`: from which carriage positions each arm harvests each fruit.
* :mod:`coplan.row.stops` -- the stop rules (optimised, fixed stride, fewest stops).
* :mod:`coplan.row.plan` -- :func:`plan_row`: stops, each stop's cell, one verified row plan.
* :mod:`coplan.row.moving` -- :func:`plan_moving`: pick on the move, the speed searched, each
  candidate a plan of :mod:`coplan.row.continuous` (the carriage never stops;
  :mod:`~coplan.row.cruise` its motion and the pick windows, :mod:`~coplan.row.track` the tip held
  over a moving fruit, :mod:`~coplan.row.booking` cycles booked clear of the neighbours,
  :mod:`~coplan.row.assign` CP-SAT's assignment and order).
* :mod:`coplan.row.metrics` -- fruit per hour, share harvested, idle by cause, real-time figures.
* :mod:`coplan.row.live` -- :func:`run_live_row`: a live row from a simulated camera
  (:mod:`~coplan.row.sensing` its options and faults, :mod:`~coplan.row.livemove` the carriage's
  motion changed on the move).

The entry points and their options are also names of this package (``from coplan.row import
RowOptions, plan_row``), imported when first used.
"""

_SUBMODULES = ("assign", "booking", "continuous", "cruise", "live", "livemove", "liverun", "livestops", "metrics", "moving", "plan",
               "reach", "sensing", "stops", "stranded", "track")


_EXPORTS = {"plan_row": "plan", "RowOptions": "plan", "RowResult": "plan", "plan_moving": "moving",
            "MovingOptions": "continuous", "run_live_row": "live", "LiveRowOptions": "sensing", "RowFaults": "sensing",
            "StopWindow": "stops", "row_metrics": "metrics",
            "row_bounds": "coplan.allocate.row_bound", "RowBounds": "coplan.allocate.row_bound"}  # (the bounds: stage 2's)
__all__ = sorted(_EXPORTS)


def __getattr__(name: str):
    # the submodules the docs name (``coplan.row.moving.plan_moving``), reachable after
    # ``import coplan``, and the entry points and options (``from coplan.row import RowOptions``)
    import importlib

    if name in _SUBMODULES:
        return importlib.import_module(f".{name}", __name__)
    if name in _EXPORTS:
        mod = _EXPORTS[name]
        return getattr(importlib.import_module(mod if mod.startswith("coplan.") else f".{mod}", __name__), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__():  # (tab completion: the lazy names too)
    return sorted(set(globals()) | set(_EXPORTS) | set(_SUBMODULES))
