"""The live cell's records: its options (:class:`LiveOptions`), a believed fruit
(:class:`Track`), one re-plan (:class:`Replan`) and a tip's close-range moment
(:class:`CloseRange`). :class:`coplan.live.cell.LiveCell` makes and keeps them (and re-exports them)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..kinds import ReplanCause, TrackState
from ..planners.coordinated.planner import CoordinatedOptions
from ..errors import Issue, check_fields, finite_number, found, known_fields, plain_scalars
from .feed import DEFAULT_CLOSE_DISTANCE

__all__ = ["LiveOptions", "Track", "Replan", "CloseRange"]


@known_fields
@dataclass(frozen=True)
class LiveOptions:
    """horizon : commit horizon (s): motion up to the first rest instant after ``now + horizon``
        is kept at a re-plan (must cover the re-planning latency)
    gate : detections of one fruit are merged when closer than ``max(gate, 3 sigma)`` (m),
        sigma the combined standard deviation (``3 sigma`` alone for a track refined at close range)
    margin : extra clearance (m) kept while coordinating (as the coordinated planner)
    max_checks : work cap (conflict checks) of one coordination attempt
    close_distance : the refined measurement comes when the tip is this close to its target (m)
    correction_delay : s from the refined measurement to the start of the corrected approach
    max_correction : largest joint change (rad) a corrected approach may make; a refined pose
        further away (across a joint limit, another branch) is planned again instead
    work : conflict checks a re-plan may spend (its first plan's included) before it stops
        trying better candidates (it always keeps its first plan): a work budget, so that the
        same feed and seed give the same run on any machine, about the 50 ms a re-plan had
        on a 2-core machine (a median 0.5 ms a check there); None: no such cap
    budget : wall-clock seconds a re-plan may spend before it stops trying better candidates
        (None, the default: no clock; a real cell that must answer in time sets it, and its
        plans then depend on the machine's speed and load)
    max_open : the most tracks one re-plan coordinates: those the current plan holds, then the
        pending ones first seen (a burst of 500 false detections exhausted every coordination
        attempt's work and left real fruit pending to the end: 9 of 11 harvested; with 40, 11 of
        11 in the burst-free run's makespan); the rest wait, pending, for the next re-plan
    """

    horizon: float = 0.1
    gate: float = 0.03
    margin: float = CoordinatedOptions.margin
    max_checks: int = CoordinatedOptions.attempt_checks
    close_distance: float = DEFAULT_CLOSE_DISTANCE
    correction_delay: float = 0.01
    work: int | None = 100
    budget: float | None = None
    max_correction: float = 0.3
    max_open: int = 40

    def __post_init__(self):
        plain_scalars(self)
        issues = []
        if not (isinstance(self.horizon, (int, float)) and 0.0 < self.horizon < float("inf")):
            issues.append(Issue("horizon", f"expected a commit horizon > 0 s (at least the re-planning "
                                           f"latency), found {self.horizon!r}"))
        if isinstance(self.max_open, bool) or not isinstance(self.max_open, int) or self.max_open < 1:
            issues.append(Issue("max_open", f"expected a whole number of tracks >= 1, found {self.max_open!r}"))
        # (only horizon and max_open were checked: margin -0.5 or NaN planned two arms into each other,
        # a NaN gate merged nothing, an infinite correction delay was a ValueError deep in NumPy);
        # check_fields judges every field's type, finiteness and sign, these their ranges
        ranges = {"gate": (0.0, 1.0, "m"), "close_distance": (0.005, 1.0, "m"), "correction_delay": (0.0, 10.0, "s"),
                  "max_correction": (1e-3, 2 * np.pi, "rad")}
        for name, (lo, hi, unit) in ranges.items():
            v = getattr(self, name)
            if finite_number(v) and not lo <= v <= hi:
                issues.append(Issue(name, f"expected a number in [{lo:g}, {hi:g}] {unit}, found {found(v)}"))
        check_fields(self, {"max_checks", "max_correction"}, "LiveOptions", issues)


@dataclass
class Track:
    """One believed fruit: merged detections, the estimate (inverse-variance weighted) and state."""

    id: str
    position: np.ndarray
    sigma: float
    first_seen: float
    detections: list[str] = field(default_factory=list)
    state: TrackState = TrackState.PENDING
    arm: str | None = None
    refined: bool = False
    pick_end: float | None = None  # when its committed pick ends
    note: str = ""

    def to_dict(self) -> dict:
        return {"id": self.id, "position": [float(x) for x in self.position], "sigma": self.sigma,
                "first_seen": self.first_seen, "detections": list(self.detections), "state": self.state.value,
                "arm": self.arm, "refined": self.refined, "pick_end": self.pick_end, "note": self.note}


@dataclass
class Replan:
    """One re-plan: when, why, how long it took and what changed."""

    t: float
    cause: ReplanCause
    commit_until: dict[str, float]
    latency: float = 0.0
    ok: bool = True
    added: list[str] = field(default_factory=list)
    dropped: list[str] = field(default_factory=list)
    reassigned: dict[str, list] = field(default_factory=dict)
    unreachable: list[str] = field(default_factory=list)
    makespan_before: float = 0.0
    makespan_after: float = 0.0
    note: str = ""
    corrected: str | None = None  # the arm whose approach under way a close-range correction changed
    # the candidates coordinated: allocation, priority, makespan (None: no plan within its checks), checks spent
    tried: list[dict] = field(default_factory=list)

    def to_dict(self) -> dict:
        return {"t": self.t, "cause": self.cause.value, "latency": self.latency, "ok": self.ok,
                "commit_until": dict(self.commit_until), "added": self.added, "dropped": self.dropped,
                "reassigned": self.reassigned, "unreachable": self.unreachable,
                "makespan_before": self.makespan_before, "makespan_after": self.makespan_after, "note": self.note,
                "corrected": self.corrected, "tried": self.tried}


@dataclass(frozen=True)
class CloseRange:
    """A tip comes within the close-range distance of its target at ``t``."""

    t: float
    arm: str
    track: str
