"""The static feasibility screen: locked arms, exact q1 intervals, and that it never rules out
what a plan can do."""

from __future__ import annotations

import json
import math
from dataclasses import replace

import numpy as np
import pytest

from coplan.generate import random_problem, to_yaml
from coplan.planners.heuristic import plan_heuristic
from coplan.problem import Arm, Fruit, Problem, Task, load_problem, parse_problem, shipped_problems
from coplan.allocate.screen import screen
from layouts import squeezed

LOCKED = next(p for p in shipped_problems() if p.name == "locked_arms.yaml")

TWO = """name: two
defaults: {{links: [1.0, 0.8], link_radius: 0.04, joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]],
  max_velocity: [3, 4], max_acceleration: [8, 12], max_jerk: [80, 120], home: [1.5708, 0.0]}}
arms:
  - {{name: left, base: [{xl}, 0.0], bin: [{xl}, -0.5]}}
  - {{name: right, base: [{xr}, 0.0], bin: [{xr}, -0.5]}}
fruits:
{fruits}
task: {{pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}}
"""


def two_arms(spacing: float, fruits: dict[str, tuple[float, float]] | None = None) -> Problem:
    """Two lesson arms ``spacing`` apart, both home pointing straight up, bins 0.5 m below."""
    fruits = fruits or {"mid": (0.0, 1.2)}
    lines = "\n".join(f"  - {{id: {k}, position: [{x}, {y}]}}" for k, (x, y) in fruits.items())
    return parse_problem(TWO.format(xl=-spacing / 2, xr=spacing / 2, fruits=lines))


def _point_segment(p, a, b):
    ab = b - a
    t = np.clip(((p - a) * ab).sum(-1) / (ab * ab).sum(-1), 0.0, 1.0)
    return np.linalg.norm(a + t[..., None] * ab - p, axis=-1)


def _link_clear(problem: Problem, arm: Arm, q: np.ndarray, slack: float = 0.0, links=(0, 1)) -> np.ndarray:
    """(N,) whether the arm at poses q (N, 2) keeps ``clearance + radii + slack`` from every other base."""
    pts = np.stack([np.broadcast_to(arm.base, q.shape), *_fk(arm, q)], axis=-2)  # (N, 3, 2)
    ok = np.ones(len(q), dtype=bool)
    for other in problem.arms:
        if other is arm:
            continue
        need = problem.task.clearance + arm.link_radius + other.link_radius + slack
        for k in links:
            ok &= _point_segment(np.asarray(other.base), pts[:, k], pts[:, k + 1]) >= need
    return ok


def _fk(arm: Arm, q):
    l1, l2 = arm.links
    e = np.asarray(arm.base) + l1 * np.stack([np.cos(q[:, 0]), np.sin(q[:, 0])], -1)
    return e, e + l2 * np.stack([np.cos(q[:, 0] + q[:, 1]), np.sin(q[:, 0] + q[:, 1])], -1)


# --------------------------------------------------------------------------- the shipped showcase
def test_locked_arms_verdict() -> None:
    p = load_problem(LOCKED)
    s = screen(p)
    assert s.arm_ok == {"r1": False, "r2": True, "r3": False, "r4": True}
    assert s.locked == ("r1", "r3")
    ids = [f.id for f in p.fruits]
    harvest = {a: [ids[j] for j in np.flatnonzero(s.reach[i])] for i, a in enumerate(s.arms)}
    assert harvest == {"r1": [], "r2": ["p002", "p004"], "r3": [], "r4": ["p001"]}
    assert s.unharvestable == ("p003",)
    assert not (s.reach & ~p.reach_matrix()).any()
    # r1 sweeps from home q1 = 1.425 up to the limit and down only to r2's arc (asin(R / D))
    need = 0.0749 + 2 * 0.036
    lo, hi = s.q1_range["r1"]
    assert lo == pytest.approx(math.asin(need / (-0.6948 + 1.7379)), abs=1e-9) and hi == pytest.approx(3.1416)
    assert s.q1_range["r3"][0] == pytest.approx(math.asin(need / 1.0), abs=1e-9)
    assert s.bin_branches["r1"] == [] and s.bin_branches["r2"] == [0, 1]
    for arm, blocker in (("r1", "r2"), ("r3", "r4")):
        r = s.reasons[arm]
        assert r.startswith(f"{arm} cannot reach its bin") and f"cross {blocker}'s base" in r
        assert "joint limit q1 <= 3.1416 blocks the way round" in r
    assert s.reasons["p003"].startswith("p003: out of every arm's reach: ")
    assert "beyond its outer reach" in s.reasons["p003"] and "reach_margin" in s.reasons["p003"]
    assert set(s.reasons) == {"r1", "r3", "p003"}
    summary = json.loads(json.dumps(s.summary()))
    assert summary["locked"] == ["r1", "r3"] and summary["arms"]["r2"]["fruit"] == ["p002", "p004"]
    lines = s.lines()
    assert lines[0] == "screen: 2 of 4 arms locked (r1, r3); 3 of 4 fruit harvestable, 1 not (p003)"
    assert any("r1 cannot reach its bin" in ln for ln in lines)


