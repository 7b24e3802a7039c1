"""Pure, vectorised kinematics of a planar 2R arm.

Every function takes joint angles ``q`` with shape ``(..., 2)`` (``q[..., 0]`` is the
shoulder angle theta1, ``q[..., 1]`` the elbow angle theta2, in rad) and link lengths
``links = (l1, l2)`` in m. Positions are returned in the world frame when ``base`` is
given, otherwise relative to the base.

The forward kinematics, the Jacobian and the manipulability are written once and can be
evaluated on NumPy arrays or on CasADi symbols (``SX``/``MX`` column vectors of length 2,
or matrices of shape ``(T, 2)``), so the optimiser uses exactly these formulas.

Conventions (as in the course's ``Robot2R``):
    elbow = base + l1 (cos t1, sin t1)
    tip   = elbow + l2 (cos(t1 + t2), sin(t1 + t2))
    branch 0 ("elbow up") has t2 >= 0, branch 1 ("elbow down") has t2 <= 0.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

__all__ = [
    "fk",
    "fk_points",
    "ik",
    "ik_one",
    "jacobian",
    "manipulability",
    "singularity_proximity",
    "in_workspace",
    "project_to_workspace",
    "dls_velocity",
    "max_point_speed",
    "wrap_angle",
    "sweep_box",
    "jacobian_entries",
    "jacobian_rate_entries",
]


def _is_casadi(x: Any) -> bool:
    mod = type(x).__module__
    return mod.startswith("casadi")


def _poses(q: Any, fn: str, name: str = "q") -> Any:
    """``q`` checked: NumPy (any array-like, as floats) with its last axis of 2, or CasADi as
    one (2, 1) column or a (T, 2) matrix. A ValueError says what was expected and what was found
    (a (2, T) array -- poses in columns -- gave T wrong answers without a word)."""
    if _is_casadi(q):
        rows, cols = q.shape
        if not ((cols == 1 and rows == 2) or cols == 2):
            raise ValueError(f"{fn}: {name} as CasADi symbols: expected one pose as a (2, 1) column or T poses as a "
                             f"(T, 2) matrix, found shape {q.shape}")
        return q
    try:
        a = np.asarray(q, dtype=float)
    except (TypeError, ValueError):
        raise ValueError(f"{fn}: {name}: expected numbers of shape (..., 2), found {type(q).__name__} {q!r:.80}") from None
    if a.ndim == 0 or a.shape[-1] != 2:
        hint = f" (poses in columns? {name}.T gives them in rows)" if a.ndim == 2 and a.shape[0] == 2 else ""
        raise ValueError(f"{fn}: {name}: expected shape (..., 2), the two values on the last axis, found shape {a.shape}{hint}")
    return a


def _pair(v: Any, fn: str, name: str, what: str, symbolic: bool = False) -> tuple[Any, Any]:
    """Two numbers (``links``, ``base``) as floats -- with ``symbolic`` (:func:`fk` of CasADi
    poses), a base of two SX/MX symbols stays symbolic -- or a ValueError saying what was found."""
    if symbolic and type(v).__name__ in ("SX", "MX") and v.numel() == 2:
        return v[0], v[1]
    if type(v).__name__ == "DM" and v.numel() == 2:  # (CasADi numbers: as floats)
        return float(v[0]), float(v[1])
    try:
        a, b = (float(x) for x in v)
    except (TypeError, ValueError):
        raise ValueError(f"{fn}: {name}: expected {what}, two numbers, found {v!r:.80}") from None
    return a, b


def _ops(x: Any):
    """Return (sin, cos, column-getter, hstack) for NumPy or CasADi inputs.

    CasADi inputs are either one pose as a (2, 1) column or T poses as a (T, 2) matrix
    (T = 1 included: a (1, 2) row is one pose in matrix form and gives (1, 2) results).
    """
    if _is_casadi(x):
        import casadi as ca

        column = x.shape[1] == 1

        def col(a, i):
            return a[i] if column else a[:, i]

        def stack(a, b):
            return ca.vertcat(a, b) if column else ca.horzcat(a, b)

        return ca.sin, ca.cos, col, stack
    return np.sin, np.cos, (lambda a, i: a[..., i]), (lambda a, b: np.stack([a, b], axis=-1))


def fk(q: Any, links, base=(0.0, 0.0)):
    """Forward kinematics.

    Parameters
    ----------
    q : array (..., 2) or CasADi (2, 1) / (T, 2)
    links : (l1, l2)
    base : (2,) base position in the world

    Returns
    -------
    elbow, tip : arrays (..., 2) (CasADi: (2, 1) or (T, 2))
    """
    q = _poses(q, "fk")
    sin, cos, col, stack = _ops(q)
    l1, l2 = _pair(links, "fk", "links", "(l1, l2) in m")
    bx, by = _pair(base, "fk", "base", "(x, y) in m", symbolic=_is_casadi(q))
    t1, t2 = col(q, 0), col(q, 1)
    ex = bx + l1 * cos(t1)
    ey = by + l1 * sin(t1)
    tx = ex + l2 * cos(t1 + t2)
    ty = ey + l2 * sin(t1 + t2)
    return stack(ex, ey), stack(tx, ty)


def fk_points(q: np.ndarray, links, base=(0.0, 0.0)) -> np.ndarray:
    """Base, elbow and tip as one array of shape ``(..., 3, 2)`` (NumPy only)."""
    if _is_casadi(q):
        raise ValueError("fk_points: expected a NumPy array of shape (..., 2) (fk takes CasADi symbols), found CasADi symbols")
    q = _poses(q, "fk_points")
    elbow, tip = fk(q, links, base)
    b = np.broadcast_to(np.asarray(base, dtype=float), elbow.shape)
    return np.stack([b, elbow, tip], axis=-2)


def _cos_range(a: float, b: float) -> tuple[float, float]:
    """Least and greatest cos(x) over a <= x <= b."""
    if b - a >= 2.0 * math.pi:
        return -1.0, 1.0
    ca, cb = math.cos(a), math.cos(b)
    lo, hi = min(ca, cb), max(ca, cb)
    if 2.0 * math.pi * math.floor(b / (2.0 * math.pi)) >= a:  # a multiple of 2 pi inside
        hi = 1.0
    if 2.0 * math.pi * math.floor((b - math.pi) / (2.0 * math.pi)) + math.pi >= a:  # pi + a multiple of 2 pi
        lo = -1.0
    return lo, hi


def sweep_box(q_lo, q_hi, links, base=(0.0, 0.0), pad: float = 1e-9) -> tuple[float, float, float, float]:
    """A box ``(xmin, xmax, ymin, ymax)`` holding the whole arm (base, elbow, tip and both links,
    without their radius) at every pose q with ``q_lo <= q <= q_hi`` joint by joint (scalars).

    Conservative, not tight: the tip's box is the elbow's plus the forearm's over every
    absolute forearm angle ``t1 + t2`` in ``[lo1 + lo2, hi1 + hi2]``; ``pad`` (m) covers rounding.
    Each link lies in the hull of its end points, so the box of the three points holds it.
    """
    l1, l2 = _pair(links, "sweep_box", "links", "(l1, l2) in m")
    bx, by = _pair(base, "sweep_box", "base", "(x, y) in m")
    lo, hi = _pair(q_lo, "sweep_box", "q_lo", "(t1, t2) in rad"), _pair(q_hi, "sweep_box", "q_hi", "(t1, t2) in rad")
    a0, a1 = lo[0], hi[0]
    f0, f1 = a0 + lo[1], a1 + hi[1]
    c1, s1 = _cos_range(a0, a1), _cos_range(a0 - math.pi / 2, a1 - math.pi / 2)  # sin x = cos(x - pi / 2)
    c2, s2 = _cos_range(f0, f1), _cos_range(f0 - math.pi / 2, f1 - math.pi / 2)
    ex0, ex1, ey0, ey1 = bx + l1 * c1[0], bx + l1 * c1[1], by + l1 * s1[0], by + l1 * s1[1]
    tx0, tx1, ty0, ty1 = ex0 + l2 * c2[0], ex1 + l2 * c2[1], ey0 + l2 * s2[0], ey1 + l2 * s2[1]
    return (min(bx, ex0, tx0) - pad, max(bx, ex1, tx1) + pad, min(by, ey0, ty0) - pad, max(by, ey1, ty1) + pad)


def wrap_angle(a):
    """Wrap angles into (-pi, pi]."""
    a = np.asarray(a, dtype=float)
    w = np.mod(a + np.pi, 2.0 * np.pi) - np.pi
    return np.where(w == -np.pi, np.pi, w)


def ik(target, links, base=(0.0, 0.0), joint_limits=None, tol: float = 1e-9):
    """Inverse kinematics, both elbow branches.

    Parameters
    ----------
    target : array (..., 2) world positions
    links : (l1, l2)
    base : (2,)
    joint_limits : optional array (2, 2) ``[[t1_min, t1_max], [t2_min, t2_max]]``;
        solutions outside are marked invalid (theta1 is wrapped into (-pi, pi] first; each
        angle outside its limits is also tried shifted by +-2 pi, so limits past +-pi are honoured).
    tol : targets up to ``tol`` outside the annulus are snapped onto it.

    Returns
    -------
    q : array (..., 2, 2) -- ``q[..., b, :]`` is branch ``b`` (0: sin t2 >= 0, 1: sin t2 <= 0;
        t2 in [-pi, pi] unless only its 2 pi shift is within the limits); NaN where invalid.
    valid : bool array (..., 2)
    """
    target = _poses(target, "ik", "target")
    l1, l2 = _pair(links, "ik", "links", "(l1, l2) in m")
    if not (l1 > 0 and l2 > 0 and math.isfinite(l1 + l2)):  # (zero links: valid=True with NaN angles)
        raise ValueError(f"ik: links: expected two link lengths > 0 in m, found {tuple(links)!r}")
    lim = None if joint_limits is None else np.asarray(joint_limits, dtype=float)
    if lim is not None and lim.shape != (2, 2):  # ([-1, 1]: a bare IndexError)
        raise ValueError(f"ik: joint_limits: expected [[t1_min, t1_max], [t2_min, t2_max]] (shape (2, 2)), found shape "
                         f"{lim.shape}")
    p = target - np.asarray(_pair(base, "ik", "base", "(x, y) in m"))
    px, py = p[..., 0], p[..., 1]
    r2 = px * px + py * py
    r = np.sqrt(r2)
    r_in, r_out = abs(l1 - l2), l1 + l2
    reach = (r <= r_out + tol) & (r >= r_in - tol)
    c2 = np.clip((r2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0, 1.0)
    s2 = np.sqrt(np.maximum(0.0, 1.0 - c2 * c2))
    out = np.full(target.shape[:-1] + (2, 2), np.nan)
    valid = np.zeros(target.shape[:-1] + (2,), dtype=bool)
    for b, sgn in enumerate((1.0, -1.0)):
        t2 = np.arctan2(sgn * s2, c2)
        t1 = wrap_angle(np.arctan2(py, px) - np.arctan2(l2 * sgn * s2, l1 + l2 * c2))
        ok = reach.copy()
        if lim is not None:  # (an elbow's limits past +-pi too: the same bend, 2 pi on)
            t2, ok2 = _within_all(t2, lim[1, 0], lim[1, 1])
            t1, in1 = _within_all(t1, lim[0, 0], lim[0, 1])
            ok = ok & ok2 & in1
        out[..., b, 0] = np.where(ok, t1, np.nan)
        out[..., b, 1] = np.where(ok, t2, np.nan)
        valid[..., b] = ok
    return out, valid


def _within_all(t: np.ndarray, lo: float, hi: float) -> tuple[np.ndarray, np.ndarray]:
    """Each of ``t``, else it 2 pi on either way, within ``[lo, hi]``, and where one is
    (:func:`_within` over arrays, the same arithmetic)."""
    ok = (t >= lo) & (t <= hi)
    for shift in (2.0 * np.pi, -2.0 * np.pi):
        ts = t + shift
        use = ~ok & (ts >= lo) & (ts <= hi)
        t = np.where(use, ts, t)
        ok = ok | use
    return t, ok


def ik_one(x: float, y: float, links, base, joint_limits, branch: int, tol: float = 1e-9) -> tuple[float, float]:
    """:func:`ik` of one point on one elbow branch in plain floats: ``(t1, t2)``, both NaN
    where :func:`ik` marks the branch invalid. The same bits as :func:`ik` (the arithmetic in
    the same order; the angles from ``np.arctan2`` on scalars, which runs the array's kernel:
    ``math.atan2`` may differ in the last bit), at a tenth of its cost on one point.
    ``joint_limits``: ``((t1_min, t1_max), (t2_min, t2_max))`` or None."""
    if branch not in (0, 1):  # (5 was taken as elbow-down)
        raise ValueError(f"ik_one: branch: expected 0 (sin t2 >= 0) or 1 (sin t2 <= 0), found {branch!r}")
    try:
        l1, l2, bx, by = float(links[0]), float(links[1]), float(base[0]), float(base[1])
    except (IndexError, TypeError, ValueError):  # (one link gave "tuple index out of range")
        raise ValueError(f"ik_one: expected links (l1, l2) and base (x, y), two numbers each, found {links!r:.60} and "
                         f"{base!r:.60}") from None
    px, py = float(x) - bx, float(y) - by
    r2 = px * px + py * py
    r = math.sqrt(r2)
    if not (abs(l1 - l2) - tol <= r <= l1 + l2 + tol):
        return math.nan, math.nan
    c2 = min(max((r2 - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0), 1.0)
    s2 = math.sqrt(max(0.0, 1.0 - c2 * c2))
    sgn = 1.0 if branch == 0 else -1.0
    t2 = float(np.arctan2(sgn * s2, c2))
    a = float(np.arctan2(py, px)) - float(np.arctan2(l2 * sgn * s2, l1 + l2 * c2)) + math.pi
    t1 = a % (2.0 * math.pi) - math.pi  # wrap_angle: the same remainder as np.mod
    if t1 == -math.pi:
        t1 = math.pi
    if joint_limits is not None:
        try:
            (lo1, hi1), (lo2, hi2) = joint_limits
        except (TypeError, ValueError):  # ([-1, 1]: "cannot unpack non-iterable int object")
            raise ValueError(f"ik_one: joint_limits: expected ((t1_min, t1_max), (t2_min, t2_max)) in rad or None, "
                             f"found {joint_limits!r:.80}") from None
        t2, t1 = _within(t2, lo2, hi2), _within(t1, lo1, hi1)
        if math.isnan(t1) or math.isnan(t2):
            return math.nan, math.nan
    return t1, t2


def _within(t: float, lo: float, hi: float) -> float:
    """``t``, else ``t`` 2 pi on either way, within ``[lo, hi]``; NaN where none is (as :func:`ik`)."""
    for x in (t, t + 2.0 * math.pi, t - 2.0 * math.pi):
        if lo <= x <= hi:
            return x
    return math.nan


def jacobian(q: Any, links):
    """Tip Jacobian d(tip)/dq.

    NumPy: ``q`` (..., 2) -> (..., 2, 2). CasADi: ``q`` (2, 1) -> (2, 2).
    """
    q = _poses(q, "jacobian")
    sin, cos, col, _ = _ops(q)
    l1, l2 = _pair(links, "jacobian", "links", "(l1, l2) in m")
    t1, t2 = col(q, 0), col(q, 1)
    s1, c1 = sin(t1), cos(t1)
    s12, c12 = sin(t1 + t2), cos(t1 + t2)
    if _is_casadi(q):
        import casadi as ca

        if q.shape != (2, 1):
            raise ValueError(f"jacobian on CasADi symbols expects one pose as a (2, 1) column, found shape {q.shape}")
        return ca.vertcat(
            ca.horzcat(-l1 * s1 - l2 * s12, -l2 * s12),
            ca.horzcat(l1 * c1 + l2 * c12, l2 * c12),
        )
    row0 = np.stack([-l1 * s1 - l2 * s12, -l2 * s12], axis=-1)
    row1 = np.stack([l1 * c1 + l2 * c12, l2 * c12], axis=-1)
    return np.stack([row0, row1], axis=-2)


def jacobian_entries(q0: float, q1: float, links) -> tuple[float, float, float, float]:
    """:func:`jacobian` of one pose in plain floats (``math``; no array overhead): its entries
    ``(a, b, d, e)`` for ``J = [[a, b], [d, e]]``."""
    l1, l2 = float(links[0]), float(links[1])
    t12 = q0 + q1
    s1, s12 = math.sin(q0), math.sin(t12)
    return -l1 * s1 - l2 * s12, -l2 * s12, l1 * math.cos(q0) + l2 * math.cos(t12), l2 * math.cos(t12)


def jacobian_rate_entries(q0: float, q1: float, qd0: float, qd1: float, links) -> tuple[float, float, float, float]:
    """The time derivative of :func:`jacobian_entries` along joint rates ``(qd0, qd1)``, exactly
    (each entry differentiated): ``(a', b', d', e')``."""
    l1, l2 = float(links[0]), float(links[1])
    t12, w12 = q0 + q1, qd0 + qd1
    c1, c12, s1, s12 = math.cos(q0), math.cos(t12), math.sin(q0), math.sin(t12)
    return -l1 * c1 * qd0 - l2 * c12 * w12, -l2 * c12 * w12, -l1 * s1 * qd0 - l2 * s12 * w12, -l2 * s12 * w12


def manipulability(q: Any, links):
    """Yoshikawa manipulability |det J| = l1 l2 |sin t2|; shape (...)."""
    q = _poses(q, "manipulability")
    sin, _, col, _ = _ops(q)
    l1, l2 = _pair(links, "manipulability", "links", "(l1, l2) in m")
    s = sin(col(q, 1))
    if _is_casadi(q):
        import casadi as ca

        return l1 * l2 * ca.fabs(s)
    return l1 * l2 * np.abs(s)


def singularity_proximity(q, links) -> np.ndarray:
    """How close to singular, in [0, 1]: 1 at a singular pose (t2 = 0 or pi), 0 at the best one."""
    l1, l2 = _pair(links, "singularity_proximity", "links", "(l1, l2) in m")
    return 1.0 - np.asarray(manipulability(np.asarray(q, dtype=float), links)) / (l1 * l2)


def in_workspace(target, links, base=(0.0, 0.0), margin: float = 0.0) -> np.ndarray:
    """Whether targets (..., 2) lie inside the reachable annulus shrunk by ``margin``."""
    p = _poses(target, "in_workspace", "target") - np.asarray(_pair(base, "in_workspace", "base", "(x, y) in m"))
    r = np.hypot(p[..., 0], p[..., 1])
    l1, l2 = _pair(links, "in_workspace", "links", "(l1, l2) in m")
    return (r <= l1 + l2 - margin) & (r >= abs(l1 - l2) + margin)


def project_to_workspace(target, links, base=(0.0, 0.0), margin: float = 0.05) -> np.ndarray:
    """Project targets (..., 2) onto the annulus shrunk by ``margin`` (the course's rule).

    A target at the base itself is sent to the inner boundary along +x.
    """
    target = _poses(target, "project_to_workspace", "target")
    base = np.asarray(_pair(base, "project_to_workspace", "base", "(x, y) in m"))
    l1, l2 = _pair(links, "project_to_workspace", "links", "(l1, l2) in m")
    r_in, r_out = abs(l1 - l2) + margin, l1 + l2 - margin
    d = target - base
    r = np.hypot(d[..., 0], d[..., 1])
    safe_r = np.where(r < 1e-10, 1.0, r)
    direction = np.where((r < 1e-10)[..., None], np.array([1.0, 0.0]), d / safe_r[..., None])
    new_r = np.clip(np.where(r < 1e-10, r_in, r), r_in, r_out)
    return np.where(((r >= r_in) & (r <= r_out))[..., None], target, base + direction * new_r[..., None])


def dls_velocity(J: np.ndarray, v_desired: np.ndarray, threshold: float = 0.05, damping: float = 0.1) -> np.ndarray:
    """Damped-least-squares resolved-rate solver from the course.

    ``qd = J^T (J J^T + lam^2 I)^-1 v`` with ``lam = damping (1 - |det J| / threshold)`` when
    ``|det J| < threshold``, the plain inverse otherwise. ``J`` (..., 2, 2), ``v`` (..., 2).
    Always finite, also at exactly singular poses.
    """
    J = np.asarray(J, dtype=float)
    v = _poses(v_desired, "dls_velocity", "v_desired")
    try:  # (one J for many velocities, or many J for one, broadcast as NumPy does)
        np.broadcast_shapes(J.shape[:-2], v.shape[:-1])
        fits = J.ndim >= 2 and J.shape[-2:] == (2, 2)
    except ValueError:
        fits = False
    if not fits:
        raise ValueError(f"dls_velocity: expected J of shape (..., 2, 2) and v_desired (..., 2) over the same (or "
                         f"broadcastable) poses, found J {J.shape} and v_desired {v.shape}")
    det = np.abs(np.linalg.det(J))
    lam = np.where(det < threshold, damping * (1.0 - det / threshold), 0.0)
    JJt = J @ np.swapaxes(J, -1, -2) + (lam**2)[..., None, None] * np.eye(2)
    # where lam == 0 the pose is regular enough for the plain inverse: J^T (J J^T)^-1 = J^-1
    y = np.linalg.solve(JJt, v[..., None])[..., 0]
    return np.einsum("...ji,...j->...i", J, y)


def max_point_speed(qd, links) -> np.ndarray:
    """Upper bound on the speed of any point of the arm for joint rates ``qd`` (..., 2).

    A point on link 1 moves at most l1 |qd1|; on link 2 at most l1 |qd1| + l2 |qd1 + qd2|.
    """
    qd = _poses(qd, "max_point_speed", "qd")
    l1, l2 = _pair(links, "max_point_speed", "links", "(l1, l2) in m")
    return l1 * np.abs(qd[..., 0]) + l2 * np.abs(qd[..., 0] + qd[..., 1])
