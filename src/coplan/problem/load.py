"""Problem files: safe YAML loading, validation with key paths and lines.

Entry point: :func:`load_problem` (a file) or :func:`parse_problem` (text). Both return a
validated, frozen :class:`~coplan.problem.model.Problem` or raise :class:`ProblemError`, which
lists *every* problem found, each with its key path (``arms[1].links[0]``), the line where
possible, what was expected and what was found. :func:`file_record`: the file a problem was
read from, for a plan to name it. The shipped problems: :func:`default_problem_path`,
:func:`shipped_problems`, :func:`shipped_rows`.
"""

from __future__ import annotations

import difflib
import math
import os
import unicodedata
from collections.abc import Mapping
from dataclasses import replace
from types import SimpleNamespace
from pathlib import Path
from typing import Any

from pydantic import ValidationError

from . import plausible
from ..errors import Issue, ProblemError, coplan_file_kind, is_joint_csv, plural
from .gantry import off_rail, parse_gantry
from .model import MAX_ARMS, MAX_FRUITS, Arm, Fruit, Problem, Task
from .poses import copy_issues, home_pair_issues
from .spec import (ARM_REQUIRED, EXPECT, TOP_KEYS, ArmFieldsSpec, ArmSpec, FruitSpec, TaskSpec, kind_of, missing,
                   name_value)
from .yamlsafe import MAX_FILE_BYTES, did_you_mean, line_of, nearest_name, path_str, read_yaml, read_input_text

__all__ = ["load_problem", "parse_problem", "file_record", "text_digest", "resolve_name", "default_problem_path",
           "shipped_problems", "shipped_rows"]


def _suggest(key: Any, choices) -> str:
    return did_you_mean(key, choices) or f"; allowed keys: {', '.join(choices)}"


def _user_loc(data: Any, loc: tuple, missing: bool) -> tuple:
    """Keep only the parts of a pydantic error location that index into the user's data.

    Pydantic may insert internal tags (``function-before[...]``, ``tuple[float, float]``,
    union member names) into locations; walking the actual data drops them all. For a
    missing field the last part (the field's name) is kept.
    """
    out: list = []
    cur = data
    for i, part in enumerate(loc):
        if isinstance(cur, dict) and part in cur:
            out.append(part)
            cur = cur[part]
        elif isinstance(cur, (list, tuple)) and isinstance(part, int) and 0 <= part < len(cur):
            out.append(part)
            cur = cur[part]
        elif missing and i == len(loc) - 1 and isinstance(part, str):
            out.append(part)
    return tuple(out)


def _validate(model, data, prefix: tuple, lines: dict, issues: list):
    """Validate ``data`` against a pydantic model, turning every error into an :class:`Issue`."""
    try:
        return model.model_validate(data)
    except ValidationError as e:
        # a mis-spelt key is said once, as unknown with its 'did you mean', not also as the field it
        # meant missing (as in defaults: task.pick_dwel, gantry.max_accel were said twice)
        meant = {(tuple(err["loc"])[:-1], nearest_name(str(err["loc"][-1]), model.model_fields))
                 for err in e.errors() if err["type"] == "extra_forbidden" and len(err["loc"]) == 1}
        for err in e.errors():
            etype = err["type"]
            if etype == "missing" and (tuple(err["loc"])[:-1], err["loc"][-1]) in meant:
                continue
            loc = prefix + _user_loc(data, tuple(err["loc"]), etype == "missing")
            path = path_str(loc)
            if etype == "invalid_key":  # (a key YAML reads as a number or a boolean: 1, 1.5, true)
                key = err.get("input")
                loc = prefix + _user_loc(data, tuple(err["loc"])[:-1], False)
                issues.append(Issue(path_str(loc), f"expected a known key (a name), found the key {kind_of(key)}: YAML reads "
                                                   f"an unquoted number or true/false as a value, not a name",
                                    line_of(lines, loc + (key,))))  # (the key's line, else its mapping's)
            elif etype == "extra_forbidden":
                key = loc[-1]
                issues.append(Issue(path, f"expected a known key, found unknown key {key!r}{_suggest(key, model.model_fields)}", line_of(lines, loc)))
            elif etype == "missing":
                issues.append(Issue(path, missing(loc[-1]), line_of(lines, loc[:-1])))
            elif etype in ("model_type", "model_attributes_type", "dict_type"):
                issues.append(Issue(path, f"expected a mapping, found {kind_of(err.get('input'))}", line_of(lines, loc)))
            else:
                msg = err["msg"].removeprefix("Value error, ")
                want = EXPECT.get(str(loc[-1]), "")  # (a scalar's unit: "a number >= 0" is "a number >= 0 in s" for a dwell)
                if want.startswith("a number") and msg.startswith(f"expected {want.split(' in ')[0]},"):
                    msg = f"expected {want}," + msg[len(f"expected {want.split(' in ')[0]},"):]
                if "found" not in msg:
                    msg = f"{msg}; found {kind_of(err.get('input'))}"
                issues.append(Issue(path, msg, line_of(lines, loc)))
        return None