def test_the_locked_arm_really_breaches_on_the_way_to_its_bin() -> None:
    """The heuristic plan sends the locked arms it gives fruit to to their bins: link 1 does
    breach a neighbour base's clearance on the way."""
    p = load_problem(LOCKED)
    plan = plan_heuristic(p)
    busy = [name for name in ("r1", "r3") if plan.allocation.get(name)]
    assert busy
    for name in busy:
        assert not _link_clear(p, p.arm(name), plan.q[name], links=(0,)).all()


@pytest.mark.parametrize("path", [p for p in shipped_problems() if p.name != "locked_arms.yaml"], ids=lambda p: p.stem)
def test_other_shipped_problems_pass_unchanged(path) -> None:
    p = load_problem(path)
    s = screen(p)
    assert not s.locked
    np.testing.assert_array_equal(s.reach, p.reach_matrix())
    assert list(s.unharvestable) == p.unreachable()


# --------------------------------------------------------------------------- analytic cases
def test_two_arms_close_left_is_locked_right_is_not() -> None:
    # 0.9 m apart, link 1 = 1.0 m: the left arm (home up, bin below) must swing link 1 down
    # through the right base's direction, or the long way round past q1 = pi (the limit)
    s = screen(two_arms(0.9, {"far_left": (-1.6, 0.8), "mid": (0.0, 1.2)}))
    assert s.arm_ok == {"left": False, "right": True}
    assert "cross right's base" in s.reasons["left"] and "q1 <= 3.1416" in s.reasons["left"]
    assert s.reasons["far_left"] == "far_left: only left reaches it and left cannot reach its bin"
    s2 = screen(load_problem(LOCKED))  # p004: r1, r2 and r3 reach it; two of them are locked
    assert s2.reach[:, 3].tolist() == [False, True, False, False]
    assert s.reach.tolist() == [[False, False], [False, True]]
    # the right arm swings down clockwise, away from the left base; the arc is blocked above
    half = math.asin(0.13 / 0.9)
    assert s.q1_range["right"] == pytest.approx((-math.pi + half, math.pi - half))
    assert s.q1_range["left"] == pytest.approx((half, 3.1416))


def test_two_arms_far_apart_are_free() -> None:
    p = two_arms(2.5, {"a": (0.0, 1.2), "b": (-1.9, 0.6)})
    s = screen(p)
    assert all(s.arm_ok.values()) and not s.reasons
    assert s.q1_range == {"left": (-3.1416, 3.1416), "right": (-3.1416, 3.1416)}
    np.testing.assert_array_equal(s.reach, p.reach_matrix())


def test_link2_pose_check() -> None:
    # bases 1.5 m apart (link 1 can never reach the other base), but a pick right next to the
    # right base makes the left arm's link 2 lie across it; the right arm is too close to reach it
    p = two_arms(1.5, {"a": (0.87, 0.08), "c": (0.85, 0.12), "free": (0.0, 1.2)})
    s = screen(p)
    assert p.reach_matrix()[:, 0].tolist() == [True, False]
    assert s.fruit_branches["left", "a"] == [] and s.fruit_branches["left", "c"] == [1]
    assert s.unharvestable == ("a",)
    assert s.reasons["a"] == (
        "a: only left reaches it and left cannot pick it: "
        "link 2 would come within the clearance of right's base at the pick pose"
    )
    # with the exact poses only, nothing changes here; the tolerance only ever adds poses
    s0 = screen(p, tip_tolerance=0.0)
    assert not (s0.reach & ~s.reach).any()


