"""The verifier's data objects: options, findings and the :class:`Verification` verdict.

Produced by :func:`coplan.verify.verify` (and re-exported there); see that module for what
each check means. ``Verification.summary()`` is the small dict stored in ``plan.json``,
``Verification.save()`` writes ``verification.json`` with everything.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from dataclasses import dataclass, field, fields
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np

from .clearance import DEFAULT_SUBSTEPS
from ..errors import Issue, OptionsError, check_fields, finite_number, known_fields
from ..kinds import FclMode
from ..output import atomic_text
from ..plan import finer_grid, on_lattice
from .fclcheck import FCL_TOLERANCE, FclReport

__all__ = [
    "FclMode",
    "ViolationKind",
    "WarningKind",
    "IntervalKind",
    "VerifyOptions",
    "Violation",
    "Finding",
    "ContactInterval",
    "PairClearance",
    "Verification",
    "report_path",
    "rounding_allowance",
    "blurred_by_rounding",
    "rounding_words",
    "UNCHECKABLE_SHARE",
]

#: A finite-difference limit check on a grid finer than 100 Hz whose rounding allowance exceeds
#: this share of the limit certifies too little: the limit is reported as not checkable there
#: (1e-7 rad on a 200 Hz grid: 3.2 rad/s^3 of jerk, 4 % of an 80 rad/s^3 limit; at 1 kHz 400).
UNCHECKABLE_SHARE = 0.05


def rounding_allowance(values: np.ndarray, resolution: float, dt: float, k: int) -> float:
    """What rounding the stored ``values`` to ``resolution`` (plan.json and plan.csv keep 1e-7)
    can add to a k-th difference over ``dt^k``: ``2^(k-1) resolution / dt^k``. On the 100 Hz
    grid coplan plans on (or coarser) that allowance always applies (0.4 rad/s^3 at most). On a
    finer grid it grows as ``dt^-k`` (400 rad/s^3 at 1 kHz), so it applies only where the values
    really sit on the ``resolution`` lattice; values stored at full precision get the allowance
    of their floating point (about 1e-15 of their size) instead."""
    if not finer_grid(dt):
        return 2.0 ** (k - 1) * resolution / dt ** k
    v = np.asarray(values, float)
    r = resolution if on_lattice(v, resolution) else 8.0 * np.finfo(float).eps * max(1.0, float(np.max(np.abs(v), initial=0.0)))
    return 2.0 ** (k - 1) * r / dt ** k


def blurred_by_rounding(diff: np.ndarray, limit: float, rel_tolerance: float, allow: float, dt: float) -> np.ndarray | None:
    """Where a limit check cannot tell (a failure, "not checkable"): on a grid finer than 100 Hz
    whose rounding allowance ``allow`` (:func:`rounding_allowance`) exceeds
    :data:`UNCHECKABLE_SHARE` of ``limit``, the differences ``diff`` over the limit by no more than
    that allowance, as a mask; None where there are none (the check passes or fails them itself)."""
    if not finer_grid(dt) or allow <= UNCHECKABLE_SHARE * limit:
        return None
    top = limit * (1.0 + rel_tolerance)
    hit = (diff > top) & (diff <= top + allow)
    return hit if hit.any() else None


def rounding_words(stored: str, unit: str, resolution: float, dt: float, allow: float, limit: float, what: str) -> str:
    """Why a difference :func:`blurred_by_rounding` found is not checkable, for its message."""
    return (f"{stored} stored to {resolution:g} {unit} on a {1.0 / dt:.4g} Hz grid carry up to {allow:.3g} of rounding "
            f"in their {what}, {100.0 * allow / limit:.0f} % of the limit; write the plan at full precision or on the "
            f"100 Hz grid")


class ViolationKind(str, Enum):
    """What failed; any violation fails the plan."""

    COLLISION = "collision"  # capsules of two arms overlap (an interval)
    CLEARANCE = "clearance"  # closer than task.clearance (an interval without overlap)
    UNCERTIFIED = "uncertified"  # samples clear, but the gap between them cannot be certified
    CROSS_CHECK = "cross_check"  # FCL and the NumPy distances disagree: the verifier itself is suspect
    JOINT_LIMIT = "joint_limit"
    VELOCITY = "velocity"
    ACCELERATION = "acceleration"
    JERK = "jerk"
    PICK_MISSED = "pick_missed"  # tip never within position_tolerance of the fruit during the pick
    PICK_DWELL = "pick_dwell"  # on the fruit, but not still for pick_dwell
    PLACE_MISSED = "place_missed"
    PLACE_DWELL = "place_dwell"
    DUPLICATE_PICK = "duplicate_pick"
    UNREACHABLE_PICK = "unreachable_pick"  # the arm cannot reach that fruit (problem.reach_matrix())
    UNKNOWN_FRUIT = "unknown_fruit"
    SEQUENCE = "sequence"  # overlapping events, a place without its pick, a pick never placed
    EVENT = "event"  # an event of an unknown arm or outside the plan's time span
    CARRIAGE = "carriage"  # a row plan's carriage: off the rail, not starting at rest at start, over a limit
    HOME = "home"  # an arm that does not start at its home pose (problem ``home``): an unplanned jump


class WarningKind(str, Enum):
    """Listed, never a failure."""

    SINGULAR = "singular"  # manipulability below task.singularity_threshold
    NOT_HARVESTED = "not_harvested"  # a reachable fruit is not picked and placed (the plan is partial)
    PROBLEM_NAME = "problem_name"  # the plan names another problem
    EVENTS_INFERRED = "events_inferred"  # the plan declares no events: they were inferred from its motion
    NOT_HOME = "not_home"  # an arm that does not end at its home pose (left out; or stopped by a declared fault)
    STATED_FIGURES = "stated_figures"  # the plan file's own figures (metrics) are not its motion's


class IntervalKind(str, Enum):
    COLLISION = "collision"  # capsules overlap (distance < 0)
    CLEARANCE = "clearance"  # 0 <= distance < task.clearance


@known_fields
@dataclass(frozen=True)
class VerifyOptions:
    """Settings of :func:`coplan.verify.verify` (units: m, s, rad).

    Attributes
    ----------
    substeps : dense clearance samples per plan interval (10: 1 kHz on a 100 Hz plan)
    refine_levels, refine_factor : how often / how finely uncertified gaps are subdivided
    fcl : FCL cross-check mode; ``fcl_samples`` seeded random instants per pair (``seed``)
        on top of the critical ones, of which at most ``fcl_max_intervals`` interval worst
        points per pair; ``fcl_tolerance`` is the allowed disagreement
    position_tolerance : tip to fruit / bin during an event (5 mm)
    still_speed : "still" means no point of the arm faster than this (5 mm/s)
    dwell_tolerance : allowed shortfall of a dwell; None = one plan sample period
    q_resolution : resolution of the stored joint angles (plan.json rounds to 1e-7 rad);
        sets the finite-difference tolerances together with ``rel_tolerance``
    joint_tolerance : allowed excess over a joint limit
    carriage_tolerance : a row plan's carriage may miss ``gantry.start`` / overrun the rail by this
    home_tolerance : an arm's first and last pose may miss its home by this (each joint)
    infer_events : when a plan declares no events, infer them from its motion
        (:mod:`coplan.verify.infer`) and say so; otherwise nothing counts as harvested
    margin_rel : 0 (the default): a clear pair's certified least distance is refined to within
        0.5 um of its least sampled distance; > 0: to within that share of the distance where
        it is more, never more than half the pair's margin -- the same verdict, a coarser
        margin (:func:`coplan.verify.clearance.certify_pair`; the speed search screens its
        candidates with 1, then verifies the plan it keeps with 0)
    """

    substeps: int = DEFAULT_SUBSTEPS
    refine_levels: int = 2
    refine_factor: int = 10
    fcl: FclMode = FclMode.CRITICAL
    fcl_samples: int = 32
    fcl_max_intervals: int = 200
    seed: int = 0
    fcl_tolerance: float = FCL_TOLERANCE
    position_tolerance: float = 0.005
    still_speed: float = 0.005
    dwell_tolerance: float | None = None
    q_resolution: float = 1e-7
    rel_tolerance: float = 1e-6
    joint_tolerance: float = 1e-7
    infer_events: bool = True
    carriage_tolerance: float = 1e-6  # m: a row plan's carriage start and rail ends
    home_tolerance: float = 1e-6  # rad: an arm's first and last pose against its home (plan.csv keeps 1e-7)
    margin_rel: float = 0.0

    def __post_init__(self):
        # built in Python: every value checked (OptionsError: what was expected, found); a
        # refinement that splits an interval into one would never end
        check_fields(self, {"substeps", "refine_factor", "position_tolerance", "still_speed", "q_resolution"})
        if not 0.0 <= self.margin_rel <= 1.0:
            raise OptionsError([Issue("margin_rel", f"expected a share of the least distance from 0 to 1, found "
                                                    f"{self.margin_rel}")], "VerifyOptions")
        if self.refine_factor < 2:
            raise OptionsError([Issue("refine_factor", f"expected an integer >= 2 (each uncertified interval split "
                                                       f"into that many), found {self.refine_factor}")], "VerifyOptions")


def _plain(v):
    """NumPy scalars (also inside tuples) as Python numbers: a finding reads ``amount=6.29``,
    not ``amount=np.float64(6.29)``, and compares and serialises as a number."""
    if isinstance(v, np.generic):
        return v.item()
    if isinstance(v, tuple):
        return tuple(_plain(u) for u in v)
    return v


def _plain_fields(obj) -> None:
    for f in fields(obj):
        object.__setattr__(obj, f.name, _plain(getattr(obj, f.name)))


@dataclass(frozen=True)
class Violation:
    """One failed check: ``value`` measured against ``limit``; ``amount`` is by how much."""

    kind: ViolationKind
    arms: tuple[str, ...]
    t: float
    amount: float
    value: float | None = None
    limit: float | None = None
    t_start: float | None = None
    t_end: float | None = None
    joint: int | None = None
    fruit: str | None = None
    message: str = ""
    step: bool = False  # a jerk violation that is one jump of the acceleration (value, limit in rad/s^2): unbounded jerk

    def __post_init__(self) -> None:
        _plain_fields(self)


@dataclass(frozen=True)
class Finding:
    """A warning: listed, never a failure."""

    kind: WarningKind
    arms: tuple[str, ...]
    t: float | None
    value: float | None = None
    limit: float | None = None
    t_start: float | None = None
    t_end: float | None = None
    message: str = ""

    def __post_init__(self) -> None:
        _plain_fields(self)


@dataclass(frozen=True)
class ContactInterval:
    """A maximal run of samples in collision (or inside the clearance) for one arm pair.

    ``least_distance`` < 0 is a penetration of ``-least_distance``; ``links`` (link of the
    first arm, link of the second) and ``points`` ((2, 2): the closest point on each) are at
    ``t_worst``.
    """

    kind: IntervalKind
    arms: tuple[str, str]
    t_start: float
    t_end: float
    t_worst: float
    least_distance: float
    links: tuple[int, int]
    points: tuple[tuple[float, float], tuple[float, float]]

    def __post_init__(self) -> None:
        _plain_fields(self)

    @property
    def penetration(self) -> float:
        return max(0.0, -self.least_distance)


@dataclass(frozen=True)
class PairClearance:
    """Least sampled and certified clearance of one arm pair (m), when and where."""

    arms: tuple[str, str]
    min_clearance: float
    t: float
    links: tuple[int, int]
    points: tuple[tuple[float, float], tuple[float, float]]
    certified: float
    t_certified: float
    samples: int
    refined: int

    def __post_init__(self) -> None:
        _plain_fields(self)

    @property
    def key(self) -> str:
        return f"{self.arms[0]}-{self.arms[1]}"


@dataclass
class Verification:
    """The verdict on one plan; ``summary()`` goes into ``plan.json``, ``save()`` writes the rest."""

    problem: str  # the name of the problem checked against (a plan naming another: a problem_name warning)
    planner: str
    duration: float
    required_clearance: float
    options: VerifyOptions
    pairs: list[PairClearance] = field(default_factory=list)
    intervals: list[ContactInterval] = field(default_factory=list)
    violations: list[Violation] = field(default_factory=list)
    warnings: list[Finding] = field(default_factory=list)
    peaks: dict[str, dict[str, float]] = field(default_factory=dict)
    unharvested: list[str] = field(default_factory=list)
    fcl: FclReport | None = None
    timings: dict[str, float] = field(default_factory=dict)
    inferred_events: list | None = None  # the events inferred from the motion, when the plan declared none
    # the pick whose tip came least close to its fruit: {"fruit", "arm", "distance" (m, its closest), "t"} (None: no picks)
    worst_pick: dict | None = None
    # the problem text checked against and the one the plan records it was planned from:
    # {"sha256": str | None, "planned_from": {"path", "sha256"} | None, "same_text": bool | None}
    problem_file: dict | None = None
    # the figures the plan file states (its ``metrics``) that its motion does not bear out:
    # ``{name: {"stated", "measured"}}`` (makespan, harvested, a row's row_time); empty where they agree
    stated_figures: dict[str, dict[str, float]] = field(default_factory=dict)
    # the figures its motion bears out: {"makespan": the last place of a fruit it harvests within
    # its samples (s; 0 without one), "harvested": reachable fruit picked and placed}
    measured: dict[str, float] = field(default_factory=dict)

    def __repr__(self) -> str:  # (short: the pairs' intervals and every finding stay out of a notebook cell)
        kinds = sorted({v.kind.value for v in self.violations})
        cert = self.certified_clearance
        room = "-" if not math.isfinite(cert) else f"{cert:.4f} m (margin {1e3 * self.margin:+.1f} mm)"
        left = ", ".join(self.unharvested[:5]) + (", ..." if len(self.unharvested) > 5 else "")
        return (f"Verification(problem={self.problem!r}, planner={self.planner!r}, passed={self.passed}, "
                f"complete={self.complete}, certified_clearance={room}, violations={len(self.violations)}"
                f"{f' {kinds}' if kinds else ''}, warnings={len(self.warnings)}"
                f"{f', unharvested=[{left}]' if self.unharvested else ''}, duration={self.duration:.4f} s)")

    @property
    def passed(self) -> bool:
        """Safe as planned: no violation -- no collision or clearance shortfall (certified between
        samples), no joint or carriage limit exceeded, every pick and place it declares made where
        and as long as it says, each arm starting at its home (:class:`ViolationKind`). Says
        nothing of how much it harvests: a plan that picks nothing passes; :attr:`complete` says
        whether every reachable fruit was harvested."""
        return not self.violations

    @property
    def complete(self) -> bool:
        """Every fruit some arm can reach was picked and placed (``unharvested`` is empty). A plan
        is a success only when it has :attr:`passed` and is complete; passed and not complete is
        a verified partial plan."""
        return not self.unharvested

    @property
    def collisions(self) -> list[ContactInterval]:
        """The intervals in which two arms' links touch (less than no clearance at all)."""
        return [c for c in self.intervals if c.kind == IntervalKind.COLLISION]

    @property
    def min_clearance(self) -> float:
        """The least distance between neighbouring arms' links at the plan's samples (m; inf
        with fewer than two arms that can meet)."""
        return min((p.min_clearance for p in self.pairs), default=math.inf)

    @property
    def certified_clearance(self) -> float:
        """The least distance between neighbouring arms' links certified between samples as well
        (m; at most :attr:`min_clearance`; inf with fewer than two arms that can meet)."""
        return min((p.certified for p in self.pairs), default=math.inf)

    @property
    def margin(self) -> float:
        """The certified margin: least certified clearance less the required one (m; inf without pairs)."""
        return self.certified_clearance - self.required_clearance

    def acceleration_steps(self) -> dict[str, float]:
        """``{arm: its largest acceleration step, rad/s^2}`` for the arms whose acceleration jumps
        between samples (the course's cubic starts and stops that way): their jerk is unbounded."""
        out: dict[str, float] = {}
        for v in self.violations:
            if v.step and v.value is not None:
                for a in v.arms:
                    out[a] = max(out.get(a, 0.0), float(v.value))
        return out

    def summary(self) -> dict[str, Any]:
        """Small JSON-able verdict (stored in ``plan.json``). Clearances are ``inf`` without pairs."""
        return {
            "passed": self.passed,
            "complete": self.complete,
            "collision_count": len(self.collisions),
            "clearance_breach_count": sum(c.kind == IntervalKind.CLEARANCE for c in self.intervals),
            "min_clearance": self.min_clearance,
            "certified_clearance": self.certified_clearance,
            "required_clearance": self.required_clearance,
            "margin": self.margin,
            "violation_count": len(self.violations),
            "violation_kinds": sorted({v.kind.value for v in self.violations}),
            "warning_count": len(self.warnings),
            "unharvested": list(self.unharvested),
            "events_inferred": self.inferred_events is not None,
            "worst_pick": self.worst_pick,
            # per arm, the largest acceleration step (rad/s^2): its jerk is unbounded, whatever a
            # sampled figure says (a finite difference of a step grows with the rate)
            "acceleration_steps": self.acceleration_steps(),
            "position_tolerance": self.options.position_tolerance,
            "pairs": {p.key: {"min_clearance": p.min_clearance, "t": p.t, "certified": p.certified,
                              "margin": p.certified - self.required_clearance} for p in self.pairs},
            "peaks": self.peaks,
            "fcl_agree": None if self.fcl is None else self.fcl.agree,
        }

    def to_dict(self) -> dict[str, Any]:
        """Everything, JSON-able (non-finite numbers become ``null``)."""
        doc = {
            "format": "coplan.verification/1",
            "problem": self.problem,
            "planner": self.planner,
            "duration": self.duration,
            "summary": self.summary(),
            "options": {f.name: getattr(self.options, f.name) for f in fields(self.options)},
            "pairs": [_asdict(p) | {"key": p.key} for p in self.pairs],
            "intervals": [_asdict(c) | {"penetration": c.penetration} for c in self.intervals],
            "violations": [_asdict(v) for v in self.violations],
            "warnings": [_asdict(w) for w in self.warnings],
            "fcl": None if self.fcl is None else self.fcl.to_dict(),
            "inferred_events": None if self.inferred_events is None else [e.to_dict() for e in self.inferred_events],
            "problem_file": self.problem_file,
            "stated_figures": self.stated_figures,
            "measured": self.measured,
            "timings": self.timings,
        }
        return _json(doc)

    def save(self, path: str | Path) -> Path:
        """Write ``verification.json`` (``path`` may be a folder: :func:`report_path`); returns
        the file written."""
        p = report_path(path)
        p.parent.mkdir(parents=True, exist_ok=True)
        atomic_text(p, json.dumps(self.to_dict(), indent=1, allow_nan=False))
        return p