def _name_key(value: str) -> str:
    """A name as it reads: Unicode-normalised (NFKC) with invisible format characters (a zero-width
    space, a joiner) dropped -- two names that print alike are one name."""
    return "".join(ch for ch in unicodedata.normalize("NFKC", value) if unicodedata.category(ch) != "Cf")


def _check_unique(seen: dict[str, int], value: str, loc: tuple, what: str, lines: dict, issues: list) -> bool:
    """Record ``value`` at list index ``loc[1]``; on a repeat (as it reads: :func:`_name_key`),
    report it (naming the first) and return False."""
    key = _name_key(value)
    if key in seen:
        alike = "" if key == value else ", the same once Unicode is normalised and invisible characters dropped"
        issues.append(Issue(path_str(loc), f"expected a unique {what}, found {value!r} again "
                                            f"(also {loc[0]}[{seen[key]}].{loc[2]}{alike})", line_of(lines, loc)))
        return False
    seen[key] = loc[1]
    return True


def _implausible(field_name: str, value, loc: tuple, lines: dict, issues: list) -> bool:
    """Report every element of ``value`` outside :data:`coplan.plausible.BOUNDS`; True if any."""
    bad = plausible.field_issues(field_name, value, loc)
    issues.extend(Issue(path_str(where), msg, line_of(lines, where)) for where, msg in bad)
    return bool(bad)


def _build(data: Any, lines: dict, source: str | None) -> Problem:
    """A validated :class:`Problem` from parsed YAML, or :class:`ProblemError` with every issue.

    Steps: the top level (:func:`_top_level`), the arm, fruit and task specs (:func:`_specs`),
    each arm merged with ``defaults`` and checked (:func:`_arm`), the fruit (:func:`_fruits`),
    home poses against the clearance (:func:`coplan.problem.poses.home_pair_issues`), the gantry, then what the whole
    problem must satisfy (:func:`_whole`)."""
    issues: list[Issue] = []
    name, description = _top_level(data, lines, source, issues)
    defaults, arm_specs, fruit_specs, task, broken = _specs(data, lines, issues)
    arms: list[tuple[int, Arm]] = []
    origins: dict[int, dict[str, tuple]] = {}
    seen_names: dict[str, int] = {}
    raw_arms = data.get("arms") if isinstance(data.get("arms"), list) else []
    for i, spec in arm_specs:
        if spec is None:  # its own fields failed: what does not depend on them is still said now
            _unvalidated_arm(i, raw_arms[i], defaults, broken, seen_names, lines, issues)
            continue
        _check_unique(seen_names, spec.name, ("arms", i, "name"), "arm name", lines, issues)
        if defaults is None:
            continue  # the defaults are broken: already reported, don't guess
        built = _arm(i, spec, defaults, broken, lines, issues)
        if built is not None:
            arms.append((i, built[0]))
            origins[i] = built[1]
    fruits, where = _fruits(fruit_specs, data.get("fruits") if isinstance(data.get("fruits"), list) else [], lines, issues,
                            row="gantry" in data)
    if task is not None:
        issues += home_pair_issues(arms, origins, task, lines)
    gantry = parse_gantry(data["gantry"], lines, issues) if "gantry" in data else None
    if gantry is not None and arms and len(arms) == len(arm_specs):  # (said beside the rest: it was said only once all else was mended)
        issues += _off_rail(SimpleNamespace(gantry=gantry, arms=[a for _, a in arms]), fruits, where, lines)
    if issues:
        raise ProblemError(_tidy(issues), source)
    problem = Problem(name=name, arms=tuple(a for _, a in arms), fruits=tuple(fruits), task=task,
                      description=description, source=source, gantry=gantry)
    _whole(problem, fruits, lines, source)
    return problem


