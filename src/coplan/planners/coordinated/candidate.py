"""One coordinated candidate (:class:`Coordinated`): allocation, conflict-free schedules and
how they were made -- what the coordinated planner's stages, its fallbacks and the optimal
planner's search pass around."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

from ...allocate.allocation import Allocation
from .schedule import ArmSchedule

__all__ = ["BranchRule", "Fallback", "Coordinated", "makespan_of"]


class BranchRule(str, Enum):
    """How a candidate's elbow branches are chosen from its allocation and orders: the fastest
    (each arm's dynamic programme alone), or keeping out of the neighbours' way with each
    move charged a price (s) per neighbour pose it would hit
    (:func:`coplan.planners.coordinated.routing.choose_branches`). ``BRANCHES`` (0.5 s) is the
    coordinated planner's rule; the optimal planner's search also tries lighter and heavier prices."""

    FASTEST = "fastest"
    AVOID_LIGHT = "avoid-0.1"
    AVOID_SOME = "avoid-0.25"
    BRANCHES = "branches"
    AVOID_HEAVY = "avoid-1.0"

    @property
    def price(self) -> float:
        return _PRICE[self]


_PRICE = {BranchRule.FASTEST: 0.0, BranchRule.AVOID_LIGHT: 0.1, BranchRule.AVOID_SOME: 0.25, BranchRule.BRANCHES: 0.5,
          BranchRule.AVOID_HEAVY: 1.0}


class Fallback(str, Enum):
    """How a candidate was made when no coordinated one was found: the arms' picks in turns
    (``SERIAL``), or each arm alone while the others wait at home (``ONE_AT_A_TIME``)."""

    SERIAL = "serial"
    ONE_AT_A_TIME = "one_at_a_time"


@dataclass
class Coordinated:
    """One coordinated candidate: allocation, conflict-free schedules, priority order used."""

    alloc: Allocation
    schedules: dict[str, ArmSchedule]
    makespan: float
    order: list[str] = field(default_factory=list)
    variant: BranchRule | Fallback = BranchRule.BRANCHES  # how its schedules were made
    waits: int = 0
    fallback: bool = False
    left_out: dict = field(default_factory=dict)  # fruit -> why it could not be scheduled
    margin: float | None = None  # the buffer it was coordinated with, where not the options' (0: the clearance alone)

    @property
    def total(self) -> float:
        """Sum of the arms' last places (the search's tie-breaker)."""
        return float(sum(s.last_place for s in self.schedules.values()))


def makespan_of(schedules: dict[str, ArmSchedule]) -> float:
    return max((s.last_place for s in schedules.values()), default=0.0)
