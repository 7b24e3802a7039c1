"""Problem files: every validation error names its key path (and line), all at once.

Each bad file below is the shipped ``greenhouse_row.yaml`` with one targeted edit, so a
test can only pass because of that edit. Every message must read
``file:line: key.path: expected X, found Y`` with no pydantic internals leaking.
"""

from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

import numpy as np
import pytest

from coplan.errors import ProblemError
from coplan.problem.model import Problem
from coplan.problem.load import default_problem_path, load_problem, parse_problem, shipped_problems
from coplan.problem.yamlsafe import MAX_FILE_BYTES

GREENHOUSE = default_problem_path()
BASE = GREENHOUSE.read_text(encoding="utf-8")
SRC = "cell.yaml"
ISSUE_LINE = re.compile(r"^  (?P<src>[^:\n]+?)(?::(?P<line>\d+))?: (?P<path>\S+): (?P<msg>.+)$")


def edit(text: str, old: str, new: str) -> str:
    """Replace the first ``old`` by ``new``, failing loudly when ``old`` is absent (so a test
    can never silently validate an unmodified file)."""
    assert old in text, f"fixture text not found: {old!r}"
    return text.replace(old, new, 1)


def issue_lines(err: Exception) -> list[dict]:
    """Parse an error message into its ``file:line: key.path: message`` rows (all must match)."""
    rows = []
    for ln in str(err).splitlines()[1:]:
        if ln.startswith("  ... and "):
            continue
        m = ISSUE_LINE.match(ln)
        assert m, f"issue line not in 'file:line: key.path: message' form: {ln!r}"
        rows.append(m.groupdict())
    return rows

# default arm fields as written in greenhouse_row.yaml
LINKS = "  links: [1.0, 0.8]\n"
LIMITS = "joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]]"
LEFT = "{name: left,   base: [-2.0, 0.0], bin: [-2.0, -0.5]}"
CENTER = "{name: center, base: [0.0, 0.0],  bin: [0.0, -0.5]}"
RIGHT = "{name: right,  base: [2.0, 0.0],  bin: [2.0, -0.5]}"
F02 = "{id: f02, position: [3.155, 0.776]}"


def line_of(text: str, snippet: str, nth: int = 1) -> int:
    """1-based line of the ``nth`` line containing ``snippet`` (comment lines left out: a file's
    header may name a key in prose)."""
    hits = [i + 1 for i, ln in enumerate(text.splitlines()) if snippet in ln and not ln.lstrip().startswith("#")]
    assert len(hits) >= nth, f"{snippet!r} not in text"
    return hits[nth - 1]


def errors_of(text: str, source: str = SRC) -> ProblemError:
    with pytest.raises(ProblemError) as ei:
        parse_problem(text, source)
    return ei.value


def only_issue(text: str):
    """The single issue a one-edit file must produce, plus its formatted row."""
    err = errors_of(text)
    assert len(err.issues) == 1, str(err)
    return err.issues[0], issue_lines(err)[0]


LEAKS = ("function-", "tuple[", "Value error", "Input should", "NoneType", "pydantic", "model_type", "[type=")


def assert_clean(err: ProblemError) -> None:
    """Every message reads ``expected ..., found ...`` and shows no pydantic internals."""
    text = str(err)
    for leak in LEAKS:
        assert leak not in text, f"internal detail {leak!r} leaked into: {text}"
    for it in err.issues:
        assert it.message.startswith("expected "), it.message
        assert "found" in it.message, it.message


# --------------------------------------------------------------------------- shipped files
def test_greenhouse_row_is_the_lessons_cell(greenhouse: Problem) -> None:
    p = greenhouse
    assert p.name == "greenhouse-row"
    assert [a.name for a in p.arms] == ["left", "center", "right"]
    assert [a.base for a in p.arms] == [(-2.0, 0.0), (0.0, 0.0), (2.0, 0.0)]
    assert [a.bin for a in p.arms] == [(-2.0, -0.5), (0.0, -0.5), (2.0, -0.5)]
    for a in p.arms:  # defaults applied to every arm
        assert a.links == (1.0, 0.8) and a.link_radius == 0.04
        assert a.joint_limits == ((-3.1416, 3.1416), (-3.0416, 3.0416))
        assert a.max_velocity == (3.0, 4.0) and a.max_acceleration == (8.0, 12.0) and a.max_jerk == (80.0, 120.0)
        assert a.home == (1.0472, 0.7854)
    assert (p.task.pick_dwell, p.task.place_dwell, p.task.clearance) == (0.3, 0.2, 0.05)
    assert [f.id for f in p.fruits] == [f"f{i:02d}" for i in range(1, 13)]


def test_greenhouse_fruit_are_the_lessons_seed_42_draws(greenhouse: Problem) -> None:
    """f01..f12 are np.random.seed(42); x ~ U(-3.5, 3.5) then y ~ U(0.5, 1.8), to 4 decimals."""
    rs = np.random.RandomState(42)
    x = rs.uniform(-3.5, 3.5, 12)
    y = rs.uniform(0.5, 1.8, 12)
    np.testing.assert_allclose(greenhouse.fruit_positions, np.c_[x, y], atol=5.1e-5)


def test_every_shipped_problem_loads() -> None:
    paths = shipped_problems()
    names = {p.name for p in paths}
    assert {"greenhouse_row.yaml", "single_arm.yaml"} <= names
    for path in paths:
        prob = load_problem(path)
        assert prob.source == str(path)
        assert len(prob.arms) >= 1


def test_parse_problem_equals_load_problem() -> None:
    a = load_problem(GREENHOUSE)
    b = parse_problem(BASE)
    assert a == b  # ``source`` is not part of equality
    assert b.source is None and a.source == str(GREENHOUSE)


def test_arm_value_overrides_default() -> None:
    text = edit(BASE, CENTER, "{name: center, base: [0.0, 0.0],  bin: [0.0, -0.5], links: [0.9, 0.9], max_jerk: [50, 60]}")
    p = parse_problem(text)
    assert p.arm("center").links == (0.9, 0.9) and p.arm("center").max_jerk == (50.0, 60.0)
    assert p.arm("left").links == (1.0, 0.8) and p.arm("right").max_jerk == (80.0, 120.0)