def _top_level(data: Any, lines: dict, source: str | None, issues: list) -> tuple[str, str]:
    """The document is a problem (a mapping, not another coplan file), its keys are known and
    present; returns its name and description."""
    if is_joint_csv(data):  # the header of coplan's plan CSV (coplan.plancsv)
        raise ProblemError([Issue("", "expected a problem file (keys name, arms, fruits, task), found a coplan plan CSV (a "
                                      "replay of joint samples: t,<arm>_q1,<arm>_q2,...); were the arguments swapped?", 1)], source)
    if not isinstance(data, dict):
        raise ProblemError(
            [Issue("", f"expected a mapping with keys name, arms, fruits, task; found {kind_of(data)}", 1)], source
        )
    if set(data) == {"events"} or {"joint_names", "points"} <= set(data):  # (an export's file: four unknown keys were listed)
        what = "events (the picks and places" if "events" in data else "JointTrajectory (one arm"
        raise ProblemError([Issue("", f"expected a problem file (keys name, arms, fruits, task), found an export's {what} "
                                      "of a `coplan export --format json` or `yaml`); were the arguments swapped?", 1)], source)
    fmt, kind = data.get("format"), coplan_file_kind(data)
    if kind is not None:  # a problem file has no format: a plan, feed, ... file
        raise ProblemError([Issue("", f"expected a problem file (keys name, arms, fruits, task), found a coplan {kind} file "
                                      f"(format {fmt!r}); were the arguments swapped?", line_of(lines, ("format",)))], source)
    if "base" in data and set(data) & {"vary", "fixed", "problems"} and "arms" not in data:  # (seven issues were listed)
        raise ProblemError([Issue("", "expected a problem file (keys name, arms, fruits, task), found a sweep file (keys "
                                      "base, vary, fixed, ...): run it with coplan sweep FILE", line_of(lines, ("base",)))], source)
    for k in data:
        if k not in TOP_KEYS:
            issues.append(Issue(str(k), f"expected a known key, found unknown key {k!r}{_suggest(k, TOP_KEYS)}", line_of(lines, (k,))))
    for k in ("name", "arms", "task"):
        if k not in data:
            issues.append(Issue(k, missing(k)))
    name = data.get("name", "")
    if "name" in data:
        try:
            name = name_value(data["name"])
        except ValueError as e:
            issues.append(Issue("name", str(e), line_of(lines, ("name",))))
    description = data.get("description", "") or ""
    if not isinstance(description, str):
        issues.append(Issue("description", f"expected a string, found {kind_of(description)}", line_of(lines, ("description",))))
        description = ""
    return name, description


