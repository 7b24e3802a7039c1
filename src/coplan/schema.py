"""JSON Schemas of coplan's file formats: problem files (YAML), plan files (``plan.json``) and
vision feeds (YAML, ``coplan.feed/1``).

The schemas are exported from the pydantic models below (:func:`json_schema`) and shipped as
package data (``coplan/schemas/problem.schema.json``, ``plan.schema.json``,
``feed.schema.json``; :func:`shipped_path`); a test keeps the shipped files equal to what the
models export, and validates every shipped problem, a solved ``plan.json`` and generated feeds
against them. ``coplan schema problem|plan|feed`` prints one.

A schema tells editors and other tools the shape of a file: keys, types, units, required
fields. It is a necessary condition only: coplan's own loaders check more (joint limits
min < max, unique names, a uniform time grid, plausible values, geometry) and say where.
The problem models mirror :mod:`coplan.problem`'s validation models field for field (a test
cross-checks the two on seeded mutations of the shipped problems).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from .kinds import EventKind, SchemaKind
from .plan import PLAN_FORMAT
from .problem.model import MAX_ARMS, MAX_FRUITS
from .problem.plausible import MAX_PLAN_SECONDS

__all__ = ["json_schema", "schema_text", "shipped_path", "SCHEMA_DIR", "ProblemFile", "PlanFile", "FeedFile"]

SCHEMA_DIR = Path(__file__).with_name("schemas")
_ID = "https://coplan.invalid/schemas/"  # a stable identifier, not a download location

Pos = Annotated[float, Field(gt=0)]
NonNeg = Annotated[float, Field(ge=0)]
Name = Annotated[str, Field(min_length=1, pattern=r"\S")]  # (blank: refused by coplan, it passed the schema)
# a problem's names and ids are kept as written: ``id: 2``, ``name: 12`` or ``name: true`` is the
# text "2", "12", "true" (the schema said "is not of type 'string'" of files coplan reads)
Text = Name | int | float | bool
Point = Annotated[list[float], Field(min_length=2, max_length=2)]
PosPair = Annotated[list[Pos], Field(min_length=2, max_length=2)]
Limits = Annotated[list[Point], Field(min_length=2, max_length=2)]


class _Closed(BaseModel):
    model_config = ConfigDict(extra="forbid")


class ArmFields(_Closed):
    """Arm fields an arm may set, or take from ``defaults``."""

    links: PosPair | None = Field(None, description="[l1, l2]: two link lengths > 0, m")
    link_radius: Pos | None = Field(None, description="links are capsules of this radius, m")
    joint_limits: Limits | None = Field(None, description="[[t1_min, t1_max], [t2_min, t2_max]], rad")
    max_velocity: PosPair | None = Field(None, description="[v1, v2]: joint speed limits, rad/s")
    max_acceleration: PosPair | None = Field(None, description="[a1, a2]: joint acceleration limits, rad/s^2")
    max_jerk: PosPair | None = Field(None, description="[j1, j2]: joint jerk limits, rad/s^3")
    home: Point | None = Field(None, description="[t1, t2]: joint angles at start and end, rad")


class ArmSpec(ArmFields):
    """One arm: its name, base and bin, and any arm field not taken from ``defaults``."""

    name: Text = Field(description="unique arm name (a number is kept as written)")
    base: Point = Field(description="[x, y] of the shoulder joint, m")
    bin: Point = Field(description="[x, y] where the arm places its fruit, m")


class FruitSpec(_Closed):
    id: Text = Field(description="unique fruit id (a number is kept as written)")
    position: Point = Field(description="[x, y], m")


class TaskSpec(_Closed):
    pick_dwell: NonNeg = Field(description="s the tip must stay still on a fruit")
    place_dwell: NonNeg = Field(description="s the tip must stay still over the bin")
    clearance: NonNeg = Field(description="m, least distance between capsules of two different arms")
    reach_margin: NonNeg = Field(0.01, description="m: a fruit this close to the workspace boundary counts as unreachable")
    singularity_threshold: NonNeg = Field(0.05, description="|det J| below this is reported as near-singular")


class GantrySpec(_Closed):
    """A row's carriage: with it, bases and bins are relative to the carriage and fruit in row coordinates."""

    start: float = Field(description="x of the carriage origin at t = 0, m")
    end: float = Field(description="end of the row, m (> start; the carriage never goes past it)")
    max_velocity: float = Field(gt=0, description="carriage speed limit, m/s")
    max_acceleration: float = Field(gt=0, description="carriage acceleration limit, m/s^2")
    max_jerk: float = Field(gt=0, description="carriage jerk limit, m/s^3")
    settle: float = Field(0.0, ge=0, description="s at rest after a move before an arm may pick")


