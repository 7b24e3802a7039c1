"""Problem generators: valid, deterministic, and the shipped files are what they say."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import yaml

from coplan import kinematics as kin
from coplan.kinematics import capsule_distance
from coplan.generate import LESSON_DEFAULTS, LESSON_TASK, overlap_problem, random_problem, row_problem, to_yaml
from coplan.problem import Problem, load_problem, parse_problem


def test_fifty_random_problems_validate_and_vary() -> None:
    arms, spacings, links, fruit = set(), set(), set(), set()
    for seed in range(50):
        d = random_problem(seed)
        p = parse_problem(to_yaml(d))
        assert 2 <= len(p.arms) <= 5
        assert 3 * len(p.arms) <= len(p.fruits) <= 8 * len(p.arms)
        xs = [a.base[0] for a in p.arms]
        gaps = np.diff(xs)
        assert np.allclose(gaps, gaps[0], atol=2e-4) and 1.2 - 1e-4 <= gaps[0] <= 2.4 + 1e-4
        for a in p.arms:
            assert a.can_reach(a.bin)
            assert all(lo < h < hi for h, (lo, hi) in zip(a.home, a.joint_limits))
        arms.add(len(p.arms))
        spacings.add(round(gaps[0], 2))
        links.update(a.links for a in p.arms)
        fruit.add(len(p.fruits))
    # the draws really do vary: every arm count, many spacings, link lengths and fruit counts
    assert arms == {2, 3, 4, 5}
    assert len(spacings) > 30 and len(links) > 50 and len(fruit) > 15


def test_random_problems_include_arm_level_overrides() -> None:
    overridden = sum("links" in arm for seed in range(50) for arm in random_problem(seed)["arms"])
    assert overridden > 10


def test_same_seed_same_problem_different_seed_different_problem() -> None:
    assert random_problem(7) == random_problem(7)
    assert to_yaml(random_problem(7)) == to_yaml(random_problem(7))
    assert random_problem(7) != random_problem(8)
    assert row_problem(4, 20, seed=3) == row_problem(4, 20, seed=3)
    assert row_problem(4, 20, seed=3)["fruits"] != row_problem(4, 20, seed=4)["fruits"]
    assert overlap_problem(seed=2) == overlap_problem(seed=2)


def test_random_problem_honours_requested_counts() -> None:
    d = random_problem(11, n_arms=4, n_fruits=9)
    assert len(d["arms"]) == 4 and len(d["fruits"]) == 9
    parse_problem(to_yaml(d))


def test_row_problem_reproduces_the_lessons_cell(greenhouse: Problem) -> None:
    """np.random.seed(42), x ~ U(-3.5, 3.5) then y ~ U(0.5, 1.8): the lesson's twelve fruit."""
    d = row_problem(3, 12, seed=42, arm_names=("left", "center", "right"), name="greenhouse-row")
    p = parse_problem(to_yaml(d))
    assert [f.position for f in p.fruits] == [f.position for f in greenhouse.fruits]
    assert p.arms == greenhouse.arms and p.task == greenhouse.task


def test_row_problem_layout() -> None:
    d = row_problem(4, 200, spacing=1.7, seed=1, y_range=(0.6, 1.4), bin_offset=-0.4)
    p = parse_problem(to_yaml(d))
    assert [a.base for a in p.arms] == [(-2.55, 0.0), (-0.85, 0.0), (0.85, 0.0), (2.55, 0.0)]
    assert [a.bin for a in p.arms] == [(x, -0.4) for x in (-2.55, -0.85, 0.85, 2.55)]
    assert [f.id for f in p.fruits[:2]] == ["f001", "f002"] and p.fruits[-1].id == "f200"
    xy = p.fruit_positions
    assert xy[:, 0].min() >= -2.55 - 1.5 and xy[:, 0].max() <= 2.55 + 1.5
    assert xy[:, 1].min() >= 0.6 and xy[:, 1].max() <= 1.4
    assert xy[:, 0].min() < -3.8 and xy[:, 0].max() > 3.8  # the whole extent is covered
    np.testing.assert_array_equal(xy, np.round(xy, 4))
    assert d["defaults"] == LESSON_DEFAULTS and d["task"] == LESSON_TASK


def test_row_problem_reachable_only_leaves_no_holes() -> None:
    plain = parse_problem(to_yaml(row_problem(5, 33, seed=5)))
    assert len(plain.unreachable()) > 0  # gaps between 2 m bases above ~1.49 m are out of reach
    full = parse_problem(to_yaml(row_problem(5, 33, seed=5, reachable_only=True)))
    assert full.unreachable() == [] and len(full.fruits) == 33
    # fruit that were reachable anyway are kept as drawn
    kept = {f.position for f in plain.fruits if f.id not in plain.unreachable()}
    assert kept <= {f.position for f in full.fruits}