def _specs(data: dict, lines: dict, issues: list):
    """The ``defaults``, arm, fruit and task sections, each validated on its own (a list too
    long is cut at its cap, the excess reported); returns ``(defaults, arm specs, fruit specs,
    task, broken)`` with None for what failed. Where some of the defaults' fields fail (reported),
    the others still serve (``broken``: the names of those that failed), so that what does not
    depend on them is said now -- a home in degrees beside a negative velocity limit was said only
    once the limit was mended."""
    defaults: ArmFieldsSpec | None = ArmFieldsSpec()
    broken: set[str] = set()
    if data.get("defaults") is not None:
        defaults = _validate(ArmFieldsSpec, data["defaults"], ("defaults",), lines, issues)
        if defaults is None and isinstance(data["defaults"], dict):
            defaults, broken = _partial_defaults(data["defaults"])
    arms_raw = data.get("arms", [])
    if not isinstance(arms_raw, list):
        issues.append(Issue("arms", f"expected a list of arms, found {kind_of(arms_raw)}", line_of(lines, ("arms",))))
        arms_raw = []
    elif "arms" in data and not arms_raw:
        issues.append(Issue("arms", "expected at least one arm, found an empty list", line_of(lines, ("arms",))))
    if len(arms_raw) > MAX_ARMS:
        issues.append(Issue("arms", f"expected at most {MAX_ARMS} arms, found {len(arms_raw)}", line_of(lines, ("arms",))))
        arms_raw = arms_raw[:MAX_ARMS]
    arm_specs = [(i, _validate(ArmSpec, a, ("arms", i), lines, issues)) for i, a in enumerate(arms_raw)]
    fruits_raw = data.get("fruits", []) or []
    if not isinstance(fruits_raw, list):
        issues.append(Issue("fruits", f"expected a list of fruit, found {kind_of(fruits_raw)}", line_of(lines, ("fruits",))))
        fruits_raw = []
    if len(fruits_raw) > MAX_FRUITS:
        issues.append(Issue("fruits", f"expected at most {MAX_FRUITS} fruit, found {len(fruits_raw)}", line_of(lines, ("fruits",))))
        fruits_raw = fruits_raw[:MAX_FRUITS]
    fruit_specs = [(j, _validate(FruitSpec, f, ("fruits", j), lines, issues)) for j, f in enumerate(fruits_raw)]
    task = None
    if "task" in data:
        t = _validate(TaskSpec, data["task"], ("task",), lines, issues)
        if t is not None and not any([_implausible(f, v, ("task", f), lines, issues) for f, v in t.model_dump().items()]):
            task = Task(**t.model_dump())
    return defaults, arm_specs, fruit_specs, task, broken


def _partial_defaults(raw: dict) -> tuple[ArmFieldsSpec, set[str]]:
    """The fields of a ``defaults`` mapping that validate on their own (its failures are
    reported already), as defaults, and the names of those that do not -- with the field a
    mis-spelt key is nearest to (reported as unknown, with its 'did you mean')."""
    good: dict[str, Any] = {}
    broken: set[str] = set()
    for key, value in raw.items():
        if key not in ArmFieldsSpec.model_fields:  # (an unknown key, reported with its 'did you mean': that field is not said missing)
            near = nearest_name(key, ArmFieldsSpec.model_fields)
            if near is not None:
                broken.add(near)
            continue
        try:
            ArmFieldsSpec.model_validate({key: value})
            good[key] = value
        except ValidationError:
            broken.add(key)
    return ArmFieldsSpec.model_validate(good), broken


def _limits_in_order(lim, loc0: tuple, lines: dict, issues: list) -> bool:
    """Each joint's limits ``lim`` (at key path ``loc0``) with min < max; the issues appended."""
    ok = True
    for j in range(2):
        if lim[j][0] >= lim[j][1]:
            loc = loc0 + (j,)
            issues.append(Issue(path_str(loc), f"expected min < max, found min {lim[j][0]} >= max {lim[j][1]}", line_of(lines, loc)))
            ok = False
    return ok