class ProblemFile(_Closed):
    """A coplan problem file (YAML; SI units). Every arm field must be given on the arm or in ``defaults``."""

    model_config = ConfigDict(extra="forbid", title="coplan problem")

    name: Text = Field(description="the problem's name (a number is kept as written)")
    description: str | int | float | bool | None = Field("", description="free text")
    defaults: ArmFields | None = Field(None, description="arm fields used by every arm that does not set them")
    arms: list[ArmSpec] = Field(min_length=1, max_length=MAX_ARMS)
    fruits: list[FruitSpec] | None = Field(default_factory=list, max_length=MAX_FRUITS,
                                           description="none (or null): nothing to harvest")
    task: TaskSpec
    # (optional, but a mapping where given: ``gantry: null`` passed the schema, coplan refuses it)
    gantry: GantrySpec = Field(None, description="a mobile gantry: the problem is a row (bases and bins on the carriage)")


class EventSpec(_Closed):
    arm: str
    fruit: str
    kind: EventKind = Field(description="pick: the tip still on the fruit; place: still over the arm's bin")
    t_start: float = Field(description="s")
    t_end: float = Field(description="s, >= t_start")


class ArmTrajectory(BaseModel):
    q: list[Point] = Field(description="one [t1, t2] pair (rad) per time of the grid")


class GantryTrajectory(BaseModel):  # (open, as the plan is: coplan reads a plan with more keys)
    x: list[float] = Field(description="the carriage origin's x at every time of the grid, m (linear between samples)")


class ProblemFileRecord(_Closed):
    path: str = Field(description="absolute path of the problem YAML when the plan was written")
    sha256: str = Field(description="sha256 of that file's text: a file changed since is not taken for it")


class ArmMetrics(BaseModel):  # (open: coplan may add figures)
    fruit: int | None = Field(None, description="fruit this arm placed in its bin")
    last_place: float | None = Field(None, description="s, the end of this arm's last place")
    cycle_time: float | None = Field(None, description="s per fruit: last_place / fruit")
    idle_fraction: float | None = Field(None, description="share of the makespan (0-1) the arm is not moving, picking or placing")
    rms_jerk: float | None = Field(None, description="rad/s^3, the RMS over the whole plan of the joint jerk vector's length, "
                                                    "sqrt(mean(j1^2 + j2^2)) (third differences)")
    peak_jerk: float | None = Field(None, description="rad/s^3, the largest joint jerk")