# --------------------------------------------------------------------------- one error per edit
# (id, edit function, expected key path, line snippet (in the edited text) or None, message fragments)
CASES = [
    # unknown keys, with the closest key suggested
    ("unknown-top", lambda t: edit(t, "name: greenhouse-row", "name: greenhouse-row\nfruit: []"), "fruit", "fruit: []",
     ["unknown key 'fruit'", "did you mean 'fruits'?"]),
    ("unknown-arm", lambda t: edit(t, CENTER, "{name: center, base: [0.0, 0.0],  bin: [0.0, -0.5], lnks: [1, 1]}"),
     "arms[1].lnks", "name: center", ["unknown key 'lnks'", "did you mean 'links'?"]),
    ("unknown-defaults", lambda t: edit(t, "link_radius: 0.04", "link_radus: 0.04"), "defaults.link_radus", "link_radus",
     ["unknown key 'link_radus'", "did you mean 'link_radius'?"]),
    ("unknown-task", lambda t: edit(t, "clearance: 0.05", "clearance: 0.05\n  pick_dwel: 0.3"), "task.pick_dwel", "pick_dwel:",
     ["unknown key 'pick_dwel'", "did you mean 'pick_dwell'?"]),
    ("unknown-fruit", lambda t: edit(t, F02, "{id: f02, position: [3.155, 0.776], colour: red}"), "fruits[1].colour", "id: f02",
     ["unknown key 'colour'", "allowed keys: id, position"]),
    # missing fields
    ("missing-bin", lambda t: edit(t, CENTER, "{name: center, base: [0.0, 0.0]}"), "arms[1].bin", "name: center",
     ["expected [x, y] in m", "found nothing", "required"]),
    ("missing-arm-name", lambda t: edit(t, CENTER, "{base: [0.0, 0.0],  bin: [0.0, -0.5]}"), "arms[1].name",
     "base: [0.0, 0.0],  bin", ["expected a non-empty string", "found nothing"]),
    ("missing-task-field", lambda t: edit(t, "  place_dwell: 0.2\n", ""), "task.place_dwell", "task:",
     ["expected a number >= 0 in s", "found nothing"]),
    ("missing-fruit-position", lambda t: edit(t, F02, "{id: f02}"), "fruits[1].position", "id: f02", ["found nothing"]),
    ("missing-task", lambda t: t[: t.index("task:")], "task", None, ["pick_dwell", "found nothing"]),
    # wrong types
    ("type-str-in-pair", lambda t: edit(t, "links: [1.0, 0.8]", 'links: [1.0, "long"]'), "defaults.links[1]", "links:",
     ["expected a number", "found string 'long'"]),
    ("type-scalar-for-pair", lambda t: edit(t, "link_radius: 0.04", "link_radius: [0.04]"), "defaults.link_radius",
     "link_radius", ["expected a number", "found list [0.04]"]),
    ("type-pair-for-scalar", lambda t: edit(t, "links: [1.0, 0.8]", "links: 1.8"), "defaults.links", "links:",
     ["expected a list of 2 items", "found number 1.8"]),
    ("type-three-items", lambda t: edit(t, "links: [1.0, 0.8]", "links: [1.0, 0.8, 0.5]"), "defaults.links", "links:",
     ["expected a list of 2 items", "found a list of 3 items"]),
    ("type-one-item", lambda t: edit(t, "links: [1.0, 0.8]", "links: [1.0]"), "defaults.links", "links:",
     ["expected a list of 2 items", "found a list of 1 item"]),
    ("type-limits-flat", lambda t: edit(t, LIMITS, "joint_limits: [[-3.1416, 3.1416], 3.0]"), "defaults.joint_limits[1]",
     "joint_limits", ["expected a list of 2 items", "found number 3.0"]),
    ("type-bool", lambda t: edit(t, "pick_dwell: 0.3", "pick_dwell: yes"), "task.pick_dwell", "pick_dwell",
     ["expected a number", "found boolean True"]),
    ("type-null", lambda t: edit(t, F02, "{id: f02, position: [3.155, null]}"), "fruits[1].position[1]", "id: f02",
     ["expected a number", "found null"]),
    ("type-name", lambda t: edit(t, "name: greenhouse-row", "name: [greenhouse]"), "name", "name: [greenhouse]",
     ["expected a string", "found list"]),
    ("type-arms", lambda t: edit(t, "arms:\n", "arms: 3\nxarms:\n"), "arms", "arms: 3", ["expected a list of arms", "found integer 3"]),
    ("type-arm-scalar", lambda t: edit(t, CENTER, "center"), "arms[1]", "- center", ["expected a mapping", "found string 'center'"]),
    ("type-task-scalar", lambda t: t[: t.index("task:")] + "task: 5\n", "task", "task: 5", ["expected a mapping", "found integer 5"]),
    ("type-fruit-id", lambda t: edit(t, "id: f02", "id: {a: 1}"), "fruits[1].id", "{a: 1}", ["expected a string", "found mapping"]),
    # NaN / inf
    ("nan", lambda t: edit(t, F02, "{id: f02, position: [.nan, 0.776]}"), "fruits[1].position[0]", "id: f02",
     ["expected a finite number", "found nan"]),
    ("inf", lambda t: edit(t, "max_velocity: [3.0, 4.0]", "max_velocity: [.inf, 4.0]"), "defaults.max_velocity[0]",
     "max_velocity", ["expected a finite number", "found inf"]),
    ("minus-inf", lambda t: edit(t, LIMITS, "joint_limits: [[-.inf, 3.1416], [-3.0416, 3.0416]]"),
     "defaults.joint_limits[0][0]", "joint_limits", ["expected a finite number", "found -inf"]),
    ("nan-task", lambda t: edit(t, "clearance: 0.05", "clearance: .NaN"), "task.clearance", "clearance",
     ["expected a finite number", "found nan"]),
    ("nan-base", lambda t: edit(t, CENTER, "{name: center, base: [.nan, 0.0],  bin: [0.0, -0.5]}"), "arms[1].base[0]",
     "name: center", ["expected a finite number"]),
    # non-positive lengths, radii, limits; negative dwell/clearance
    ("zero-link", lambda t: edit(t, "links: [1.0, 0.8]", "links: [0, 0.8]"), "defaults.links[0]", "links:",
     ["expected a number > 0", "found 0.0"]),
    ("negative-radius", lambda t: edit(t, "link_radius: 0.04", "link_radius: -0.04"), "defaults.link_radius", "link_radius",
     ["expected a number > 0", "found -0.04"]),
    ("zero-velocity", lambda t: edit(t, "max_velocity: [3.0, 4.0]", "max_velocity: [3.0, 0.0]"), "defaults.max_velocity[1]",
     "max_velocity", ["expected a number > 0"]),
    ("negative-acceleration", lambda t: edit(t, "max_acceleration: [8.0, 12.0]", "max_acceleration: [-8.0, 12.0]"),
     "defaults.max_acceleration[0]", "max_acceleration", ["expected a number > 0", "found -8.0"]),
    ("zero-jerk", lambda t: edit(t, "max_jerk: [80.0, 120.0]", "max_jerk: [80.0, 0]"), "defaults.max_jerk[1]", "max_jerk",
     ["expected a number > 0"]),
    ("arm-negative-link", lambda t: edit(t, CENTER, "{name: center, base: [0.0, 0.0],  bin: [0.0, -0.5], links: [1.0, -0.8]}"),
     "arms[1].links[1]", "name: center", ["expected a number > 0", "found -0.8"]),
    ("negative-dwell", lambda t: edit(t, "place_dwell: 0.2", "place_dwell: -0.2"), "task.place_dwell", "place_dwell",
     ["expected a number >= 0", "found -0.2"]),
    ("negative-clearance", lambda t: edit(t, "clearance: 0.05", "clearance: -0.01"), "task.clearance", "clearance",
     ["expected a number >= 0"]),
    # min > max joint limits (a default is reported once, not once per arm)
    ("limits-min-gt-max", lambda t: edit(t, LIMITS, "joint_limits: [[-3.1416, 3.1416], [3.0416, -3.0416]]"),
     "defaults.joint_limits[1]", "joint_limits", ["expected min < max", "found min 3.0416 >= max -3.0416"]),
    ("limits-min-eq-max", lambda t: edit(t, LIMITS, "joint_limits: [[1.0, 1.0], [-3.0416, 3.0416]]"),
     "defaults.joint_limits[0]", "joint_limits", ["expected min < max"]),
    ("arm-limits-min-gt-max",
     lambda t: edit(t, RIGHT, "{name: right,  base: [2.0, 0.0],  bin: [2.0, -0.5], joint_limits: [[2, -2], [-3, 3]]}"),
     "arms[2].joint_limits[0]", "name: right", ["expected min < max", "found min 2.0 >= max -2.0"]),
    # home outside joint limits: in defaults, on an arm, default home vs an arm's own limits
    ("home-out-defaults", lambda t: edit(t, "home: [1.0472, 0.7854]", "home: [1.0472, 3.5]"), "defaults.home[1]", "home:",
     ["expected a home angle inside the joint limits [-3.0416, 3.0416]", "found 3.5"]),
    ("home-out-arm", lambda t: edit(t, LEFT, "{name: left,   base: [-2.0, 0.0], bin: [-2.0, -0.5], home: [-3.5, 0.5]}"),
     "arms[0].home[0]", "name: left", ["inside the joint limits [-3.1416, 3.1416]", "found -3.5"]),
    ("home-default-vs-arm-limits",
     lambda t: edit(t, CENTER, "{name: center, base: [0.0, 0.0],  bin: [0.0, -0.5], joint_limits: [[-1, 1], [-3, 3]]}"),
     "arms[1].home[0]", "name: center", ["this arm's joint limits [-1.0, 1.0]", "found 1.0472 (from defaults.home[0])"]),
    # duplicate arm names / fruit ids
    ("duplicate-arm", lambda t: edit(t, "name: right", "name: left"), "arms[2].name", "base: [2.0, 0.0]",
     ["expected a unique arm name", "found 'left' again", "arms[0].name"]),
    ("duplicate-fruit", lambda t: edit(t, "id: f07", "id: f03"), "fruits[6].id", "position: [-3.0934",
     ["expected a unique fruit id", "found 'f03' again", "fruits[2].id"]),
    # bins no arm can reach: too far, and inside the annulus but outside the joint limits
    ("bin-too-far", lambda t: edit(t, "bin: [0.0, -0.5]", "bin: [0.0, -2.5]"), "arms[1].bin", "name: center",
     ["expected a bin its arm 'center' can reach", "found [0.0, -2.5] at 2.500 m"]),
    ("bin-inside-annulus",
     lambda t: edit(t, CENTER, "{name: center, base: [0.0, 0.0],  bin: [0.0, -0.1]}"), "arms[1].bin", "name: center",
     ["found [0.0, -0.1] at 0.100 m", "radii are [0.219, 1.800] m (the elbow"]),
    ("bin-outside-joint-limits",
     lambda t: edit(t, CENTER, "{name: center, base: [0.0, 0.0],  bin: [0.0, -0.5], joint_limits: [[0, 3.1416], [-3.0416, 3.0416]]}"),
     "arms[1].bin", "name: center", ["IK inside joint limits", "found [0.0, -0.5] at 0.500 m"]),
    # empty arm list
    ("empty-arms", lambda t: t[: t.index("arms:")] + "arms: []\n" + t[t.index("fruits:"):], "arms", "arms: []",
     ["expected at least one arm", "found an empty list"]),
    # home poses that already violate the clearance (one arm's own home; a default home at tight spacing)
    ("home-clash-arm-home",
     lambda t: edit(edit(t, LEFT, "{name: left,   base: [-2.0, 0.0], bin: [-2.0, -0.5], home: [0.0, 0.0]}"),
                    CENTER, "{name: center, base: [0.0, 0.0],  bin: [0.0, -0.5], home: [3.1416, 0.0]}"),
     "arms[1].home", "name: center", ["expected home poses at least the clearance 0.05 m apart", "'left' (arms[0]) and 'center' (arms[1])", "overlapping by 0.0800 m at home"]),
    # (bases 0.01 m apart were reported as homes "-0.0713 m apart": the overlap and the bases say it)
    ("home-clash-bases-overlap",
     lambda t: edit(edit(t, "base: [0.0, 0.0]", "base: [-1.99, 0.0]"), "bin: [0.0, -0.5]", "bin: [-1.99, -0.5]"),
     "arms[1].home", "name: center", ["overlapping by", "(their bases 0.010 m apart)"]),
    ("home-clash-default-home",
     lambda t: edit(edit(t, "base: [0.0, 0.0]", "base: [-1.9, 0.0]"), "bin: [0.0, -0.5]", "bin: [-1.9, -0.5]"),
     "arms[1].home", "name: center", ["'left' (arms[0]) and 'center' (arms[1]) 0.0066 m apart", "home from defaults.home"]),
]