def _arm(i: int, spec, defaults: ArmFieldsSpec, broken: set[str], lines: dict, issues: list) -> tuple[Arm, dict] | None:
    """Arm ``i`` merged with ``defaults`` and checked (plausible values, joint limits, home
    inside them, a bin it reaches); ``(arm, where each field came from)`` or None. A value taken
    from ``defaults`` is reported at its place in ``defaults`` (once, not once per arm); one the
    defaults had but failed (``broken``, reported there) is not said missing. Each check runs
    where the values it needs are there and sound, whatever else is wrong: a home outside valid
    joint limits is said beside an implausible velocity limit, not once that is mended; a bin out
    of reach beside a home outside the limits. ``spec``: an :class:`ArmSpec`, or the fields of an
    arm that failed validation that are sound on their own (the others None, and in ``broken``)."""
    merged: dict[str, Any] = {}
    origin: dict[str, tuple] = {}
    absent = []
    for f in ARM_REQUIRED:
        v = getattr(spec, f)
        origin[f] = ("arms", i, f)
        if v is None and f not in broken:
            v = getattr(defaults, f)
            origin[f] = ("defaults", f)
        if v is None:
            if f not in broken:
                issues.append(Issue(path_str(("arms", i, f)), missing(f, " on the arm or in defaults"), line_of(lines, ("arms", i))))
            absent.append(f)
            continue
        merged[f] = v
    # far outside any real cell (degrees for radians, 1e308, 1e-9): refused before any arithmetic
    fields = [(f, v, ("arms", i, f)) for f, v in (("base", spec.base), ("bin", spec.bin)) if v is not None]
    implausible = [f for f, v, loc in fields + [(f, merged[f], origin[f]) for f in merged] if _implausible(f, v, loc, lines, issues)]
    limits_ok = ("joint_limits" in merged and "joint_limits" not in implausible  # (said beside the others, not once they are mended)
                 and _limits_in_order(merged["joint_limits"], origin["joint_limits"], lines, issues))
    ok = limits_ok and not absent and not implausible and spec.name is not None and spec.base is not None and spec.bin is not None
    if limits_ok and "home" in merged and "home" not in implausible:
        lim, home = merged["joint_limits"], merged["home"]
        for j in range(2):
            if not lim[j][0] <= home[j] <= lim[j][1]:
                home_loc, lim_loc = origin["home"] + (j,), origin["joint_limits"] + (j,)
                if home_loc[0] == "defaults" and lim_loc[0] == "arms":
                    # the default home does not fit this arm's own limits: report at the arm
                    loc = ("arms", i, "home", j)
                    msg = (
                        f"expected a home angle inside this arm's joint limits [{lim[j][0]}, {lim[j][1]}] "
                        f"({path_str(lim_loc)}), found {home[j]} (from {path_str(home_loc)})"
                    )
                    line = line_of(lines, lim_loc)
                else:
                    loc = home_loc
                    msg = f"expected a home angle inside the joint limits [{lim[j][0]}, {lim[j][1]}] ({path_str(lim_loc)}), found {home[j]}"
                    line = line_of(lines, home_loc)
                issues.append(Issue(path_str(loc), msg, line))
                ok = False
    reach_sound = "links" in merged and spec.base is not None and spec.bin is not None and not (
        {"links", "base", "bin"} & set(implausible))
    reached = limits_ok and reach_sound and _bin_reached(i, spec, merged, lines, issues)
    if reach_sound and not limits_ok and "joint_limits" not in absent:
        # (the joint limits are wrong, said: a bin no joint angles reach is said beside them, not once they are mended)
        _bin_reached(i, spec, merged | {"joint_limits": ((-math.pi, math.pi), (-math.pi, math.pi))}, lines, issues)
    if not ok or not reached:
        return None
    return Arm(name=spec.name, base=spec.base, bin=spec.bin, **merged), origin


def _bin_reached(i: int, spec, merged: dict, lines: dict, issues: list) -> bool:
    """Whether arm ``i`` reaches its bin (IK inside its joint limits), the issue appended if not;
    from its links, joint limits and base alone (``merged``: the arm's fields with its defaults),
    whatever else of it is wrong: an arm whose velocity limit failed had its bin 5 m away said
    only once the limit was mended. The fields the reach does not read stand in where missing."""
    stand_in = {"link_radius": 0.0, "max_velocity": (1.0, 1.0), "max_acceleration": (1.0, 1.0), "max_jerk": (1.0, 1.0),
                "home": (0.0, 0.0)}
    arm = Arm(name=spec.name if spec.name is not None else f"arms[{i}]", base=spec.base, bin=spec.bin,
              **(stand_in | {f: merged[f] for f in ("links", "joint_limits")}))
    if arm.can_reach(arm.bin):
        return True
    issues.append(Issue(path_str(("arms", i, "bin")), f"expected a bin its arm {arm.name!r} can reach (IK inside joint limits), "
                                                     f"found {list(arm.bin)} {arm.reach_words(arm.bin)}",
                        line_of(lines, ("arms", i, "bin"))))
    return False


