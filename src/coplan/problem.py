"""Problem files: safe YAML loading, validation with key paths and lines, the immutable Problem.

Entry point: :func:`load_problem` (a file) or :func:`parse_problem` (text). Both return a
validated, frozen :class:`Problem` or raise :class:`ProblemError`, which lists *every*
problem found, each with its key path (``arms[1].links[0]``), the line where possible,
what was expected and what was found.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any

import numpy as np
import yaml
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError

from . import kinematics as kin
from .errors import Issue, ProblemError
from .geometry import segment_distance

__all__ = [
    "Arm",
    "Fruit",
    "Task",
    "Problem",
    "ProblemError",
    "Issue",
    "load_problem",
    "parse_problem",
    "default_problem_path",
    "shipped_problems",
]

MAX_FILE_BYTES = 4 * 1024 * 1024
MAX_ARMS = 64
MAX_FRUITS = 20_000
MAX_DEPTH = 12


def _path_str(loc) -> str:
    out = ""
    for part in loc:
        if isinstance(part, int):
            out += f"[{part}]"
        else:
            out += ("." if out else "") + str(part)
    return out


# --------------------------------------------------------------------------- raw schema
def _number(v: Any) -> Any:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"expected a number, found {type(v).__name__} {v!r}")
    if not math.isfinite(float(v)):
        raise ValueError(f"expected a finite number, found {v!r}")
    return float(v)


def _positive(v: Any) -> Any:
    v = _number(v)
    if v <= 0:
        raise ValueError(f"expected a number > 0, found {v!r}")
    return v


def _nonneg(v: Any) -> Any:
    v = _number(v)
    if v < 0:
        raise ValueError(f"expected a number >= 0, found {v!r}")
    return v


def _pair_list(v: Any) -> Any:
    if not isinstance(v, (list, tuple)):
        raise ValueError(f"expected a list of 2 items, found {type(v).__name__} {v!r}")
    if len(v) != 2:
        raise ValueError(f"expected a list of 2 items, found {len(v)} items")
    return tuple(v)


def _name(v: Any) -> Any:
    if isinstance(v, bool) or not isinstance(v, (str, int)):
        raise ValueError(f"expected a string, found {type(v).__name__} {v!r}")
    v = str(v).strip()
    if not v:
        raise ValueError("expected a non-empty string")
    return v


Num = Annotated[float, BeforeValidator(_number)]
Pos = Annotated[float, BeforeValidator(_positive)]
NonNeg = Annotated[float, BeforeValidator(_nonneg)]
Name = Annotated[str, BeforeValidator(_name)]
Point = Annotated[tuple[Num, Num], BeforeValidator(_pair_list)]
PosPair = Annotated[tuple[Pos, Pos], BeforeValidator(_pair_list)]
Limits = Annotated[tuple[Point, Point], BeforeValidator(_pair_list)]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class _ArmFields(_Strict):
    links: PosPair | None = None
    link_radius: Pos | None = None
    joint_limits: Limits | None = None
    max_velocity: PosPair | None = None
    max_acceleration: PosPair | None = None
    max_jerk: PosPair | None = None
    home: Point | None = None


class _ArmSpec(_ArmFields):
    name: Name
    base: Point
    bin: Point


class _FruitSpec(_Strict):
    id: Name
    position: Point


class _TaskSpec(_Strict):
    pick_dwell: NonNeg
    place_dwell: NonNeg
    clearance: NonNeg
    reach_margin: NonNeg = Field(default=0.01)
    singularity_threshold: NonNeg = Field(default=0.05)


_TOP_KEYS = ("name", "description", "defaults", "arms", "fruits", "task")
_ARM_REQUIRED = tuple(_ArmFields.model_fields)


# --------------------------------------------------------------------------- data objects
@dataclass(frozen=True)
class Arm:
    """One 2R arm, fully specified (defaults already applied). SI units."""

    name: str
    base: tuple[float, float]
    bin: tuple[float, float]
    links: tuple[float, float]
    link_radius: float
    joint_limits: tuple[tuple[float, float], tuple[float, float]]
    max_velocity: tuple[float, float]
    max_acceleration: tuple[float, float]
    max_jerk: tuple[float, float]
    home: tuple[float, float]

    @property
    def reach(self) -> float:
        return self.links[0] + self.links[1]

    @property
    def inner_radius(self) -> float:
        return abs(self.links[0] - self.links[1])

    @property
    def limits(self) -> np.ndarray:
        """Joint limits as a (2, 2) array ``[[min1, max1], [min2, max2]]``."""
        return np.array(self.joint_limits, dtype=float)

    def ik(self, point, margin: float = 0.0):
        """IK of a world point, both branches, inside joint limits and the annulus shrunk by ``margin``.

        Returns ``q`` (..., 2, 2) with NaN where invalid and ``valid`` (..., 2).
        """
        q, valid = kin.ik(point, self.links, self.base, self.limits)
        if margin > 0:
            inside = kin.in_workspace(point, self.links, self.base, margin)
            valid = valid & inside[..., None]
            q = np.where(valid[..., None], q, np.nan)
        return q, valid

    def can_reach(self, point, margin: float = 0.0) -> bool:
        return bool(np.any(self.ik(point, margin)[1]))


@dataclass(frozen=True)
class Fruit:
    id: str
    position: tuple[float, float]


@dataclass(frozen=True)
class Task:
    pick_dwell: float
    place_dwell: float
    clearance: float
    reach_margin: float = 0.01
    singularity_threshold: float = 0.05


@dataclass(frozen=True)
class Problem:
    """A validated, immutable harvesting problem."""

    name: str
    arms: tuple[Arm, ...]
    fruits: tuple[Fruit, ...]
    task: Task
    description: str = ""
    source: str | None = field(default=None, compare=False)

    def arm(self, name: str) -> Arm:
        for a in self.arms:
            if a.name == name:
                return a
        raise KeyError(f"no arm named {name!r}; arms are {[a.name for a in self.arms]}")

    def fruit(self, fid: str) -> Fruit:
        for f in self.fruits:
            if f.id == fid:
                return f
        raise KeyError(f"no fruit with id {fid!r}")

    @property
    def fruit_positions(self) -> np.ndarray:
        """(F, 2) array of fruit positions in file order."""
        return np.array([f.position for f in self.fruits], dtype=float).reshape(-1, 2)

    def reach_matrix(self) -> np.ndarray:
        """(A, F) bool: arm a can reach fruit f (IK inside joint limits, ``reach_margin`` kept)."""
        pts = self.fruit_positions
        return np.array([a.ik(pts, self.task.reach_margin)[1].any(axis=-1) for a in self.arms]).reshape(
            len(self.arms), len(self.fruits)
        )

    def unreachable(self) -> list[str]:
        """Ids of fruit that no arm can reach (left out of every plan)."""
        m = self.reach_matrix()
        return [f.id for j, f in enumerate(self.fruits) if not m[:, j].any()]

    def reachable_ids(self) -> list[str]:
        m = self.reach_matrix()
        return [f.id for j, f in enumerate(self.fruits) if m[:, j].any()]

    def neighbour_pairs(self) -> list[tuple[int, int]]:
        """Index pairs of arms whose swept discs (reach + radius + clearance) can touch."""
        out = []
        for i, a in enumerate(self.arms):
            for j in range(i + 1, len(self.arms)):
                b = self.arms[j]
                d = math.dist(a.base, b.base)
                if d < a.reach + b.reach + a.link_radius + b.link_radius + self.task.clearance:
                    out.append((i, j))
        return out


# --------------------------------------------------------------------------- YAML
class _LineLoader(yaml.SafeLoader):
    """SafeLoader that refuses duplicate keys and aliases (checked on the node tree)."""


def _walk_nodes(node, path, lines: dict, issues: list, depth: int = 0):
    if depth > MAX_DEPTH:
        issues.append(Issue(_path_str(path), f"nesting deeper than {MAX_DEPTH} levels", node.start_mark.line + 1))
        return
    lines[tuple(path)] = node.start_mark.line + 1
    if isinstance(node, yaml.MappingNode):
        seen: dict[str, int] = {}
        for k, v in node.value:
            key = k.value if isinstance(k, yaml.ScalarNode) else str(k)
            if key in seen:
                issues.append(
                    Issue(
                        _path_str(path + [key]),
                        f"duplicate key {key!r} (first at line {seen[key]}); keys must be unique",
                        k.start_mark.line + 1,
                    )
                )
            else:
                seen[key] = k.start_mark.line + 1
            _walk_nodes(v, path + [key], lines, issues, depth + 1)
    elif isinstance(node, yaml.SequenceNode):
        for i, v in enumerate(node.value):
            _walk_nodes(v, path + [i], lines, issues, depth + 1)


def _read_yaml(text: str, source: str | None):
    lines: dict = {}
    issues: list[Issue] = []
    try:
        for ev in yaml.parse(text, Loader=_LineLoader):
            if isinstance(ev, yaml.AliasEvent):
                raise ProblemError(
                    [Issue("", "YAML anchors/aliases (*name) are not supported in problem files", ev.start_mark.line + 1)],
                    source,
                )
        node = yaml.compose(text, Loader=_LineLoader)
    except yaml.YAMLError as e:
        mark = getattr(e, "problem_mark", None)
        line = mark.line + 1 if mark is not None else None
        msg = getattr(e, "problem", None) or str(e)
        raise ProblemError([Issue("", f"not valid YAML: {msg}", line)], source) from None
    if node is None:
        raise ProblemError([Issue("", "expected a mapping with keys name, arms, fruits, task; found an empty file")], source)
    _walk_nodes(node, [], lines, issues)
    if issues:
        raise ProblemError(issues, source)
    data = yaml.load(text, Loader=_LineLoader)
    return data, lines


def _line(lines: dict, loc) -> int | None:
    loc = tuple(loc)
    while loc:
        if loc in lines:
            return lines[loc]
        loc = loc[:-1]
    return lines.get(())


def _suggest(key: str, choices) -> str:
    m = difflib.get_close_matches(str(key), list(choices), n=1, cutoff=0.5)
    return f"; did you mean {m[0]!r}?" if m else f"; allowed keys: {', '.join(choices)}"


def _validate(model, data, prefix: tuple, lines: dict, issues: list):
    try:
        return model.model_validate(data)
    except ValidationError as e:
        for err in e.errors():
            loc = prefix + tuple(p for p in err["loc"] if not (isinstance(p, str) and p.startswith("function-")))
            # pydantic appends internal tags for tuple items/annotated types; keep user-facing parts
            loc = tuple(p for p in loc if p not in ("tuple[float, float]",))
            etype = err["type"]
            if etype == "extra_forbidden":
                key = loc[-1]
                fields = [f for f in model.model_fields]
                issues.append(Issue(_path_str(loc), f"unknown key {key!r}{_suggest(key, fields)}", _line(lines, loc)))
            elif etype == "missing":
                issues.append(Issue(_path_str(loc), "missing required field", _line(lines, loc[:-1])))
            elif etype == "model_type":
                found = err.get("input")
                issues.append(
                    Issue(_path_str(loc), f"expected a mapping, found {type(found).__name__} {found!r}", _line(lines, loc))
                )
            else:
                msg = err["msg"].removeprefix("Value error, ")
                if "found" not in msg:
                    msg = f"{msg}; found {err.get('input')!r}"
                issues.append(Issue(_path_str(loc), msg, _line(lines, loc)))
        return None


def _build(data: Any, lines: dict, source: str | None) -> Problem:
    issues: list[Issue] = []
    if not isinstance(data, dict):
        raise ProblemError(
            [Issue("", f"expected a mapping with keys name, arms, fruits, task; found {type(data).__name__}", 1)], source
        )
    for k in data:
        if k not in _TOP_KEYS:
            issues.append(Issue(str(k), f"unknown key {k!r}{_suggest(k, _TOP_KEYS)}", _line(lines, (k,))))
    for k in ("name", "arms", "task"):
        if k not in data:
            issues.append(Issue(k, "missing required field", 1))
    name = data.get("name", "")
    if "name" in data:
        try:
            name = _name(data["name"])
        except ValueError as e:
            issues.append(Issue("name", str(e), _line(lines, ("name",))))
    description = data.get("description", "") or ""
    if not isinstance(description, str):
        issues.append(Issue("description", f"expected a string, found {type(description).__name__}", _line(lines, ("description",))))
        description = ""

    defaults = _ArmFields()
    if data.get("defaults") is not None:
        d = _validate(_ArmFields, data["defaults"], ("defaults",), lines, issues)
        defaults = d if d is not None else None

    arms_raw = data.get("arms", [])
    arm_specs: list[tuple[int, _ArmSpec | None]] = []
    if not isinstance(arms_raw, list):
        issues.append(Issue("arms", f"expected a list of arms, found {type(arms_raw).__name__}", _line(lines, ("arms",))))
        arms_raw = []
    elif "arms" in data and not arms_raw:
        issues.append(Issue("arms", "expected at least one arm, found an empty list", _line(lines, ("arms",))))
    if len(arms_raw) > MAX_ARMS:
        issues.append(Issue("arms", f"expected at most {MAX_ARMS} arms, found {len(arms_raw)}", _line(lines, ("arms",))))
        arms_raw = arms_raw[:MAX_ARMS]
    for i, a in enumerate(arms_raw):
        arm_specs.append((i, _validate(_ArmSpec, a, ("arms", i), lines, issues)))

    fruits_raw = data.get("fruits", []) or []
    if not isinstance(fruits_raw, list):
        issues.append(Issue("fruits", f"expected a list of fruit, found {type(fruits_raw).__name__}", _line(lines, ("fruits",))))
        fruits_raw = []
    if len(fruits_raw) > MAX_FRUITS:
        issues.append(Issue("fruits", f"expected at most {MAX_FRUITS} fruit, found {len(fruits_raw)}", _line(lines, ("fruits",))))
        fruits_raw = fruits_raw[:MAX_FRUITS]
    fruit_specs = [(j, _validate(_FruitSpec, f, ("fruits", j), lines, issues)) for j, f in enumerate(fruits_raw)]

    task = None
    if "task" in data:
        t = _validate(_TaskSpec, data["task"], ("task",), lines, issues)
        if t is not None:
            task = Task(**t.model_dump())

    # ---- merge defaults, semantic checks per arm
    arms: list[tuple[int, Arm]] = []
    seen_names: dict[str, int] = {}
    for i, spec in arm_specs:
        if spec is None or defaults is None:
            continue
        merged: dict[str, Any] = {}
        origin: dict[str, tuple] = {}
        ok = True
        for f in _ARM_REQUIRED:
            v = getattr(spec, f)
            origin[f] = ("arms", i, f)
            if v is None:
                v = getattr(defaults, f)
                origin[f] = ("defaults", f)
            if v is None:
                issues.append(Issue(_path_str(("arms", i, f)), "missing required field (set it on the arm or in defaults)", _line(lines, ("arms", i))))
                ok = False
            merged[f] = v
        if spec.name in seen_names:
            issues.append(
                Issue(_path_str(("arms", i, "name")), f"duplicate arm name {spec.name!r} (also arms[{seen_names[spec.name]}])", _line(lines, ("arms", i, "name")))
            )
        else:
            seen_names[spec.name] = i
        if not ok:
            continue
        lim = merged["joint_limits"]
        for j in range(2):
            if lim[j][0] >= lim[j][1]:
                loc = origin["joint_limits"] + (j,)
                issues.append(Issue(_path_str(loc), f"expected min < max, found min {lim[j][0]} >= max {lim[j][1]}", _line(lines, loc)))
                ok = False
        if not ok:
            continue
        home = merged["home"]
        for j in range(2):
            if not lim[j][0] <= home[j] <= lim[j][1]:
                loc = origin["home"] + (j,)
                issues.append(
                    Issue(
                        _path_str(loc) + f" (arm {spec.name!r})",
                        f"expected home angle inside joint limits [{lim[j][0]}, {lim[j][1]}], found {home[j]}",
                        _line(lines, loc),
                    )
                )
                ok = False
        arm = Arm(name=spec.name, base=spec.base, bin=spec.bin, **merged)
        if task is not None and not arm.can_reach(arm.bin):
            r = math.dist(arm.base, arm.bin)
            issues.append(
                Issue(
                    _path_str(("arms", i, "bin")),
                    f"bin {list(arm.bin)} cannot be reached by its arm {arm.name!r} (distance {r:.3f} m from the base; "
                    f"reachable annulus [{arm.inner_radius:.3f}, {arm.reach:.3f}] m within joint limits)",
                    _line(lines, ("arms", i, "bin")),
                )
            )
            ok = False
        if ok:
            arms.append((i, arm))

    fruits: list[Fruit] = []
    seen_ids: dict[str, int] = {}
    for j, spec in fruit_specs:
        if spec is None:
            continue
        if spec.id in seen_ids:
            issues.append(
                Issue(_path_str(("fruits", j, "id")), f"duplicate fruit id {spec.id!r} (also fruits[{seen_ids[spec.id]}])", _line(lines, ("fruits", j, "id")))
            )
            continue
        seen_ids[spec.id] = j
        fruits.append(Fruit(id=spec.id, position=spec.position))

    # ---- home poses must already respect the clearance
    if task is not None:
        for x in range(len(arms)):
            for y in range(x + 1, len(arms)):
                (i, a), (k, b) = arms[x], arms[y]
                pa = kin.fk_points(np.array(a.home), a.links, a.base)
                pb = kin.fk_points(np.array(b.home), b.links, b.base)
                dmin = min(
                    float(segment_distance(pa[s], pa[s + 1], pb[u], pb[u + 1])) for s in range(2) for u in range(2)
                ) - a.link_radius - b.link_radius
                if dmin < task.clearance:
                    issues.append(
                        Issue(
                            _path_str(("arms", k, "home")),
                            f"home poses of arms {a.name!r} and {b.name!r} are {dmin:.4f} m apart; "
                            f"expected at least the clearance {task.clearance} m",
                            _line(lines, ("arms", k)),
                        )
                    )

    if issues:
        raise ProblemError(issues, source)
    return Problem(
        name=name,
        arms=tuple(a for _, a in arms),
        fruits=tuple(fruits),
        task=task,
        description=description,
        source=source,
    )


def parse_problem(text: str, source: str | None = None) -> Problem:
    """Validate YAML text and return a :class:`Problem` (raises :class:`ProblemError`)."""
    if len(text.encode("utf-8", errors="replace")) > MAX_FILE_BYTES:
        raise ProblemError([Issue("", f"expected a file of at most {MAX_FILE_BYTES} bytes, found {len(text)} characters")], source)
    data, lines = _read_yaml(text, source)
    return _build(data, lines, source)


def load_problem(path: str | Path) -> Problem:
    """Load and validate a problem file (raises :class:`ProblemError`, never a bare traceback)."""
    p = Path(path)
    src = str(p)
    if not p.exists():
        raise ProblemError([Issue("", "file not found")], src)
    if p.is_dir():
        raise ProblemError([Issue("", "expected a YAML file, found a directory")], src)
    size = p.stat().st_size
    if size > MAX_FILE_BYTES:
        raise ProblemError([Issue("", f"expected a file of at most {MAX_FILE_BYTES} bytes, found {size} bytes")], src)
    try:
        text = p.read_text(encoding="utf-8")
    except UnicodeDecodeError as e:
        raise ProblemError([Issue("", f"expected UTF-8 text, found undecodable bytes at offset {e.start}")], src) from None
    except OSError as e:
        raise ProblemError([Issue("", f"cannot read file: {e.strerror}")], src) from None
    return parse_problem(text, src)


def _problems_dir() -> Path:
    from importlib.resources import files

    return Path(str(files("coplan") / "problems"))


def default_problem_path() -> Path:
    """Path of the shipped default problem (``greenhouse_row.yaml``)."""
    return _problems_dir() / "greenhouse_row.yaml"


def shipped_problems() -> list[Path]:
    """All problem files shipped inside the package, sorted by name."""
    return sorted(_problems_dir().glob("*.yaml"))
