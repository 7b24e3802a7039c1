"""A record of one :func:`coplan.planners.coordinated.coordinate.coordinate` run, so that a
later run whose legs differ only from some leg on can start where they first differ.

The coordinator books legs in turns (one turn: the arm due first books its next leg, waits for
a neighbour, or breaks a deadlock). Until its first *barrier* -- a turn that looks at a
neighbour's remaining work (a finished arm checking whether home is in the way, parking, a
deadlock broken by a yield or the other elbow branch) -- a turn depends only on what is
already booked, on the one leg the arm due books, and on which arms still have legs. So a run
whose legs agree with a recorded one on every leg read before turn ``e`` (and on which arms
have legs left) makes exactly the same turns up to ``e``; :func:`resume_point` finds the
latest such ``e`` and the coordinator continues from the state recorded there. The result is
identical to a run from scratch (a property test checks this on seeded random searches).
"""

from __future__ import annotations

from dataclasses import dataclass, field

__all__ = ["Trace", "Turn", "resume_point"]


@dataclass(frozen=True)
class Turn:
    """The coordinator's state at the start of one turn, and what the turn reads.

    checks : conflict checks made before it
    t : the time the arm due tries its next leg
    arm : index of the arm due
    tracks : per arm ``(booked steps, end, pose, legs done, ready, stuck, blocker)``
    """

    checks: int
    t: float
    arm: int
    tracks: tuple

    def done(self, j: int) -> int:
        return self.tracks[j][3]


@dataclass
class Trace:
    """One run's record (filled by the coordinator when given one).

    key : what must be equal for a run to resume from this one (priority ranks, clearance,
        sampling rate, quantum, work cap, yield cap)
    legs : per arm, the legs it was given (tuples of :class:`~.legs.Leg`)
    turns : one :class:`Turn` per turn up to and including the first barrier
    barrier : index of the first barrier turn (None: the run had none)
    steps : per arm, every step the run booked (a turn's ``tracks`` say how many were booked before it)
    """

    key: tuple = ()
    legs: list = field(default_factory=list)
    turns: list = field(default_factory=list)
    barrier: int | None = None
    steps: list = field(default_factory=list)


def _first_difference(old: tuple, new: tuple) -> int | None:
    """Index of the first leg that differs (the shorter length if one is a prefix of the other);
    None if they are the same."""
    for i, (a, b) in enumerate(zip(old, new)):
        if a != b:
            return i
    return None if len(old) == len(new) else min(len(old), len(new))


def resume_point(trace: Trace, key: tuple, legs: list, horizon: float) -> int:
    """The latest turn of ``trace`` from which a run with ``key``, ``legs`` (per arm) and plan-time
    ``horizon`` makes the same turns as the recorded one did before it (0: start afresh)."""
    if key != trace.key or len(legs) != len(trace.legs) or not trace.turns:
        return 0
    diff = [_first_difference(old, tuple(new)) for old, new in zip(trace.legs, legs)]
    changed = [(j, d, min(len(trace.legs[j]), len(legs[j]))) for j, d in enumerate(diff) if d is not None]
    last = len(trace.turns) - 1 if trace.barrier is None else min(trace.barrier, len(trace.turns) - 1)
    for e in range(last + 1):
        turn = trace.turns[e]
        if turn.t > horizon:  # the new run stops here (its horizon is shorter): redo this turn
            return e
        for j, d, shortest in changed:
            k = turn.done(j)
            if k > d or (k == d == shortest):  # a changed leg was booked, or which arms have legs left differs
                return e
            if turn.arm == j and k == d:  # this turn reads a changed leg
                return e
    return last
