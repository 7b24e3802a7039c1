"""Arm-to-arm clearance along a plan: the verifier's NumPy fast path and its gap certificate.

Every link is a capsule: the segment base-elbow or elbow-tip widened by the arm's
``link_radius``. The clearance of two arms is the least distance between any link of one
and any link of the other (negative when they overlap).

Sampling contract. A plan holds joint angles at 100 Hz and joints move *linearly* between
two samples (:meth:`coplan.plan.Plan.sample`). :func:`clearance_profile` evaluates the
exact capsule distances on that linear interpolant at ``substeps`` points per interval
(default 10, i.e. 1 kHz).

Gap certificate. Inside one plan interval the joint rates ``qd`` are constant, so no point of
an arm moves faster than ``V = l1 |qd1| + l2 |qd1 + qd2|``
(:func:`coplan.kinematics.max_point_speed`), and the distance of two arms changes no
faster than ``L = V_a + V_b``. Between two dense samples ``h`` apart with distances ``d0``
and ``d1`` the distance therefore never drops below ``(d0 + d1 - L h) / 2`` (the lower
envelope of the two Lipschitz cones). :func:`certify_pair` computes that bound for every
dense interval and refines (subdivides ``refine_factor`` times, up to ``refine_levels``
times) only the intervals whose samples are clear but whose bound is not yet: where the
arms are far apart nothing is refined, where they pass close the certificate tightens to
the micrometre. The same bound, applied to the plan's own intervals first, tells which of
them cannot hold a dense sample below the clearance or the least distance: those are not
densified at all (same figures as uniform 1 kHz sampling, several times faster).

Independent on purpose: this module shares no code with the planners. Its segment distance
(:func:`segment_distances`) is its own, written apart from the planners' one implementation
(:mod:`coplan.kinematics.geometry`), so that an error in either cannot hide in both; FCL
cross-checks it (:mod:`coplan.verify.fclcheck`). Keep it that way: do not replace it by the
planners' function.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..kinematics import arm as kin
from ..plan import Plan
from ..problem.model import Problem

__all__ = [
    "DEFAULT_SUBSTEPS",
    "segment_distances",
    "arm_link_distances",
    "ArmMotion",
    "arm_motions",
    "dense_grid",
    "clearance_profile",
    "clearance_chunks",
    "PairSamples",
    "certify_pair",
    "runs",
]

DEFAULT_SUBSTEPS = 10  # dense samples per 100 Hz interval: 1 kHz


# --------------------------------------------------------------------------- exact kernel
def _pt_seg_sq(px, py, ax, ay, ux, uy, uu):
    """Squared distance from points (px, py) to segments a + s u, s in [0, 1]; shapes broadcast."""
    wx = px - ax
    wy = py - ay
    s = np.divide(wx * ux + wy * uy, uu, out=np.zeros(np.broadcast(wx, uu).shape), where=uu > 0)
    np.clip(s, 0.0, 1.0, out=s)
    ex = wx - s * ux
    ey = wy - s * uy
    return ex * ex + ey * ey


def _crossing(ax, ay, ux, uy, bx, by, vx, vy):
    """Proper crossing of segments a + s u and b + r v (strictly opposite orientations)."""
    d1 = ux * (by - ay) - uy * (bx - ax)
    d2 = ux * (by + vy - ay) - uy * (bx + vx - ax)
    d3 = vx * (ay - by) - vy * (ax - bx)
    d4 = vx * (ay + uy - by) - vy * (ax + ux - bx)
    return (d1 * d2 < 0) & (d3 * d4 < 0)


def segment_distances(a0, a1, b0, b1) -> np.ndarray:
    """Exact least distance between 2-D segments ``a0-a1`` and ``b0-b1``.

    Inputs are arrays (..., 2) that broadcast; returns (...). Zero when the segments cross or
    touch; otherwise the least endpoint-to-segment distance (in the plane the closest pair
    of two disjoint segments always includes an endpoint). Zero-length segments are points.
    """
    a0, a1, b0, b1 = (np.asarray(x, dtype=float) for x in (a0, a1, b0, b1))
    ax, ay = a0[..., 0], a0[..., 1]
    bx, by = b0[..., 0], b0[..., 1]
    ux, uy = a1[..., 0] - ax, a1[..., 1] - ay
    vx, vy = b1[..., 0] - bx, b1[..., 1] - by
    uu = ux * ux + uy * uy
    vv = vx * vx + vy * vy
    d2 = np.minimum(
        np.minimum(_pt_seg_sq(bx, by, ax, ay, ux, uy, uu), _pt_seg_sq(bx + vx, by + vy, ax, ay, ux, uy, uu)),
        np.minimum(_pt_seg_sq(ax, ay, bx, by, vx, vy, vv), _pt_seg_sq(ax + ux, ay + uy, bx, by, vx, vy, vv)),
    )
    d = np.sqrt(d2)
    return np.where(_crossing(ax, ay, ux, uy, bx, by, vx, vy), 0.0, d)


#: Instants per block of :func:`arm_link_distances`.
LINK_BLOCK = 1024


def arm_link_distances(pa: np.ndarray, pb: np.ndarray) -> np.ndarray:
    """Core-segment distances of every link pair of two arms.

    Parameters
    ----------
    pa, pb : (K, 3, 2) base, elbow and tip of each arm at K instants.

    Returns
    -------
    (K, 4) distances; column ``2 * la + lb`` is link ``la`` of arm a against link ``lb`` of
    arm b (link 0: base-elbow, link 1: elbow-tip). Endpoint-to-segment distances are shared
    between link pairs (12 evaluations instead of 16), all of one arm's points against all of
    the other's links in one evaluation over (3 points, 2 links, K instants), ``LINK_BLOCK``
    instants at a time (the temporaries then stay in the cache).
    """
    if pa.shape[0] > LINK_BLOCK:
        return np.concatenate([arm_link_distances(pa[i:i + LINK_BLOCK], pb[i:i + LINK_BLOCK])
                               for i in range(0, pa.shape[0], LINK_BLOCK)])
    xa, ya = np.ascontiguousarray(np.moveaxis(pa, 0, -1)).transpose(1, 0, 2)  # (3, K) each: base, elbow, tip
    xb, yb = np.ascontiguousarray(np.moveaxis(pb, 0, -1)).transpose(1, 0, 2)
    uxa, uya, uxb, uyb = xa[1:] - xa[:2], ya[1:] - ya[:2], xb[1:] - xb[:2], yb[1:] - yb[:2]  # (2, K): each link
    uua, uub = uxa * uxa + uya * uya, uxb * uxb + uyb * uyb
    # point p of arm a (0 base, 1 elbow, 2 tip) to link l of arm b, and vice versa: (3, 2, K)
    a_to_b = _pt_seg_sq(xa[:, None], ya[:, None], xb[None, :2], yb[None, :2], uxb[None], uyb[None], uub[None])
    b_to_a = _pt_seg_sq(xb[:, None], yb[:, None], xa[None, :2], ya[None, :2], uxa[None], uya[None], uua[None])
    # link la of a (its points la, la + 1) against link lb of b, and b's points lb, lb + 1 against la: (la, lb, K)
    d2 = np.minimum(np.minimum(a_to_b[:2], a_to_b[1:]), np.minimum(b_to_a[:2], b_to_a[1:]).transpose(1, 0, 2))
    cross = _crossing(xa[:2, None], ya[:2, None], uxa[:, None], uya[:, None], xb[None, :2], yb[None, :2], uxb[None], uyb[None])
    return np.where(cross, 0.0, np.sqrt(d2)).reshape(4, -1).T


# --------------------------------------------------------------------------- motion on the grid
@dataclass(frozen=True)
class ArmMotion:
    """One arm's replayed motion: samples, per-interval joint rates and point-speed bound.

    Attributes
    ----------
    q : (N, 2) joint samples
    qd : (N - 1, 2) constant joint rates of each interval (the linear replay)
    speed : (N - 1,) bound on the speed of any point of the arm in each interval, m/s
    """

    name: str
    links: tuple[float, float]
    base: tuple[float, float]
    radius: float
    q: np.ndarray
    qd: np.ndarray
    speed: np.ndarray
    shift: np.ndarray | None = None  # (N,) a row plan: the carriage's x, the base moves with it (linear between samples)
    shift_rate: np.ndarray | None = None  # (N - 1,) the carriage's speed in each interval, m/s

    def points(self, seg: np.ndarray, frac: np.ndarray) -> np.ndarray:
        """Base, elbow, tip (K, 3, 2) in the row frame at fraction ``frac`` (K,) of plan intervals ``seg`` (K,)."""
        nxt = np.minimum(seg + 1, len(self.q) - 1)
        q = self.q[seg] + frac[:, None] * (self.q[nxt] - self.q[seg])
        pts = kin.fk_points(q, self.links, self.base)
        if self.shift is not None:
            pts[..., 0] += (self.shift[seg] + frac * (self.shift[nxt] - self.shift[seg]))[:, None]
        return pts

    def tips(self) -> np.ndarray:
        """The tip (N, 2) at every sample, in the row frame."""
        tip = kin.fk(self.q, self.links, self.base)[1]
        if self.shift is not None:
            tip = tip + np.c_[self.shift, np.zeros_like(self.shift)]
        return tip


def arm_motions(problem: Problem, plan: Plan) -> list[ArmMotion]:
    """The replayed motion of every arm of ``problem`` (in problem order) from ``plan``."""
    dt = plan.dt
    out = []
    shift = None if plan.gantry_x is None else np.asarray(plan.gantry_x, float)
    rate = None if shift is None else (np.diff(shift) / dt if shift.size > 1 else np.zeros(0))
    for arm in problem.arms:
        q = np.asarray(plan.q[arm.name], dtype=float)
        qd = np.diff(q, axis=0) / dt if len(q) > 1 else np.zeros((0, 2))
        out.append(ArmMotion(arm.name, arm.links, arm.base, arm.link_radius, q, qd, kin.max_point_speed(qd, arm.links),
                             shift, rate))
    return out


def dense_grid(plan: Plan, substeps: int, first: int = 0, last: int | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Dense instants on the plan's grid: ``substeps`` per interval, knots included.

    Returns ``(t, seg, frac)``, each (K,) with ``K = (N - 1) * substeps + 1``: time, index of
    the plan interval the instant starts (the last knot belongs to interval N - 2 at
    fraction 1) and the fraction inside it. ``first``, ``last``: only the intervals
    ``first .. last - 1`` (the plan's last knot only when ``last`` is the last interval's end).
    """
    n = plan.time.size
    if n < 2:
        return plan.time.astype(float).copy(), np.zeros(n, dtype=int), np.zeros(n)
    last = n - 1 if last is None else last
    s = max(1, int(substeps))
    seg = np.repeat(np.arange(first, last), s)
    frac = np.tile(np.arange(s) / s, last - first)
    if last == n - 1:
        seg = np.append(seg, n - 2)
        frac = np.append(frac, 1.0)
    t = plan.time[seg] + frac * (plan.time[seg + 1] - plan.time[seg])
    return t, seg, frac


