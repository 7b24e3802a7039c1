"""Which elbow branches reach a fruit from each carriage position: screened once per problem.

For :class:`coplan.row.booking.Booker` (:meth:`~coplan.row.booking.Booker.branches`) and the
row planners that book many candidates of one row (a speed search, the moving stops): the table
depends on the geometry only, not on the carriage's motion, so every booking of one fixed
problem shares it.
"""

from __future__ import annotations

import math
import weakref

import numpy as np

from ..allocate.screen import usable_picks
from ..problem.gantry import cell_at
from ..problem.model import Problem

__all__ = ["branch_table", "screen_branches"]

#: Per problem and grid step: (arm index, fruit id) -> (first carriage position, (K, 2) usable
#: branches at positions first + k step). It depends on the geometry only, not on the carriage's
#: motion, so every candidate of a speed search shares it (forked workers inherit it screened).
_BRANCHES: "weakref.WeakKeyDictionary[Problem, dict[float, dict]]" = weakref.WeakKeyDictionary()


def branch_table(problem: Problem, step: float) -> dict[tuple[int, str], tuple[float, np.ndarray]]:
    """The elbow branches screened so far for ``problem`` (immutable) on grid ``step``, shared by
    every :class:`coplan.row.booking.Booker` given it (:func:`screen_branches` fills it)."""
    return _BRANCHES.setdefault(problem, {}).setdefault(float(step), {})


def screen_branches(problem: Problem, step: float, pairs, table: dict, xy: dict | None = None, cell: Problem | None = None) -> dict:
    """Screen each ``(arm index, fruit id)`` of ``pairs`` into ``table`` for
    :meth:`Booker.branches`, each arm's in one vectorised call; pairs already in it are skipped.
    Each pair's points are computed as alone (the same positions, the same answers). ``xy``:
    fruit id -> where the fruit is (None: the problem's positions; a live row's booker passes its
    own, moved by the close-range measurement); ``cell``: the problem in the carriage frame
    (None: made here). Returns ``table``."""
    cell = cell if cell is not None else cell_at(problem, 0.0, ())  # the carriage frame
    g = problem.gantry
    if xy is None:
        xy = {f.id: (float(f.position[0]), float(f.position[1])) for f in problem.fruits}
    todo: dict[int, list[tuple[str, float, np.ndarray]]] = {}
    for i, fid in dict.fromkeys(pairs):
        if (i, fid) in table:
            continue
        x, y = xy[fid]
        arm = problem.arms[i]
        # on the row screen's grid (positions g.start + k step), so a window's ends are grid points
        lo = g.start + step * max(0, math.floor((x - arm.base[0] - arm.reach - g.start) / step) - 1)
        cs = lo + step * np.arange(int(math.ceil((x - arm.base[0] + arm.reach - lo) / step)) + 2)
        todo.setdefault(i, []).append((fid, lo, np.c_[x - cs, np.full(cs.size, y)]))
    for i, items in todo.items():
        use = usable_picks(cell, np.concatenate([p for _, _, p in items]), arms=(i,))[i]
        at = 0
        for fid, lo, p in items:
            table[(i, fid)] = (lo, use[at:at + len(p)])
            at += len(p)
    return table
