"""One coordinated candidate (:class:`Coordinated`): allocation, conflict-free schedules and
how they were made -- what the coordinated planner's stages, its fallbacks and the optimal
planner's search pass around."""

from __future__ import annotations

from dataclasses import dataclass, field

from ...allocate.allocation import Allocation
from .schedule import ArmSchedule

__all__ = ["Coordinated", "makespan_of"]


@dataclass
class Coordinated:
    """One coordinated candidate: allocation, conflict-free schedules, priority order used."""

    alloc: Allocation
    schedules: dict[str, ArmSchedule]
    makespan: float
    order: list[str] = field(default_factory=list)
    variant: str = "branches"
    waits: int = 0
    fallback: bool = False
    left_out: dict = field(default_factory=dict)  # fruit -> why it could not be scheduled

    @property
    def total(self) -> float:
        """Sum of the arms' last places (the search's tie-breaker)."""
        return float(sum(s.last_place for s in self.schedules.values()))


def makespan_of(schedules: dict[str, ArmSchedule]) -> float:
    return max((s.last_place for s in schedules.values()), default=0.0)