def _raw_name(raw: Any, key: str) -> str | None:
    """``raw[key]`` where ``raw`` is an entry whose validation failed but this key is a valid name; else None."""
    if not isinstance(raw, dict) or key not in raw:
        return None
    try:
        return name_value(raw[key])
    except (ValueError, TypeError):
        return None


_STAND_IN = {"name": "arm", "base": [0.0, 0.0], "bin": [0.0, 0.0]}  # (an arm's required fields, for one field's validation)


def _unvalidated_arm(i: int, raw: Any, defaults: ArmFieldsSpec | None, broken: set[str], seen_names: dict, lines: dict,
                     issues: list) -> None:
    """Arm ``i``, whose own fields failed validation (reported): its name's uniqueness and the
    fields it lacks that ``defaults`` does not give either, reported now, not once its other
    mistakes are fixed."""
    name = _raw_name(raw, "name")
    if name is not None:
        _check_unique(seen_names, name, ("arms", i, "name"), "arm name", lines, issues)
    if defaults is None or not isinstance(raw, dict):
        return
    # the checks of its fields that are sound on their own (those that failed are said already):
    # a home in degrees, reversed joint limits or a bin 5 m away were said only once a negative
    # velocity limit beside them was mended
    sound: dict[str, Any] = {}
    failed = set(broken) | {nearest_name(str(k), ArmSpec.model_fields) for k in raw if k not in ArmSpec.model_fields} - {None}
    for f in ArmSpec.model_fields:
        if f not in raw:
            continue
        try:
            sound[f] = getattr(ArmSpec.model_validate(_STAND_IN | {f: raw[f]}), f)
        except ValidationError:
            failed.add(f)
    _arm(i, SimpleNamespace(**{f: sound.get(f) for f in ArmSpec.model_fields}), defaults, failed, lines, issues)


def _fruits(fruit_specs: list, raw: list, lines: dict, issues: list, row: bool = False) -> tuple[list[Fruit], list[int]]:
    """The fruit with unique ids and plausible positions (``raw``: the file's entries; an entry
    that failed validation still takes its id, if that is a valid one, for the uniqueness check;
    ``row``: the problem has a gantry, its fruit's x along the rail); and each one's index in the file."""
    fruits: list[Fruit] = []
    seen_ids: dict[str, int] = {}
    where: list[int] = []  # each fruit's index in the file
    for j, spec in fruit_specs:
        if spec is None:
            fid = _raw_name(raw[j], "id") if j < len(raw) else None
            if fid is not None:
                _check_unique(seen_ids, fid, ("fruits", j, "id"), "fruit id", lines, issues)
            continue
        if not _check_unique(seen_ids, spec.id, ("fruits", j, "id"), "fruit id", lines, issues):
            continue
        bad = plausible.fruit_position_issues(spec.position, ("fruits", j, "position"), row=row)
        issues.extend(Issue(path_str(at), msg, line_of(lines, at)) for at, msg in bad)
        if bad:
            continue
        fruits.append(Fruit(id=spec.id, position=spec.position))
        where.append(j)
    issues += copy_issues(fruits, where, lines)  # (a copy would be counted, planned and "harvested" twice)
    return fruits, where


def _off_rail(row, fruits: list[Fruit], where: list[int], lines: dict) -> list[Issue]:
    """A fruit beyond what any arm of ``row`` reaches from anywhere on its rail is not of this row
    (``where``: each fruit's index in the file)."""
    return [Issue(path_str(("fruits", where[j], "position", 0)), msg, line_of(lines, ("fruits", where[j], "position")))
            for j, msg in off_rail(row, fruits)]