def test_home_inside_a_neighbours_clearance_gives_an_empty_range() -> None:
    p = two_arms(0.9)
    left = replace(p.arms[0], home=(0.0, 1.0))  # link 1 lies across the right base
    bad = Problem(name="bad", arms=(left, p.arms[1]), fruits=p.fruits, task=p.task)
    s = screen(bad)
    assert s.q1_range["left"] is None and not s.arm_ok["left"] and s.bin_branches["left"] == []
    assert "already within the clearance of right's base at home" in s.reasons["left"]
    assert s.summary()["arms"]["left"]["q1_range"] is None
    assert "  left: LOCKED: takes no fruit; its shoulder cannot move from home without hitting a neighbour" in s.lines()


def test_limits_wider_than_a_turn_open_the_way_round() -> None:
    # three arms 0.9 m apart; with q1 in [-4.5, 4.5] an arm may swing up past pi to q1 + 2 pi
    p = two_arms(0.9)
    wide = ((-4.5, 4.5), (-3.0416, 3.0416))
    far = replace(p.arms[1], name="far", base=(1.35, 0.0), bin=(1.35, -0.5))
    arms = tuple(replace(a, joint_limits=wide) for a in (*p.arms, far))
    s = screen(Problem(name="wide", arms=arms, fruits=(), task=p.task))
    assert s.reach.shape == (3, 0) and s.unharvestable == ()
    # the bin (0.5 m below) needs q1 = -2.486 (elbow up) or -0.656 (elbow down); + 2 pi only
    # the first fits under 4.5, and only the left arm has no neighbour's base on that way round
    assert s.arm_ok == {"left": True, "right": False, "far": True}
    assert s.bin_branches == {"left": [0], "right": [], "far": [0, 1]}
    assert s.q1_range["left"] == pytest.approx((math.asin(0.13 / 0.9), 4.5))
    assert s.reasons["right"] == (
        "right cannot reach its bin: elbow up: link 1 would cross far's base on the way to q1 = -2.486 and left's base "
        "blocks the way round; elbow down: link 1 would cross far's base on the way to q1 = -0.656 and the joint limit "
        "q1 <= 4.5 blocks the way round"
    )


# --------------------------------------------------------------------------- exactness
def _brute_range(problem: Problem, arm: Arm, step: float = 5e-5):
    """The connected q1 interval around home, by sampling link 1 against the other bases."""
    lo, hi = arm.joint_limits[0]
    grid = np.arange(lo, hi + step / 2, step)
    ok = _link_clear(problem, arm, np.c_[grid, np.zeros_like(grid)], links=(0,))
    h = int(np.searchsorted(grid, arm.home[0]))
    h = min(h, len(grid) - 1)
    if not ok[h] or not _link_clear(problem, arm, np.array([arm.home]), links=(0,))[0]:
        return None
    a = h
    while a > 0 and ok[a - 1]:
        a -= 1
    b = h
    while b < len(grid) - 1 and ok[b + 1]:
        b += 1
    return grid[a], grid[b]


