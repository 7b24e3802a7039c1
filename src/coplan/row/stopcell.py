"""A live stop's leftovers planned as a cell (:meth:`coplan.row.stopgo.StopAndGo.as_cell`).

At a stop the live arms book direct moves between bin and fruit, one cycle at a time
(:mod:`coplan.row.booking`). Where arms stand close (about 1.5 m apart or less), a neighbour,
resting or working, can stand in the way of every such move, and the stop's share was left --
passed for good once the carriage hopped on (12 m rows with arms 1.2 m apart, seeds 0-3: 1-6
of the 32-46 fruit the offline plan harvests, the carriage creeping on in 5 cm hops). The
offline stop-and-go planner plans each stop as a cell, whose coordinator tucks an arm round its
neighbour. :func:`book_cell` does the same for what the live booking left: once every arm's
booked motion is over, the leftovers are planned by
:func:`coplan.planners.coordinated.plan_coordinated` on the cell the carriage makes there, each
arm starting and ending where it rests then (the fruit where the close-range camera measured
them), and the cell plan is booked for every arm from that instant on.
"""

from __future__ import annotations

import time as _time
from dataclasses import dataclass, replace
from typing import Callable

import numpy as np

from ..plan import Event, EventKind, PlanStatus
from ..planners.coordinated.schedule import arm_points, points_too_close
from ..problem.gantry import cell_at
from ..problem.model import Fruit
from .booking import Booker, Cycle

__all__ = ["CellBooking", "book_cell"]


@dataclass(frozen=True)
class CellBooking:
    """What :func:`book_cell` did: the fruit it booked, and why it booked nothing where it did not."""

    picked: tuple[str, ...]
    seconds: float  # wall time of the decision (planning, checking)
    why_not: str = ""
    probed: tuple[str, ...] = ()  # reports the arm came to and found empty (``found`` False): probes
    lead: float = 0.0  # s from ``t_from`` (the decision's instant) to the first motion the cell plan books:
    # the time the decision has -- every arm's booked motion runs until then


def book_cell(booker: Booker, fruit: list[str], x: float, t_from: float,
              found: Callable[[str], bool] | None = None) -> CellBooking:
    """Book ``fruit`` (report ids; their positions ``booker.fruit_xy``) as a cell plan at carriage
    position ``x``, where it rests from ``t_from`` on for the whole of it: the coordinated cell
    plan from the instant every arm's booked motion is over (and ``t_from``), each arm starting
    and ending where it rests then. Booked only where the run draws no arm fault (the cell plan
    does not model an arm that stops), the cell plan verified and every pair of neighbours kept ``booker.need``
    apart in it (clearance and the live margin); otherwise nothing is booked and ``why_not``
    says why.
    ``found(fid)``, asked in the order of the cell plan's picks: whether the close-range camera
    finds the fruit there when the arm comes (a second report of a fruit picked a moment before:
    False) -- where it does not, the arm's motion stays as planned, its pick and place are no
    events, and the report is a probe (:attr:`Booker.probes`)."""
    from ..planners.coordinated import CoordinatedOptions, plan_coordinated

    t0 = _time.perf_counter()
    problem = booker.problem
    k_start = max([booker.up(t_from)] + [st.k_free for st in booker.arms])  # (the cell's first motion)
    lead = max(0.0, k_start * booker.dt - t_from)

    def none(why: str) -> CellBooking:
        return CellBooking((), _time.perf_counter() - t0, why, lead=lead)

    if not fruit:
        return none("nothing left")
    if booker.halted:
        return none("the run draws an arm fault: the cell plan does not model an arm that stops")
    rest = [st.q[st.k_free].copy() for st in booker.arms]
    arms = tuple(replace(a, home=(float(r[0]), float(r[1]))) for a, r in zip(problem.arms, rest))
    cell = cell_at(replace(problem, arms=arms, fruits=tuple(Fruit(f, tuple(booker.fruit_xy[f])) for f in fruit)), x,
                   name=f"{problem.name}: the stop at {x:.3f} m")
    # (the booking's clearance is a requirement here, not a buffer to drop: a plan within it is refused below)
    res = plan_coordinated(cell, options=CoordinatedOptions(margin=booker.need - problem.task.clearance, relax_margin=False))
    plan = res.plan
    if plan.status not in (PlanStatus.SUCCESS, PlanStatus.PARTIAL) or not any(
            e.kind == EventKind.PICK for e in plan.events):
        return none(f"the cell planner harvested none of them ({plan.status.value})")
    if round(plan.dt * booker.rate) != 1:
        return none("the cell plan's grid is not the booker's")
    qs = [plan.q[a.name] for a in problem.arms]
    for i, j in problem.neighbour_pairs():
        a, b = problem.arms[i], problem.arms[j]
        if points_too_close(arm_points(a, qs[i]), arm_points(b, qs[j]), a.link_radius + b.link_radius,
                            booker.need).any():
            return none("the cell plan comes within the live margin of a neighbour")
    if any(not np.allclose(q[[0, -1]], r, atol=1e-9) for q, r in zip(qs, rest)):
        return none("the cell plan does not start and end where the arms rest")
    for i, st in enumerate(booker.arms):
        q = np.vstack([np.repeat(st.q[st.k_free:st.k_free + 1], k_start - st.k_free, axis=0), qs[i]])
        booker.commit(Cycle(i, "", st.k_free, q, []))
    t_shift = k_start * booker.dt
    empty = set()
    for e in sorted(plan.events, key=lambda e: (e.t_start, e.arm)):
        if e.kind == EventKind.PICK and found is not None and not found(e.fruit):
            empty.add(e.fruit)
            booker.probes.add(e.fruit)
    events = [Event(e.arm, e.fruit, e.kind, e.t_start + t_shift, e.t_end + t_shift) for e in plan.events
              if e.fruit not in empty]
    booker.events += events
    picked = {e.fruit for e in events if e.kind == EventKind.PICK}
    names = [a.name for a in problem.arms]
    for a, fs in plan.allocation.items():
        booker.arms[names.index(a)].fruit += [f for f in fs if f in picked]
    booker.work_end = max([booker.work_end] + [e.t_end for e in events])
    return CellBooking(tuple(sorted(picked)), _time.perf_counter() - t0, probed=tuple(sorted(empty)), lead=lead)