def _whole(problem: Problem, fruits: list[Fruit], lines: dict, source: str | None) -> None:
    """What the whole problem must satisfy: on a row, every fruit within what some arm reaches
    from the rail; in a cell, a plan short enough for its 100 Hz grid (a lower bound on its
    length, refused up front)."""
    gantry = problem.gantry
    if gantry is not None:  # a fruit beyond what any arm reaches from anywhere on the rail is not of this row
        far = _off_rail(problem, fruits, list(range(len(fruits))), lines)
        if far:
            raise ProblemError(far, source)
        # (the row planners bound the rest: each cell is checked as it is made, a speed on the move by the cruise)
        slow = plausible.row_duration_issues(problem)
        if slow:
            raise ProblemError([Issue(path_str(loc), msg, line_of(lines, loc)) for loc, msg in slow], source)
        return
    too_long = plausible.duration_issues(problem)
    if too_long:
        raise ProblemError([Issue(path_str(loc), msg, line_of(lines, loc)) for loc, msg in too_long], source)


def _tidy(issues: list[Issue]) -> list[Issue]:
    """Drop exact repeats and order by line (issues without a line first, file order kept)."""
    seen: set = set()
    out = []
    for it in issues:
        key = (it.path, it.message, it.line)
        if key not in seen:
            seen.add(key)
            out.append(it)
    return sorted(out, key=lambda it: -1 if it.line is None else it.line)


def parse_problem(text: str, source: str | None = None) -> Problem:
    """Validate YAML text and return a :class:`Problem` (raises :class:`ProblemError`; TypeError
    for anything but text)."""
    if not isinstance(text, str):
        hint = ("a problem as a mapping (coplan.generate's): parse_problem(coplan.generate.to_yaml(mapping)), or "
                "coplan.solve(mapping)" if isinstance(text, Mapping) else "a file: coplan.load_problem(path)")
        raise TypeError(f"problem: expected YAML text (a str), found {type(text).__name__}; {hint}")
    n = len(text.encode("utf-8", errors="replace"))
    if n > MAX_FILE_BYTES:
        raise ProblemError([Issue("", f"expected at most {MAX_FILE_BYTES} bytes of YAML, found {n} bytes")], source)
    far: list[Issue] = []  # numbers no float holds, each read as null: said beside the file's other mistakes
    data, lines = read_yaml(text, source, keep_text=_is_text_path, out_of_range=far)
    try:
        problem = _build(data, lines, source)
    except ProblemError as e:
        if not far:
            raise
        raise ProblemError(_tidy(far + [i for i in e.issues if not any(_within(i.path, f.path) for f in far)]), source) from None
    if far:
        raise ProblemError(_tidy(far), source)
    return replace(problem, digest=text_digest(text))


def _within(path: str, outer: str) -> bool:
    """Whether key path ``path`` is ``outer`` or inside it (``arms[0].links[1]`` within ``arms[0].links``)."""
    return path == outer or path.startswith((outer + ".", outer + "["))


def text_digest(text: str) -> str:
    """The sha256 of a problem's YAML text (what a plan records to find its problem again)."""
    import hashlib

    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def file_record(problem: Problem) -> dict[str, str] | None:
    """Where ``problem`` was read from, for a plan to name it: ``{"path": absolute path,
    "sha256": the text's digest}``; None when it did not come from a file, or is no longer
    what that file holds (changed in Python with ``dataclasses.replace``, or the file since:
    a viewer would otherwise draw the file's layout under this problem's plan)."""
    if problem.source is None or problem.digest is None or not Path(problem.source).is_file():
        return None
    try:
        text = Path(problem.source).read_text(encoding="utf-8")
        same = text_digest(text) == problem.digest and parse_problem(text, problem.source) == problem
    except (OSError, UnicodeDecodeError, ProblemError):
        same = False
    return {"path": str(Path(problem.source).resolve()), "sha256": problem.digest} if same else None


def _is_text_path(path: tuple) -> bool:
    """Key paths of names and ids: kept exactly as written (``id: no`` is the id ``'no'``, not
    false; ``id: 012`` is ``'012'``, not 10)."""
    return path in (("name",), ("description",)) or (len(path) == 3 and (path[0], path[2]) in (("arms", "name"), ("fruits", "id")))