def _pair_eval(ma: ArmMotion, mb: ArmMotion, seg: np.ndarray, frac: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Capsule distance (K,) and the closest link pair (K,) (index 2 la + lb) of two arms."""
    if seg.size == 0:
        return np.zeros(0), np.zeros(0, dtype=int)
    dl = arm_link_distances(ma.points(seg, frac), mb.points(seg, frac))
    k = np.argmin(dl, axis=1)
    return dl[np.arange(dl.shape[0]), k] - ma.radius - mb.radius, k


def clearance_profile(
    problem: Problem,
    plan: Plan,
    rate: float | None = None,
    substeps: int = DEFAULT_SUBSTEPS,
    pairs: list[tuple[int, int]] | None = None,
) -> tuple[np.ndarray, dict[tuple[int, int], np.ndarray]]:
    """Capsule clearance of every neighbouring arm pair, densely along the plan.

    Parameters
    ----------
    rate : dense sampling rate in Hz; rounded to a whole number of samples per plan
        interval. Default: ``substeps`` per interval (10, i.e. 1 kHz on a 100 Hz plan).
    pairs : arm index pairs (i < j, problem order); default ``problem.neighbour_pairs()``.

    Returns
    -------
    times : (K,) dense instants
    distances : {(i, j): (K,)} least capsule-to-capsule distance, m (negative = overlap)
    """
    pairs = problem.neighbour_pairs() if pairs is None else pairs
    parts = list(clearance_chunks(problem, plan, rate, substeps, pairs))
    if not parts:
        return np.zeros(0), {p: np.zeros(0) for p in pairs}
    return (np.concatenate([t for t, _ in parts]),
            {p: np.concatenate([d[p] for _, d in parts]) for p in pairs})


#: plan intervals per piece of :func:`clearance_chunks`: 20,000 intervals at 10 substeps are
#: 200,000 instants, a few tens of MB of link geometry per pair (a 2 h plan in one piece took
#: 2.2 GB)
CHUNK_INTERVALS = 20_000


def clearance_chunks(
    problem: Problem,
    plan: Plan,
    rate: float | None = None,
    substeps: int = DEFAULT_SUBSTEPS,
    pairs: list[tuple[int, int]] | None = None,
    chunk: int | None = None,
):
    """:func:`clearance_profile` in pieces of ``chunk`` plan intervals, in time order, so that a
    long plan's profile can be reduced as it is computed (``chunk``: default
    :data:`CHUNK_INTERVALS`): yields ``(times (k,), {(i, j): (k,)})``;
    the pieces concatenated are :func:`clearance_profile`'s arrays."""
    if rate is not None:
        substeps = max(1, int(round(float(rate) * plan.dt)))
    motions = arm_motions(problem, plan)
    pairs = problem.neighbour_pairs() if pairs is None else pairs
    n = plan.time.size
    step = max(1, int(CHUNK_INTERVALS if chunk is None else chunk))
    for a in range(0, max(n - 1, 1), step):  # (a plan of one sample: one piece, that sample)
        t, seg, frac = dense_grid(plan, substeps, a, min(a + step, n - 1))
        yield t, {(i, j): _pair_eval(motions[i], motions[j], seg, frac)[0] for i, j in pairs}


