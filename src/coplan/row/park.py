"""Where an arm the screen locks waits on a moving carriage: out of its neighbours' way.

Entry point: :func:`park_poses` (``arm index -> pose``), used by :class:`coplan.row.booking.Booker`.

An arm that cannot reach its bin (:func:`coplan.row.reach.locked_arms`: the bins ride with the
carriage, so wherever it stands) harvests nothing, but it is still there. At home it may lean
over the fruit a neighbour must reach (two arms 0.3 m apart, link 1 as long as the gap is
wide), and a booking that leaves it there gives those fruit up: a 10 m row with one such arm
harvested 6 of the 17 fruit live, stop and go, that the stationary cell planner harvests
(which moves a resting arm aside where it must: :mod:`coplan.planners.coordinated.alone`).
On a moving carriage the locked arm is parked once, before anything else moves, at the pose
among its stow poses (:func:`coplan.planners.coordinated.routing.stow_poses`: over its bin,
folded elbows around the shoulder) that

1. a time-optimal move reaches from home clear of every neighbour at home and over its bin,
   leaving the neighbours' own home and bin poses clear, and
2. the fewest of its neighbours' poses come too close to: each neighbour's IK poses for points
   all over its reach (a polar grid -- not the fruit: a live row does not know them yet),
   both elbow branches;

ties by the quickest move (:func:`coplan.ties.quantised`: the same pose on any CPU). An arm
with no such pose stays at home, as before.
"""

from __future__ import annotations

import math

import numpy as np

from ..planners.coordinated.routing import ArmGeometry, stow_poses
from ..planners.coordinated.schedule import scurve_move
from ..problem.gantry import cell_at
from ..problem.model import Problem
from ..ties import quantised
from .reach import locked_arms

__all__ = ["park_poses"]

_RADII = 5  # rings of the polar grid over a neighbour's reach
_ANGLES = 36  # directions on each ring


def _reach_poses(arm, margin: float) -> np.ndarray:
    """(M, 2) ``arm``'s IK poses (both branches, within its joint limits) for a polar grid over
    its reach in the carriage frame."""
    l1, l2 = arm.links
    r = np.linspace(abs(l1 - l2) + margin, l1 + l2 - margin, _RADII)
    a = np.linspace(-math.pi, math.pi, _ANGLES, endpoint=False)
    pts = np.asarray(arm.base, float) + np.stack([np.outer(r, np.cos(a)), np.outer(r, np.sin(a))], axis=-1).reshape(-1, 2)
    q, valid = arm.ik(pts)
    return q[valid]


def park_poses(problem: Problem, need: float) -> dict[int, np.ndarray]:
    """``arm index -> pose`` for every arm the screen locks that has a better place to wait
    than home (module docstring); ``need`` the clearance kept (clearance and margin), m."""
    cell = cell_at(problem, 0.0, ())
    locked = locked_arms(cell)
    if not locked:
        return {}
    geo = ArmGeometry(cell, need)
    names = [a.name for a in cell.arms]
    out: dict[int, np.ndarray] = {}
    for i, arm in enumerate(cell.arms):
        if arm.name not in locked or not geo.nbrs[i]:
            continue
        home = np.asarray(arm.home, float)
        cand = stow_poses(arm, n_shoulder=24)
        lim = arm.limits
        cand = cand[np.all((cand >= lim[:, 0]) & (cand <= lim[:, 1]), axis=1)]
        score = np.zeros(len(cand), int)
        ok = np.ones(len(cand), bool)
        rests = {}
        for j in geo.nbrs[i]:
            nb = cell.arms[j]
            qb, vb = nb.ik(np.asarray(nb.bin, float))
            rests[j] = np.vstack([np.asarray(nb.home, float)[None, :], qb[vb]])
            ok &= geo.static_hits(i, cand, j, rests[j]) == 0  # the neighbour's own rests stay clear
            if names[j] in locked:
                continue  # (a locked neighbour works nowhere)
            score += geo.static_hits(i, cand, j, _reach_poses(nb, problem.task.reach_margin))
        if not ok.any():
            continue
        home_score = int(score[0]) if np.allclose(cand[0], home) else None
        best = None
        for k in np.argsort(np.where(ok, score, np.iinfo(np.int64).max), kind="stable"):
            if not ok[k] or (best is not None and score[k] > best[0]):
                break
            path = geo.move_path(i, home, cand[k])
            if any(geo.static_hits(i, path, j, rests[j]).any() for j in geo.nbrs[i]):
                continue  # (the move out sweeps over a neighbour at home or over its bin)
            t = float(quantised(scurve_move(arm, 0.0, home, cand[k]).duration))
            if best is None or (score[k], t) < best[:2]:
                best = (int(score[k]), t, cand[k])
        if best is not None and (home_score is None or best[0] < home_score):
            out[i] = np.asarray(best[2], float)
    return out
