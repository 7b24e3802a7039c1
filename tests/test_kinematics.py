"""2R kinematics and segment geometry: property tests, analytic values, cross-checks.

Random cases come from hypothesis (modest ``max_examples``) or seeded NumPy generators.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from coplan import kinematics as kin
from coplan.kinematics import capsule_distance, segment_distance

SETTINGS = settings(max_examples=60, deadline=None)
LINK = st.floats(0.2, 2.0)
ANGLE = st.floats(-math.pi + 1e-3, math.pi - 1e-3)
ELBOW = st.floats(0.02, math.pi - 0.02)  # |t2| away from the singular 0 and pi
BASE = st.tuples(st.floats(-3, 3), st.floats(-3, 3))


def angle_diff(a, b):
    """Difference of angles on the circle, in [0, pi]."""
    return np.abs(kin.wrap_angle(np.asarray(a) - np.asarray(b)))


# --------------------------------------------------------------------------- forward kinematics
def test_fk_reference_values() -> None:
    elbow, tip = kin.fk(np.array([0.0, 0.0]), (1.0, 0.8), (2.0, -1.0))
    np.testing.assert_allclose(elbow, [3.0, -1.0])
    np.testing.assert_allclose(tip, [3.8, -1.0])
    elbow, tip = kin.fk(np.array([math.pi / 2, -math.pi / 2]), (1.0, 0.8))
    np.testing.assert_allclose(elbow, [0.0, 1.0], atol=1e-15)
    np.testing.assert_allclose(tip, [0.8, 1.0], atol=1e-15)
    # the lesson's home (pi/3, pi/4) on the centre arm
    _, tip = kin.fk(np.array([math.pi / 3, math.pi / 4]), (1.0, 0.8))
    np.testing.assert_allclose(tip, [0.5 + 0.8 * math.cos(7 * math.pi / 12), math.sqrt(3) / 2 + 0.8 * math.sin(7 * math.pi / 12)])


def test_fk_points_is_base_elbow_tip() -> None:
    q = np.random.default_rng(0).uniform(-3, 3, (5, 4, 2))
    pts = kin.fk_points(q, (1.1, 0.7), (0.5, 0.25))
    assert pts.shape == (5, 4, 3, 2)
    elbow, tip = kin.fk(q, (1.1, 0.7), (0.5, 0.25))
    np.testing.assert_array_equal(pts[..., 0, :], np.broadcast_to([0.5, 0.25], (5, 4, 2)))
    np.testing.assert_array_equal(pts[..., 1, :], elbow)
    np.testing.assert_array_equal(pts[..., 2, :], tip)
    np.testing.assert_allclose(np.linalg.norm(pts[..., 1, :] - pts[..., 0, :], axis=-1), 1.1)
    np.testing.assert_allclose(np.linalg.norm(pts[..., 2, :] - pts[..., 1, :], axis=-1), 0.7)


@pytest.mark.parametrize("shape", [(2,), (7, 2), (3, 5, 2), (0, 2)])
def test_shapes_are_preserved(shape) -> None:
    q = np.random.default_rng(1).uniform(-3, 3, shape)
    elbow, tip = kin.fk(q, (1.0, 0.8))
    assert elbow.shape == tip.shape == shape
    assert kin.jacobian(q, (1.0, 0.8)).shape == shape[:-1] + (2, 2)
    assert np.shape(kin.manipulability(q, (1.0, 0.8))) == shape[:-1]
    assert np.shape(kin.singularity_proximity(q, (1.0, 0.8))) == shape[:-1]
    sol, valid = kin.ik(tip, (1.0, 0.8))
    assert sol.shape == shape[:-1] + (2, 2) and valid.shape == shape[:-1] + (2,)
    assert kin.project_to_workspace(tip, (1.0, 0.8)).shape == shape
    assert kin.in_workspace(tip, (1.0, 0.8)).shape == shape[:-1]


# --------------------------------------------------------------------------- inverse kinematics
@SETTINGS
@given(l1=LINK, l2=LINK, t1=ANGLE, e=ELBOW, branch=st.sampled_from([0, 1]), base=BASE)
def test_fk_ik_round_trip_on_both_branches(l1, l2, t1, e, branch, base) -> None:
    """IK of FK(q) returns q on q's own branch, and the other branch reaches the same tip."""
    t2 = e if branch == 0 else -e
    q = np.array([t1, t2])
    _, tip = kin.fk(q, (l1, l2), base)
    sol, valid = kin.ik(tip, (l1, l2), base)
    assert valid.all()
    assert angle_diff(sol[branch, 0], t1) < 1e-7 and abs(sol[branch, 1] - t2) < 1e-7
    for b in range(2):
        np.testing.assert_allclose(kin.fk(sol[b], (l1, l2), base)[1], tip, atol=1e-9)
    # branch convention: 0 is elbow-up (t2 >= 0), 1 elbow-down (t2 <= 0), mirror images
    assert sol[0, 1] >= 0 >= sol[1, 1]
    assert sol[0, 1] == pytest.approx(-sol[1, 1], abs=1e-12)


