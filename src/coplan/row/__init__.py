"""The row stage: a mobile gantry's carriage along a greenhouse row, stop by stop.

* :mod:`coplan.row.reach` -- :func:`row_reach`: from which carriage positions each arm harvests each fruit.
* :mod:`coplan.row.stops` -- the stop rules (optimised, fixed stride, fewest stops).
* :mod:`coplan.row.plan` -- :func:`plan_row`: stops, each stop's cell, one verified row plan.
* :mod:`coplan.row.bound` -- the row's lower bounds.
* :mod:`coplan.row.metrics` -- fruit per hour, share harvested, idle by cause, real-time figures.
"""
