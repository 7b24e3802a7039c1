"""Independent cross-check of the NumPy clearance (:mod:`coplan.verify.clearance`) with FCL.

Each link becomes an ``fcl.Capsule`` (FCL capsules are 3-D and lie along their local z axis,
centred on the origin): the transform rotates z onto the link direction in the xy plane and
moves the centre to the link's midpoint.

FCL pitfalls handled here:

* request/result objects are created fresh for every query (python-fcl's ``distance`` keeps
  the smaller of the old and new ``min_distance`` and ``collide`` ORs ``is_collision``, so a
  reused result keeps stale values);
* for overlapping shapes FCL's plain ``distance`` is not a penetration depth (documented as
  -1), and its signed distance (``enable_signed_distance``, GJK/EPA) is approximate (errors
  of 5e-5 m seen) and on parallel or collinear capsules throws ``std::logic_error`` from
  EPA ("The origin is outside of the polytope", fcl issues #390, #445, #493), which
  python-fcl does not catch: the process aborts. So signed distance is never used. An
  overlap is confirmed with ``fcl.collide`` on the capsules, and its depth with FCL's
  distance between the capsules' *cores* (radius-0 capsules, i.e. the link segments,
  never overlapping in a way FCL must measure): depth = ``ra + rb - core distance``;
* continuous collision (``continuousCollide``) moves a shape rigidly between two poses,
  not about its joint, so it is never used.

Tolerance: :data:`FCL_TOLERANCE` (1e-6 m) on every compared distance, separated or
overlapping (in practice the two agree to 1e-13 m). Capsules within that tolerance of
touching are accepted with either ``collide`` verdict.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

import fcl
import numpy as np

from ..kinds import FclMode
from .clearance import ArmMotion, arm_link_distances

__all__ = [
    "FCL_TOLERANCE",
    "DisagreementKind",
    "Disagreement",
    "FclReport",
    "capsule_object",
    "place_capsule",
    "fcl_capsule_distance",
    "cross_check",
]

FCL_TOLERANCE = 1e-6  # m


class DisagreementKind(str, Enum):
    DISTANCE = "distance"  # separated capsules, distances differ
    OVERLAP = "overlap"  # one side says overlap, the other does not
    PENETRATION = "penetration"  # overlapping (or touching): depths differ


@dataclass(frozen=True)
class Disagreement:
    kind: DisagreementKind
    arms: tuple[str, str]
    links: tuple[int, int]
    t: float
    numpy: float
    fcl: float

    def to_dict(self) -> dict:
        return {
            "kind": self.kind.value,
            "arms": list(self.arms),
            "links": list(self.links),
            "t": self.t,
            "numpy": self.numpy,
            "fcl": self.fcl,
        }


@dataclass
class FclReport:
    """What the FCL cross-check compared and found.

    ``max_abs_diff`` is over separated link pairs (capsule distances), ``max_penetration_diff``
    over overlapping ones (core distances), in m. ``agree`` is False after any disagreement.
    """

    mode: FclMode
    samples: int = 0
    queries: int = 0
    max_abs_diff: float = 0.0
    max_penetration_diff: float = 0.0
    tolerance: float = FCL_TOLERANCE
    disagreements: list[Disagreement] = field(default_factory=list)

    @property
    def agree(self) -> bool:
        return not self.disagreements

    def to_dict(self) -> dict:
        return {
            "mode": self.mode.value,
            "agree": self.agree,
            "samples": self.samples,
            "queries": self.queries,
            "max_abs_diff": self.max_abs_diff,
            "max_penetration_diff": self.max_penetration_diff,
            "tolerance": self.tolerance,
            "disagreements": [d.to_dict() for d in self.disagreements[:50]],
            "disagreement_count": len(self.disagreements),
        }


def _transform(p0, p1) -> tuple[np.ndarray, np.ndarray, float]:
    """Rotation (3, 3) taking z onto the segment direction, midpoint (3,), length."""
    d = np.asarray(p1, float) - np.asarray(p0, float)
    length = float(np.hypot(d[0], d[1]))
    ux, uy = (d / length) if length > 0 else (1.0, 0.0)
    rot = np.array([[-uy, 0.0, ux], [ux, 0.0, uy], [0.0, 1.0, 0.0]])  # columns x', y', z' (right-handed)
    mid = 0.5 * (np.asarray(p0, float) + np.asarray(p1, float))
    return rot, np.array([mid[0], mid[1], 0.0]), length


def capsule_object(p0, p1, radius: float) -> fcl.CollisionObject:
    """An FCL capsule around the 2-D segment ``p0``-``p1`` (z = 0) with ``radius``."""
    rot, trans, length = _transform(p0, p1)
    return fcl.CollisionObject(fcl.Capsule(float(radius), length), fcl.Transform(rot, trans))


def place_capsule(obj: fcl.CollisionObject, p0, p1) -> None:
    """Move a link capsule made by :func:`capsule_object` (same length) onto ``p0``-``p1``."""
    rot, trans, _ = _transform(p0, p1)
    obj.setTransform(fcl.Transform(rot, trans))


def _distance(oa: fcl.CollisionObject, ob: fcl.CollisionObject) -> float:
    """FCL's (unsigned) distance with fresh request/result objects."""
    return float(fcl.distance(oa, ob, fcl.DistanceRequest(), fcl.DistanceResult()))