def test_overlap_problem_puts_every_fruit_in_a_shared_zone() -> None:
    p = parse_problem(to_yaml(overlap_problem(4, 18, spacing=1.4, seed=3)))
    bases = [a.base[0] for a in p.arms]
    reach = p.reach_matrix()
    for j, f in enumerate(p.fruits):
        gap = j % 3
        mid = (bases[gap] + bases[gap + 1]) / 2
        assert abs(f.position[0] - mid) <= 0.35 + 1e-4
        assert reach[gap, j] and reach[gap + 1, j]


@pytest.mark.parametrize(
    "value", [1e-05, 1e20, 0.1 + 0.2, -3.0, 7, True, None, "yes", "plain-name_1.0", "has: colon", "café", "3 arms", ""]
)
def test_to_yaml_round_trips_scalars(value) -> None:
    d = {"k": value, "lst": [value, [value]], "m": {"inner": value}}
    assert yaml.safe_load(to_yaml(d)) == d


def test_to_yaml_layout_and_header() -> None:
    text = to_yaml(row_problem(2, 2, seed=0), header="line one\nline two")
    lines = text.splitlines()
    assert lines[:2] == ["# line one", "# line two"]
    assert "  links: [1.0, 0.8]" in lines
    assert "  - {name: arm1, base: [-1.0, 0.0], bin: [-1.0, -0.5]}" in lines
    assert sum(ln.startswith("  - {id: f00") for ln in lines) == 2


# --------------------------------------------------------------------------- shipped coordination problems
def _body(path: Path) -> str:
    return "".join(ln for ln in path.read_text().splitlines(keepends=True) if not ln.startswith("#"))


def test_dense_overlap_is_what_its_header_says(problems_dir: Path) -> None:
    path = problems_dir / "dense_overlap.yaml"
    p = load_problem(path)
    d = overlap_problem(3, 15, spacing=1.5, seed=0, arm_names=("left", "center", "right"), name="dense-overlap",
                        description=p.description)
    assert _body(path) == to_yaml(d)
    assert "overlap_problem(3, 15, spacing=1.5, seed=0" in path.read_text()
    assert [a.base for a in p.arms] == [(-1.5, 0.0), (0.0, 0.0), (1.5, 0.0)]
    assert 12 <= len(p.fruits) <= 18 and p.unreachable() == []
    assert (p.reach_matrix().sum(axis=0) >= 2).all()  # every fruit in a shared zone
    _same_arm_and_task_as_greenhouse(p)


def test_five_arm_row_is_what_its_header_says(problems_dir: Path) -> None:
    path = problems_dir / "five_arm_row.yaml"
    p = load_problem(path)
    d = row_problem(5, 33, spacing=2.0, seed=0, reachable_only=True, name="five-arm-row", description=p.description)
    assert _body(path) == to_yaml(d)
    assert "row_problem(5, 33, spacing=2.0, seed=0, reachable_only=True" in path.read_text()
    assert len(p.arms) == 5 and 30 <= len(p.fruits) <= 36 and p.unreachable() == []
    assert [a.base[0] for a in p.arms] == [-4.0, -2.0, 0.0, 2.0, 4.0]
    _same_arm_and_task_as_greenhouse(p)


def _same_arm_and_task_as_greenhouse(p: Problem) -> None:
    g = load_problem(Path(__file__).resolve().parents[1] / "src" / "coplan" / "problems" / "greenhouse_row.yaml")
    ref = g.arms[0]
    for a in p.arms:
        for f in ("links", "link_radius", "joint_limits", "max_velocity", "max_acceleration", "max_jerk", "home"):
            assert getattr(a, f) == getattr(ref, f), f
        assert a.bin == (a.base[0], a.base[1] - 0.5)
    assert p.task == g.task
    # neighbours' home poses are far more than the clearance apart (capsule to capsule)
    for i in range(len(p.arms) - 1):
        a, b = p.arms[i], p.arms[i + 1]
        pa, pb = kin.fk_points(np.array(a.home), a.links, a.base), kin.fk_points(np.array(b.home), b.links, b.base)
        d = min(float(capsule_distance(pa[s], pa[s + 1], a.link_radius, pb[u], pb[u + 1], b.link_radius))
                for s in range(2) for u in range(2))
        assert math.isfinite(d) and d > 1.0


def test_gantry_row_takes_only_the_gantry_keys_given() -> None:
    """(``gantry={'settle': 0.5}`` replaced the whole section: the problem then lacked every limit.)"""
    from coplan.generate import LESSON_GANTRY, gantry_row

    d = gantry_row(length=6, n_arms=2, density=2, seed=1, gantry={"settle": 0.5, "max_velocity": 0.3})
    g = parse_problem(to_yaml(d)).gantry
    assert (g.settle, g.max_velocity) == (0.5, 0.3)
    assert (g.max_acceleration, g.max_jerk, g.start, g.end) == (LESSON_GANTRY["max_acceleration"], LESSON_GANTRY["max_jerk"], 0.0, 6.0)
    with pytest.raises(TypeError, match="gantry: expected a mapping"):
        gantry_row(length=6, gantry=0.5)