class RowMetrics(BaseModel):  # (open: coplan may add figures)
    """A row plan's ``metrics.row`` (:func:`coplan.row.metrics.row_metrics`): what a grower and
    an engineer judge it by. Times in s, distances in m."""

    mode: str | None = Field(None, description="stop-and-go, or continuous: picked on the move")
    fruit: int | None = Field(None, description="the row's fruit")
    harvestable: int | None = Field(None, description="fruit the row's screen finds a carriage position for")
    harvested: int | None = Field(None, description="fruit placed in a bin")
    share_harvested: float | None = Field(None, description="harvested / harvestable (0-1)")
    share_of_all_fruit: float | None = Field(None, description="harvested / fruit (0-1)")
    screened_out: dict[str, str] | None = Field(None, description="fruit id -> why no carriage position serves it: out "
                                                                  "of every arm's reach (metrics.fruit_ids.unreachable) or "
                                                                  "reachable and ruled out (fruit_ids.screened_out)")
    locked_arms: dict[str, str] | None = Field(None, description="arm -> why the screen locks it (it cannot reach its "
                                                                 "bin, which rides with the carriage): it harvests nothing")
    row_time: float | None = Field(None, description="s, the end of the last place")
    row_length: float | None = Field(None, description="m, gantry end - start")
    time_per_metre: float | None = Field(None, description="s per m of row: row_time / row_length")
    fruit_per_hour: float | None = Field(None, description="harvested per hour of row time")
    fruit_per_hour_per_arm: dict[str, float] | None = Field(None, description="arm name -> its fruit per hour of row time")
    stops: int | None = Field(None, description="stops the carriage makes (0 on the move)")
    stop_positions: list[float] | None = Field(None, description="m, the carriage origin's x at each stop")
    mean_time_per_stop: float | None = Field(None, description="s, from the carriage's arrival to the end of the stop's "
                                                                "last pick, when it may leave (null: no stop, on the move)")
    carriage_moving_share: float | None = Field(None, description="share of the row time (0-1) the carriage moves")
    picking_share: float | None = Field(None, description="share of the row time (0-1) some arm holds still on a fruit")
    overlap_seconds: float | None = Field(None, description="s the carriage moves while some arm works (away from home), "
                                                             "which the stop-and-go bound's model excludes")
    idle_share: dict[str, dict[str, float]] | None = Field(None, description="arm -> share of the row time idle by cause: "
        "carriage (at rest while the carriage moves), no_fruit (at a stop with nothing in its reach), others (done at a "
        "stop, waiting for the other arms), coordination (holding still within its work for a neighbour), making_way "
        "(moving out of a neighbour's way where it has no fruit)")
    planning_time: float | None = Field(None, description="s of planning (the stop rule and every stop's cell, or the speed search)")
    planning_over_row_time: float | None = Field(None, description="planning_time / row_time")
    first_stop_seconds: float | None = Field(None, description="s of planning until the first stop was known")
    first_motion_seconds: float | None = Field(None, description="s of planning until the row can start moving (on the "
                                                                  "move: the end of planning)")
    slowest_stop_seconds: float | None = Field(None, description="s, the longest planning of one stop's cell (null: no stop)")
    least_slack_seconds: float | None = Field(None, description="s, the least time a stop's cell was planned before the "
                                                                 "carriage needed it (negative: late; null on the move)")
    kept_ahead: bool | None = Field(None, description="every stop's cell planned before the carriage needed it (null: "
                                                       "no stop, or on the move)")
    lower_bound: dict[str, Any] | None = Field(None, description="the row's bounds (coplan.allocate.row_bound.RowBounds): "
                                                                  "any_plan, stop_and_go, work, travel, moves, priced "
                                                                  "(stops and positions priced together), arrival: s; "
                                                                  "reach_to: m; fruit, priced_stops: counts; seconds: "
                                                                  "the time computing them took, s")
    ratio_any_plan_bound: float | None = Field(None, description="row_time / the bound valid for any carriage motion")
    ratio_stop_and_go_bound: float | None = Field(None, description="row_time / the bound for plans that pick only at rest")
    picks_at_rest: int | None = Field(None, description="on the move: picks whose whole dwell has the carriage at rest")
    profile: str | None = Field(None, description="on the move: the carriage's speed profile (constant or by density)")
    mean_speed: float | None = Field(None, description="on the move: m/s, over the time the carriage moves")
    top_speed: float | None = Field(None, description="on the move: m/s")
    plans_tried: int | None = Field(None, description="on the move: full plans the speed search tried, each verified")


