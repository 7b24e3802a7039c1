"""The coordinator's cheap screens give exactly the answers of the exact test they skip.

The coordinator tests a leg against its neighbours' commitments thousands of times per plan.
Two screens make that cheaper without changing a single answer:

* a box screen: when a box holding the arm wherever its leg takes it and a box holding the
  neighbour over the whole span are further apart than the clearance needed, the exact test
  is skipped (it could find nothing). The boxes come from :func:`coplan.kinematics.arm.sweep_box`
  over stretches of each S-curve move, whose joints each move one way;
* link midpoints and half lengths computed once per set of samples (``LinkPoints``) and,
  for a set of poses against a set of samples, every pair at once (``links_too_close_pairs``).

These tests check the facts each screen rests on, and that plans come out the same with the
box screen switched off.
"""

from __future__ import annotations

import numpy as np
import pytest

from coplan import kinematics as kin
from coplan.allocate.allocation import allocate
from coplan.kinematics import SCurve
from coplan.kinematics.arm import sweep_box
from coplan.planners.coordinated import coordinate as coordinate_module
from coplan.planners.coordinated.coordinate import coordinate
from coplan.planners.coordinated.routing import ArmGeometry
from coplan.planners.coordinated.schedule import (
    CurveTable,
    Step,
    StepKind,
    arm_points,
    decoupled_schedules,
    links_too_close,
    links_too_close_pairs,
    points_too_close,
    scurve_move,
)
from coplan.problem import load_problem

MARGIN = 0.015


def _inside(points: np.ndarray, box) -> bool:
    x, y = points[..., 0], points[..., 1]
    return bool(x.min() >= box[0] and x.max() <= box[1] and y.min() >= box[2] and y.max() <= box[3])


def test_sweep_box_holds_the_arm_at_every_pose_in_the_joint_box():
    rng = np.random.default_rng(1)
    for _ in range(2000):
        lo = rng.uniform(-7.0, 7.0, 2)
        hi = lo + rng.uniform(0.0, rng.choice([0.01, 1.0, 4.0, 8.0]), 2)
        links, base = rng.uniform(0.1, 1.0, 2), rng.uniform(-2.0, 2.0, 2)
        q = np.vstack([lo + rng.uniform(0.0, 1.0, (300, 2)) * (hi - lo), lo, hi, [lo[0], hi[1]], [hi[0], lo[1]]])
        # base, elbow, tip; the links are segments between them, so inside their box
        assert _inside(kin.fk_points(q, links, base), sweep_box(lo, hi, links, base))


def test_sweep_box_of_one_pose_is_its_points_box():
    q, links, base = np.array([0.7, -1.9]), (0.6, 0.45), (2.0, -0.3)
    p = kin.fk_points(q, links, base)
    box = sweep_box(q, q, links, base, pad=0.0)
    np.testing.assert_allclose(box, (p[:, 0].min(), p[:, 0].max(), p[:, 1].min(), p[:, 1].max()), atol=1e-12)
    # a full turn of both joints: the whole reach
    assert sweep_box((0, 0), (2 * np.pi, 2 * np.pi), links, base, pad=0.0) == pytest.approx((0.95, 3.05, -1.35, 0.75))


def test_scurve_moves_each_joint_one_way_between_its_end_values():
    """What the move boxes rest on: a rest-to-rest S-curve never turns a joint back."""
    rng = np.random.default_rng(2)
    for _ in range(200):
        q0, q1 = rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        if rng.random() < 0.2:  # some joints stay put
            j = int(rng.integers(0, 2))
            q1[j] = q0[j]
        c = SCurve.between(q0, q1, rng.uniform(0.5, 4, 2), rng.uniform(1, 12, 2), rng.uniform(5, 120, 2))
        q = CurveTable(c).eval(np.linspace(0.0, c.duration, 2001))
        steps = np.diff(q, axis=0) * np.sign(q1 - q0)
        assert (steps >= -1e-12).all()
        assert (q >= np.minimum(q0, q1) - 1e-12).all() and (q <= np.maximum(q0, q1) + 1e-12).all()


def _coordinator(problems_dir, name):
    p = load_problem(problems_dir / f"{name}.yaml")
    base = decoupled_schedules(p, allocate(p))
    c = coordinate_module._Coordinator(p, base, MARGIN, 200.0, 0.02, None, None, None, None)
    return p, c


