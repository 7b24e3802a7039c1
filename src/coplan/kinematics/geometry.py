"""Exact, vectorised 2-D segment geometry (NumPy).

Capsules are segments with a radius; the distance between two capsules is the distance
between their core segments minus both radii (negative when they overlap).
"""

from __future__ import annotations

import numpy as np

__all__ = ["segment_distance", "capsule_distance"]


def _point_segment(p, a, b):
    """Distance (...) and closest point (..., 2) from points p to segments a-b."""
    ab = b - a
    denom = np.einsum("...i,...i->...", ab, ab)
    t = np.where(denom > 0, np.einsum("...i,...i->...", p - a, ab) / np.where(denom > 0, denom, 1.0), 0.0)
    t = np.clip(t, 0.0, 1.0)
    c = a + t[..., None] * ab
    return np.linalg.norm(p - c, axis=-1), c


def segment_distance(p1, p2, q1, q2, return_points: bool = False):
    """Least distance between segments p1-p2 and q1-q2 (all arrays (..., 2), broadcast).

    Exact: zero when the segments cross, otherwise the least of the four point-segment
    distances (in 2-D the closest pair of non-crossing segments always involves an endpoint).
    Degenerate (zero-length) segments are handled as points.

    Returns
    -------
    d : array (...)
    (optionally) pa, pb : closest points (..., 2) on each segment
    """
    p1, p2, q1, q2 = np.broadcast_arrays(*(np.asarray(x, dtype=float) for x in (p1, p2, q1, q2)))
    cand = [
        _point_segment(p1, q1, q2) + (None,),
        _point_segment(p2, q1, q2) + (None,),
        _point_segment(q1, p1, p2) + (None,),
        _point_segment(q2, p1, p2) + (None,),
    ]
    ds = np.stack([c[0] for c in cand], axis=0)
    k = np.argmin(ds, axis=0)
    d = np.take_along_axis(ds, k[None], axis=0)[0]

    # proper crossing test (orientation signs strictly opposite on both segments)
    def cross(a, b):
        return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]

    r, s = p2 - p1, q2 - q1
    d1 = cross(r, q1 - p1)
    d2 = cross(r, q2 - p1)
    d3 = cross(s, p1 - q1)
    d4 = cross(s, p2 - q1)
    crossing = (d1 * d2 < 0) & (d3 * d4 < 0)
    d = np.where(crossing, 0.0, d)
    if not return_points:
        return d
    # closest points
    pa_c = np.stack([p1, p2, cand[2][1], cand[3][1]], axis=0)
    pb_c = np.stack([cand[0][1], cand[1][1], q1, q2], axis=0)
    pa = np.take_along_axis(pa_c, k[None, ..., None], axis=0)[0]
    pb = np.take_along_axis(pb_c, k[None, ..., None], axis=0)[0]
    if np.any(crossing):
        denom = cross(r, s)
        t = np.where(crossing, cross(q1 - p1, s) / np.where(crossing, denom, 1.0), 0.0)
        x = p1 + t[..., None] * r
        pa = np.where(crossing[..., None], x, pa)
        pb = np.where(crossing[..., None], x, pb)
    return d, pa, pb


def capsule_distance(p1, p2, ra, q1, q2, rb):
    """Signed distance between capsules (segment p1-p2, radius ra) and (q1-q2, rb)."""
    return segment_distance(p1, p2, q1, q2) - (ra + rb)