def test_ik_round_trip_seeded_batch() -> None:
    """The same property, vectorised over 2000 seeded random arms and poses at once."""
    rng = np.random.default_rng(2024)
    n = 2000
    l1, l2 = rng.uniform(0.3, 1.5), rng.uniform(0.3, 1.5)
    q = np.c_[rng.uniform(-math.pi, math.pi, n), rng.uniform(0.01, math.pi - 0.01, n) * rng.choice([-1, 1], n)]
    _, tip = kin.fk(q, (l1, l2))
    sol, valid = kin.ik(tip, (l1, l2))
    assert valid.all()
    own = np.where(q[:, 1] >= 0, 0, 1)
    back = sol[np.arange(n), own]
    assert angle_diff(back[:, 0], q[:, 0]).max() < 1e-7
    assert np.abs(back[:, 1] - q[:, 1]).max() < 1e-7
    assert (sol[:, 0, 1] >= 0).all() and (sol[:, 1, 1] <= 0).all()
    # theta1 comes back wrapped into (-pi, pi]
    assert (sol[..., 0] > -math.pi).all() and (sol[..., 0] <= math.pi).all()


def test_ik_reference_value() -> None:
    """The lesson demo's pick (1.2, 0.8) with L1 = 1, L2 = 0.8, by the textbook formulas."""
    c2 = (1.2**2 + 0.8**2 - 1.0 - 0.64) / (2 * 0.8)
    t2 = math.acos(c2)
    t1 = math.atan2(0.8, 1.2) - math.atan2(0.8 * math.sin(t2), 1.0 + 0.8 * c2)
    sol, valid = kin.ik(np.array([1.2, 0.8]), (1.0, 0.8))
    assert valid.all()
    np.testing.assert_allclose(sol[0], [t1, t2], atol=1e-12)
    np.testing.assert_allclose(sol[1], [math.atan2(0.8, 1.2) + math.atan2(0.8 * math.sin(t2), 1.0 + 0.8 * c2), -t2], atol=1e-12)


def test_ik_joint_limit_filtering() -> None:
    links = (1.0, 0.8)
    target = np.array([1.2, 0.8])
    sol, _ = kin.ik(target, links)
    # an elbow limit of [0, 3] keeps only branch 0; [-3, 0] only branch 1
    s_up, v_up = kin.ik(target, links, joint_limits=[[-3.2, 3.2], [0.0, 3.0]])
    assert v_up.tolist() == [True, False] and np.isnan(s_up[1]).all()
    np.testing.assert_array_equal(s_up[0], sol[0])
    s_dn, v_dn = kin.ik(target, links, joint_limits=[[-3.2, 3.2], [-3.0, 0.0]])
    assert v_dn.tolist() == [False, True] and np.isnan(s_dn[0]).all()
    # a shoulder limit between the two branches' theta1 keeps exactly one of them
    lo = min(sol[0, 0], sol[1, 0])
    s, v = kin.ik(target, links, joint_limits=[[lo - 0.01, lo + 0.01], [-3.0, 3.0]])
    assert v.sum() == 1 and np.nanmax(np.abs(s[v][0] - sol[v][0])) == 0.0
    # nothing inside: both invalid, all NaN
    s, v = kin.ik(target, links, joint_limits=[[2.0, 2.5], [-3.0, 3.0]])
    assert not v.any() and np.isnan(s).all()


def test_ik_honours_shoulder_limits_wider_than_pi() -> None:
    """A target below-left of the base needs theta1 near -2.4 rad, i.e. +3.9 rad when the
    shoulder range is [0, 2 pi]: IK returns the shifted angle, which reaches the same tip."""
    links = (1.0, 0.8)
    target = np.array([-1.0, -0.9])
    sol, _ = kin.ik(target, links)
    shifted, v = kin.ik(target, links, joint_limits=[[0.0, 2 * math.pi], [-3.0, 3.0]])
    assert v.all()
    assert (shifted[:, 0] >= 0).all() and (shifted[:, 0] <= 2 * math.pi).all()
    np.testing.assert_allclose(kin.wrap_angle(shifted[:, 0]), sol[:, 0], atol=1e-12)
    np.testing.assert_allclose(kin.fk(shifted, links)[1], np.stack([target, target]), atol=1e-12)


