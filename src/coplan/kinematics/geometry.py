"""Exact, vectorised 2-D segment geometry (NumPy): the planners' one implementation.

Capsules are segments with a radius; the distance between two capsules is the distance
between their core segments minus both radii (negative when they overlap).

:func:`segment_distance_xy` works on coordinate arrays (``ax, ay, bx, by, ...``, broadcast),
which is what the coordinated planner's pose-pair tests hold; :func:`segment_distance` is the
same computation on point arrays ``(..., 2)``, optionally with the closest points. Both give
bit-identical distances. The verifier does not use this module for its verdict: it keeps its
own, independent implementation (:func:`coplan.verify.clearance.segment_distances`).
"""

from __future__ import annotations

import numpy as np

__all__ = ["segment_distance", "segment_distance_xy", "capsule_distance"]


def _point_segment(px, py, ax, ay, ux, uy, uu_safe):
    """Squared distance from points p to segments a + s u, s in [0, 1], and the closest points:
    ``(d2, cx, cy)``, coordinate arrays (broadcast). ``uu_safe``: |u|^2, kept above 0."""
    t = np.clip(((px - ax) * ux + (py - ay) * uy) / uu_safe, 0.0, 1.0)
    cx = ax + t * ux
    cy = ay + t * uy
    ex = px - cx
    ey = py - cy
    return ex * ex + ey * ey, cx, cy


def _crossing(ax, ay, ux, uy, cx, cy, vx, vy, bx, by, dx, dy):
    """Whether segments a-b (a + u) and c-d (c + v) properly cross (orientation signs strictly
    opposite on both)."""
    d1 = ux * (cy - ay) - uy * (cx - ax)
    d2 = ux * (dy - ay) - uy * (dx - ax)
    d3 = vx * (ay - cy) - vy * (ax - cx)
    d4 = vx * (by - cy) - vy * (bx - cx)
    return (d1 * d2 < 0) & (d3 * d4 < 0)


def _candidates(ax, ay, bx, by, cx, cy, dx, dy):
    ux, uy = bx - ax, by - ay
    vx, vy = dx - cx, dy - cy
    uu = ux * ux + uy * uy
    vv = vx * vx + vy * vy
    # (a zero-length segment is its first point: the numerator is 0 too; one shorter than
    # 1e-150 m counts as that point)
    uu = np.maximum(uu, 1e-300)
    vv = np.maximum(vv, 1e-300)
    cand = (_point_segment(ax, ay, cx, cy, vx, vy, vv), _point_segment(bx, by, cx, cy, vx, vy, vv),
            _point_segment(cx, cy, ax, ay, ux, uy, uu), _point_segment(dx, dy, ax, ay, ux, uy, uu))
    return cand, _crossing(ax, ay, ux, uy, cx, cy, vx, vy, bx, by, dx, dy), (ux, uy, vx, vy)


def segment_distance_xy(ax, ay, bx, by, cx, cy, dx, dy):
    """Least distance between segments a-b and c-d given by coordinate arrays (broadcast).

    Exact: zero when the segments cross, otherwise the least of the four endpoint-to-segment
    distances (in 2-D the closest pair of non-crossing segments always involves an endpoint).
    Degenerate (zero-length) segments are handled as points.
    """
    cand, crossing, _ = _candidates(ax, ay, bx, by, cx, cy, dx, dy)
    d2 = np.minimum(np.minimum(cand[0][0], cand[1][0]), np.minimum(cand[2][0], cand[3][0]))
    return np.where(crossing, 0.0, np.sqrt(d2))  # (the root of the least square: the least root)


def _points(x, name: str) -> np.ndarray:
    """``x`` as floats of shape (..., 2), or a ValueError saying what was found (3-D points lost
    their third coordinate without a word; one number gave an IndexError)."""
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"segment_distance: {name}: expected points of shape (..., 2), found {type(x).__name__} {x!r:.80}") from None
    if a.ndim == 0 or a.shape[-1] != 2:
        raise ValueError(f"segment_distance: {name}: expected points of shape (..., 2) (planar: x, y), found shape {a.shape}")
    return a


def segment_distance(p1, p2, q1, q2, return_points: bool = False):
    """Least distance between segments p1-p2 and q1-q2 (all arrays (..., 2), broadcast):
    :func:`segment_distance_xy` on point arrays.

    Returns
    -------
    d : array (...)
    (optionally) pa, pb : closest points (..., 2) on each segment
    """
    p1, p2, q1, q2 = np.broadcast_arrays(*(_points(x, n) for x, n in zip((p1, p2, q1, q2), ("p1", "p2", "q1", "q2"))))
    xy = (p1[..., 0], p1[..., 1], p2[..., 0], p2[..., 1], q1[..., 0], q1[..., 1], q2[..., 0], q2[..., 1])
    if not return_points:
        return np.asarray(segment_distance_xy(*xy))
    cand, crossing, (ux, uy, vx, vy) = _candidates(*xy)
    ds = np.sqrt(np.stack([c[0] for c in cand], axis=0))
    k = np.argmin(ds, axis=0)
    d = np.where(crossing, 0.0, np.take_along_axis(ds, k[None], axis=0)[0])
    # closest points: an endpoint of one segment and its closest point on the other
    pa_c = np.stack([p1, p2, np.stack(cand[2][1:], -1), np.stack(cand[3][1:], -1)], axis=0)
    pb_c = np.stack([np.stack(cand[0][1:], -1), np.stack(cand[1][1:], -1), q1, q2], axis=0)
    pa = np.take_along_axis(pa_c, k[None, ..., None], axis=0)[0]
    pb = np.take_along_axis(pb_c, k[None, ..., None], axis=0)[0]
    if np.any(crossing):
        denom = ux * vy - uy * vx
        wx, wy = q1[..., 0] - p1[..., 0], q1[..., 1] - p1[..., 1]
        t = np.where(crossing, (wx * vy - wy * vx) / np.where(crossing, denom, 1.0), 0.0)
        x = p1 + t[..., None] * (p2 - p1)
        pa = np.where(crossing[..., None], x, pa)
        pb = np.where(crossing[..., None], x, pb)
    return d, pa, pb


def capsule_distance(p1, p2, ra, q1, q2, rb):
    """Signed distance between capsules (segment p1-p2, radius ra) and (q1-q2, rb); the radii
    are numbers (or arrays) at least 0."""
    radii = []
    for r, name in ((ra, "ra"), (rb, "rb")):
        try:
            v = np.asarray(r, dtype=float)
        except (TypeError, ValueError):
            raise ValueError(f"capsule_distance: {name}: expected a radius (m) of at least 0, found {r!r:.80}") from None
        if not np.all(np.isfinite(v)) or np.any(v < 0):
            raise ValueError(f"capsule_distance: {name}: expected a radius (m) of at least 0, found {r!r:.80}")
        radii.append(v)
    return segment_distance(p1, p2, q1, q2) - (radii[0] + radii[1])