def test_a_move_box_holds_the_arm_at_every_sample_of_the_move(problems_dir):
    p, c = _coordinator(problems_dir, "dense_overlap")
    rng = np.random.default_rng(4)
    for _ in range(100):
        i = int(rng.integers(0, len(p.arms)))
        arm = p.arms[i]
        q0, q1 = (tuple(map(float, rng.uniform(arm.limits[:, 0], arm.limits[:, 1]))) for _ in range(2))
        st = scurve_move(arm, 0.0, q0, q1)
        box = c.boxes.step(i, st)
        q = CurveTable(st.curve).eval(np.linspace(0.0, st.curve.duration, 4001))
        pts = np.stack(arm_points(arm, q), axis=-1)  # (K, 6): bx, by, ex, ey, tx, ty
        assert _inside(pts.reshape(-1, 3, 2), box)
        # a pose's box is its own points' box
        rest = Step(StepKind.WAIT, 0.0, 1.0, q1, q1)
        assert _inside(kin.fk_points(np.array(q1), arm.links, arm.base), c.boxes.step(i, rest))


def test_pairs_of_samples_are_the_broadcast_answers(problems_dir):
    p = load_problem(problems_dir / "five_arm_row.yaml")
    geo = ArmGeometry(p, p.task.clearance + MARGIN)
    rng = np.random.default_rng(0)
    hits = 0
    for _ in range(200):
        i = int(rng.integers(0, len(p.arms) - 1))
        poses = rng.uniform(-3.2, 3.2, (int(rng.integers(1, 12)), 2))
        samples = rng.uniform(-3.2, 3.2, (int(rng.integers(1, 300)), 2))
        r = p.arms[i].link_radius + p.arms[i + 1].link_radius
        pairs = links_too_close_pairs(geo.links(i, poses), geo.links(i + 1, samples), r, geo.need)
        broadcast = points_too_close(arm_points(p.arms[i], poses[:, None, :]), arm_points(p.arms[i + 1], samples[None]),
                                     r, geo.need)
        assert np.array_equal(pairs, broadcast)
        hits += int(pairs.sum())
        # and slices of prepared samples are the samples' own answers
        a, b = geo.links(i, samples), geo.links(i + 1, samples[::-1].copy())
        k = int(rng.integers(0, len(samples)))
        pa = tuple(x[k:] for x in arm_points(p.arms[i], samples))
        pb = tuple(x[k:] for x in arm_points(p.arms[i + 1], samples[::-1]))
        assert np.array_equal(links_too_close(a[k:], b[k:], r, geo.need), points_too_close(pa, pb, r, geo.need))
    assert hits > 0


def test_many_samples_one_pair_of_links_at_a_time_are_the_exact_answers(problems_dir):
    """From ``ONE_LINK_PAIR_AT_A_TIME`` samples (or pairs of samples) on, the pairs of links are
    tested one at a time and a sample already found too close is not tested again: the answers
    are the exact test's (``points_clearance < need``) and the all-at-once path's on the same
    samples in small slices, for sample by sample and for every pair."""
    from coplan.planners.coordinated.schedule import ONE_LINK_PAIR_AT_A_TIME, LinkPoints, points_clearance

    p = load_problem(problems_dir / "dense_overlap.yaml")
    rng = np.random.default_rng(3)
    a, b = p.arms[0], p.arms[1]
    r = a.link_radius + b.link_radius
    for need in (0.0, 0.05, 0.3):
        qa, qb = rng.uniform(-3.2, 3.2, (2 * ONE_LINK_PAIR_AT_A_TIME, 2)), rng.uniform(-3.2, 3.2, (2 * ONE_LINK_PAIR_AT_A_TIME, 2))
        pa, pb = arm_points(a, qa), arm_points(b, qb)
        la, lb = LinkPoints.of(pa), LinkPoints.of(pb)
        close = links_too_close(la, lb, r, need)
        assert 0 < close.sum() < close.size
        assert np.array_equal(close, points_clearance(pa, pb, r) < need)
        step = ONE_LINK_PAIR_AT_A_TIME // 4
        assert np.array_equal(close, np.concatenate([links_too_close(la[k:k + step], lb[k:k + step], r, need)
                                                     for k in range(0, close.size, step)]))
        n, m = 40, ONE_LINK_PAIR_AT_A_TIME // 10  # 40 x 204 pairs: one pair of links at a time
        pairs = links_too_close_pairs(la[:n], lb[:m], r, need)
        assert np.array_equal(pairs, points_clearance(tuple(x[:n, None] for x in pa), tuple(x[None, :m] for x in pb), r) < need)
        assert np.array_equal(pairs, np.vstack([links_too_close_pairs(la[k:k + 1], lb[:m], r, need) for k in range(n)]))