def _collide(oa: fcl.CollisionObject, ob: fcl.CollisionObject) -> bool:
    """FCL's overlap verdict with fresh request/result objects."""
    return fcl.collide(oa, ob, fcl.CollisionRequest(), fcl.CollisionResult()) > 0


def fcl_capsule_distance(p0, p1, ra: float, q0, q1, rb: float) -> tuple[float, float, bool]:
    """FCL's view of two 2-D capsules: (capsule distance, core-segment distance, collide verdict).

    The capsule distance is meaningful for separated capsules only; for overlapping ones
    ``core - ra - rb`` is the (negative) distance.
    """
    full = _distance(capsule_object(p0, p1, ra), capsule_object(q0, q1, rb))
    core = _distance(capsule_object(p0, p1, 0.0), capsule_object(q0, q1, 0.0))
    return full, core, _collide(capsule_object(p0, p1, ra), capsule_object(q0, q1, rb))


@dataclass
class _Link:
    """FCL objects of one link: the capsule and its radius-0 core."""

    capsule: fcl.CollisionObject
    core: fcl.CollisionObject


def _compare(report: FclReport, arms, links, t, d_np: float, ra: float, rb: float, a: _Link, b: _Link) -> None:
    tol = report.tolerance
    report.queries += 1
    if d_np > tol:
        d_fcl = _distance(a.capsule, b.capsule)
        diff = abs(d_fcl - d_np)
        report.max_abs_diff = max(report.max_abs_diff, diff)
        if diff > tol:
            report.disagreements.append(Disagreement(DisagreementKind.DISTANCE, arms, links, t, d_np, d_fcl))
        elif d_np <= 10 * tol and _collide(a.capsule, b.capsule):
            report.disagreements.append(Disagreement(DisagreementKind.OVERLAP, arms, links, t, d_np, d_fcl))
        return
    d_fcl = _distance(a.core, b.core) - ra - rb
    diff = abs(d_fcl - d_np)
    if d_np < -tol:
        report.max_penetration_diff = max(report.max_penetration_diff, diff)
        if not _collide(a.capsule, b.capsule):
            report.disagreements.append(Disagreement(DisagreementKind.OVERLAP, arms, links, t, d_np, d_fcl))
            return
    if diff > tol:
        report.disagreements.append(Disagreement(DisagreementKind.PENETRATION, arms, links, t, d_np, d_fcl))


def cross_check(
    motions: list[ArmMotion],
    samples: list[tuple[int, int, int, float, float]],
    mode: FclMode = FclMode.CRITICAL,
    tolerance: float = FCL_TOLERANCE,
) -> FclReport:
    """Compare NumPy and FCL link-pair distances at the given instants.

    Parameters
    ----------
    motions : every arm's replayed motion (problem order)
    samples : ``(i, j, seg, frac, t)`` -- arm pair, plan interval, fraction inside it, time

    Every one of the 4 link pairs is compared at each instant.
    """
    report = FclReport(mode=FclMode(mode), tolerance=tolerance)
    objects: dict[int, list[_Link]] = {}

    def links_of(k: int, pts: np.ndarray) -> list[_Link]:
        if k not in objects:
            objects[k] = [_Link(capsule_object(pts[s], pts[s + 1], motions[k].radius), capsule_object(pts[s], pts[s + 1], 0.0))
                          for s in (0, 1)]
        else:
            for s in (0, 1):
                place_capsule(objects[k][s].capsule, pts[s], pts[s + 1])
                place_capsule(objects[k][s].core, pts[s], pts[s + 1])
        return objects[k]

    by_pair: dict[tuple[int, int], list[tuple[int, float, float]]] = {}
    for i, j, seg, frac, t in samples:
        by_pair.setdefault((i, j), []).append((seg, frac, t))
    for (i, j), rows in by_pair.items():
        ma, mb = motions[i], motions[j]
        seg = np.array([r[0] for r in rows], dtype=int)
        frac = np.array([r[1] for r in rows], dtype=float)
        pa, pb = ma.points(seg, frac), mb.points(seg, frac)
        d_np = arm_link_distances(pa, pb) - ma.radius - mb.radius  # (S, 4), vectorised
        for s, (_, _, t) in enumerate(rows):
            oa, ob = links_of(i, pa[s]), links_of(j, pb[s])
            report.samples += 1
            for la in (0, 1):
                for lb in (0, 1):
                    _compare(report, (ma.name, mb.name), (la, lb), float(t), float(d_np[s, 2 * la + lb]), ma.radius, mb.radius,
                             oa[la], ob[lb])
    return report