@pytest.mark.parametrize("seed", range(6))
def test_q1_range_and_poses_match_brute_force(seed: int) -> None:
    rng = np.random.default_rng(seed)
    n = 3
    xs = np.cumsum(rng.uniform(0.5, 1.6, n))
    task = Task(pick_dwell=0.2, place_dwell=0.2, clearance=float(rng.uniform(0.02, 0.1)))
    arms = []
    for i, x in enumerate(xs):
        l1, l2 = rng.uniform(0.7, 1.3), rng.uniform(0.5, 1.0)
        q1max = rng.uniform(2.0, 3.1416)
        by = float(rng.uniform(-0.2, 0.2))  # (a bin the arm reaches: one it does not is refused, as a file's is)
        arms.append(Arm(name=f"a{i}", base=(float(x), by), bin=(float(x), by - max(l1, l2)),
                        links=(l1, l2), link_radius=float(rng.uniform(0.02, 0.05)),
                        joint_limits=((-q1max, q1max), (-3.0, 3.0)), max_velocity=(3, 4),
                        max_acceleration=(8, 12), max_jerk=(80, 120),
                        home=(float(rng.uniform(-q1max, q1max)), 0.5)))
    fruits = tuple(
        Fruit(id=f"f{k:02d}", position=(float(rng.uniform(xs[0] - 1.5, xs[-1] + 1.5)), float(rng.uniform(-1.0, 1.8))))
        for k in range(40)
    )
    p = Problem(name="brute", arms=tuple(arms), fruits=fruits, task=task)
    s = screen(p, tip_tolerance=0.0)
    for arm in p.arms:
        want = _brute_range(p, arm)
        got = s.q1_range[arm.name]
        if want is None:
            assert got is None
            continue
        assert got is not None
        assert got[0] == pytest.approx(want[0], abs=1e-4) and got[1] == pytest.approx(want[1], abs=1e-4)
        # poses: usable <=> q1 inside the range and link 2 clear (skip razor-edge cases)
        for f in p.fruits:
            q, valid = arm.ik(f.position, p.task.reach_margin)
            if not valid.any():
                assert (arm.name, f.id) not in s.fruit_branches
                continue
            for b in np.flatnonzero(valid):
                inside = want[0] + 1e-3 <= q[b, 0] <= want[1] - 1e-3
                outside = q[b, 0] < want[0] - 1e-3 or q[b, 0] > want[1] + 1e-3
                clear = _link_clear(p, arm, q[b][None], links=(1,))[0]
                if inside and clear:
                    assert b in s.fruit_branches[arm.name, f.id]
                elif outside or not _link_clear(p, arm, q[b][None], slack=-1e-3, links=(1,))[0]:
                    assert b not in s.fruit_branches[arm.name, f.id]


# --------------------------------------------------------------------------- never too strict
def _tight(seed: int) -> Problem | None:
    """random_problem(seed) squeezed to bases 0.9-1.4 m apart (about half its arms lock)."""
    return squeezed(seed, n_fruits=12)


@pytest.mark.parametrize("tight", [False, True], ids=["random", "tight"])
@pytest.mark.parametrize("seed", range(8))
def test_screen_never_rules_out_what_the_heuristic_plan_does(seed: int, tight: bool) -> None:
    """Every arm whose heuristic trajectory (1 kHz replay) clearly keeps clear of every other
    base is not locked, stays inside its q1 range, and keeps every fruit it picks."""
    p = _tight(seed) if tight else parse_problem(to_yaml(random_problem(seed, n_fruits=12)))
    if p is None:
        pytest.skip("squeezed layout does not validate")
    s = screen(p)
    full = p.reach_matrix()
    assert not (s.reach & ~full).any()
    plan = plan_heuristic(p)
    q = plan.sample(np.arange(0.0, plan.duration, 1e-3))
    ids = [f.id for f in p.fruits]
    for i, arm in enumerate(p.arms):
        if not plan.events_of(arm.name) or not _link_clear(p, arm, q[arm.name], slack=0.01).all():
            continue  # an idle arm proves nothing about its bin
        assert s.arm_ok[arm.name]
        lo, hi = s.q1_range[arm.name]
        assert lo - 1e-9 <= q[arm.name][:, 0].min() and q[arm.name][:, 0].max() <= hi + 1e-9
        for e in plan.events_of(arm.name):
            if e.kind.value == "pick":
                assert s.reach[i, ids.index(e.fruit)], (arm.name, e.fruit)


@pytest.mark.parametrize("seed", range(6))
def test_far_apart_bases_change_nothing(seed: int) -> None:
    d = random_problem(seed)
    links = [a.get("links", d["defaults"]["links"]) for a in d["arms"]]
    gap = 2 * max(sum(ls) for ls in links) + 0.2
    for i, a in enumerate(d["arms"]):
        a["base"] = [round(i * gap, 4), 0.0]
        a["bin"] = [round(i * gap, 4), a["bin"][1]]
    p = parse_problem(to_yaml(d))
    s = screen(p)
    assert not s.locked and not any(r.split(":")[1].strip() != "out of every arm's reach" for r in s.reasons.values())
    np.testing.assert_array_equal(s.reach, p.reach_matrix())


