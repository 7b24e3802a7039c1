"""What :func:`coplan.planners.optimal.search.improve` is given and why it stops: its options
(work budgets, moves, seed), its moves, the elbow-branch rules a state may use, and its stop reasons."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from ..coordinated.candidate import BranchRule

__all__ = ["BranchRule", "Move", "SearchOptions", "StopReason"]


class Move(str, Enum):
    """The search's moves (:mod:`coplan.planners.optimal.search`'s docstring says what each does)."""

    FIRST = "first"
    RELOCATE = "relocate"
    SWAP = "swap"
    EXCHANGE = "exchange"
    MOVE = "move"
    TWOOPT = "twoopt"
    REVERSE = "reverse"
    FLIP = "flip"
    VARIANT = "variant"
    PRIORITY = "priority"


class StopReason(str, Enum):
    PROVEN_OPTIMAL = "proven_optimal"  # the makespan meets the lower bound
    BUDGET = "budget"  # the work budget (evaluations) is spent
    STALLED = "stalled"  # no improvement within ``patience`` evaluations, after ``starts`` fresh starts
    TIME_LIMIT = "time_limit"  # the explicit clock limit
    INTERRUPTED = "interrupted"  # Ctrl-C
    EXHAUSTED = "exhausted"  # every state was tried or bounded out: the coordinator's best


@dataclass(frozen=True)
class SearchOptions:
    """Work budget and rules of :func:`improve`.

    evaluations : coordinator runs (a cap)
    work : conflict checks over all coordinator runs (the work budget: proportional to
        time on a given machine, and the same on every machine)
    patience : after this many evaluations without a new best, start afresh from the start
        state (the moves' random stream goes on, so the new start explores elsewhere); stop
        after ``starts`` such fresh starts
    starts : fresh starts before the search stops for lack of progress
    stall : restart from the best state (with ``kick`` random moves) after this many
        evaluations without progress of the current state
    attempt_checks : work cap of one coordinator run (conflict checks), or ``checks_per_fruit``
        per fruit if more (:func:`~coplan.planners.coordinated.budget.attempt_checks`)
    seed : seed of the move generator
    fixed_assignment : keep which arm takes which fruit (order, branches and priorities
        still change); used when the caller asked for a given allocation method
    tolerance : a makespan this close to the lower bound (s) is optimal
    exhaustive : when the whole state space (allocations x orders x elbow branches x variants x
        priorities) has at most this many states, and at most half of ``evaluations`` of them
        have an estimate below the start's makespan, try those instead, cheapest estimate
        first, until the estimate alone cannot beat the best (branch and bound): the result
        is then the best plan the coordinator can make; 0 turns this off
    temperature : accept a slower state with probability exp(-(its makespan - current) / T),
        T falling linearly from ``temperature`` (s) to 0 as the first ``cooling`` checks of the
        work budget are spent (simulated annealing, seeded like the moves); the best state is
        kept whatever is accepted
    cooling : work (checks) over which the temperature falls to 0 (at most ``work``); a larger
        budget then buys more descent and fresh starts, not a longer random walk
    """

    evaluations: int = 400
    work: int = 8_000
    patience: int = 60
    starts: int = 0
    stall: int = 25
    kick: int = 2
    attempt_checks: int = 600
    checks_per_fruit: int = 8
    seed: int = 0
    fixed_assignment: bool = False
    tolerance: float = 1e-3
    temperature: float = 0.0
    cooling: int = 30_000
    exhaustive: int = 20_000
