"""Choices that do not depend on the CPU.

Move times come from transcendental functions (IK, S-curves, forward kinematics) whose last
bits differ between machines: NumPy picks SIMD kernels at run time (an AVX-512 and an AVX2
``arctan2`` disagree by an ulp), and so may a BLAS. Wherever the planners *choose* between
values that are equal in exact arithmetic -- the optima of a min-max MILP, two orders of one
arm's fruit with the same total, two arms finishing together -- those bits would decide, and
the same input would give another plan on another machine. So every such choice goes through
this module: times are :func:`quantised` to whole microseconds before they become MILP
coefficients or sort keys, and a minimum is the *first* item (in a canonical order the caller
gives: arm index, fruit id, enumeration order) within a tolerance of the least. Import-free but
for NumPy.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import TypeVar

import numpy as np

__all__ = ["TIME_QUANTUM", "TIE", "quantised", "first_min", "first_min_index", "first_max_index"]

T = TypeVar("T")

#: Times that become MILP coefficients or sort keys are whole multiples of this (s), rounded
#: down (so a bound computed from them stays a bound). Two machines' times then agree bit for
#: bit unless one lies within an ulp of a microsecond boundary (about 2e-9 per value).
TIME_QUANTUM = 1e-6

#: Two times closer than this (s) are the same time when choosing between them.
TIE = 1e-9


def quantised(t) -> np.ndarray:
    """Times (s), any shape, rounded down to whole :data:`TIME_QUANTUM`."""
    return np.floor(np.asarray(t, float) / TIME_QUANTUM) * TIME_QUANTUM


def first_min(items: Iterable[T], key: Callable[[T], float], tol: float = TIE) -> T:
    """The first of ``items`` whose ``key`` is within ``tol`` of the least key.

    Where ``min(items, key=key)`` lets the last bits decide between equal keys, this keeps
    the caller's order: the same item on every machine. Raises ``ValueError`` when empty."""
    pairs = [(key(x), x) for x in items]
    if not pairs:
        raise ValueError("first_min() of an empty sequence")
    least = min(k for k, _ in pairs)
    return next(x for k, x in pairs if k <= least + tol)


def first_min_index(values, tol: float = TIE) -> int:
    """The index of the first value within ``tol`` of the least (cf. ``np.argmin``; inf allowed)."""
    v = np.asarray(values, float)
    return int(np.flatnonzero(v <= v.min() + tol)[0])


def first_max_index(values, tol: float = TIE) -> int:
    """The index of the first value within ``tol`` of the greatest (cf. ``np.argmax``)."""
    v = np.asarray(values, float)
    return int(np.flatnonzero(v >= v.max() - tol)[0])
