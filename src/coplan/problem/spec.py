"""The raw schema of a problem file: pydantic field validators and models, and the words of
the messages that say what each field expects (used by :mod:`coplan.problem.load`)."""

from __future__ import annotations

import math
from typing import Annotated, Any

from pydantic import BaseModel, BeforeValidator, ConfigDict, Field

__all__ = ["kind_of", "number", "positive", "nonneg", "pair_list", "name_value", "Num", "Pos", "NonNeg", "Name", "Point",
           "PosPair", "Limits", "StrictSpec", "ArmFieldsSpec", "ArmSpec", "FruitSpec", "TaskSpec", "TOP_KEYS", "ARM_REQUIRED",
           "EXPECT", "missing"]


def kind_of(v: Any) -> str:
    """A YAML reader's name for the type of ``v`` plus its value, e.g. ``string 'a'``, ``null``."""
    if v is None:
        return "null"
    names = {bool: "boolean", int: "integer", float: "number", str: "string", list: "list", tuple: "list", dict: "mapping"}
    kind = names.get(type(v), type(v).__name__)
    text = repr(v)
    if len(text) > 60:
        text = text[:57] + "..."
    return f"{kind} {text}"


# --------------------------------------------------------------------------- raw schema
def number(v: Any) -> Any:
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        raise ValueError(f"expected a number, found {kind_of(v)}")
    if not math.isfinite(float(v)):
        raise ValueError(f"expected a finite number, found {v!r}")
    return float(v)


def positive(v: Any) -> Any:
    v = number(v)
    if v <= 0:
        raise ValueError(f"expected a number > 0, found {v!r}")
    return v


def nonneg(v: Any) -> Any:
    v = number(v)
    if v < 0:
        raise ValueError(f"expected a number >= 0, found {v!r}")
    return v


def pair_list(v: Any) -> Any:
    if not isinstance(v, (list, tuple)):
        raise ValueError(f"expected a list of 2 items, found {kind_of(v)}")
    if len(v) != 2:
        raise ValueError(f"expected a list of 2 items, found a list of {len(v)} item{'' if len(v) == 1 else 's'}")
    return tuple(v)


def name_value(v: Any) -> Any:
    if isinstance(v, bool) or not isinstance(v, (str, int)):
        raise ValueError(f"expected a string, found {kind_of(v)}")
    v = str(v).strip()
    if not v:
        raise ValueError("expected a non-empty string, found an empty one")
    return v


Num = Annotated[float, BeforeValidator(number)]
Pos = Annotated[float, BeforeValidator(positive)]
NonNeg = Annotated[float, BeforeValidator(nonneg)]
Name = Annotated[str, BeforeValidator(name_value)]
Point = Annotated[tuple[Num, Num], BeforeValidator(pair_list)]
PosPair = Annotated[tuple[Pos, Pos], BeforeValidator(pair_list)]
Limits = Annotated[tuple[Point, Point], BeforeValidator(pair_list)]


class StrictSpec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class ArmFieldsSpec(StrictSpec):
    links: PosPair | None = None
    link_radius: Pos | None = None
    joint_limits: Limits | None = None
    max_velocity: PosPair | None = None
    max_acceleration: PosPair | None = None
    max_jerk: PosPair | None = None
    home: Point | None = None


class ArmSpec(ArmFieldsSpec):
    name: Name
    base: Point
    bin: Point


class FruitSpec(StrictSpec):
    id: Name
    position: Point


class TaskSpec(StrictSpec):
    pick_dwell: NonNeg
    place_dwell: NonNeg
    clearance: NonNeg
    reach_margin: NonNeg = Field(default=0.01)
    singularity_threshold: NonNeg = Field(default=0.05)


TOP_KEYS = ("name", "description", "defaults", "arms", "fruits", "task", "gantry")
ARM_REQUIRED = tuple(ArmFieldsSpec.model_fields)


# What each field expects, for "missing field" messages.
EXPECT = {
    "name": "a non-empty string",
    "arms": "a list of arms",
    "task": "a mapping with pick_dwell, place_dwell and clearance",
    "links": "[l1, l2]: two link lengths > 0 in m",
    "link_radius": "a capsule radius > 0 in m",
    "joint_limits": "[[t1_min, t1_max], [t2_min, t2_max]] in rad",
    "max_velocity": "[v1, v2]: two joint speeds > 0 in rad/s",
    "max_acceleration": "[a1, a2]: two joint accelerations > 0 in rad/s^2",
    "max_jerk": "[j1, j2]: two joint jerks > 0 in rad/s^3",
    "home": "[t1, t2]: joint angles in rad",
    "base": "[x, y] in m",
    "bin": "[x, y] in m",
    "id": "a non-empty string",
    "position": "[x, y] in m",
    "pick_dwell": "a number >= 0 in s",
    "place_dwell": "a number >= 0 in s",
    "clearance": "a number >= 0 in m",
}


def missing(field_name: str, where: str = "") -> str:
    what = EXPECT.get(str(field_name), "a value")
    return f"expected {what}, found nothing (required field{where})"