@pytest.mark.parametrize("elbow", [(-2.5, 3.6), (3.2, 4.0), (-4.0, -3.2), (-2 * math.pi, 2 * math.pi)])
def test_ik_honours_elbow_limits_past_pi(elbow) -> None:
    """(From a user's trial: with the elbow's limits [-2.5, 3.6] a fruit at fk([0.3, 3.4]) was
    called unreachable -- only the shoulder was tried 2 pi on.) Seeded poses inside limits that
    reach past +-pi: IK finds each one's tip on a branch within the limits, the same tip."""
    rng = np.random.default_rng(7)
    links, base = (1.0, 0.8), (0.2, -0.1)
    lim = np.array([[-math.pi, math.pi], elbow])
    q = np.c_[rng.uniform(-math.pi, math.pi, 2000), rng.uniform(elbow[0], elbow[1], 2000)]
    q = q[np.abs(np.sin(q[:, 1])) > 1e-6]  # (a fully stretched or folded elbow is on both branches)
    tip = kin.fk(q, links, base)[1]
    sol, valid = kin.ik(tip, links, base, lim)
    assert valid.any(axis=1).all()
    for b in (0, 1):
        ok = valid[:, b]
        assert ((sol[ok, b, 1] >= elbow[0]) & (sol[ok, b, 1] <= elbow[1])).all()
        np.testing.assert_allclose(kin.fk(sol[ok, b], links, base)[1], tip[ok], atol=1e-9)
    # the pose asked for is one of them, 2 pi on or not (the branch of its sin t2)
    b = np.where(np.sin(q[:, 1]) >= 0, 0, 1)
    got = sol[np.arange(q.shape[0]), b]
    np.testing.assert_allclose(kin.wrap_angle(got - q), 0.0, atol=1e-9)


def test_ik_outside_the_annulus_is_invalid_but_tolerance_snaps() -> None:
    links = (1.0, 0.8)
    _, v = kin.ik(np.array([[1.81, 0.0], [0.19, 0.0], [0.0, 0.0]]), links)
    assert not v.any()
    sol, v = kin.ik(np.array([1.8 + 5e-10, 0.0]), links)
    assert v.all() and np.allclose(sol[:, 1], 0.0)


def test_ik_at_the_boundaries_has_no_nan() -> None:
    links = (1.0, 0.8)
    # full extension: t2 = 0 on both branches, t1 = the target's bearing
    sol, v = kin.ik(np.array([0.0, 1.8]), links)
    assert v.all()
    np.testing.assert_allclose(sol, [[math.pi / 2, 0.0], [math.pi / 2, 0.0]], atol=1e-12)
    # inner radius: folded, |t2| = pi
    sol, v = kin.ik(np.array([0.2, 0.0]), links)
    assert v.all() and np.allclose(np.abs(sol[:, 1]), math.pi)
    np.testing.assert_allclose(kin.fk(sol, links)[1], [[0.2, 0.0], [0.2, 0.0]], atol=1e-12)
    # folded arms exclude it once the elbow limit is the lesson's pi - 0.1
    _, v = kin.ik(np.array([0.2, 0.0]), links, joint_limits=[[-math.pi, math.pi], [-math.pi + 0.1, math.pi - 0.1]])
    assert not v.any()
    # equal links: the base itself is reachable (folded), no NaN
    sol, v = kin.ik(np.array([0.0, 0.0]), (0.9, 0.9))
    assert v.all() and np.isfinite(sol).all()
    np.testing.assert_allclose(kin.fk(sol, (0.9, 0.9))[1], np.zeros((2, 2)), atol=1e-12)


def test_wrap_angle() -> None:
    a = np.array([-math.pi, math.pi, 3 * math.pi, -3 * math.pi, 0.5, 2 * math.pi + 0.5, -2 * math.pi - 0.5])
    np.testing.assert_allclose(kin.wrap_angle(a), [math.pi, math.pi, math.pi, math.pi, 0.5, 0.5, -0.5], atol=1e-12)
    w = kin.wrap_angle(np.random.default_rng(3).uniform(-50, 50, 1000))
    assert (w > -math.pi).all() and (w <= math.pi).all()


# --------------------------------------------------------------------------- Jacobian, manipulability
@SETTINGS
@given(l1=LINK, l2=LINK, t1=st.floats(-4, 4), t2=st.floats(-4, 4))
def test_jacobian_matches_central_differences(l1, l2, t1, t2) -> None:
    q = np.array([t1, t2])
    h = 1e-6
    num = np.stack(
        [(kin.fk(q + h * e, (l1, l2))[1] - kin.fk(q - h * e, (l1, l2))[1]) / (2 * h) for e in np.eye(2)], axis=-1
    )
    np.testing.assert_allclose(kin.jacobian(q, (l1, l2)), num, atol=1e-8)