# --------------------------------------------------------------------------- certificate
@dataclass
class PairSamples:
    """One arm pair's samples after refinement and its certificate.

    Attributes (K = number of samples, K - 1 intervals)
    ----------
    t, seg, frac, d, link : (K,) time, plan interval, fraction, distance (m), link pair
    bound : (K - 1,) certified least distance inside each interval, m
    refined : how many intervals were subdivided, over all levels
    """

    i: int
    j: int
    t: np.ndarray
    seg: np.ndarray
    frac: np.ndarray
    d: np.ndarray
    link: np.ndarray
    bound: np.ndarray
    refined: int = 0

    @property
    def certified(self) -> float:
        """Certified least distance over the whole plan (the static distance for one sample)."""
        if self.bound.size:
            return float(self.bound.min())
        return float(self.d.min()) if self.d.size else float("inf")

    def uncertified(self, clearance: float) -> np.ndarray:
        """Indices of intervals whose samples clear ``clearance`` but whose bound does not."""
        return np.flatnonzero((self.bound < clearance) & (self.d[:-1] >= clearance) & (self.d[1:] >= clearance))


def _bounds(ma: ArmMotion, mb: ArmMotion, t, seg, d) -> np.ndarray:
    if t.size < 2:
        return np.zeros(0)
    lip = ma.speed[seg[:-1]] + mb.speed[seg[:-1]]
    if ma.shift_rate is not None or mb.shift_rate is not None:  # the carriages' own motion: zero for one carriage
        ra = ma.shift_rate[seg[:-1]] if ma.shift_rate is not None else 0.0
        rb = mb.shift_rate[seg[:-1]] if mb.shift_rate is not None else 0.0
        lip = lip + np.abs(ra - rb)
    h = np.diff(t)
    env = 0.5 * (d[:-1] + d[1:] - lip * h)
    return np.minimum(env, np.minimum(d[:-1], d[1:]))


