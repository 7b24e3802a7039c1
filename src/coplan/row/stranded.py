"""After a fault: which fruit a working arm could still have harvested (a live row's report).

A live row (:mod:`coplan.row.live`) counts the fruit it missed though a working arm could still
reach them: the true fruit, from a carriage position the carriage had not yet passed when the
arm stopped (stop and go: one it could still brake to -- picks are made at rest), under the
screen's rules (:func:`coplan.allocate.screen.usable_picks`), with a pick pose that keeps the
clearance from every stopped arm where it rests. Entry point: :func:`still_reachable`.
"""

from __future__ import annotations

import numpy as np

from ..problem.model import Problem
from .booking import Booker
from .cruise import stop_from

__all__ = ["still_reachable"]


def _cannot_stop_at(problem: Problem, state, x_to: float) -> bool:
    try:
        stop_from(problem, state, x_to)
    except ValueError:
        return True
    return False


def still_reachable(booker: Booker, grid: np.ndarray, xy, t0: float, working: list[int], halt: dict[int, float],
                    at_rest: bool) -> bool:
    """Whether a working arm can pick the fruit at row point ``xy`` from a carriage position at
    or ahead of where ``booker``'s carriage is at ``t0`` (it never goes back; ``at_rest``: stop and
    go, where it can still come to rest from its motion then), on the row screen's ``grid``,
    under the screen's rules (:func:`coplan.allocate.screen.usable_picks`), with a pick pose
    that keeps the clearance from every stopped arm where it rests (the screen knows nothing of
    a stopped arm; a pose blocked by one is no longer reachable)."""
    from ..allocate.screen import usable_picks
    from ..planners.coordinated.schedule import arm_points, points_too_close

    problem = booker.problem
    cruise = booker.cruise
    state = tuple(float(u[0]) for u in cruise.state(np.array([min(t0, cruise.duration)])))  # x, v, a then
    cs = grid[(grid >= state[0] - 1e-9) & (grid <= cruise.x1 + 1e-9)]
    if at_rest and abs(state[1]) + abs(state[2]) > 1e-12:  # picks only at rest: where it can still come to rest
        while cs.size and _cannot_stop_at(problem, state, float(cs[0])):
            cs = cs[1:]
    if cs.size == 0 or not working:
        return False
    pts = np.c_[xy[0] - cs, np.full(cs.size, xy[1])]
    cell = booker.cell  # the carriage frame
    use = usable_picks(cell, pts, arms=tuple(working))
    for a in working:
        arm = cell.arms[a]
        q, _ = arm.ik(pts)
        for b in (0, 1):
            ok = use[a, :, b]
            if not ok.any():
                continue
            pa = arm_points(arm, q[ok, b])
            for j in halt:
                rest = booker.arms[j].q[booker.arms[j].k_free]
                clear = ~points_too_close(pa, arm_points(cell.arms[j], rest), arm.link_radius + cell.arms[j].link_radius,
                                          problem.task.clearance)
                pa = tuple(p[clear] for p in pa)
            if pa[0].size:
                return True
    return False