@SETTINGS
@given(l1=LINK, l2=LINK, t1=st.floats(-4, 4), t2=st.floats(-4, 4))
def test_manipulability_is_abs_det_j(l1, l2, t1, t2) -> None:
    q = np.array([t1, t2])
    m = kin.manipulability(q, (l1, l2))
    assert m == pytest.approx(l1 * l2 * abs(math.sin(t2)), abs=1e-12)
    assert m == pytest.approx(abs(np.linalg.det(kin.jacobian(q, (l1, l2)))), abs=1e-9)
    prox = kin.singularity_proximity(q, (l1, l2))
    assert 0.0 <= prox <= 1.0 and prox == pytest.approx(1 - abs(math.sin(t2)), abs=1e-12)


def test_singular_poses() -> None:
    links = (1.0, 0.8)
    q = np.array([[0.3, 0.0], [0.3, math.pi], [0.3, -math.pi], [1.0, math.pi / 2]])
    np.testing.assert_allclose(kin.manipulability(q, links), [0.0, 0.0, 0.0, 0.8], atol=1e-15)
    np.testing.assert_allclose(kin.singularity_proximity(q, links), [1.0, 1.0, 1.0, 0.0], atol=1e-15)
    assert np.isfinite(kin.jacobian(q, links)).all()


# --------------------------------------------------------------------------- damped least squares
def lesson_dls(J: np.ndarray, v: np.ndarray, threshold: float = 0.05, damping: float = 0.1) -> np.ndarray:
    """The course's ``singularity_safe_ik_velocity``, verbatim."""
    det_J = abs(np.linalg.det(J))
    if det_J < threshold:
        lam = damping * (1 - det_J / threshold)
        JJT = J @ J.T + lam**2 * np.eye(2)
        return J.T @ np.linalg.solve(JJT, v)
    return np.linalg.solve(J, v)


def test_dls_equals_the_lesson_and_the_inverse_when_regular() -> None:
    rng = np.random.default_rng(7)
    links = (1.0, 0.8)
    q = np.c_[rng.uniform(-3, 3, 400), rng.uniform(-3.1, 3.1, 400)]
    q[:40, 1] = 0.0  # exactly singular
    q[40:80, 1] = math.pi
    q[80:120, 1] = rng.uniform(-0.06, 0.06, 40)  # near singular (|det J| < 0.05)
    v = rng.normal(size=(400, 2))
    J = kin.jacobian(q, links)
    qd = kin.dls_velocity(J, v)
    assert np.isfinite(qd).all()
    ref = np.array([lesson_dls(J[i], v[i]) for i in range(400)])
    np.testing.assert_allclose(qd, ref, rtol=1e-9, atol=1e-12)
    regular = np.abs(np.linalg.det(J)) >= 0.05
    assert regular.sum() > 200
    np.testing.assert_allclose(qd[regular], np.linalg.solve(J[regular], v[regular][..., None])[..., 0], rtol=1e-9, atol=1e-12)


def test_dls_at_an_exact_singularity_is_bounded() -> None:
    """At det J = 0 the damping is the full 0.1: the gain sigma / (sigma^2 + lam^2) <= 1 / (2 lam) = 5."""
    links = (1.0, 0.8)
    J = kin.jacobian(np.array([0.4, 0.0]), links)
    for v in (np.array([1.0, 0.0]), np.array([0.0, 1.0]), np.array([-math.sin(0.4), math.cos(0.4)])):
        qd = kin.dls_velocity(J, v)
        assert np.isfinite(qd).all() and np.linalg.norm(qd) <= 5.0 * np.linalg.norm(v) + 1e-12
    # a radial command (along the stretched arm) is impossible: the DLS answer is (almost) no motion
    qd = kin.dls_velocity(J, np.array([math.cos(0.4), math.sin(0.4)]))
    assert np.linalg.norm(qd) < 1e-12


# --------------------------------------------------------------------------- workspace
def lesson_project(target, base, r_inner, r_outer, margin=0.05):
    """The course's ``project_to_workspace``, verbatim."""
    d = target - base
    r = np.linalg.norm(d)
    if r < 1e-10:
        return base + np.array([r_inner + margin, 0.0])
    direction = d / r
    if r > r_outer - margin:
        return base + direction * (r_outer - margin)
    elif r < r_inner + margin:
        return base + direction * (r_inner + margin)
    return target


