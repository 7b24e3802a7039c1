"""What the pictures show, computed from a plan (NumPy only, no matplotlib).

* :func:`schedule` -- per arm, the phases moving / picking / placing / idle as time segments,
  from the plan's events and its joint motion.
* :func:`pair_clearance` -- capsule-to-capsule clearance of every neighbouring pair over time.
* :func:`joint_derivatives` -- velocity, acceleration, jerk by finite differences.
* :func:`fruit_states` -- where each fruit is at a time (on the plant, carried, in the bin).
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np

from ..kinematics import arm as kin
from ..kinematics.geometry import segment_distance
from ..plan import EventKind, Plan
from ..problem.model import Problem

__all__ = [
    "ArmPhase",
    "Segment",
    "schedule",
    "arm_schedule",
    "phase_at",
    "pair_clearance",
    "joint_derivatives",
    "limit_tolerance",
    "arm_points",
    "fruit_states",
    "harvested_count",
]

MOVE_TOL = 1e-7  # rad per sample: below this an arm counts as standing still


class ArmPhase(str, Enum):
    """What an arm is doing over a :class:`Segment` (its value is the word the plots, the
    animation and the viewer show, and the viewer's JSON carries)."""

    MOVING = "moving"
    PICKING = "picking"
    PLACING = "placing"
    IDLE = "idle"

    def __str__(self) -> str:  # (in f-strings too: "picking f3", not "ArmPhase.PICKING f3")
        return self.value


@dataclass(frozen=True)
class Segment:
    """One stretch of an arm's timeline in a single phase.

    ``fruit`` is the fruit concerned: picked, placed, or (moving) the fruit of the arm's next
    event -- its pick (approaching) or its place (carrying). ``None`` when idle or after the
    last event.
    """

    arm: str
    phase: ArmPhase
    t0: float
    t1: float
    fruit: str | None = None

    @property
    def duration(self) -> float:
        return self.t1 - self.t0


def arm_schedule(plan: Plan, arm: str, tol: float = MOVE_TOL) -> list[Segment]:
    """Phases of one arm over ``[0, plan.duration]`` as consecutive segments."""
    t = plan.time
    if t.size < 2:
        return [Segment(arm, ArmPhase.IDLE, 0.0, plan.duration)]
    q = plan.q[arm]
    moving = np.any(np.abs(np.diff(q, axis=0)) > tol, axis=1)  # per interval k: [t_k, t_k+1]
    mid = 0.5 * (t[:-1] + t[1:])
    phase = np.where(moving, 1, 3)  # codes: 1 moving, 2 picking, 3 idle, 4 placing
    fruit_of = np.full(mid.size, -1)
    evs = sorted(plan.events_of(arm), key=lambda e: e.t_start)
    fruit_ids: list[str] = []
    for e in evs:
        m = (mid >= e.t_start) & (mid <= e.t_end)
        phase[m] = 2 if e.kind == EventKind.PICK else 4
        fruit_ids.append(e.fruit)
        fruit_of[m] = len(fruit_ids) - 1
    # a move is labelled with the next event's fruit (approaching it or carrying it)
    starts = np.array([e.t_start for e in evs]) if evs else np.zeros(0)
    mv = np.flatnonzero(phase == 1)
    if mv.size and starts.size:
        nxt = np.searchsorted(starts, mid[mv] - 1e-9)
        ok = nxt < starts.size
        fruit_of[mv[ok]] = nxt[ok]
    names = {1: ArmPhase.MOVING, 2: ArmPhase.PICKING, 3: ArmPhase.IDLE, 4: ArmPhase.PLACING}
    segs: list[Segment] = []
    k0 = 0
    for k in range(1, mid.size + 1):
        if k == mid.size or phase[k] != phase[k0] or fruit_of[k] != fruit_of[k0]:
            f = int(fruit_of[k0])
            segs.append(Segment(arm, names[int(phase[k0])], float(t[k0]), float(t[k]), fruit_ids[f] if f >= 0 else None))
            k0 = k
    return segs


def schedule(plan: Plan, tol: float = MOVE_TOL) -> dict[str, list[Segment]]:
    """Arm name -> its phase segments (see :func:`arm_schedule`)."""
    return {a: arm_schedule(plan, a, tol) for a in plan.q}


def phase_at(segments: list[Segment], t: float) -> Segment:
    """The segment covering time ``t`` (the last one after the end)."""
    starts = [s.t0 for s in segments]
    i = int(np.searchsorted(starts, t, side="right")) - 1
    return segments[max(0, min(i, len(segments) - 1))]


def arm_points(problem: Problem, plan: Plan, times=None) -> dict[str, np.ndarray]:
    """Arm name -> (K, 3, 2) base/elbow/tip positions at ``times`` (default: every sample)."""
    q = plan.q if times is None else plan.sample(times)
    out = {}
    for a in problem.arms:
        if a.name in q:
            out[a.name] = kin.fk_points(q[a.name], a.links, a.base)
    return out


def pair_clearance(
    problem: Problem, plan: Plan, times=None, pairs=None, dense: bool = True
) -> tuple[np.ndarray, dict[tuple[str, str], np.ndarray]]:
    """Clearance of neighbouring arm pairs over time.

    Clearance is the least distance between the two arms' link capsules (segment distance
    minus both link radii); negative means the capsules overlap (a collision).

    Returns ``(times, {(arm_a, arm_b): (K,) clearance in m})`` for ``problem.neighbour_pairs()``
    (or the given index pairs). With ``times=None`` and ``dense=True`` this is the
    verifier's own profile (:func:`coplan.verify.clearance.clearance_profile`, 10 points per plan
    interval), so the plots show the numbers the verification reports; otherwise the
    clearance at the plan's samples (or at ``times``).
    """
    pairs = problem.neighbour_pairs() if pairs is None else list(pairs)
    if times is None and dense:
        try:
            from ..verify.clearance import clearance_profile
        except ImportError:  # the verifier's module is optional here
            clearance_profile = None
        if clearance_profile is not None:
            t, prof = clearance_profile(problem, plan, pairs=pairs)
            return t, {(problem.arms[i].name, problem.arms[j].name): np.asarray(d, float) for (i, j), d in prof.items()}
    times = plan.time if times is None else np.asarray(times, float)
    pts = arm_points(problem, plan, None if times is plan.time else times)
    out: dict[tuple[str, str], np.ndarray] = {}
    for i, j in pairs:
        a, b = problem.arms[i], problem.arms[j]
        if a.name not in pts or b.name not in pts:
            continue
        pa, pb = pts[a.name], pts[b.name]
        d = np.full(times.size, np.inf)
        for s in range(2):
            for u in range(2):
                d = np.minimum(d, segment_distance(pa[:, s], pa[:, s + 1], pb[:, u], pb[:, u + 1]))
        out[(a.name, b.name)] = d - a.link_radius - b.link_radius
    return times, out


def joint_derivatives(plan: Plan, arm: str) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Position, velocity, acceleration, jerk of one arm by finite differences, as verified.

    Like the verifier: the arm is at rest before and after the plan (3 samples of padding)
    and the k-th derivative is the k-th difference over ``dt^k``, placed at the middle of
    the samples it spans. Returns ``{"position"|"velocity"|"acceleration"|"jerk":
    (times (K,), values (K, 2))}``.
    """
    q = plan.q[arm]
    dt = plan.dt
    out = {"position": (plan.time, q)}
    pad = np.concatenate([np.repeat(q[:1], 3, axis=0), q, np.repeat(q[-1:], 3, axis=0)])
    tp = (np.arange(len(pad)) - 3) * dt
    for k, name in enumerate(("velocity", "acceleration", "jerk"), start=1):
        out[name] = (0.5 * (tp[:-k] + tp[k:]), np.diff(pad, n=k, axis=0) / dt**k)
    return out


def limit_tolerance(limit, order: int, dt: float):
    """The verifier's allowance over a velocity (1), acceleration (2) or jerk (3) limit:
    relative tolerance plus the effect of plan.json's rounding of the joint angles."""
    try:
        from ..verify.verdict import VerifyOptions

        rel, qres = VerifyOptions.rel_tolerance, VerifyOptions.q_resolution
    except (ImportError, AttributeError):
        rel, qres = 1e-6, 1e-7
    return rel * np.asarray(limit, float) + 2.0 ** (order - 1) * qres / dt**order


def fruit_states(problem: Problem, plan: Plan, t: float) -> dict[str, tuple[str, str | None]]:
    """Fruit id -> (state, arm) at time ``t``.

    States: ``ripe`` (still on the plant), ``picking`` (the tip is on it), ``carried``
    (picked, on its way to the bin), ``binned`` (placed). ``arm`` is who harvests it.
    """
    out: dict[str, tuple[str, str | None]] = {f.id: ("ripe", None) for f in problem.fruits}
    picks = {e.fruit: e for e in plan.events if e.kind == EventKind.PICK}
    places = {e.fruit: e for e in plan.events if e.kind == EventKind.PLACE}
    for fid, e in picks.items():
        if fid not in out:
            continue
        pl = places.get(fid)
        if t < e.t_start:
            continue
        if t <= e.t_end:
            out[fid] = ("picking", e.arm)
        elif pl is not None and t >= pl.t_end:
            out[fid] = ("binned", pl.arm)
        else:
            out[fid] = ("carried", e.arm)
    return out


def harvested_count(plan: Plan, arm: str, t: float) -> int:
    """Fruit the arm has placed in its bin by time ``t``."""
    return sum(1 for e in plan.events_of(arm, EventKind.PLACE) if e.t_end <= t)
