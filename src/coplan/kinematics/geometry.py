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

__all__ = ["segment_distance", "segment_distance_xy", "segment_distance_rows", "capsule_distance"]


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
    return segment_distance_rows(np.stack(np.broadcast_arrays(ax, ay, bx, by, cx, cy, dx, dy)).astype(float, copy=False))


#: Columns per block of :func:`segment_distance_rows` (its temporaries then stay in the cache).
ROWS_BLOCK = 2048


def segment_distance_rows(C: np.ndarray) -> np.ndarray:
    """:func:`segment_distance_xy` of the coordinates stacked in ``C`` (8, ...): rows ``ax, ay,
    bx, by, cx, cy, dx, dy``; returns (...). The same arithmetic as :func:`_candidates`, element by
    element (the same distances to the bit), on the four endpoint-to-segment problems at once --
    a and b to c-d, c and d to a-b, as (2, 2, n) arrays, ``ROWS_BLOCK`` columns at a time -- so
    a few dozen NumPy calls per block, where the planners' many small tests paid a hundred."""
    shape = C.shape[1:]
    C = C.reshape(8, -1)
    n = C.shape[1]
    if n <= ROWS_BLOCK:
        return _rows_distance(C).reshape(shape)
    return np.concatenate([_rows_distance(C[:, i:i + ROWS_BLOCK]) for i in range(0, n, ROWS_BLOCK)]).reshape(shape)


def _rows_distance(C: np.ndarray) -> np.ndarray:
    X, Y = C[0::2].reshape(2, 2, -1), C[1::2].reshape(2, 2, -1)  # [[ax, bx], [cx, dx]] and the y's
    Ux, Uy = X[:, 1:] - X[:, :1], Y[:, 1:] - Y[:, :1]  # [[ux], [vx]], [[uy], [vy]]
    uu = np.maximum(Ux * Ux + Uy * Uy, 1e-300)  # (a zero-length segment is its first point)
    Ux, Uy, uu, Ox, Oy = Ux[::-1], Uy[::-1], uu[::-1], X[::-1, :1], Y[::-1, :1]  # each endpoint's other segment
    DX, DY = X - Ox, Y - Oy  # [[a - c, b - c], [c - a, d - a]]
    t = np.minimum(np.maximum(0.0, (DX * Ux + DY * Uy) / uu), 1.0)  # (np.clip's values, a fraction of its cost)
    ex = X - (Ox + t * Ux)
    ey = Y - (Oy + t * Uy)
    d2 = ex * ex + ey * ey
    E = Ux * DY - Uy * DX  # _crossing's orientations: [[d3, d4], [d1, d2]]
    crossing = (E[1, 0] * E[1, 1] < 0) & (E[0, 0] * E[0, 1] < 0)
    return np.where(crossing, 0.0, np.sqrt(np.minimum(np.minimum(d2[0, 0], d2[0, 1]), np.minimum(d2[1, 0], d2[1, 1]))))


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