def test_project_to_workspace_matches_the_course() -> None:
    rng = np.random.default_rng(11)
    base = np.array([0.5, -0.2])
    links = (1.0, 0.7)
    pts = base + rng.uniform(-2.5, 2.5, (500, 2))
    pts[:5] = base  # at the base
    pts[5:10] = base + 0.1 * rng.normal(size=(5, 2))  # inside the hole
    for margin in (0.05, 0.0, 0.2):
        got = kin.project_to_workspace(pts, links, base, margin)
        ref = np.array([lesson_project(p, base, 0.3, 1.7, margin) for p in pts])
        np.testing.assert_allclose(got, ref, atol=1e-12)
        assert kin.in_workspace(got, links, base, margin - 1e-9).all()


def test_in_workspace_annulus() -> None:
    links = (1.0, 0.8)
    r = np.array([0.0, 0.19, 0.2, 0.21, 1.0, 1.79, 1.8, 1.81])
    pts = np.c_[r, np.zeros_like(r)]  # on the x axis from the origin: radii are exact
    assert kin.in_workspace(pts, links).tolist() == [False, False, True, True, True, True, True, False]
    pts = np.c_[r * math.cos(0.7), r * math.sin(0.7)] + [1.0, 2.0]
    inside = kin.in_workspace(pts, links, (1.0, 2.0), 0.015)
    assert inside.tolist() == [False, False, False, False, True, False, False, False]


def test_max_point_speed_bounds_every_point_of_the_arm() -> None:
    rng = np.random.default_rng(5)
    links = (1.0, 0.8)
    q, qd = rng.uniform(-3, 3, (300, 2)), rng.uniform(-4, 4, (300, 2))
    bound = kin.max_point_speed(qd, links)
    np.testing.assert_allclose(bound, np.abs(qd[:, 0]) + 0.8 * np.abs(qd[:, 0] + qd[:, 1]))
    # tip velocity J qd never exceeds it; nor does any point along link 2 (elbow + s l2 u)
    for s in (0.0, 0.5, 1.0):
        J = kin.jacobian(q, (1.0, 0.8 * s))
        v = np.einsum("nij,nj->ni", J, qd)
        assert (np.linalg.norm(v, axis=-1) <= bound + 1e-12).all()


# --------------------------------------------------------------------------- CasADi
def test_casadi_symbols_give_the_numpy_numbers() -> None:
    links, base = (1.1, 0.75), (0.3, -0.4)
    q = ca.SX.sym("q", 2)
    elbow, tip = kin.fk(q, links, base)
    f = ca.Function("f", [q], [elbow, tip, kin.jacobian(q, links), kin.manipulability(q, links), ca.jacobian(tip, q)])
    for qv in np.random.default_rng(9).uniform(-3.5, 3.5, (25, 2)):
        e, t, J, m, J_ad = (np.array(x) for x in f(qv))
        e_np, t_np = kin.fk(qv, links, base)
        np.testing.assert_allclose(e[:, 0], e_np, atol=1e-14)
        np.testing.assert_allclose(t[:, 0], t_np, atol=1e-14)
        np.testing.assert_allclose(J, kin.jacobian(qv, links), atol=1e-14)
        np.testing.assert_allclose(J_ad, J, atol=1e-14)  # CasADi's own derivative agrees
        assert m.item() == pytest.approx(float(kin.manipulability(qv, links)), abs=1e-14)


@pytest.mark.parametrize("T", [1, 6])
def test_casadi_matrix_of_poses_keeps_shape(T: int) -> None:
    links = (1.0, 0.8)
    Q = ca.SX.sym("Q", T, 2)
    elbow, tip = kin.fk(Q, links, (2.0, 0.0))
    assert elbow.shape == tip.shape == (T, 2)
    assert kin.manipulability(Q, links).shape == (T, 1)
    f = ca.Function("f", [Q], [elbow, tip, kin.manipulability(Q, links)])
    qv = np.random.default_rng(T).uniform(-3, 3, (T, 2))
    e, t, m = (np.array(x) for x in f(qv))
    e_np, t_np = kin.fk(qv, links, (2.0, 0.0))
    np.testing.assert_allclose(e, e_np, atol=1e-14)
    np.testing.assert_allclose(t, t_np, atol=1e-14)
    np.testing.assert_allclose(m[:, 0], kin.manipulability(qv, links), atol=1e-14)


def test_casadi_mx_and_jacobian_shape_guard() -> None:
    q = ca.MX.sym("q", 2)
    assert kin.fk(q, (1.0, 0.8))[1].shape == (2, 1)
    with pytest.raises(ValueError, match=r"\(2, 1\)"):
        kin.jacobian(ca.SX.sym("Q", 3, 2), (1.0, 0.8))


# --------------------------------------------------------------------------- segment geometry
P = np.array