def _subdivide(ma: ArmMotion, mb: ArmMotion, ps: PairSamples, idx: np.ndarray, r: int) -> PairSamples:
    """Split intervals ``idx`` of ``ps`` into ``r`` equal parts (``r - 1`` new samples each)."""
    if idx.size == 0 or r < 2:
        return ps
    steps = np.arange(1, r) / r
    # new instants stay inside their plan interval (the fraction grows, the interval does not)
    f0 = ps.frac[idx]
    f1 = np.where(ps.seg[idx + 1] == ps.seg[idx], ps.frac[idx + 1], 1.0)
    nfrac = (f0[:, None] + (f1 - f0)[:, None] * steps).ravel()
    nseg = np.repeat(ps.seg[idx], r - 1)
    nt = (ps.t[idx, None] + (ps.t[idx + 1] - ps.t[idx])[:, None] * steps).ravel()
    nd, nlink = _pair_eval(ma, mb, nseg, nfrac)
    order = np.argsort(np.concatenate([ps.t, nt]), kind="stable")
    t = np.concatenate([ps.t, nt])[order]
    seg = np.concatenate([ps.seg, nseg])[order]
    d = np.concatenate([ps.d, nd])[order]
    return PairSamples(ps.i, ps.j, t, seg, np.concatenate([ps.frac, nfrac])[order], d,
                       np.concatenate([ps.link, nlink])[order], _bounds(ma, mb, t, seg, d), ps.refined)


