"""An arm's work as legs: a move to a pose, then its pick or place (the unit the coordinator
books, :mod:`coplan.planners.coordinated.coordinate`, and the serial fallback orders,
:mod:`coplan.planners.coordinated.serial`)."""

from __future__ import annotations

from dataclasses import dataclass

from ...problem.model import Problem
from .routing import same_pose
from .schedule import ArmSchedule, StepKind

__all__ = ["Leg", "legs_of"]


@dataclass
class Leg:
    """One unit of an arm's work: a move to ``target`` (then an optional pick/place dwell)."""

    target: tuple[float, float]
    kind: StepKind | None = None  # PICK / PLACE after the move, or None
    dwell: float = 0.0
    fruit: str | None = None
    point: tuple[float, float] | None = None  # world point of a pick/place (for the other IK branch)
    home: bool = False  # the final move home


def legs_of(problem: Problem, sch: ArmSchedule, always_home: bool = False) -> list[Leg]:
    """An arm's schedule as legs (waits dropped); it ends with a move home if it has any legs
    (``always_home``: even if it has none). Also the serial fallback's (:mod:`coplan.planners.coordinated.serial`)."""
    arm = sch.arm
    fruit_pos = {f.id: tuple(map(float, f.position)) for f in problem.fruits}
    legs: list[Leg] = []
    for st in sch.steps:
        if st.kind == StepKind.MOVE:
            legs.append(Leg(tuple(map(float, st.q1))))
        elif st.kind in (StepKind.PICK, StepKind.PLACE):
            point = fruit_pos[st.fruit] if st.kind == StepKind.PICK else tuple(map(float, arm.bin))
            leg = Leg(tuple(map(float, st.q1)), st.kind, st.duration, st.fruit, point)
            if legs and legs[-1].kind is None and same_pose(legs[-1].target, leg.target):
                legs[-1].kind, legs[-1].dwell, legs[-1].fruit, legs[-1].point = leg.kind, leg.dwell, leg.fruit, leg.point
            else:  # a dwell right where the arm already is
                legs.append(leg)
    home = tuple(map(float, arm.home))
    if legs and legs[-1].kind is None and same_pose(legs[-1].target, home):
        legs[-1].home = True
    elif legs or always_home:
        legs.append(Leg(home, home=True))
    return legs