@pytest.mark.parametrize(
    "p1,p2,q1,q2,d",
    [
        ((0, 0), (2, 2), (0, 2), (2, 0), 0.0),  # crossing X
        ((0, 0), (2, 0), (0, 1), (2, 1), 1.0),  # parallel, overlapping in x
        ((0, 0), (2, 0), (3, 1), (5, 1), math.sqrt(2)),  # parallel, offset: endpoint to endpoint
        ((0, 0), (2, 0), (1, 0), (3, 0), 0.0),  # collinear overlapping
        ((0, 0), (1, 0), (3, 0), (5, 0), 2.0),  # collinear disjoint
        ((0, 0), (2, 0), (1, 0), (1, 3), 0.0),  # T-junction: an endpoint on the other segment
        ((0, 0), (2, 0), (1, 0.5), (1, 3), 0.5),  # near T
        ((1, 1), (1, 1), (4, 5), (4, 5), 5.0),  # two points
        ((1, 1), (1, 1), (0, 0), (2, 0), 1.0),  # point and segment
        ((0, 0), (1, 1), (0, 0), (1, 1), 0.0),  # identical
        ((0, 0), (4, 0), (1, 1e-9), (3, -1e-9), 0.0),  # crossing at a grazing angle
        ((0, 0), (1, 0), (2, 1), (2, -1), 1.0),  # perpendicular, not touching
    ],
)
def test_segment_distance_reference_cases(p1, p2, q1, q2, d) -> None:
    args = [P(x, float) for x in (p1, p2, q1, q2)]
    assert float(segment_distance(*args)) == pytest.approx(d, abs=1e-12)
    assert float(segment_distance(args[2], args[3], args[0], args[1])) == pytest.approx(d, abs=1e-12)  # symmetric
    assert float(segment_distance(args[1], args[0], args[3], args[2])) == pytest.approx(d, abs=1e-12)  # orientation
    dd, pa, pb = segment_distance(*args, return_points=True)
    assert float(np.linalg.norm(pa - pb)) == pytest.approx(d, abs=1e-9)
    assert float(capsule_distance(args[0], args[1], 0.1, args[2], args[3], 0.2)) == pytest.approx(d - 0.3, abs=1e-12)


def _on_segment(p, a, b, tol=1e-9) -> bool:
    ab = b - a
    t = 0.0 if ab @ ab == 0 else np.clip((p - a) @ ab / (ab @ ab), 0, 1)
    return bool(np.linalg.norm(a + t * ab - p) < tol)


def test_segment_distance_against_brute_force_sampling() -> None:
    """Vectorised exact distance vs a dense sampling of both segments (an upper bound that
    converges): the exact value is never above it and within the sampling resolution."""
    rng = np.random.default_rng(123)
    n = 200
    p1, p2, q1, q2 = (rng.uniform(-1, 1, (n, 2)) for _ in range(4))
    q2[:30] = q1[:30]  # some point-like segments
    p2[30:60] = p1[30:60] + 0.5 * (p2[30:60] - p1[30:60]) * 1e-12  # nearly degenerate
    d, pa, pb = segment_distance(p1, p2, q1, q2, return_points=True)
    assert d.shape == (n,)
    s = np.linspace(0, 1, 201)[:, None]
    brute = np.empty(n)
    for i in range(n):
        A = p1[i] + s * (p2[i] - p1[i])  # (201, 2)
        B = q1[i] + s * (q2[i] - q1[i])
        brute[i] = np.sqrt(((A[:, None] - B[None]) ** 2).sum(-1).min())
    seg_len = np.linalg.norm(p2 - p1, axis=-1) + np.linalg.norm(q2 - q1, axis=-1)
    assert (d <= brute + 1e-12).all()
    assert (brute - d <= seg_len / 200 + 1e-12).all()
    # the returned closest points lie on their segments and realise the distance
    np.testing.assert_allclose(np.linalg.norm(pa - pb, axis=-1), d, atol=1e-9)
    assert all(_on_segment(pa[i], p1[i], p2[i]) and _on_segment(pb[i], q1[i], q2[i]) for i in range(n))