def resolve_name(path: str | Path) -> tuple[Path, str | None]:
    """The file a problem argument names, and what a bare name was taken as (None: the path as
    given): where no such file exists (or a folder: a run's output, named like its problem) and the name has no folder, ``NAME.yaml`` in the working
    folder, else the shipped problem of that name (``NAME`` or ``NAME.yaml``). The one rule of
    :func:`load_problem` and the ``coplan`` commands."""
    p = Path(path)
    if (p.exists() and not p.is_dir()) or p.parent != Path("."):  # (a folder of that name here -- often a run's
        return p, None                                              # output -- is no problem file: the name still names one)
    if not p.name.endswith(".yaml") and Path(p.name + ".yaml").is_file():  # (a file of the name here comes first)
        return Path(p.name + ".yaml"), f"the file {p.name}.yaml here"
    stem = p.name[:-5] if p.name.endswith(".yaml") else p.name
    hit = next((s for s in shipped_problems() + shipped_rows() if s.stem == stem), None)
    return (hit, f"the shipped problem {hit}") if hit is not None else (p, None)


def load_problem(path: str | Path) -> Problem:
    """Load and validate a problem file (raises :class:`ProblemError`, never a bare traceback).

    A bare name (``dense_overlap``) is ``dense_overlap.yaml`` in the working folder when there
    is one, else the shipped problem of that name (``dense_overlap.yaml`` too), as the
    ``coplan`` commands take it; a
    missing file elsewhere named like one gets an error that gives the shipped file's path."""
    if not isinstance(path, (str, os.PathLike)):
        raise TypeError(f"problem: expected the path of a YAML problem file or a shipped problem's name (str or Path; "
                        f"coplan.solve also takes a Problem or a mapping), found {type(path).__name__}"
                        + ("; a problem as a mapping (coplan.generate's): coplan.solve(mapping), or "
                           "coplan.parse_problem(coplan.generate.to_yaml(mapping))"
                           if isinstance(path, Mapping) else ""))
    if isinstance(path, str) and ("\n" in path or len(path) > 1024):  # (YAML text: "File name too long", or "no file")
        lines = plural(path.count("\n") + 1, "line")
        raise ProblemError([Issue("", f"expected the path of a YAML problem file or a shipped problem's name, found "
                                      f"text of {lines} ({path.strip()[:40]!r}...): "
                                      f"a problem's YAML text is read by coplan.parse_problem(text)")], "<argument>")
    p = Path(path)
    named, taken_as = resolve_name(p)
    if taken_as is not None:
        return load_problem(named)
    if not p.exists():
        name = p.name[:-5] if p.name.endswith(".yaml") else p.name
        shipped = {s.stem: s for s in shipped_problems() + shipped_rows()}
        if name in shipped:
            raise ProblemError([Issue("", f"expected an existing YAML file, found no file at this path; "
                                          f"{name!r} is a shipped problem, its file is {shipped[name]} "
                                          f"('coplan problems' lists them all)")], str(p))
        near = difflib.get_close_matches(name, list(shipped), n=1, cutoff=0.8) if p.parent == Path(".") else []
        if near:  # a shipped problem's name, misspelt
            raise ProblemError([Issue("", f"expected an existing YAML file, found no file at this path; did you mean "
                                          f"the shipped problem {near[0]!r}? ('coplan problems' lists them all)")], str(p))
        if p.parent == Path(".") and not p.suffix:  # (a bare word, far from every shipped name: said as such)
            raise ProblemError([Issue("", "expected an existing YAML file or a shipped problem's name, found neither (no "
                                          "file at this path, no shipped problem of this name: 'coplan problems' lists "
                                          "them)")], str(p))
    return parse_problem(read_input_text(path, ProblemError), str(p))


def _problems_dir() -> Path:
    from importlib.resources import files

    return Path(str(files("coplan") / "problems"))


def default_problem_path() -> Path:
    """Path of the shipped default problem (``greenhouse_row.yaml``)."""
    return _problems_dir() / "greenhouse_row.yaml"


def shipped_problems() -> list[Path]:
    """All problem files (stationary cells) shipped inside the package, sorted by name."""
    return sorted(_problems_dir().glob("*.yaml"))


def shipped_rows() -> list[Path]:
    """The shipped rows (problems with a gantry: ``problems/rows/``), sorted by name."""
    return sorted((_problems_dir() / "rows").glob("*.yaml"))