def certify_pair(
    motions: list[ArmMotion],
    i: int,
    j: int,
    plan: Plan,
    clearance: float,
    substeps: int = DEFAULT_SUBSTEPS,
    refine_levels: int = 2,
    refine_factor: int = 10,
    max_refine: int = 50_000,
    margin_tol: float = 5e-7,
    margin_rel: float = 0.0,
) -> PairSamples:
    """Sample arms ``i`` and ``j`` densely, bound every gap, refine where needed.

    1. Exact distances at the plan's samples and the certificate of every plan interval.
    2. Every interval whose certificate is below ``max(clearance, least sampled distance)``
       gets ``substeps`` samples. The others cannot hold a dense sample below either value,
       so the least distance, the collision and clearance intervals and the certificate are
       exactly those of uniform dense sampling (``clearance_profile``), at a fraction of the
       cost when the arms spend most of the time apart.
    3. Up to ``refine_levels`` times, intervals whose samples clear ``clearance`` but whose
       certificate does not are split in ``refine_factor`` (at most ``max_refine`` per level,
       the worst first).
    4. Where every sample clears ``clearance``, up to five more levels split the intervals whose
       certificate lies more than ``margin_tol`` below the least sampled distance: the certified
       least distance (the plan's certified margin) is then the least distance to within
       ``margin_tol``, not the Lipschitz bound's slack at 1 kHz (5 mm where two arms close at
       10 m/s). With ``margin_rel`` > 0, to within ``margin_rel`` of the least sampled distance
       where that is more, but never more than half the pair's margin (so every interval whose
       certificate lies below ``clearance`` is still split: the same verdict): a screening
       verification, where the verdict matters and not the margin's last micrometres. It spares
       pairs the Lipschitz bound cannot close in on: an arm whose base is nearest its neighbour
       while it sweeps at 4 m/s leaves 2 mm of slack at 1 kHz on a distance that does not
       change, and certifying that to 0.5 um took a 6 m row's verification 1.6 million samples
       (2.1 s; ``max_refine`` a level left it 21 um short anyway).
    """
    ma, mb = motions[i], motions[j]
    t, seg, frac = dense_grid(plan, 1)
    d, link = _pair_eval(ma, mb, seg, frac)
    ps = PairSamples(i, j, t, seg, frac, d, link, _bounds(ma, mb, t, seg, d))
    if ps.bound.size:
        ps = _subdivide(ma, mb, ps, np.flatnonzero(ps.bound < max(clearance, float(d.min()))), int(substeps))
    for _ in range(max(0, refine_levels)):
        bad = ps.uncertified(clearance)
        if bad.size == 0:
            break
        ps = _refined(ma, mb, ps, bad, refine_factor, max_refine)
    least = float(ps.d.min()) if ps.d.size else -np.inf
    for _ in range(_MARGIN_LEVELS if least - margin_tol > clearance else 0):
        least = float(ps.d.min())
        bad = ps.uncertified(least - max(margin_tol, min(margin_rel * least, 0.5 * (least - clearance))))
        if bad.size == 0:
            break
        ps = _refined(ma, mb, ps, bad, refine_factor, max_refine)
    return ps


#: the most levels the margin's certificate is refined (1 ms / 10^5: 10 ns intervals)
_MARGIN_LEVELS = 5


def _refined(ma: ArmMotion, mb: ArmMotion, ps: PairSamples, bad: np.ndarray, factor: int, most: int) -> PairSamples:
    """``ps`` with the intervals ``bad`` split in ``factor`` (at most ``most`` of them, the worst first)."""
    if bad.size > most:
        bad = np.sort(bad[np.argsort(ps.bound[bad])[:most]])
    out = _subdivide(ma, mb, ps, bad, max(2, int(factor)))
    out.refined += bad.size
    return out


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """Maximal runs of True in a 1-D mask as ``(first, last)`` index pairs (inclusive)."""
    m = np.asarray(mask, dtype=bool)
    if not m.any():
        return []
    edges = np.diff(np.concatenate([[0], m.astype(np.int8), [0]]))
    starts = np.flatnonzero(edges == 1)
    ends = np.flatnonzero(edges == -1) - 1
    return list(zip(starts.tolist(), ends.tolist()))