def test_segment_distance_in_blocks_of_stacked_rows_is_the_endpoint_by_endpoint_answer_bit_for_bit() -> None:
    """The planners' path (``segment_distance_rows``: the four endpoint-to-segment problems stacked,
    in blocks of ``ROWS_BLOCK`` columns) and the closest-points path (endpoint by endpoint) give
    the same distances to the bit -- crossings, shared endpoints, point-like and collinear segments,
    more columns than one block -- and the verifier's independent kernel agrees to 1e-12."""
    from coplan.kinematics.geometry import ROWS_BLOCK
    from coplan.verify.clearance import segment_distances

    rng = np.random.default_rng(11)
    n = 2 * ROWS_BLOCK + 37
    p1, p2, q1, q2 = (rng.uniform(-1, 1, (n, 2)) for _ in range(4))
    q2[:50] = q1[:50]  # point-like
    p2[50:100] = p1[50:100]
    q1[100:150] = p2[100:150]  # a shared endpoint
    p1[150:400], p2[150:400], q1[150:400], q2[150:400] = (np.round(x[150:400], 1) for x in (p1, p2, q1, q2))  # ties, collinear
    fast = segment_distance(p1, p2, q1, q2)
    slow = segment_distance(p1, p2, q1, q2, return_points=True)[0]
    assert np.array_equal(fast, slow) and (fast == 0).sum() > 100  # (crossings among them)
    np.testing.assert_allclose(fast, segment_distances(p1, p2, q1, q2), rtol=0, atol=1e-12)


def test_segment_distance_broadcasts() -> None:
    p1 = np.zeros((4, 1, 2))
    p2 = np.array([1.0, 0.0])
    q1 = np.stack([np.array([x, 1.0]) for x in range(3)])[None]  # (1, 3, 2)
    q2 = q1 + [0.0, 1.0]
    d = segment_distance(p1, p2, q1, q2)
    assert d.shape == (4, 3)
    np.testing.assert_allclose(d[0], [1.0, 1.0, math.sqrt(2)])


def test_scalar_jacobian_entries_are_the_jacobian_and_its_rate_its_derivative() -> None:
    """``jacobian_entries`` (plain floats, for one pose at a time) is :func:`jacobian`;
    ``jacobian_rate_entries`` is its time derivative along the joint rates (central finite
    differences of the Jacobian along q + qd t)."""
    rng = np.random.default_rng(8)
    for _ in range(200):
        q, qd, links = rng.uniform(-3.2, 3.2, 2), rng.uniform(-2.0, 2.0, 2), rng.uniform(0.2, 1.0, 2)
        a, b, d, e = kin.jacobian_entries(float(q[0]), float(q[1]), links)
        np.testing.assert_allclose([[a, b], [d, e]], kin.jacobian(q, links), rtol=0, atol=1e-14)
        h = 1e-6
        fd = (kin.jacobian(q + h * qd, links) - kin.jacobian(q - h * qd, links)) / (2 * h)
        ad, bd, dd, ed = kin.jacobian_rate_entries(float(q[0]), float(q[1]), float(qd[0]), float(qd[1]), links)
        np.testing.assert_allclose([[ad, bd], [dd, ed]], fd, rtol=0, atol=1e-8)


@pytest.mark.parametrize("limits", [None, [[-math.pi, math.pi], [-math.pi + 0.1, math.pi - 0.1]],
                                    [[0.0, 2 * math.pi], [-3.0, 3.0]], [[-2 * math.pi, -0.5], [0.0, 3.0]],
                                    [[-math.pi, math.pi], [-2.5, 3.6]], [[-math.pi, math.pi], [3.2, 4.0]]])
def test_ik_one_gives_the_bits_of_ik(limits) -> None:
    """The plain-float IK of one point (the moving-carriage booking's) equals the vectorised one
    to the last bit, NaN where it is invalid: 20,000 seeded points over and past the annulus,
    both branches, limits narrower and wider than a turn."""
    rng = np.random.default_rng(29)
    links, base = (0.9, 0.7), (0.3, -0.2)
    r = rng.uniform(0.0, 1.8, 20_000)
    r[:200] = 1.6 + rng.choice([-1e-10, 0.0, 1e-10], 200)  # at the boundaries and just past them
    r[200:400] = 0.2 + rng.choice([-1e-10, 0.0, 1e-10], 200)
    a = rng.uniform(-math.pi, math.pi, r.size)
    pts = np.c_[base[0] + r * np.cos(a), base[1] + r * np.sin(a)]
    q, valid = kin.ik(pts, links, base, None if limits is None else np.array(limits))
    for k in range(pts.shape[0]):
        for b in (0, 1):
            one = np.array(kin.ik_one(pts[k, 0], pts[k, 1], links, base, limits, b))
            assert np.isfinite(one).all() == valid[k, b]
            assert np.array_equal(one, q[k, b], equal_nan=True), (pts[k], b, one, q[k, b])