class PlanMetrics(BaseModel):
    """The figures coplan writes under ``metrics`` (open: more keys may follow; a plan from
    elsewhere needs none). Times in s, distances in m."""

    harvested: int | None = Field(None, description="fruit placed in a bin")
    reachable: int | None = Field(None, description="fruit within some arm's reach, task.reach_margin kept (a row's: "
                                                     "those its screen finds a carriage position for)")
    unreachable: int | None = Field(None, description="fruit out of every arm's reach")
    makespan: float | None = Field(None, description="s, the end of the last place")
    cycle_time: float | None = Field(None, description="s per fruit, the worst arm's")
    cycle_time_mean: float | None = Field(None, description="s per fruit, the mean over the arms that harvest")
    throughput: float | None = Field(None, description="fruit per SECOND: harvested / makespan (a sweep's table gives "
                                                        "fruit per minute; a row's metrics.row fruit per hour)")
    per_arm: dict[str, ArmMetrics] | None = Field(None, description="arm name -> its figures")
    lower_bound: float | None = Field(None, description="s, a makespan no plan can beat (a row's: for any carriage motion)")
    gap_to_lower_bound: float | None = Field(None, description="a RATIO, makespan / lower_bound (1.0: no gap)")
    optimality: str | None = Field(None, description="proven when the makespan meets the lower bound")
    margin: float | None = Field(None, description="m, the least certified clearance beyond the required one")
    margin_per_pair: dict[str, float | None] | None = Field(None, description="'a-b' (neighbouring arms) -> m, as margin")
    fruit: int | None = Field(None, description="the problem's fruit")
    harvestable: int | None = Field(None, description="reachable fruit the screen does not rule out")
    screened_out: int | None = Field(None, description="reachable fruit the screen rules out (reasons: solver.screen)")
    fruit_ids: dict[str, list[str]] | None = Field(None, description="the ids of the unreachable, screened_out and "
                                                                      "left_out (harvestable, not harvested) fruit")
    coordinated_makespan: float | None = Field(None, description="s, the optimal planner's first (coordinated) plan")
    improvement_over_coordinated: float | None = Field(None, description="share (0.05: 5 %) by which the makespan is "
                                                                          "shorter than coordinated_makespan")
    baseline_makespan: float | None = Field(None, description="s, the course's heuristic plan made beside it (baseline.json)")
    baseline_status: str | None = Field(None, description="that plan's verified status")
    time_to_first_verified: float | None = Field(None, description="s of planning to the first verified plan")
    time_of_last_improvement: float | None = Field(None, description="s of planning to the plan kept")
    time_to_ratio: dict[str, float | None] | None = Field(None, description="'1.05', '1.02', '1.01' -> s of planning to a "
                                                                             "plan within that ratio of lower_bound (null: never)")
    row: RowMetrics | None = Field(None, description="a row plan's figures: fruit per hour, shares, stops, idle by "
                                                      "cause, ratios to the row's bounds")


class PlanFile(BaseModel):
    """A coplan plan file (``plan.json``): every arm's joints on one uniform grid (100 Hz or
    finer, from 0), linear between samples, and the pick/place events."""

    model_config = ConfigDict(extra="allow", title="coplan plan")

    format: Literal["coplan.plan/1"]
    problem: str = Field(description="the name of the problem the plan is for")
    planner: Name = Field("external", description="the planner's name (any; coplan's: heuristic, coordinated, optimal)")
    status: str | None = Field(None, description="what the writer claimed; ignored when verifying (the verdict is the verifier's)")
    time: list[float] = Field(min_length=1, description="uniform grid of times from 0, s")
    arms: dict[str, ArmTrajectory] = Field(min_length=1, description="arm name -> its joint angles")
    events: list[EventSpec]
    allocation: dict[str, list[str]] = Field(default_factory=dict, description="arm name -> fruit ids in harvesting order")
    unreachable: list[str] = Field(default_factory=list, description="fruit no arm can reach")
    metrics: PlanMetrics | None = Field(None, description="what coplan measured of the plan (units in each field)")
    solver: dict[str, Any] | None = None
    verification: dict[str, Any] | None = None
    gantry: GantryTrajectory | None = Field(None, description="a row plan: the carriage's position on the same grid")
    problem_file: ProblemFileRecord | None = Field(
        None, description="the problem file the plan was made from (the plot, animate and view commands find it there)")
    software: dict[str, str | None] | None = Field(
        None, description="what made the plan: coplan's version (and its git commit where it ran from a checkout), Python's, the machine, the versions of the libraries "
                          "that decide a plan (numpy, scipy, casadi, ortools, ruckig, python-fcl) and OPENBLAS_CORETYPE")