@pytest.mark.parametrize("make,path,line_snippet,fragments", [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_validation_error_names_key_path_and_line(make, path, line_snippet, fragments) -> None:
    text = make(BASE)
    err = errors_of(text)
    assert_clean(err)
    paths = [it.path for it in err.issues]
    assert path in paths, str(err)
    it = err.issues[paths.index(path)]
    for frag in fragments:
        assert frag in it.message, f"{frag!r} not in {it.message!r}"
    if line_snippet is None:
        assert it.line is None
    else:
        assert it.line == line_of(text, line_snippet), str(err)
    # the formatted row reads file:line: key.path: message
    row = issue_lines(err)[paths.index(path)]
    assert row["src"] == SRC and row["path"] == path
    assert row["line"] == (None if it.line is None else str(it.line))


@pytest.mark.parametrize(
    "make",
    [c[1] for c in CASES if c[0] not in ("unknown-arm", "missing-arm-name", "type-arms", "home-clash-arm-home")],
    ids=[c[0] for c in CASES if c[0] not in ("unknown-arm", "missing-arm-name", "type-arms", "home-clash-arm-home")],
)
def test_one_edit_gives_exactly_one_issue(make) -> None:
    """Errors are not repeated (e.g. once per arm for a bad default) nor cascaded."""
    err = errors_of(make(BASE))
    assert len(err.issues) == 1, str(err)


def test_unknown_key_without_close_match_lists_allowed_keys() -> None:
    text = edit(BASE, "pick_dwell: 0.3", "pick_dwell: 0.3\n  zzzz: 1")
    it, _ = only_issue(text)
    assert it.path == "task.zzzz"
    assert "allowed keys: pick_dwell, place_dwell, clearance" in it.message


def test_arm_field_missing_from_arm_and_defaults_reported_for_every_arm() -> None:
    text = edit(BASE, LINKS, "")
    err = errors_of(text)
    assert_clean(err)
    assert [it.path for it in err.issues] == ["arms[0].links", "arms[1].links", "arms[2].links"]
    for it, snippet in zip(err.issues, ("name: left", "name: center", "name: right")):
        assert it.line == line_of(text, snippet)
        assert "on the arm or in defaults" in it.message


def test_missing_fields_on_an_arm_without_defaults_are_all_listed() -> None:
    text = "name: x\narms:\n  - {name: a, base: [0, 0], bin: [0, -0.5]}\ntask: {pick_dwell: 0, place_dwell: 0, clearance: 0}\n"
    err = errors_of(text)
    fields = ["links", "link_radius", "joint_limits", "max_velocity", "max_acceleration", "max_jerk", "home"]
    assert [it.path for it in err.issues] == [f"arms[0].{f}" for f in fields]
    assert all(it.line == 3 for it in err.issues)


def test_unknown_key_in_arm_is_said_once_with_the_key_it_replaced() -> None:
    """A misspelt required key is said once, as unknown, naming the key it replaced, at the arm's
    line (it was also said missing: two issues for one slip, where defaults, task and gantry said one)."""
    text = edit(BASE, LEFT, "{name: left,   bsae: [-2.0, 0.0], bin: [-2.0, -0.5]}")
    err = errors_of(text)
    (it,) = err.issues
    assert it.path == "arms[0].bsae" and "did you mean 'base'?" in it.message and it.line == line_of(text, "name: left")


# --------------------------------------------------------------------------- YAML-level safety
def test_duplicate_yaml_keys_are_refused_not_merged() -> None:
    text = edit(BASE, "  place_dwell: 0.2\n", "  place_dwell: 0.2\n  pick_dwell: 9.0\n")
    it, _ = only_issue(text)
    assert it.path == "task.pick_dwell"
    assert it.line == line_of(text, "pick_dwell: 9.0")
    assert f"first at line {line_of(text, 'pick_dwell: 0.3')}" in it.message


def test_duplicate_keys_in_a_flow_mapping_and_at_top_level() -> None:
    text = edit(BASE, CENTER, "{name: center, name: middle, base: [0.0, 0.0],  bin: [0.0, -0.5]}")
    text = edit(text, "name: greenhouse-row", "name: greenhouse-row\nname: other")
    err = errors_of(text)
    assert [it.path for it in err.issues] == ["name", "arms[1].name"]
    assert err.issues[0].line == line_of(text, "name: other")
    assert all("duplicate keys are never merged" in it.message for it in err.issues)


@pytest.mark.parametrize("first,second", [("1", "0x1"), ("yes", "true"), ("1.0", "1.00")])
def test_keys_that_construct_to_the_same_value_are_duplicates(first: str, second: str) -> None:
    """A dict would silently merge ``1:`` and ``0x1:`` (both the integer 1)."""
    text = edit(BASE, "name: greenhouse-row", f"name: greenhouse-row\n{first}: a\n{second}: b")
    err = errors_of(text)
    dup = [it for it in err.issues if "duplicate keys are never merged" in it.message]
    assert len(dup) == 1 and dup[0].path == second and dup[0].line == line_of(text, f"{second}: b")
    assert f"first at line {line_of(text, f'{first}: a')}" in dup[0].message


def test_yaml_anchors_and_aliases_are_refused() -> None:
    text = edit(BASE, "defaults:", "defaults: &arm")
    text = edit(text, "task:", "spare: *arm\ntask:")
    err = errors_of(text)
    rows = {it.path: it for it in err.issues}
    assert set(rows) == {"defaults", "spare"}
    assert "anchor &arm" in rows["defaults"].message and rows["defaults"].line == line_of(text, "defaults: &arm")
    assert "alias *arm" in rows["spare"].message and rows["spare"].line == line_of(text, "spare: *arm")


def test_billion_laughs_is_refused_before_expansion() -> None:
    lol = "a: &a [x, x, x, x, x, x, x, x, x]\n" + "".join(
        f"{c}: &{c} [{', '.join([f'*{p}'] * 9)}]\n" for p, c in zip("abcdefgh", "bcdefghi")
    )
    err = errors_of(lol)
    assert any("alias" in it.message for it in err.issues)
    # the first five said where they are, the other 76 of its 81 anchors and aliases in one issue
    # (each said alone buried the message in 81 lines)
    said = [it for it in err.issues if "anchors and aliases are not supported" in it.message]
    assert len(said) == 6 and [it.path for it in said[:5]] == ["a", "b", "b[0]", "b[1]", "b[2]"]
    assert "found 76 more anchors and aliases (lines 2-9)" in said[5].message and (said[5].path, said[5].line) == ("b[3]", 2)


def test_python_tags_are_refused_and_never_executed(tmp_path: Path) -> None:
    marker = tmp_path / "pwned"
    text = edit(BASE, "name: greenhouse-row", f'name: !!python/object/apply:pathlib.Path.touch [!!python/object/apply:pathlib.Path ["{marker}"]]')
    err = errors_of(text)
    assert err.issues[0].path == "name" and "tags are not supported" in err.issues[0].message
    assert not marker.exists()


def test_complex_keys_are_refused() -> None:
    text = edit(BASE, "name: greenhouse-row", "name: greenhouse-row\n? [a, b]\n: 1")
    it, _ = only_issue(text)
    assert "expected string keys, found a list used as a key" in it.message and it.line == line_of(text, "? [a, b]")


def test_yaml_syntax_error_has_a_line() -> None:
    text = edit(BASE, "  - {id: f05", "  - {id: f05 [")
    it, _ = only_issue(text)
    assert it.message.startswith("expected valid YAML, found a syntax error")
    assert it.line is not None and abs(it.line - line_of(text, "{id: f05 [")) <= 1


def test_deep_nesting_is_refused_without_recursion_error() -> None:
    it, _ = only_issue("[" * 100_000)
    assert "levels of nesting" in it.message
    it, _ = only_issue(BASE + "description: " + "[" * 30 + "]" * 30 + "\n")
    assert it.path.startswith("description[0][0]")


def test_huge_flat_list_stops_at_the_node_cap() -> None:
    text = BASE[: BASE.index("fruits:")] + "fruits: [" + ",".join(["1"] * 400_000) + "]\n" + BASE[BASE.index("task:"):]
    err = errors_of(text)
    assert len(err.issues) == 1 and "YAML values in a file" in err.issues[0].message


def test_many_bad_fruit_are_all_in_issues_but_the_message_is_capped() -> None:
    text = BASE[: BASE.index("fruits:")] + "fruits: [" + ",".join(["1"] * 300) + "]\n" + BASE[BASE.index("task:"):]
    err = errors_of(text)
    assert len(err.issues) == 300
    assert [it.path for it in err.issues[:2]] == ["fruits[0]", "fruits[1]"]
    assert str(err).rstrip().endswith("... and 100 more")


def test_oversize_file_and_text(tmp_path: Path) -> None:
    big = tmp_path / "big.yaml"
    big.write_text(BASE + "#" * (MAX_FILE_BYTES + 1))
    with pytest.raises(ProblemError) as ei:
        load_problem(big)
    assert f"expected a file of at most {MAX_FILE_BYTES} bytes" in str(ei.value)
    assert ei.value.source == str(big)
    it, _ = only_issue("#" + "é" * (MAX_FILE_BYTES // 2))  # 2 bytes a character: counted in bytes
    assert f"found {1 + MAX_FILE_BYTES // 2 * 2} bytes" in it.message


def test_non_utf8_file(tmp_path: Path) -> None:
    p = tmp_path / "latin1.yaml"
    p.write_bytes(BASE.replace("greenhouse-row", "serre-café").encode("latin-1"))
    with pytest.raises(ProblemError) as ei:
        load_problem(p)
    (it,) = ei.value.issues
    assert "expected UTF-8 text, found the undecodable byte 0xe9" in it.message
    assert it.line == line_of(BASE, "name: greenhouse-row")


@pytest.mark.parametrize(
    "text,found",
    [("", "found an empty file"), ("   \n# just a comment\n", "found an empty file"), ("- a\n- b\n", "found list ['a', 'b']"),
     ("42\n", "found integer 42"), ("null\n", "found null")],
    ids=["empty", "comment-only", "list", "scalar", "null"],
)
def test_top_level_must_be_a_mapping(text: str, found: str) -> None:
    it, row = only_issue(text)
    assert it.path == "" and row["path"] == "<top>"
    assert it.message.startswith("expected a mapping with keys name, arms, fruits, task") and found in it.message


def test_directory_and_missing_file(tmp_path: Path) -> None:
    with pytest.raises(ProblemError) as ei:
        load_problem(tmp_path)
    assert ei.value.issues[0].message == "expected a YAML file, found a directory"
    with pytest.raises(ProblemError) as ei:
        load_problem(tmp_path / "absent.yaml")
    assert "found no file at this path" in ei.value.issues[0].message
    assert str(ei.value).startswith(str(tmp_path / "absent.yaml"))


def test_load_problem_reports_the_file_name(tmp_path: Path) -> None:
    p = tmp_path / "bad.yaml"
    text = edit(BASE, "link_radius: 0.04", "link_radius: 0")
    p.write_text(text)
    with pytest.raises(ProblemError) as ei:
        load_problem(p)
    (row,) = issue_lines(ei.value)
    assert row == {"src": str(p), "line": str(line_of(text, "link_radius")), "path": "defaults.link_radius",
                   "msg": "expected a number > 0, found 0.0"}


# --------------------------------------------------------------------------- all at once
def test_several_problems_are_all_reported_at_once_in_line_order() -> None:
    text = BASE
    text = edit(text, "name: greenhouse-row", "name: greenhouse-row\nfruitz: []")     # unknown top key
    text = edit(text, "link_radius: 0.04", "link_radius: -1")                         # non-positive
    text = edit(text, "max_jerk: [80.0, 120.0]", "max_jerk: [80.0, .inf]")            # inf
    text = edit(text, "name: right", "name: left")                                    # duplicate arm
    text = edit(text, "{id: f04, position: [0.6906, 0.7384]}", "{id: f04, position: [0.6906]}")  # wrong length
    text = edit(text, "id: f09", "id: f01")                                           # duplicate fruit
    text = edit(text, "clearance: 0.05", "clearance: .nan")                           # NaN
    err = errors_of(text)
    assert_clean(err)
    assert [it.path for it in err.issues] == [
        "fruitz", "defaults.link_radius", "defaults.max_jerk[1]", "arms[2].name",
        "fruits[3].position", "fruits[8].id", "task.clearance",
    ]
    lines = [it.line for it in err.issues]
    assert lines == sorted(lines) and None not in lines
    assert str(err).splitlines()[0] == f"{SRC}: 7 problems found"


def test_no_source_is_shown_as_input() -> None:
    with pytest.raises(ProblemError) as ei:
        parse_problem(edit(BASE, "link_radius: 0.04", "link_radius: 0"))
    assert str(ei.value).splitlines()[1].startswith("  <input>:")


# --------------------------------------------------------------------------- not errors
def test_unreachable_fruit_is_not_an_error(greenhouse: Problem) -> None:
    assert greenhouse.unreachable() == ["f01"]
    text = BASE.replace("task:", "  - {id: far, position: [10.0, 10.0]}\n  - {id: base, position: [0.0, 0.0]}\ntask:")
    p = parse_problem(text)
    assert p.unreachable() == ["f01", "far", "base"]
    assert "far" not in p.reachable_ids() and len(p.reachable_ids()) == 11


def test_reach_matrix_matches_the_lessons_ik_margin(greenhouse: Problem) -> None:
    """f01 at (-0.8782, 1.5822) is 1.8096 m from the centre base and 1.9152 m from the left:
    outside both reaches (1.8 m) -- the lesson's own unreachable fruit."""
    m = greenhouse.reach_matrix()
    assert m.shape == (3, 12) and not m[:, 0].any()
    bases = np.array([a.base for a in greenhouse.arms])
    r = np.linalg.norm(greenhouse.fruit_positions[None] - bases[:, None], axis=-1)
    np.testing.assert_array_equal(m, (r <= 1.8 - 0.01) & (r >= 0.2 + 0.01))


def test_neighbour_pairs(greenhouse: Problem) -> None:
    # bases 2 m apart: swept discs 1.8 + 1.8 + 2 * 0.04 + 0.05 = 3.73 m > 2 m, but < 4 m for left-right
    assert greenhouse.neighbour_pairs() == [(0, 1), (1, 2)]


def test_zero_dwells_and_clearance_are_allowed_and_fruits_optional() -> None:
    text = edit(edit(edit(BASE, "pick_dwell: 0.3", "pick_dwell: 0"), "place_dwell: 0.2", "place_dwell: 0"), "clearance: 0.05", "clearance: 0")
    text = text[: text.index("fruits:")] + text[text.index("task:"):]
    p = parse_problem(text)
    assert p.fruits == () and p.task.clearance == 0.0 and p.unreachable() == []


# --------------------------------------------------------------------------- immutability
def test_problem_is_frozen(greenhouse: Problem) -> None:
    with pytest.raises(dataclasses.FrozenInstanceError):
        greenhouse.name = "x"  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        greenhouse.arms[0].links = (2.0, 2.0)  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        greenhouse.task.clearance = 0.0  # type: ignore[misc]
    with pytest.raises(dataclasses.FrozenInstanceError):
        greenhouse.fruits[0].position = (0.0, 0.0)  # type: ignore[misc]
    assert isinstance(greenhouse.arms, tuple) and isinstance(greenhouse.fruits, tuple)
    assert isinstance(greenhouse.arms[0].joint_limits[0], tuple)
    # derived arrays are fresh copies: scribbling on them changes nothing
    greenhouse.fruit_positions[:] = 0.0
    greenhouse.arms[0].limits[:] = 0.0
    assert greenhouse.fruits[1].position == (3.155, 0.776) and greenhouse.arms[0].joint_limits[0] == (-3.1416, 3.1416)
    assert hash(greenhouse) == hash(load_problem(GREENHOUSE))


def test_lookup_helpers(greenhouse: Problem) -> None:
    assert greenhouse.arm("right").base == (2.0, 0.0)
    assert greenhouse.fruit("f12").position == (3.2894, 0.9763)
    with pytest.raises(KeyError, match="arms are"):
        greenhouse.arm("middle")
    with pytest.raises(KeyError):
        greenhouse.fruit("f99")
    assert math.isclose(greenhouse.arms[0].reach, 1.8) and math.isclose(greenhouse.arms[0].inner_radius, 0.2)


def test_two_fruit_at_one_position_are_refused_from_a_file_and_from_python():
    """(Found by a new user: a copied fruit was counted, planned and 'harvested' twice, the
    second pick closing on nothing; the lower bound and 'proven optimal' counted it too.)"""
    import dataclasses

    from coplan.problem.model import Fruit

    text = """
name: dup
defaults: {links: [1.0, 0.8], link_radius: 0.04, joint_limits: [[-3.1416, 3.1416], [-3.0416, 3.0416]],
           max_velocity: [3, 4], max_acceleration: [8, 12], max_jerk: [80, 120], home: [1.0472, 0.7854]}
arms:
  - {name: a, base: [0, 0], bin: [0, -0.5]}
fruits:
  - {id: d1, position: [0.5, 1.0]}
  - {id: d2, position: [0.5, 1.0]}
  - {id: d3, position: [0.5, 1.0001]}
  - {id: d5, position: [0.5000000001, 1.0001]}
task: {pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}
"""
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "dup.yaml")
    first, second = e.value.issues  # (an exact copy, and one 1e-10 m off: both copies)
    assert first.path == "fruits[1].position" and first.line == 9 and "also fruits[0] 'd1'" in first.message
    assert second.path == "fruits[3].position" and second.line == 11 and "also fruits[2] 'd3'" in second.message
    text = text.replace("  - {id: d5, position: [0.5000000001, 1.0001]}\n", "")
    ok = parse_problem(text.replace("  - {id: d2, position: [0.5, 1.0]}\n", ""), "dup.yaml")  # 0.1 mm apart: two fruit
    assert [f.id for f in ok.fruits] == ["d1", "d3"]
    import coplan

    copied = dataclasses.replace(ok, fruits=ok.fruits + (Fruit("d4", (0.5, 1.0001 + 1e-9)),))  # (a live planner's reports may coincide)
    with pytest.raises(ProblemError) as e:
        coplan.solve(copied, planner="coordinated")  # ... a problem to plan may not
    assert any(i.path == "fruits[2].position" and "also fruits[1] 'd3'" in i.message for i in e.value.issues)


@pytest.mark.parametrize("elbow, radii", [("[-2.5, 2.5]", "[0.607, 1.700]"), ("[-0.3, 0.3]", "[1.682, 1.700]")])
def test_a_bin_out_of_reach_is_measured_against_the_radii_the_elbow_s_limits_allow(elbow, radii):
    """(It said 'the reachable annulus is [0.300, 1.700] m' of a bin 0.5 m from the base.)"""
    text = f"""
name: binx
defaults: {{link_radius: 0.04, max_velocity: [3, 4], max_acceleration: [8, 12], max_jerk: [80, 120], home: [1.0, 0.2]}}
arms:
  - {{name: x, links: [1.0, 0.7], joint_limits: [[-3, 3], {elbow}], base: [0, 0], bin: [0, -0.5]}}
fruits: [{{id: f, position: [0.5, 1.0]}}]
task: {{pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}}
"""
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "bin.yaml")
    (issue,) = e.value.issues
    assert issue.path == "arms[0].bin" and f"the reachable radii are {radii} m (the elbow's joint limits" in issue.message
    arm = parse_problem(text.replace("bin: [0, -0.5]", "bin: [0, -1.69]"), "bin.yaml").arms[0]
    lo, hi = arm.radii()
    for q2 in np.linspace(*arm.joint_limits[1], 201):  # the radii are the tip's least and greatest distance
        r = np.hypot(1.0 + 0.7 * np.cos(q2), 0.7 * np.sin(q2))
        assert lo - 1e-9 <= r <= hi + 1e-9
    assert lo == pytest.approx(np.hypot(1.0 + 0.7 * np.cos(arm.joint_limits[1][1]), 0.7 * np.sin(arm.joint_limits[1][1])))


@pytest.mark.parametrize("elbow", [(3.2, 4.0), (-2.5, 3.6), (-4.0, -3.2), (0.5, 6.0), (-6.2, -0.1)])
def test_the_radii_an_elbow_s_limits_allow_past_pi_are_the_tip_s_distances(elbow):
    """(From a user's trial: elbow limits [3.2, 4.0] were taken as fully folded, radii [0.2, 0.2]
    m, and a bin the arm reaches at q2 = 3.4 was refused.) The radii are the least and greatest
    distance of the tip over the elbow's range, however far past +-pi it goes."""
    from coplan.problem.model import Arm

    arm = Arm(name="x", base=(0.0, 0.0), bin=(0.0, -0.5), links=(1.0, 0.8), link_radius=0.04,
              joint_limits=((-3.0, 3.0), elbow), max_velocity=(3, 4), max_acceleration=(8, 12), max_jerk=(80, 120),
              home=(0.0, float(np.mean(elbow))))
    q2 = np.linspace(elbow[0], elbow[1], 20001)
    r = np.hypot(1.0 + 0.8 * np.cos(q2), 0.8 * np.sin(q2))
    lo, hi = arm.radii()
    assert lo == pytest.approx(r.min(), abs=1e-6) and hi == pytest.approx(r.max(), abs=1e-6)


def test_a_problem_changed_in_python_whose_homes_overlap_is_refused_when_solved(tmp_path, greenhouse):
    """(Found by a new user: two bases moved together with dataclasses.replace gave an 'unsafe'
    plan of 0 s, harvesting nothing, where the same file says why.)"""
    import coplan

    left, center, right = greenhouse.arms
    moved = dataclasses.replace(greenhouse, arms=(left, dataclasses.replace(center, base=left.base, bin=left.bin), right))
    with pytest.raises(ProblemError) as e:
        coplan.solve(moved, planner="coordinated", out_dir=tmp_path / "out")
    assert any(i.path == "arms[1].home" and "expected home poses at least the clearance" in i.message for i in e.value.issues)
    assert not (tmp_path / "out").exists()


def test_an_arm_or_fruit_with_a_bad_field_still_has_its_other_mistakes_reported_at_once() -> None:
    """(An arm missing its ``bin`` had nothing else said of it; once the bin was added, six more
    missing fields appeared. Two fruit with one id, the first with a three-item position: the
    repeated id showed only after the position was fixed.) Every mistake is reported at once:
    fixing the reported ones leaves none that were there before."""
    text = """name: m1
arms:
  - {name: a, base: [0.0, 0.0], links: [0.9, 0.7]}
  - {name: a, base: [1.8, 0.0], bin: [1.8, -3.5], home: [1.0, 0.5], links: [0.9, 0.7], link_radius: 0.04,
     joint_limits: [[-3, 3], [-3, 3]], max_velocity: [1, 1], max_acceleration: [2, 2], max_jerk: [20, 20]}
fruits:
  - {id: s1, position: [0.6, 1.1, 3]}
  - {id: s1, position: [0.6, 1.2]}
task: {pick_dwell: 0.3, place_dwell: 0.2, clearance: 0.05}
"""
    err = errors_of(text)
    assert_clean(err)
    said = {i.path for i in err.issues}
    assert {"arms[0].bin", "arms[0].link_radius", "arms[0].joint_limits", "arms[0].max_velocity", "arms[0].max_acceleration",
            "arms[0].max_jerk", "arms[0].home"} <= said and "arms[0].links" not in said  # (it has links)
    assert "arms[1].name" in said  # the second "a", though the first arm failed
    assert {"fruits[0].position", "fruits[1].id"} <= said
    assert [i.line for i in err.issues if i.path == "arms[0].home"] == [line_of(text, "{name: a, base: [0.0")]


def test_a_negative_dwell_or_clearance_is_refused_with_its_unit() -> None:
    """(``task.pick_dwell: expected a number >= 0 in s`` when missing, but ``expected a number
    >= 0, found -1.0`` when negative, and so for the clearance's metres.)"""
    text = (default_problem_path().parent / "single_arm.yaml").read_text()
    text = edit(edit(text, "pick_dwell: 0.3", "pick_dwell: -1"), "clearance: 0.05", "clearance: -0.05")
    by_path = {i.path: i.message for i in errors_of(text).issues}
    assert by_path["task.pick_dwell"] == "expected a number >= 0 in s, found -1.0"
    assert by_path["task.clearance"] == "expected a number >= 0 in m, found -0.05"


@pytest.mark.parametrize("home_a", ["[0.5, 0.5]", "[10.0, 0.5]"])
def test_limits_out_of_order_are_said_beside_a_missing_or_implausible_home(home_a: str) -> None:
    """defaults.joint_limits with min > max was said only once arms[1].home (missing) or
    arms[0].home (10 rad: degrees?) was mended: it depends on neither, so it is said with them."""
    text = ("name: m\ndefaults:\n  links: [1.0, 0.8]\n  link_radius: 0.04\n  joint_limits: [[3.0, -3.0], [-3.0, 3.0]]\n"
            "  max_velocity: [3.0, 4.0]\n  max_acceleration: [8.0, 12.0]\n  max_jerk: [80.0, 120.0]\narms:\n"
            f"  - {{name: a, base: [0.0, 0.0], bin: [0.0, -0.5], home: {home_a}}}\n"
            "  - {name: b, base: [2.0, 0.0], bin: [2.0, -0.5]}\n"
            "fruits:\n  - {id: f1, position: [0.5, 1.0]}\ntask: {pick_dwell: 0.3, place_dwell: 0.3, clearance: 0.05}\n")
    err = errors_of(text)
    paths = [it.path for it in err.issues]
    assert "defaults.joint_limits[0]" in paths and "arms[1].home" in paths, paths
    assert paths.count("defaults.joint_limits[0]") == 1  # (once, not once per arm)
    assert ("arms[0].home[0]" in paths) == (home_a == "[10.0, 0.5]")


def test_a_fruit_the_elbow_reaches_only_past_pi_is_planned_verified_and_bounded():
    """(From a user's trial: elbow limits [-2.5, 3.6], a fruit at fk([0.3, 3.4]): 'unreachable';
    a bin at fk([-0.4, 3.4]) with elbow limits [3.2, 4.0] refused.) Both now solve, verified,
    no faster than the lower bound."""
    import coplan
    from coplan.kinematics import fk

    links = (1.0, 0.8)
    fruit = fk(np.array([0.3, 3.4]), links)[1]
    arm = {"name": "a", "base": [0.0, 0.0], "bin": [1.0, -0.5], "links": list(links), "link_radius": 0.04,
           "joint_limits": [[-0.5, 1.5], [-2.5, 3.6]], "max_velocity": [3.0, 4.0], "max_acceleration": [8.0, 12.0],
           "max_jerk": [80.0, 120.0], "home": [1.0, 1.0]}
    doc = {"name": "elbow-past-pi", "arms": [arm], "fruits": [{"id": "f1", "position": [float(fruit[0]), float(fruit[1])]}],
           "task": {"pick_dwell": 0.3, "place_dwell": 0.2, "clearance": 0.05}}
    res = coplan.solve(doc, planner="coordinated")
    assert res.verification.passed and res.plan.metrics["unreachable"] == 0 and res.plan.metrics["harvested"] == 1
    assert res.plan.metrics["makespan"] >= res.plan.metrics["lower_bound"] - 1e-9
    b = fk(np.array([-0.4, 3.4]), links)[1]
    arm.update(joint_limits=[[-3.1416, 3.1416], [3.2, 4.0]], home=[0.3, 3.5], bin=[float(b[0]), float(b[1])])
    res = coplan.solve(doc, planner="coordinated")  # (refused before: "the reachable radii are [0.200, 0.200] m")
    assert res.verification.passed


def test_an_unclosed_bracket_is_said_where_it_opens() -> None:
    """(A new-user trial: an unclosed flow sequence was reported at the line where the parser gave
    up, the next key or the file's end, with nothing pointing at the bracket.)"""
    text = "name: x\nfruits: [ {id: a, position: [1, 2]},\n  {id: b, position: [1, 2]}\narms: []\n"
    it, _ = only_issue(text)
    assert it.message.startswith("expected valid YAML, found a syntax error")
    assert "while parsing a flow sequence that opens at line 2, column 9" in it.message and it.line == 4
    # a bracket left open to the end of the file (PyYAML: "while parsing a flow node", at the end);
    # brackets in a comment or a quoted string do not count, closed ones neither
    for text, where in [("name: x\narms: [\n", "'[' that opens at line 2, column 7"),
                        ("# [ no\nname: \"x[\"\narms: [[1], {a: \n", "'{' that opens at line 3, column 13")]:
        it, _ = only_issue(text)
        assert f"while parsing a flow node inside the {where}" in it.message, it.message


def test_a_bare_word_that_names_no_shipped_problem_says_so() -> None:
    """(``coplan.solve("nope_problem")`` said only "found no file at this path": a bare word is a
    shipped problem's name too, and none is named so.)"""
    with pytest.raises(ProblemError) as ei:
        load_problem("nope_problem")
    msg = ei.value.issues[0].message
    assert "a shipped problem's name, found neither" in msg and "'coplan problems' lists them" in msg
    with pytest.raises(ProblemError, match="did you mean the shipped problem 'sparse_row'"):
        load_problem("sparse_rwo")


@pytest.mark.parametrize("key, choices, meant", [
    ("speed", ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle"), "max_velocity"),
    ("velocity", ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle"), "max_velocity"),
    ("accel", ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle"), "max_acceleration"),
    ("jerk", ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle"), "max_jerk"),
    ("stop", ("stops", "stop_price", "planner"), "stops"),  # a slip of spelling stays first
    ("settel", ("start", "end", "max_velocity", "settle"), "settle"),
    # a word of a longer key by its synonym, or its slip of spelling (spelling alone said max_jerk)
    ("max_speed", ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle"), "max_velocity"),
    ("max_sped", ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle"), "max_velocity"),
    ("max_accel", ("start", "end", "max_velocity", "max_acceleration", "max_jerk", "settle"), "max_acceleration"),
])
def test_an_unknown_key_suggests_the_key_it_names_not_only_the_nearest_spelling(key, choices, meant):
    """``gantry.speed`` is the carriage's top speed, ``max_velocity``: the suggestion said
    ``settle``, the nearest spelling. A key that names a word of coplan's key (or a common
    synonym of it) suggests that key; a near-miss spelling still wins."""
    from coplan.problem.yamlsafe import did_you_mean

    assert did_you_mean(key, choices) == f"; did you mean {meant!r}?"


def test_a_rows_gantry_speed_is_met_with_max_velocity_in_the_file_s_error(tmp_path):
    from coplan.problem.load import shipped_rows

    text = next(p for p in shipped_rows() if p.stem == "sparse_row").read_text()
    i = text.index("\ngantry:")
    text = text[:i] + text[i:].replace("max_velocity:", "speed:", 1)  # (the carriage's, not the arms')
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "row.yaml")
    assert "gantry.speed" in str(e.value) and "did you mean 'max_velocity'?" in str(e.value)


@pytest.mark.parametrize("key, shown", [("1", "integer 1"), ("true", "boolean True"), ("1.5", "number 1.5")])
def test_a_key_yaml_reads_as_a_number_or_a_boolean_is_named_at_its_line(key, shown):
    """(It said "task[1]: Keys should be strings", at task's line for 1.5, with no expected/found.)"""
    text = default_problem_path().read_text()
    lines = text.splitlines()
    at = next(i for i, ln in enumerate(lines) if ln.strip().startswith("place_dwell:"))
    lines.insert(at + 1, f"  {key}: 2")
    with pytest.raises(ProblemError) as e:
        parse_problem("\n".join(lines))
    [issue] = e.value.issues
    assert issue.path == "task" and issue.line == at + 2
    assert issue.message.startswith(f"expected a known key (a name), found the key {shown}")


@pytest.mark.parametrize("first, second", [("left", "le\u200bft"), ("caf\u00e9", "cafe\u0301"), ("f1", "\uff46\uff11")])
def test_names_that_print_alike_are_one_name(first, second):
    """(An NFC and an NFD 'café', or 'left' with a zero-width space, passed as two arms and printed
    alike everywhere.)"""
    text = default_problem_path().read_text().replace("name: left", f'name: "{first}"', 1).replace("name: center", f'name: "{second}"', 1)
    with pytest.raises(ProblemError) as e:
        parse_problem(text)
    [issue] = e.value.issues
    assert issue.path == "arms[1].name" and "the same once Unicode is normalised and invisible characters dropped" in issue.message


def test_a_binary_tag_is_refused_not_dropped():
    """(``name: !!binary aGVsbG8=`` was accepted as the name 'aGVsbG8=', the tag silently dropped.)"""
    text = default_problem_path().read_text()
    text = "\n".join("name: !!binary aGVsbG8=" if ln.startswith("name:") else ln for ln in text.splitlines())
    with pytest.raises(ProblemError) as e:
        parse_problem(text)
    assert [i.path for i in e.value.issues] == ["name"] and "tags are not supported" in e.value.issues[0].message


@pytest.mark.parametrize("edits, said", [
    # a broken default beside another default that does not depend on it
    ([("max_velocity: [3.0, 4.0]", "max_velocity: [3.0, -4.0]"), ("home: [1.0472, 0.7854]", "home: [9.0, 0.7854]")],
     ["defaults.max_velocity[1]: expected a number > 0", "defaults.home[0]: expected a joint angle within [-6.28319, 6.28319] rad"]),
    # an implausible limit, a task value and a home outside sound joint limits
    ([("max_velocity: [3.0, 4.0]", "max_velocity: [3.0, 4000.0]"), ("clearance: 0.05", "clearance: -1"),
      ("home: [1.0472, 0.7854]", "home: [4.0, 0.7854]")],
     ["defaults.max_velocity[1]: expected a joint velocity limit within", "task.clearance: expected a number >= 0",
      "defaults.home[0]: expected a home angle inside the joint limits"]),
])
def test_mistakes_that_do_not_depend_on_each_other_are_all_said_at_once(edits, said):
    """(A new user's trial of the README's promise: a home in degrees was said only once a negative
    velocity limit beside it was mended, and a home outside valid joint limits only once an
    implausible velocity limit and a negative clearance were: fixing two mistakes revealed a
    third.) Each check runs where the values it needs are sound."""
    text = BASE
    for old, new in edits:
        text = edit(text, old, new)
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "cell.yaml")
    assert len(e.value.issues) == len(said), str(e.value)
    for words in said:
        assert words in str(e.value), (words, str(e.value))


LEFT_ARM = "  - {name: left,   base: [-2.0, 0.0], bin: [-2.0, -0.5]}"


@pytest.mark.parametrize("arm, said", [
    # a velocity limit pydantic refuses beside a home in degrees and reversed joint limits on the same arm
    ("  - {name: left, base: [-2.0, 0.0], bin: [-2.0, -0.5], max_velocity: [0.0, 4.0], home: [90, 0.5],"
     " joint_limits: [[3.0, -3.0], [-3.0, 3.0]]}",
     ["arms[0].max_velocity[0]: expected a number > 0", "arms[0].home[0]: expected a joint angle within",
      "arms[0].joint_limits[0]: expected min < max"]),
    # an implausible jerk limit beside a bin 5 m away
    ("  - {name: left, base: [-2.0, 0.0], bin: [-2.0, -5.0], max_jerk: [1.0e9, 120.0]}",
     ["arms[0].max_jerk[0]: expected a joint jerk limit within", "arms[0].bin: expected a bin its arm 'left' can reach"]),
    # a home outside the joint limits beside a bin 5 m away
    ("  - {name: left, base: [-2.0, 0.0], bin: [-2.0, -5.0], home: [1.0, 3.1]}",
     ["arms[0].home[1]: expected a home angle inside the joint limits", "arms[0].bin: expected a bin its arm 'left' can reach"]),
    # reversed joint limits beside a bin no joint angles reach (its reach was checked only once the limits were mended)
    ("  - {name: left, base: [-2.0, 0.0], bin: [-2.0, -5.0], joint_limits: [[3.0, -3.0], [-3.0, 3.0]]}",
     ["arms[0].joint_limits[0]: expected min < max", "arms[0].bin: expected a bin its arm 'left' can reach"]),
    # a mis-spelt key: said once, as unknown with its 'did you mean', not also as the field missing
    ("  - {name: left, base: [-2.0, 0.0], bin: [-2.0, -0.5], joint_limit: [[-3.0, 3.0], [-3.0, 3.0]], links: [-1.0, 0.8]}",
     ["arms[0].joint_limit: expected a known key, found unknown key 'joint_limit'; did you mean 'joint_limits'?",
      "arms[0].links[0]: expected a number > 0"]),
])
def test_an_arm_s_mistakes_that_do_not_depend_on_each_other_are_said_at_once(arm, said):
    """(A new user's trial: on one arm, a velocity limit pydantic refuses hid a home in degrees,
    reversed joint limits and a bin 5 m away; an implausible jerk limit or a home outside the
    limits hid the bin; a mis-spelt key was said twice, once as the field missing.)"""
    with pytest.raises(ProblemError) as e:
        parse_problem(edit(BASE, LEFT_ARM, arm), "cell.yaml")
    assert len(e.value.issues) == len(said), str(e.value)
    for words in said:
        assert words in str(e.value), (words, str(e.value))


def test_a_mis_spelt_task_or_gantry_key_is_said_once():
    text = edit(BASE, "pick_dwell:", "pick_dwel:")
    with pytest.raises(ProblemError) as e:
        parse_problem(text, "cell.yaml")
    assert [i.path for i in e.value.issues] == ["task.pick_dwel"] and "did you mean 'pick_dwell'" in str(e.value)
    row = BASE + "gantry: {start: 0.0, end: 10.0, max_velocity: 0.5, max_accel: 0.5, max_jerk: 5.0}\n"
    with pytest.raises(ProblemError) as e:
        parse_problem(row, "row.yaml")
    assert [i.path for i in e.value.issues] == ["gantry.max_accel"] and "did you mean 'max_acceleration'" in str(e.value)


def test_a_fruit_off_the_rail_is_said_beside_another_fruit_s_mistake():
    """(A fruit beyond what any arm reaches from the rail was said only once every other mistake
    was mended: it is checked on the whole problem.)"""
    row = BASE + "gantry: {start: 0.0, end: 10.0, max_velocity: 0.5, max_acceleration: 0.5, max_jerk: 5.0}\n"
    row = edit(row, "  - {id: f01, position: [-0.8782, 1.5822]}", "  - {id: f01, position: [-40.0, 1.5822]}")
    row = edit(row, "  - {id: f02, position: [3.155, 0.776]}", "  - {id: f02, position: [3.155, 0.776, 1.0]}")
    with pytest.raises(ProblemError) as e:
        parse_problem(row, "row.yaml")
    assert [i.path for i in e.value.issues] == ["fruits[0].position[0]", "fruits[1].position"], str(e.value)
    assert "expected a fruit on this row: x within" in e.value.issues[0].message and "found x = -40" in e.value.issues[0].message