def test_gantry_row_moves_its_fruit_with_the_rail_and_refuses_what_it_cannot_draw() -> None:
    """(``gantry={'start': 20, 'end': 30}`` kept the fruit in [0, length], a row coplan refused;
    a reversed ``y_range`` met NumPy's 'high - low < 0'.)"""
    from coplan.generate import gantry_row

    p = parse_problem(to_yaml(gantry_row(length=10, n_arms=2, density=3, seed=1, gantry={"start": 20.0})))
    xs = [f.position[0] for f in p.fruits]
    assert (p.gantry.start, p.gantry.end) == (20.0, 30.0) and 20.0 <= min(xs) and max(xs) <= 30.0
    base = gantry_row(length=10, n_arms=2, density=3, seed=1)
    assert [f["position"][0] for f in base["fruits"]] == pytest.approx([x - 20.0 for x in xs], abs=1e-4)
    longer = parse_problem(to_yaml(gantry_row(length=10, n_arms=2, density=3, seed=1, gantry={"start": 20.0, "end": 35.0})))
    assert longer.gantry.end == 35.0 and max(f.position[0] for f in longer.fruits) <= 30.0
    with pytest.raises(ValueError, match=r"gantry end: expected at least start \+ length = 70 \(the fruit lie along length m from start\), found 30"):
        gantry_row(gantry={"start": 20, "end": 30})
    with pytest.raises(ValueError, match=r"gantry_row: y_range: expected \(low, high\), two finite numbers with low < high, found \(1.5, 0.5\)"):
        gantry_row(y_range=(1.5, 0.5))
    narrow = parse_problem(to_yaml(gantry_row(length=5, density=4, seed=2, y_range=(0.9, 1.0))))
    assert all(0.9 <= f.position[1] <= 1.0 for f in narrow.fruits)


def test_gantry_row_refuses_a_gantry_key_or_value_a_file_would_refuse_at_the_call() -> None:
    """(``gantry={'settle': nan, 'bogus': 1, 'max_velocity': -1}`` was returned as given: the
    error came only when the row was loaded, where every other argument is refused at the call.)"""
    from coplan.generate import gantry_row

    with pytest.raises(ValueError) as e:
        gantry_row(length=6, gantry={"settle": float("nan"), "bogus": 1, "max_velocity": -1})
    for says in ("gantry.bogus: expected one of start, end", "unknown key 'bogus'", "gantry.max_velocity: expected the "
                 "carriage's speed limit > 0, in m/s, found -1", "gantry.settle: expected a settling time >= 0", "found number nan"):
        assert says in str(e.value)
    with pytest.raises(ValueError, match="gantry.max_jerk: expected the carriage's jerk limit > 0, in m/s\\^3, found 0"):
        gantry_row(length=6, gantry={"max_jerk": 0})


@pytest.mark.parametrize("length, density, seed", [(0.1, 20.0, 1), (0.1, 20.0, 2), (0.2, 6.0, 1), (0.1, 6.0, 4)])
def test_a_row_shorter_than_its_first_truss_draw_has_its_fruit_on_it(length, density, seed):
    """(The first truss is drawn 0-0.3 m from the row's start: on a shorter row, past its end,
    none was left to hang the fruit on and NumPy said 'high <= 0'.)"""
    from coplan.generate import gantry_row

    p = parse_problem(to_yaml(gantry_row(length=length, density=density, seed=seed)))
    assert p.fruits and all(0.0 <= f.position[0] <= length for f in p.fruits)


@pytest.mark.parametrize("kwargs, says", [({"spacing": -2.0}, "spacing > 0"), ({"spacing": 0.0}, "spacing > 0"),
                                          ({"trusses": "no"}, "trusses True or False")])
def test_gantry_row_refuses_a_spacing_or_trusses_it_cannot_mean(kwargs, says):
    """(A negative spacing swapped the arms' order and validated; ``trusses="no"`` clustered the fruit.)"""
    from coplan.generate import gantry_row

    with pytest.raises(ValueError, match=says):
        gantry_row(length=6.0, n_arms=3, density=2.0, **kwargs)
    assert gantry_row(length=6.0, n_arms=1, density=2.0, spacing=0.0)["arms"]  # one arm: no neighbour to space


@pytest.mark.parametrize("spacing", [-1.0, 0.0])
def test_row_and_overlap_problems_refuse_a_spacing_that_is_no_spacing(spacing):
    """(``row_problem(2, 4, spacing=-1.0)`` swapped the arms, arm1 at +0.5 and arm2 at -0.5; 0 stacked
    them and was refused only at solve.) As gantry_row: spacing > 0 between neighbouring bases."""
    with pytest.raises(ValueError, match=rf"row_problem: expected spacing > 0 .* found {spacing}"):
        row_problem(2, 4, spacing=spacing)
    with pytest.raises(ValueError, match=rf"overlap_problem: expected spacing > 0 .* found {spacing}"):
        overlap_problem(n_arms=2, n_fruits=4, spacing=spacing)
    assert row_problem(1, 4, spacing=spacing)["arms"]  # one arm: no neighbour to space