assert PLAN_FORMAT == "coplan.plan/1", "PlanFile.format must name the format plan.py writes"


class CloseRangeSpec(_Closed):
    """When a gripper's tip comes close to its target, a refined measurement arrives."""

    distance: float = Field(0.10, ge=0.005, le=1.0, description="m: the tip this close to its target gets a refined "
                                                                  "measurement (coplan feed --close-distance)")
    sigma: float = Field(0.001, ge=1e-6, le=0.1, description="m: that measurement's standard deviation per coordinate "
                                                               "(coplan feed --close-sigma)")


class DetectionSpec(_Closed):
    """One detection event: when it arrives, its id, the measured position and its noise."""

    t: float = Field(ge=0, le=MAX_PLAN_SECONDS, description="s: when the detection arrives (with after: s after that "
                                                            "fruit's pick ends)")
    id: Name = Field(description="the detection's id, unique within the feed")
    position: Point = Field(description="[x, y] as measured, m, in the problem's frame")
    sigma: float = Field(gt=0, le=1.0, description="m: the standard deviation of each coordinate")
    fruit: Name | None = Field(None, description="the true fruit it is (simulation only); null: a false detection")
    after: Name | None = Field(None, description="a true fruit this one was hidden behind: t counts from that fruit's "
                                                  "pick (simulation only)")


class FeedFile(_Closed):
    """A coplan vision feed (YAML): what the camera reports, detection by detection
    (``coplan feed`` writes one; ``coplan run --feed`` reads one)."""

    model_config = ConfigDict(extra="forbid", title="coplan vision feed")

    format: Literal["coplan.feed/1"] | None = Field(None, description="the file format")
    problem: str | None = Field(None, description="the name of the problem it was made for (a note if another is run)")
    close_range: CloseRangeSpec | None = None
    detections: list[DetectionSpec] = Field(description="the detections, in any order")


_MODELS = {SchemaKind.PROBLEM: ProblemFile, SchemaKind.PLAN: PlanFile, SchemaKind.FEED: FeedFile}


def json_schema(kind: SchemaKind | str) -> dict[str, Any]:
    """The JSON Schema (draft 2020-12) of a file format, as the models export it."""
    kind = SchemaKind(kind)
    schema = _MODELS[kind].model_json_schema()
    return {"$schema": "https://json-schema.org/draft/2020-12/schema", "$id": f"{_ID}{kind.value}.schema.json", **schema}


def schema_text(kind: SchemaKind | str) -> str:
    """The schema as the shipped file holds it (indented JSON, a final newline)."""
    return json.dumps(json_schema(kind), indent=2, ensure_ascii=False) + "\n"


def shipped_path(kind: SchemaKind | str) -> Path:
    return SCHEMA_DIR / f"{SchemaKind(kind).value}.schema.json"


def write_shipped() -> list[Path]:
    """Regenerate the shipped schema files (``python -m coplan.schema``)."""
    SCHEMA_DIR.mkdir(exist_ok=True)
    out = []
    for kind in SchemaKind:
        shipped_path(kind).write_text(schema_text(kind))
        out.append(shipped_path(kind))
    return out


if __name__ == "__main__":
    for p in write_shipped():
        print(f"wrote {p}")