def stated_figures(metrics: Mapping[str, Any] | None, makespan: float | None, harvested: int,
                   slack: float = 0.0) -> dict[str, dict[str, float]]:
    """The figures a plan file states (``metrics``: makespan, harvested; a row's row time) that its
    motion does not bear out (``makespan``: its last place's end, s; ``harvested``: fruit picked and
    placed): ``{name: {"stated", "measured"}}``, empty where they agree or it states none.
    ``slack``: how much later than the truth the measured makespan may be (s; three samples where
    the events were inferred from the motion, which ends a place on a sample after its hold's)."""
    m = metrics or {}
    row = m.get("row") if isinstance(m.get("row"), Mapping) else {}

    # a row's grower figures as its motion bears them out (an edited plan.json said 99999 fruit per
    # hour and half the fruit harvested, and verify passed it without a word); the share over the
    # harvestable fruit the file itself states (the verifier does not screen the row)
    per_h = 3600.0 * harvested / makespan if makespan else None
    share = harvested / row["harvestable"] if finite_number(row.get("harvestable")) and row["harvestable"] > 0 else None
    out: dict[str, dict[str, float]] = {}
    late = 1e-6 + max(0.0, slack)
    for key, said, measured, tol in (("makespan", m.get("makespan"), makespan, late),
                                     ("harvested", m.get("harvested"), harvested, 0),
                                     ("row_time", row.get("row_time"), makespan, late),
                                     ("row.harvested", row.get("harvested"), harvested if row else None, 0),
                                     ("row.fruit_per_hour", row.get("fruit_per_hour"), per_h if row else None, 1e-6),
                                     ("row.share_harvested", row.get("share_harvested"), share, 1e-9)):
        if key == "row.fruit_per_hour" and measured is not None:  # (relative; a makespan later by the slack: less)
            tol = 1e-6 * max(1.0, abs(measured)) + abs(measured) * late / makespan
        if measured is not None and finite_number(said) and abs(said - measured) > tol:
            out[key] = {"stated": float(said), "measured": float(measured)}
    return out


