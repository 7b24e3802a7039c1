"""One shared look for every plot and the animation: per-arm colours, phase styles, units.

No matplotlib import here: the palette is plain hex strings, so data code can use it too.
"""

from __future__ import annotations

from collections.abc import Iterable

__all__ = ["ARM_PALETTE", "arm_colors", "FRUIT_COLOR", "ALERT_COLOR", "LIMIT_COLOR", "pair_label"]

# tab10 without its red: red is reserved for ripe fruit and for clearance violations.
ARM_PALETTE = (
    "#1f77b4",  # blue
    "#ff7f0e",  # orange
    "#2ca02c",  # green
    "#9467bd",  # purple
    "#8c564b",  # brown
    "#e377c2",  # pink
    "#17becf",  # cyan
    "#bcbd22",  # olive
    "#7f7f7f",  # grey
)
FRUIT_COLOR = "#d62728"  # ripe strawberry red
ALERT_COLOR = "#e00000"  # clearance violation / collision
LIMIT_COLOR = "#333333"



def _names(arms) -> list[str]:
    """Arm names, in order, from a Problem, a Plan, a dict keyed by name or an iterable."""
    if hasattr(arms, "arms") and not isinstance(arms, dict):  # Problem
        return [a.name for a in arms.arms]
    if hasattr(arms, "q") and isinstance(getattr(arms, "q"), dict):  # Plan
        return list(arms.q)
    if isinstance(arms, dict):
        return [str(k) for k in arms]
    out = []
    for a in arms if isinstance(arms, Iterable) else []:
        out.append(a.name if hasattr(a, "name") else str(a))
    return out


def arm_colors(arms) -> dict[str, str]:
    """Arm name -> colour, assigned in the problem's arm order (cycled past 9 arms).

    Pass the :class:`~coplan.problem.Problem` wherever you have it, so every figure of that
    problem (any plan, any planner) uses the same colour for the same arm.
    """
    return {n: ARM_PALETTE[i % len(ARM_PALETTE)] for i, n in enumerate(_names(arms))}


def pair_label(a: str, b: str) -> str:
    return f"{a} \u2013 {b}"