def test_poses_of_the_wrong_shape_are_refused_with_what_was_expected_and_found() -> None:
    """Poses in columns ((2, T): the easiest slip with trajectory data) gave T wrong answers
    without a word, a (T, 3) array used its first two columns; lists and tuples are poses too."""
    links = (1.0, 0.8)
    q = np.array([[0.1, 0.4], [0.7, -0.3], [1.2, 0.9]])
    for fn in (kin.fk, kin.jacobian, kin.manipulability, kin.fk_points):
        with pytest.raises(ValueError, match=r"expected shape \(\.\.\., 2\).*found shape \(2, 3\).*\.T gives them in rows"):
            fn(q.T, links)
        with pytest.raises(ValueError, match=r"found shape \(3, 3\)"):
            fn(np.c_[q, q[:, :1]], links)
        with pytest.raises(ValueError, match=r"found shape \(\)"):
            fn(0.3, links)
    assert np.array_equal(kin.fk([0.1, 0.4], links)[1], kin.fk(q[0], links)[1])  # (a list: TypeError from inside)
    assert np.array_equal(kin.jacobian([[0.1, 0.4]], links), kin.jacobian(q[:1], links))
    with pytest.raises(ValueError, match=r"links: expected \(l1, l2\) in m, two numbers, found \(1\.0,\)"):
        kin.fk(q, (1.0,))
    with pytest.raises(ValueError, match=r"base: expected \(x, y\) in m, two numbers"):
        kin.fk(q, links, base=(1.0,))
    with pytest.raises(ValueError, match=r"ik: target: expected shape \(\.\.\., 2\).*found shape \(5, 3\)"):
        kin.ik(np.zeros((5, 3)), links)
    with pytest.raises(ValueError, match=r"in_workspace: target"):
        kin.in_workspace(np.zeros((5, 3)), links)
    with pytest.raises(ValueError, match=r"dls_velocity: v_desired: expected shape \(\.\.\., 2\).*found shape \(3,\)"):
        kin.dls_velocity(np.eye(2), np.zeros(3))
    with pytest.raises(ValueError, match=r"J of shape \(\.\.\., 2, 2\) and v_desired \(\.\.\., 2\).*found J \(3, 2\) and v_desired \(2,\)"):
        kin.dls_velocity(np.zeros((3, 2)), np.zeros(2))
    with pytest.raises(ValueError, match=r"found J \(3, 2, 2\) and v_desired \(4, 2\)"):
        kin.dls_velocity(np.zeros((3, 2, 2)), np.zeros((4, 2)))
    J = kin.jacobian(q, links)  # one J for many velocities, many J for one: broadcast, as before the checks
    vs = np.array([[0.1, 0.2], [0.0, -0.3], [0.5, 0.5]])
    np.testing.assert_allclose(kin.dls_velocity(J[0], vs), [kin.dls_velocity(J[0], v) for v in vs])
    np.testing.assert_allclose(kin.dls_velocity(J, vs[0]), [kin.dls_velocity(j, vs[0]) for j in J])
    b, qs = ca.SX.sym("b", 2), ca.SX.sym("q", 2, 1)  # a symbolic base stays symbolic
    tip = ca.Function("tip", [qs, b], [kin.fk(qs, links, b)[1]])
    np.testing.assert_allclose(np.array(tip(q[1], [0.5, 0.2])).ravel(), kin.fk(q[1], links, (0.5, 0.2))[1], atol=1e-12)
    for bad in (ca.SX.sym("q", 3, 1), ca.SX.sym("q", 2, 3), ca.MX.sym("q", 1, 1)):
        with pytest.raises(ValueError, match=r"fk: q as CasADi symbols: expected one pose as a \(2, 1\) column or T poses as a \(T, 2\) matrix"):
            kin.fk(bad, links)


def test_kinematics_arguments_that_are_not_poses_limits_or_branches_are_named() -> None:
    """(From a user's trial: ik(..., joint_limits=[-1, 1]) a bare IndexError; sweep_box(1.0, 2.0,
    links) "'float' object is not subscriptable"; ik_one(..., branch=5) taken as elbow-down;
    ik with zero links valid=True with NaN angles.)"""
    with pytest.raises(ValueError, match=r"ik: joint_limits: expected \[\[t1_min, t1_max\], \[t2_min, t2_max\]\] "
                                         r"\(shape \(2, 2\)\), found shape \(2,\)"):
        kin.ik(np.ones((5, 2)), (1, 0.8), (0, 0), [-1, 1])
    with pytest.raises(ValueError, match="sweep_box: q_lo: expected"):
        kin.sweep_box(1.0, 2.0, (1, 0.8))
    with pytest.raises(ValueError, match="ik_one: branch: expected 0"):
        kin.ik_one(1.0, 0.5, (1, 0.8), (0, 0), None, 5)
    with pytest.raises(ValueError, match="ik: links: expected two link lengths > 0"):
        kin.ik([0.0, 0.0], (0.0, 0.0))
    assert kin.sweep_box((0.0, 0.0), (0.1, 0.1), (1, 0.8)) == kin.sweep_box([0, 0], np.array([0.1, 0.1]), [1.0, 0.8])
