"""The NumPy capsule distances agree with FCL on thousands of seeded random capsule pairs.

Tolerance (stated in :mod:`coplan.fclcheck`): 1e-6 m on every distance -- FCL's capsule
distance for separated capsules, FCL's core-segment distance less both radii for
overlapping ones -- and the same ``fcl.collide`` verdict (either within 1e-6 m of
touching). FCL's signed distance is never called: its EPA aborts the process on parallel
capsules (see the module docstring).
"""

from __future__ import annotations

import numpy as np
import pytest

from coplan import kinematics as kin
from coplan.verify.clearance import ArmMotion, arm_link_distances, segment_distances
from coplan.verify.fclcheck import FCL_TOLERANCE, cross_check, fcl_capsule_distance
from coplan.kinematics import segment_distance

N = 800  # per family; 6 families -> 4800 pairs


def _unit(a):
    return np.stack([np.cos(a), np.sin(a)], axis=-1)


def family(name: str, rng: np.random.Generator, n: int = N):
    """(n, 4, 2) segment endpoints p0, p1, q0, q1 and radii (n, 2) of one kind of pair."""
    r = rng.uniform(0.005, 0.1, (n, 2))
    if name == "random":
        P = rng.uniform(-1, 1, (n, 4, 2))
    elif name == "crossing":  # both segments pass through a common interior point
        c = rng.uniform(-1, 1, (n, 1, 2))
        u, v = _unit(rng.uniform(0, np.pi, n)), _unit(rng.uniform(0, np.pi, n))
        s = rng.uniform(0.05, 1, (n, 4))
        P = np.stack([c[:, 0] - s[:, :1] * u, c[:, 0] + s[:, 1:2] * u, c[:, 0] - s[:, 2:3] * v, c[:, 0] + s[:, 3:] * v], axis=1)
    elif name == "parallel":  # same direction, offset sideways (some at exactly ra + rb) and along
        p0 = rng.uniform(-1, 1, (n, 2))
        u = _unit(rng.uniform(0, 2 * np.pi, n))
        nrm = np.stack([-u[:, 1], u[:, 0]], axis=1)
        L1, L2 = rng.uniform(0.1, 1, (2, n, 1))
        off = rng.uniform(0, 0.3, (n, 1))
        off[: n // 4, 0] = r[: n // 4].sum(axis=1)  # exactly touching side by side
        along = rng.uniform(-1.2, 1.2, (n, 1))
        q0 = p0 + nrm * off + u * along
        P = np.stack([p0, p0 + u * L1, q0, q0 + u * L2], axis=1)
        P[n // 2 :, 2:] = P[n // 2 :, 2:][:, ::-1]  # half of them anti-parallel
    elif name == "collinear":  # on one line: overlapping, touching end to end, or with a gap
        p0 = rng.uniform(-1, 1, (n, 2))
        u = _unit(rng.uniform(0, 2 * np.pi, n))
        L1, L2 = rng.uniform(0.1, 1, (2, n, 1))
        gap = rng.uniform(-0.5, 0.3, (n, 1))
        gap[: n // 8] = 0.0
        gap[n // 8 : n // 4, 0] = r[n // 8 : n // 4].sum(axis=1)
        q0 = p0 + u * (L1 + gap)
        P = np.stack([p0, p0 + u * L1, q0, q0 + u * L2], axis=1)
    elif name == "touching":  # any configuration, radii chosen so the capsules just touch
        P = rng.uniform(-1, 1, (n, 4, 2))
        d = segment_distance(P[:, 0], P[:, 1], P[:, 2], P[:, 3])
        keep = d > 0.02
        P, d = P[keep], d[keep]
        share = rng.uniform(0.2, 0.8, d.size)
        r = np.stack([d * share, d * (1 - share)], axis=1)
    elif name == "t_junction":  # an endpoint exactly on the other segment, or endpoint to endpoint
        p0, p1 = rng.uniform(-1, 1, (2, n, 2))
        s = rng.uniform(0, 1, (n, 1))
        s[: n // 4] = 1.0
        q0 = p0 + s * (p1 - p0)
        q1 = q0 + rng.uniform(0.1, 1, (n, 1)) * _unit(rng.uniform(0, 2 * np.pi, n))
        P = np.stack([p0, p1, q0, q1], axis=1)
    else:
        raise ValueError(name)
    return P, r


FAMILIES = ["random", "crossing", "parallel", "collinear", "touching", "t_junction"]


@pytest.mark.parametrize("name", FAMILIES)
def test_numpy_kernels_agree_with_fcl(name):
    rng = np.random.default_rng(FAMILIES.index(name) + 11)
    P, r = family(name, rng)
    d_fast = segment_distances(P[:, 0], P[:, 1], P[:, 2], P[:, 3]) - r.sum(axis=1)
    d_geom = segment_distance(P[:, 0], P[:, 1], P[:, 2], P[:, 3]) - r.sum(axis=1)
    np.testing.assert_allclose(d_fast, d_geom, atol=1e-12, rtol=0)
    bad = []
    n_sep = n_overlap = n_touch = 0
    for k in range(P.shape[0]):
        full, core, hit = fcl_capsule_distance(P[k, 0], P[k, 1], r[k, 0], P[k, 2], P[k, 3], r[k, 1])
        d = float(d_fast[k])
        if abs(core - r[k].sum() - d) > FCL_TOLERANCE:
            bad.append((k, "core", d, core - r[k].sum(), hit))
        if d > FCL_TOLERANCE:
            n_sep += 1
            if abs(full - d) > FCL_TOLERANCE or hit:
                bad.append((k, "separated", d, full, hit))
        elif d < -FCL_TOLERANCE:
            n_overlap += 1
            if not hit:
                bad.append((k, "overlap", d, core - r[k].sum(), hit))
        else:
            n_touch += 1
    assert not bad, f"{len(bad)} disagreements, first: {bad[:3]}"
    need = {  # every family exercises the verdicts it is meant to
        "random": n_sep > N // 5 and n_overlap > N // 5,
        "crossing": n_overlap == N,
        "parallel": n_sep > N // 5 and n_overlap > N // 10 and n_touch > 0,
        "collinear": n_sep > N // 8 and n_overlap > N // 2 and n_touch >= N // 8,
        "touching": n_touch > N // 2,
        "t_junction": n_overlap == N,
    }
    assert need[name], (n_sep, n_overlap, n_touch)


def test_special_cases_exactly():
    # parallel at a 0.3 m offset, overlapping along their length
    assert segment_distances([0, 0], [1, 0], [0.5, 0.3], [2, 0.3]) == pytest.approx(0.3, abs=1e-15)
    # collinear with a 0.25 m gap; collinear overlapping
    assert segment_distances([0, 0], [1, 0], [1.25, 0], [2, 0]) == pytest.approx(0.25, abs=1e-15)
    assert segment_distances([0, 0], [1, 0], [0.5, 0], [2, 0]) == 0.0
    # crossing; T-junction; a zero-length segment (a point)
    assert segment_distances([0, 0], [1, 1], [0, 1], [1, 0]) == 0.0
    assert segment_distances([0, 0], [1, 0], [0.5, 0], [0.5, 1]) == 0.0
    assert segment_distances([0, 0], [1, 0], [0.5, 0.2], [0.5, 0.2]) == pytest.approx(0.2, abs=1e-15)
    full, core, hit = fcl_capsule_distance([0, 0], [1, 0], 0.05, [0.5, 0.3], [2, 0.3], 0.05)
    assert full == pytest.approx(0.2, abs=1e-12) and core == pytest.approx(0.3, abs=1e-12) and not hit
    full, core, hit = fcl_capsule_distance([0, 0], [1, 0], 0.05, [0.5, 0], [2, 0], 0.05)  # collinear overlap
    assert core == pytest.approx(0.0, abs=1e-12) and hit


def test_arm_level_cross_check_on_random_poses():
    """The verifier's own cross-check (4 link pairs per instant) agrees on random arm poses."""
    rng = np.random.default_rng(5)
    n = 400
    qa, qb = rng.uniform(-3, 3, (2, n, 2))
    mk = lambda name, base, q: ArmMotion(name, (1.0, 0.8), base, 0.04, q, np.zeros((n - 1, 2)), np.zeros(n - 1))
    motions = [mk("a", (-0.5, 0.0), qa), mk("b", (0.5, 0.0), qb)]
    report = cross_check(motions, [(0, 1, k, 0.0, float(k)) for k in range(n)])
    assert report.agree, report.disagreements[:3]
    assert report.samples == n and report.queries >= 4 * n
    assert report.max_abs_diff <= FCL_TOLERANCE
    # a good share of those poses overlap, so both verdicts are exercised
    pa = kin.fk_points(qa, (1.0, 0.8), (-0.5, 0.0))
    pb = kin.fk_points(qb, (1.0, 0.8), (0.5, 0.0))
    d = arm_link_distances(pa, pb).min(axis=1) - 0.08
    assert (d < 0).sum() > n // 10 and (d > 0).sum() > n // 10


def test_link_pair_distances_are_each_pairs_segment_distance_over_several_blocks():
    """``arm_link_distances`` (all of one arm's points against all of the other's links at once,
    ``LINK_BLOCK`` instants at a time): column ``2 la + lb`` is ``segment_distances`` of link la of
    one arm and link lb of the other, to 1e-12 m, over more instants than two blocks -- with arms
    crossing, touching at a shared point and folded onto themselves among them."""
    from coplan.verify.clearance import LINK_BLOCK

    rng = np.random.default_rng(17)
    n = 2 * LINK_BLOCK + 91
    pa = kin.fk_points(rng.uniform(-3, 3, (n, 2)), (1.0, 0.8), (-0.5, 0.0))
    pb = kin.fk_points(rng.uniform(-3, 3, (n, 2)), (1.0, 0.8), (0.5, 0.0))
    pb[:40, 2] = pa[:40, 2]  # tips touching
    pa[40:80, 2] = pa[40:80, 1]  # a link of no length
    d = arm_link_distances(pa, pb)
    assert d.shape == (n, 4)
    for la in (0, 1):
        for lb in (0, 1):
            ref = segment_distances(pa[:, la], pa[:, la + 1], pb[:, lb], pb[:, lb + 1])
            np.testing.assert_allclose(d[:, 2 * la + lb], ref, rtol=0, atol=1e-12)
    assert (d[:40].min(axis=1) == 0).all() and (d == 0).sum() > 100  # (touching and crossing among them)