def test_boxed_in_is_counted_from_each_neighbours_stows_as_static_hits_counts_them(problems_dir):
    """``boxed_in`` (the samples' points computed once, each neighbour's stows' once): a neighbour
    counts when each of its stows -- home and over the bin first, then the rest -- meets one of
    the samples, exactly as ``static_hits`` counts them; seeded samples of every arm, some boxing
    a neighbour in and some not."""
    p = load_problem(problems_dir / "dense_overlap.yaml")
    geo = ArmGeometry(p, p.task.clearance + MARGIN)
    rng = np.random.default_rng(5)
    counts = []
    for _ in range(60):
        i = int(rng.integers(0, len(p.arms)))
        samples = rng.uniform(-3.2, 3.2, (int(rng.integers(1, 400)), 2))
        want = sum(1 for j in geo.nbrs[i]
                   if (geo.static_hits(j, geo.stows(j)[:3], i, samples) > 0).all()
                   and (geo.static_hits(j, geo.stows(j)[3:], i, samples) > 0).all())
        assert geo.boxed_in(i, samples) == want
        counts.append(want)
    assert 0 in counts and max(counts) > 0
    assert geo.boxed_in(0, np.zeros((0, 2))) == 0


@pytest.mark.parametrize("name", ["dense_overlap", "five_arm_row", "crossing_paths"])
def test_the_box_screen_changes_no_plan(problems_dir, monkeypatch, name):
    """Coordinating with the box screen and without it gives the same steps, to the bit; the
    screen skips some exact tests on these problems."""
    p = load_problem(problems_dir / f"{name}.yaml")
    base = decoupled_schedules(p, allocate(p))
    exact = []
    real = ArmGeometry.close_links

    def counted(self, *a):
        exact.append(1)
        return real(self, *a)

    monkeypatch.setattr(ArmGeometry, "close_links", counted)
    screened = coordinate(p, base, MARGIN)
    n_screened = len(exact)
    monkeypatch.setattr(coordinate_module, "apart", lambda a, b, d: False)
    exact.clear()
    plain = coordinate(p, base, MARGIN)
    assert len(exact) > n_screened
    for name_ in screened[0]:
        a, b = screened[0][name_].steps, plain[0][name_].steps
        assert [(s.kind, s.t0, s.t1, s.q0, s.q1) for s in a] == [(s.kind, s.t0, s.t1, s.q0, s.q1) for s in b]


def test_pose_keys_are_numpy_rounding():
    """The routing memo's pose keys are ``np.round(q, 9)`` computed in plain Python: the same
    value for every pose, halves included, so a memo filled before is still found."""
    from coplan.planners.coordinated.routing import _key

    rng = np.random.default_rng(5)
    q = np.concatenate([rng.uniform(-7, 7, (20000, 2)),
                        np.round(rng.uniform(-7, 7, (20000, 2)), 9) + rng.choice([0.0, 5e-10, -5e-10, 1e-16], (20000, 2))])
    for row in q:
        assert _key(row) == tuple(np.round(row, 9))
    assert np.isnan(_key(np.array([np.nan, 0.0]))[0])


def test_a_move_cut_short_keeps_its_whole_curves_box(problems_dir):
    """A live re-plan commits a move cut short: its own curve, but a pose part way as its end.
    Its box is its curve's, not that of a fresh move between the same two poses (a different
    path), whichever was boxed first."""
    from dataclasses import replace

    p, c = _coordinator(problems_dir, "dense_overlap")
    arm = p.arms[1]
    q0, q1 = (-1.5, 2.2), (-2.0, -2.5)  # (a move whose cut path leaves the fresh move's box)
    full = scurve_move(arm, 0.0, q0, q1)
    cut_t = 0.6 * full.duration
    q_mid = tuple(map(float, CurveTable(full.curve).eval(np.array([cut_t]))[0]))
    fresh = scurve_move(arm, 0.0, q0, q_mid)  # the same end poses, its own timing
    cut = replace(full, duration=cut_t, q1=q_mid)
    boxes = [c.boxes.step(1, fresh), c.boxes.step(1, cut)]  # the fresh move boxed first
    paths = []
    for st, upto, box in ((fresh, fresh.duration, boxes[0]), (cut, cut_t, boxes[1])):
        q = CurveTable(st.curve).eval(np.linspace(0.0, upto, 2001))
        paths.append(np.stack(arm_points(arm, q), axis=-1).reshape(-1, 3, 2))
        assert _inside(paths[-1], box)
    assert not _inside(paths[1], boxes[0])  # a memo keyed by the end poses would have been wrong here