def measured_metrics(metrics: Mapping[str, Any] | None, stated: Mapping[str, Mapping[str, float]]) -> dict[str, Any]:
    """``metrics`` with each figure :func:`stated_figures` found not borne out (``stated``) replaced
    by the measured one -- a row's (``row_time``, ``row.*``) in its ``row`` entry -- for a page or
    figure that says it shows the measured figures (the viewer's row headline kept a file's
    9999 fruit/h beside a note saying 2742.65 measured were shown)."""
    out = dict(metrics or {})
    row = dict(out["row"]) if isinstance(out.get("row"), Mapping) else None
    for key, fig in stated.items():
        value = int(round(fig["measured"])) if key in ("harvested", "row.harvested") else fig["measured"]  # (a count: "11.0/11 fruit")
        if key == "row_time" or key.startswith("row."):
            if row is not None:
                row[key.removeprefix("row.")] = value
        else:
            out[key] = value
    if row is not None:
        out["row"] = row
    return out


def report_path(path: str | Path) -> Path:
    """The file :meth:`Verification.save` writes for ``path``: ``path`` itself when it names a
    ``.json`` file, else ``verification.json`` in the folder ``path``."""
    p = Path(path)
    return p / "verification.json" if p.is_dir() or p.suffix != ".json" else p


def _asdict(obj) -> dict:
    return {f.name: getattr(obj, f.name) for f in fields(obj)}


def _json(x):
    if isinstance(x, dict):
        return {str(k): _json(v) for k, v in x.items()}
    if isinstance(x, (list, tuple, np.ndarray)):
        return [_json(v) for v in x]
    if isinstance(x, Enum):
        return x.value
    if isinstance(x, (bool, np.bool_)):
        return bool(x)
    if isinstance(x, (int, np.integer)):
        return int(x)
    if isinstance(x, (float, np.floating)):
        return float(x) if math.isfinite(x) else None
    return x
