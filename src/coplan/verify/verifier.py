"""Independent verification of a plan (``coplan verify PROBLEM PLAN``).

Entry point: :func:`verify` returns a :class:`Verification`. It shares no code with the
planners' constraints: the clearance comes from :mod:`coplan.verify.clearance` (exact NumPy capsule
distances on the replayed plan, with a certificate for the gaps between samples), cross-checked
with FCL by :mod:`coplan.verify.fclcheck`; limits, picks and places are checked here. (Only the
witness points it reports -- where on two links the closest approach lies -- come from
:func:`coplan.kinematics.geometry.segment_distance`; every distance in the verdict is the
verifier's own.)

What "passes" means (every check below, with the default :class:`VerifyOptions`):

* **clearance** -- arms that can touch (``problem.neighbour_pairs()``) are sampled at 1 kHz
  on the linear replay (only where the 100 Hz certificate does not already rule out a
  lower sample: same figures, less work); a sample below 0 is a collision, below
  ``task.clearance`` a clearance breach (both reported as intervals: start, end, worst
  distance, links). Gaps between samples are certified with the Lipschitz bound of
  :mod:`coplan.verify.clearance` (refined where needed); an interval that stays uncertified is a
  violation. Both the raw sampled and the certified least clearance are reported.
* **cross-check** -- at each pair's closest instant, the worst instant of every
  interval and ``fcl_samples`` seeded random instants per pair (or every evaluated sample
  with ``fcl="full"``), FCL must agree within 1e-6 m on every link pair's distance (penetration
  depths included) and on the overlap verdict.
* **limits** -- joint limits at every sample (convex between samples). Velocity: forward
  differences of the 100 Hz samples (the replay velocity itself). Acceleration and jerk:
  second and third differences. The k-th difference divided by ``dt^k`` is a weighted mean
  (B-spline weights >= 0, summing to 1) of the k-th derivative of *any* C^(k-1) trajectory
  through the samples over the k intervals it spans, so a within-limits S-curve (jerk
  steps, continuous acceleration) never fails, and a failure proves every such trajectory
  breaks the limit in that window. Arms are at rest before and after the plan. Tolerance:
  ``rel_tolerance * limit + 2^(k-1) q_resolution / dt^k`` (the rounding of ``plan.json``
  to 1e-7 rad: 1e-5 rad/s, 2e-3 rad/s^2, 0.4 rad/s^3 at 100 Hz). On a finer grid that
  allowance grows as ``dt^-k`` (400 rad/s^3 at 1 kHz): it is taken only where the angles
  really sit on the 1e-7 lattice (else their floating point's), and where it exceeds 5 % of a
  limit, a difference over that limit by no more than the allowance is reported as not
  checkable (a failure), never passed on it (:func:`coplan.verify.verdict.blurred_by_rounding`).
* **picks and places** -- during each event the tip is within ``position_tolerance``
  (5 mm) of its fruit (of the arm's bin for a place) and *still* (every point of the arm
  slower than ``still_speed``, 5 mm/s; in a row, a pick's tip slower than that in the row
  frame: see :mod:`coplan.verify.row`) for at least the dwell, less ``dwell_tolerance``
  (default one sample period: the grid cannot place a hold's ends more finely). Every
  fruit is picked at most once, only by an arm that can reach it, picks and places
  alternate.
* **inferred events** -- a plan that declares no events (``events: []``, or a ``plan.csv``)
  has them inferred from its motion (:mod:`coplan.verify.infer`: tip on target and still for the
  dwell over a fruit, then over the arm's bin), says so (warning ``events_inferred``,
  ``Verification.inferred_events``) and is then checked as if it had declared them.
* **completeness** is reported (``complete``, ``unharvested``) but is not a failure: a
  verified plan that leaves fruit is *partial*, not unsafe. A fruit counts as harvested when it
  is picked and placed with the tip reaching it and the bin (a pick or place that misses is a
  violation, and its fruit is not harvested).
* **warnings** -- poses with manipulability below ``task.singularity_threshold``.
"""

from __future__ import annotations

import math
import os
import time as _time
from collections.abc import Mapping
from dataclasses import fields, replace
from typing import Any

import numpy as np

from ..kinematics import arm as kin
from .clearance import ArmMotion, arm_motions, certify_pair, clearance_profile, runs
from ..errors import Issue, PlanFileError
from .fclcheck import cross_check
from ..kinematics.geometry import segment_distance
from .hold import bin_track, holds_on
from .home import check_home
from .infer import infer_events
from .row import check_carriage, check_row_inputs, plan_source
from ..kinds import LIVE_PLANNER, PlannerKind
from ..plan import EventKind, Plan, grid_step, load_plan, time_grid_issues
from . import verdict as _verdict
from ..problem.model import Problem
from ..problem.given import as_problem
from ..problem.plausible import MAX_PLAN_ANGLE, MAX_PLAN_COORD
from .verdict import (
    ContactInterval,
    FclMode,
    Finding,
    IntervalKind,
    PairClearance,
    Verification,
    VerifyOptions,
    Violation,
    ViolationKind,
    WarningKind,
    blurred_by_rounding,
    rounding_allowance,
    rounding_words,
)

__all__ = [*_verdict.__all__, "verify", "clearance_profile"]  # the result types are re-exported from here


# --------------------------------------------------------------------------- input checks
def _check_inputs(problem: Problem, plan: Plan) -> None:
    issues: list[Issue] = []
    names = [a.name for a in problem.arms]
    missing = [n for n in names if n not in plan.q]
    extra = [n for n in plan.q if n not in names]
    if missing or extra:
        which = "; ".join(f"{w} {v}" for w, v in (("missing", missing), ("unknown", extra)) if v)  # (it said "missing []")
        issues.append(Issue("arms", f"expected the problem's arms {names}, found {list(plan.q)} ({which})"))
    t = np.asarray(plan.time, float)
    if t.ndim != 1 or t.size < 1 or not np.all(np.isfinite(t)):
        issues.append(Issue("time", "expected a non-empty list of finite times"))
    else:  # (as a plan file's: a plan made in Python at 10 Hz passed, its limits read on differences 10 x as coarse)
        issues += [Issue("time" if i is None else f"time[{i}]", msg) for i, msg in time_grid_issues(t)]
    for n in names:
        q = plan.q.get(n)
        if q is not None and (np.shape(q) != (t.size, 2) or not np.all(np.isfinite(q))):
            found = f"shape {np.shape(q)}"
            if np.shape(q) == (t.size, 2):  # the right shape: where the first non-finite angle is
                rows = np.flatnonzero(~np.isfinite(q).all(axis=1))
                found = f"a non-finite angle at row {rows[0]} (t = {t[rows[0]]:.3f} s)" + (
                    f" and {rows.size - 1} more rows" if rows.size > 1 else "")
            issues.append(Issue(f"arms.{n}.q", f"expected {t.size} finite rows of 2 angles, found {found}"))
        elif q is not None:
            qa = np.asarray(q, float)
            far = np.flatnonzero((np.abs(qa) > MAX_PLAN_ANGLE).any(axis=1))
            if far.size:
                r = int(far[0])
                issues.append(Issue(f"arms.{n}.q[{r}]", f"expected joint angles within +-{MAX_PLAN_ANGLE:g} rad "
                                    f"(coplan.plausible.MAX_PLAN_ANGLE), found [{', '.join(f'{v:g}' for v in qa[r])}] "
                                    f"(t = {t[r]:.3f} s)" + (f" and {far.size - 1} more rows" if far.size > 1 else "")))
    gx = getattr(plan, "gantry_x", None)
    if gx is not None and np.shape(gx) == t.shape and np.all(np.isfinite(gx)):
        far = np.flatnonzero(np.abs(np.asarray(gx, float)) > MAX_PLAN_COORD)
        if far.size:
            r = int(far[0])
            issues.append(Issue(f"gantry.x[{r}]", f"expected carriage positions within +-{MAX_PLAN_COORD:g} m "
                                f"(coplan.plausible.MAX_PLAN_COORD), found {float(gx[r]):g} (t = {t[r]:.3f} s)"
                                + (f" and {far.size - 1} more samples" if far.size > 1 else "")))
    if issues:
        raise PlanFileError(issues, plan_source(plan))


# --------------------------------------------------------------------------- clearance
def _where(motions: list[ArmMotion], i: int, j: int, seg: int, frac: float, link: int):
    la, lb = divmod(int(link), 2)
    pa = motions[i].points(np.array([seg]), np.array([frac]))[0]
    pb = motions[j].points(np.array([seg]), np.array([frac]))[0]
    _, ca, cb = segment_distance(pa[la], pa[la + 1], pb[lb], pb[lb + 1], return_points=True)
    return (la, lb), (tuple(map(float, ca)), tuple(map(float, cb)))


def _check_clearance(problem: Problem, plan: Plan, motions: list[ArmMotion], opts: VerifyOptions, ver: Verification):
    """Clearance, intervals and certificate for every neighbouring pair; returns FCL instants."""
    clear = problem.task.clearance
    rng = np.random.default_rng(opts.seed)
    fcl_samples: list[tuple[int, int, int, float, float]] = []
    for i, j in problem.neighbour_pairs():
        ps = certify_pair(motions, i, j, plan, clear, opts.substeps, opts.refine_levels, opts.refine_factor,
                          margin_rel=opts.margin_rel)
        arms = (motions[i].name, motions[j].name)
        k = int(np.argmin(ps.d))
        links, pts = _where(motions, i, j, ps.seg[k], ps.frac[k], ps.link[k])
        kb = int(np.argmin(ps.bound)) if ps.bound.size else k
        ver.pairs.append(
            PairClearance(arms, float(ps.d[k]), float(ps.t[k]), links, pts, ps.certified, float(ps.t[kb]), ps.t.size, ps.refined)
        )
        critical = [k]
        found = 0
        for kind, mask in ((IntervalKind.COLLISION, ps.d < 0), (IntervalKind.CLEARANCE, ps.d < clear)):
            for a, b in runs(mask):
                if kind == IntervalKind.CLEARANCE and np.any(ps.d[a : b + 1] < 0):
                    continue
                w = a + int(np.argmin(ps.d[a : b + 1]))
                found += 1
                if found <= opts.fcl_max_intervals:
                    critical.append(w)
                links_w, pts_w = _where(motions, i, j, ps.seg[w], ps.frac[w], ps.link[w])
                ci = ContactInterval(kind, arms, float(ps.t[a]), float(ps.t[b]), float(ps.t[w]), float(ps.d[w]), links_w, pts_w)
                ver.intervals.append(ci)
                vk = ViolationKind.COLLISION if kind == IntervalKind.COLLISION else ViolationKind.CLEARANCE
                ver.violations.append(
                    Violation(
                        vk, arms, ci.t_worst, clear - ci.least_distance if vk == ViolationKind.CLEARANCE else ci.penetration,
                        ci.least_distance, 0.0 if vk == ViolationKind.COLLISION else clear, ci.t_start, ci.t_end,
                        message=f"links {links_w[0]}/{links_w[1]} {'overlap by' if ci.least_distance < 0 else 'at'} "
                        f"{abs(ci.least_distance) * 1000:.1f} mm",
                    )
                )
        bad = ps.uncertified(clear)
        if bad.size:
            for a, b in runs(np.isin(np.arange(ps.bound.size), bad)):
                w = a + int(np.argmin(ps.bound[a : b + 1]))
                critical.append(w)
                ver.violations.append(
                    Violation(
                        ViolationKind.UNCERTIFIED, arms, float(ps.t[w]), clear - float(ps.bound[w]), float(ps.bound[w]), clear,
                        float(ps.t[a]), float(ps.t[b + 1]),
                        message="samples clear the clearance but the gap between them cannot be certified",
                    )
                )
        if opts.fcl == FclMode.FULL:
            chosen = np.arange(ps.t.size)
        else:
            extra = rng.choice(ps.t.size, size=min(opts.fcl_samples, ps.t.size), replace=False)
            chosen = np.unique(np.concatenate([np.asarray(critical, int), extra]))
        fcl_samples += [(i, j, int(ps.seg[c]), float(ps.frac[c]), float(ps.t[c])) for c in chosen]
    ver.intervals.sort(key=lambda c: (c.t_start, c.arms))
    return fcl_samples


# --------------------------------------------------------------------------- limits
def _check_limits(problem: Problem, motions: list[ArmMotion], time: np.ndarray, opts: VerifyOptions, ver: Verification):
    """Joint limits, finite-difference velocity/acceleration/jerk (module docstring), singular poses."""
    dt = grid_step(time)
    for arm, m in zip(problem.arms, motions):
        q = m.q
        lim = arm.limits
        t = time
        for jn in (0, 1):
            lo, hi = lim[jn]
            excess = np.maximum(lo - q[:, jn], q[:, jn] - hi)
            for a, b in runs(excess > opts.joint_tolerance):
                w = a + int(np.argmax(excess[a : b + 1]))
                bound = lo if q[w, jn] < lo else hi
                ver.violations.append(
                    Violation(ViolationKind.JOINT_LIMIT, (arm.name,), float(t[w]), float(excess[w]), float(q[w, jn]), float(bound),
                              float(t[a]), float(t[b]), joint=jn, message=f"joint {jn + 1} outside [{lo}, {hi}] rad")
                )
        pad = np.concatenate([np.repeat(q[:1], 3, axis=0), q, np.repeat(q[-1:], 3, axis=0)])
        tp = (np.arange(len(pad)) - 3) * dt
        peaks: dict[str, float] = {}
        for k, (kind, limits) in enumerate(
            ((ViolationKind.VELOCITY, arm.max_velocity), (ViolationKind.ACCELERATION, arm.max_acceleration),
             (ViolationKind.JERK, arm.max_jerk)), start=1,
        ):
            signed = np.diff(pad, n=k, axis=0) / dt**k
            diff = np.abs(signed)
            # the stencil's centre; a window reaching into the rest before/after the plan is
            # reported at the plan's start/end, never at a negative time
            centre = 0.5 * (tp[:-k] + tp[k:])
            tc = np.clip(centre, 0.0, t[-1])
            lim_k = np.asarray(limits, float)
            peaks[kind.value] = float(np.max(diff / lim_k)) if diff.size else 0.0
            for jn in (0, 1):
                allow = rounding_allowance(q[:, jn], opts.q_resolution, dt, k)
                tol = opts.rel_tolerance * lim_k[jn] + allow
                blurred = blurred_by_rounding(diff[:, jn], lim_k[jn], opts.rel_tolerance, allow, dt)
                if blurred is not None:  # (finer than 100 Hz, on the 1e-7 lattice: over the limit by no more than rounding)
                    w = int(np.argmax(np.where(blurred, diff[:, jn], -np.inf)))
                    ver.violations.append(Violation(
                        kind, (arm.name,), float(tc[w]), float(diff[w, jn] - lim_k[jn]), float(diff[w, jn]), float(lim_k[jn]),
                        float(tc[np.argmax(blurred)]), float(tc[len(blurred) - 1 - np.argmax(blurred[::-1])]), joint=jn,
                        message=(f"joint {jn + 1}: {kind.value} not checkable: {diff[w, jn] / lim_k[jn]:.2f} x the limit, but "
                                 + rounding_words("angles", "rad", opts.q_resolution, dt, allow, lim_k[jn], kind.value))))
                for a, b in runs(diff[:, jn] > lim_k[jn] + tol):
                    w = a + int(np.argmax(diff[a : b + 1, jn]))
                    seg = signed[a : b + 1, jn]
                    if kind == ViolationKind.JERK and b - a < _STEP_SAMPLES and (np.all(seg >= 0) or np.all(seg <= 0)):
                        step = _acceleration_step(arm.name, jn, seg, centre[a : b + 1], dt, lim_k[jn], t[-1])
                        if step.value > _STEP_FACTOR * step.limit:  # (the jump against what the limit allows over it)
                            ver.violations.append(step)
                            continue
                    ver.violations.append(
                        Violation(kind, (arm.name,), float(tc[w]), float(diff[w, jn] - lim_k[jn]), float(diff[w, jn]), float(lim_k[jn]),
                                  float(tc[a]), float(tc[b]), joint=jn,
                                  message=f"joint {jn + 1} at {diff[w, jn] / lim_k[jn]:.2f} x the {kind.value} limit")
                    )
        ver.peaks[arm.name] = peaks
        manip = kin.manipulability(q, arm.links)
        for a, b in runs(manip < problem.task.singularity_threshold):
            w = a + int(np.argmin(manip[a : b + 1]))
            ver.warnings.append(
                Finding(WarningKind.SINGULAR, (arm.name,), float(t[w]), float(manip[w]), problem.task.singularity_threshold,
                        float(t[a]), float(t[b]), message="near-singular pose (manipulability below the threshold)")
            )


# A jerk violation no longer than a third difference's stencil (3 intervals), all of one sign,
# is one jump of the acceleration between samples: its third differences / dt^3 are jump / dt (a
# grid artefact), so it is reported as the jump itself. Lobes of both signs are a jump of the
# velocity or the position (the third differences of a step in q are +1, -2, +1 times it): their
# sum says nothing of their size, so they are reported as jerk, x the limit (and the velocity and
# acceleration checks report the same instant).
_STEP_SAMPLES = 3
# ... when the change of acceleration over the run is more than this many times what the jerk
# limit allows over it. A short, smooth overshoot (the jerk at 1.05 x its limit for two samples)
# changes the acceleration by about as much as the limit allows: it was reported as an
# "acceleration discontinuity (unbounded jerk)" of a fraction of a rad/s^2; on the grid it is
# jerk, x the limit (as is a step too small to tell from one)
_STEP_FACTOR = 1.5


def _acceleration_step(arm: str, jn: int, jerk: np.ndarray, tc: np.ndarray, dt: float, jmax: float, t_end: float) -> Violation:
    """A run of third differences (``jerk``, rad/s^3, at stencil centres ``tc``) that is one
    acceleration discontinuity: its size (rad/s^2) at its time (the run's centre weighted by
    |jerk|, inside [0, t_end]), against the most a jerk-limited motion could change it.

    The run's jerk x dt sums to the change between two second differences / dt^2, weighted
    means of the acceleration whose centres lie ``span`` = run length x dt apart; any motion
    within the jerk limit changes that by at most jmax x span."""
    jump = float(np.sum(jerk) * dt)
    w = np.abs(jerk)
    t = float(np.clip(np.sum(tc * w) / np.sum(w), 0.0, t_end))
    span = jerk.size * dt
    allowed = jmax * span
    t0, t1 = (float(x) for x in np.clip(tc[[0, -1]], 0.0, t_end))
    return Violation(ViolationKind.JERK, (arm,), t, abs(jump) - allowed, abs(jump), allowed, t0, t1, joint=jn, step=True,
                     message=f"joint {jn + 1}: acceleration discontinuity of {jump:+.3f} rad/s^2 (unbounded jerk; within "
                             f"{span:.3f} s the jerk limit {jmax:g} rad/s^3 allows {allowed:.3f} rad/s^2)")


# --------------------------------------------------------------------------- events
def _hold(m: ArmMotion, tip: np.ndarray, time: np.ndarray, target, ts: float, te: float, opts: VerifyOptions,
          row_frame: bool = False):
    """Least tip distance during [ts, te] and the longest still-on-target time inside it.

    ``target``: a point, or one per sample (N, 2) (a bin riding on a carriage); ``row_frame``:
    a pick in a row: the tip (in the row frame, carriage included) must then be
    still in the row frame, its speed bounded on the linear replay (the carriage may move while the
    joints carry the tip along: a pick on the move)."""
    target = np.asarray(target, float)
    if time.size < 2:
        return float(np.hypot(*(tip[0] - (target if target.ndim == 1 else target[0])))), 0.0
    lo = max(0, int(np.searchsorted(time, ts, side="right")) - 1)
    hi = min(time.size - 1, int(np.searchsorted(time, te, side="left")))
    if hi <= lo:
        hi = min(lo + 1, time.size - 1)
    # the distances of the event's own samples lo .. hi only (d[k - lo] is sample k's), not the plan's
    d = np.hypot(*(tip[lo:hi + 1] - (target if target.ndim == 1 else target[lo:hi + 1])).T)
    n = np.arange(lo, hi)
    overlap = np.clip(np.minimum(time[n + 1], te) - np.maximum(time[n], ts), 0.0, None)
    good = holds_on(m, tip, time, target, n, opts, row_frame)
    best = max((float(overlap[a : b + 1].sum()) for a, b in runs(good & (overlap > 0))), default=0.0)
    return float(d.min()), best


def _check_events(problem: Problem, plan: Plan, motions: list[ArmMotion], opts: VerifyOptions, ver: Verification):
    """Picks and places on target and still for their dwell, bookkeeping, completeness."""
    row = problem.gantry is not None  # picks in the row frame (the carriage moving), places over the bin it carries
    reach = None if row else problem.reach_matrix()
    arm_index = {a.name: k for k, a in enumerate(problem.arms)}
    fruit_index = {f.id: k for k, f in enumerate(problem.fruits)}
    tips = {m.name: m.tips() for m in motions}
    # where each arm's bin is at every sample (it rides with the carriage): once per arm, not per place
    bins = {a.name: bin_track(a.bin, plan.gantry_x if row else None) for a in problem.arms}
    dwell_tol = plan.dt if opts.dwell_tolerance is None else opts.dwell_tolerance
    eps = 1e-9
    picks: dict[str, list[tuple[float, float, str]]] = {}  # fruit -> (t_start, t_end, arm) of each pick
    reached: dict[EventKind, set[str]] = {EventKind.PICK: set(), EventKind.PLACE: set()}  # events the tip reached
    for e in plan.events:
        if e.arm not in arm_index:
            ver.violations.append(Violation(ViolationKind.EVENT, (e.arm,), e.t_start, 0.0, fruit=e.fruit, message="unknown arm"))
            continue
        if e.fruit not in fruit_index:
            ver.violations.append(Violation(ViolationKind.UNKNOWN_FRUIT, (e.arm,), e.t_start, 0.0, fruit=e.fruit,
                                            message=f"{e.kind.value} of a fruit the problem does not have"))
            continue
        if e.t_start < -eps or e.t_end > plan.duration + eps or e.t_end < e.t_start:
            ver.violations.append(Violation(ViolationKind.EVENT, (e.arm,), e.t_start, 0.0, t_start=e.t_start, t_end=e.t_end,
                                            fruit=e.fruit, message=f"event outside the plan [0, {plan.duration}] s"))
            continue
        arm = problem.arms[arm_index[e.arm]]
        if e.kind == EventKind.PICK:
            picks.setdefault(e.fruit, []).append((e.t_start, e.t_end, e.arm))
            if reach is not None and not reach[arm_index[e.arm], fruit_index[e.fruit]]:
                ver.violations.append(Violation(ViolationKind.UNREACHABLE_PICK, (e.arm,), e.t_start, 0.0, fruit=e.fruit,
                                                message="arm picks a fruit it cannot reach"))
            target, dwell = problem.fruits[fruit_index[e.fruit]].position, problem.task.pick_dwell
            missed, short = ViolationKind.PICK_MISSED, ViolationKind.PICK_DWELL
            frame = row  # a fruit stays where it is: the tip must be still in the row frame
        else:
            target, dwell = bins[arm.name], problem.task.place_dwell
            missed, short = ViolationKind.PLACE_MISSED, ViolationKind.PLACE_DWELL
            frame = False  # the bin rides with the carriage: still relative to it
        m = motions[arm_index[e.arm]]
        least, held = _hold(m, tips[e.arm], plan.time, target, e.t_start, e.t_end, opts, frame)
        if e.kind == EventKind.PICK and (ver.worst_pick is None or least > ver.worst_pick["distance"]):
            ver.worst_pick = {"fruit": e.fruit, "arm": e.arm, "distance": float(least), "t": float(e.t_start)}
        if least > opts.position_tolerance:
            ver.violations.append(Violation(missed, (e.arm,), e.t_start, least - opts.position_tolerance, least,
                                            opts.position_tolerance, e.t_start, e.t_end, fruit=e.fruit,
                                            message=f"tip never within {opts.position_tolerance * 1000:g} mm of "
                                                    + ("the fruit" if e.kind == EventKind.PICK else f"{e.arm}'s bin (placing it)")
                                                    + f" (closest {least * 1000:.1f} mm)"))
            continue
        reached[e.kind].add(e.fruit)
        if held < dwell - dwell_tol - eps:
            ver.violations.append(Violation(short, (e.arm,), e.t_start, dwell - held, held, dwell, e.t_start, e.t_end, fruit=e.fruit,
                                            message=f"still on target for {held:.3f} s, dwell is {dwell} s"))
    for fid, when in picks.items():
        if len(when) > 1:  # reported at the second pick, with every pick's time and arm
            when = sorted(when)
            ver.violations.append(Violation(ViolationKind.DUPLICATE_PICK, tuple(sorted({a for _, _, a in when})), float(when[1][0]),
                                            float(len(when) - 1), float(len(when)), 1.0, float(when[0][0]), float(when[-1][1]),
                                            fruit=fid, message=f"picked {len(when)} times: " + ", ".join(
                                                f"by {a} at {t0:.3f}-{t1:.3f} s" for t0, t1, a in when)))
    _check_sequence(plan, ver)
    reachable = problem.reachable_ids()  # (a row's: from every carriage position on its rail)
    # (harvested: a pick and a place of it that the tip reached -- a plan checked against a fruit moved
    # 2 cm said complete, 4 of 4 harvested, beside its pick_missed)
    ver.unharvested = [f for f in reachable if f not in reached[EventKind.PICK] or f not in reached[EventKind.PLACE]]
    for f in ver.unharvested:
        ver.warnings.append(Finding(WarningKind.NOT_HARVESTED, (), None, message=f"reachable fruit {f} is not harvested"))


def _check_sequence(plan: Plan, ver: Verification) -> None:
    """Per arm: events do not overlap, picks and places alternate, every pick is placed."""
    for arm in plan.q:
        holding: str | None = None
        last_end = -math.inf
        for e in sorted(plan.events_of(arm), key=lambda e: (e.t_start, e.kind != EventKind.PICK)):
            if e.t_start < last_end - 1e-9:
                ver.violations.append(Violation(ViolationKind.SEQUENCE, (arm,), e.t_start, last_end - e.t_start, fruit=e.fruit,
                                                message="event starts before the previous one ends"))
            last_end = max(last_end, e.t_end)
            if e.kind == EventKind.PICK:
                if holding is not None:
                    ver.violations.append(Violation(ViolationKind.SEQUENCE, (arm,), e.t_start, 0.0, fruit=e.fruit,
                                                    message=f"picks {e.fruit} while still holding {holding}"))
                holding = e.fruit
            else:
                if holding != e.fruit:
                    ver.violations.append(Violation(ViolationKind.SEQUENCE, (arm,), e.t_start, 0.0, fruit=e.fruit,
                                                    message=f"places {e.fruit} without holding it"))
                holding = None
        if holding is not None:
            ver.violations.append(Violation(ViolationKind.SEQUENCE, (arm,), plan.duration, 0.0, fruit=holding,
                                            message=f"{holding} is picked but never placed"))


# --------------------------------------------------------------------------- entry point
def _arguments(problem, plan, options, overrides: dict) -> tuple[Problem, Plan, VerifyOptions]:
    """:func:`verify`'s arguments as objects: a path is read (as ``coplan.solve`` and
    ``coplan.view`` take paths); anything else of the wrong kind is a ``TypeError`` saying
    what was expected, not an ``AttributeError`` from deep inside."""
    if isinstance(problem, Plan) and isinstance(plan, (Problem, Mapping)):
        raise TypeError("verify(problem, plan): the problem comes first, then the plan; found a Plan, then a "
                        f"{type(plan).__name__} (swapped?)")
    problem = as_problem(problem, lambda p: f"verify(): problem: expected a Problem, the path of a problem file or a "
                                            f"mapping, found {type(p).__name__}")
    if isinstance(plan, (str, os.PathLike)):
        plan = load_plan(plan)
    elif not isinstance(plan, Plan) and isinstance(getattr(plan, "plan", None), Plan):  # a SolveResult: its plan
        plan = plan.plan
    elif not isinstance(plan, Plan):
        raise TypeError(f"verify(): plan: expected a Plan, a SolveResult or the path of a plan file (plan.json, plan.csv), "
                        f"found {type(plan).__name__}")
    if isinstance(options, Mapping):
        overrides, options = {**options, **overrides}, None
    elif options is not None and not isinstance(options, VerifyOptions):
        raise TypeError(f"verify(): options: expected VerifyOptions, a mapping of its fields or None, found {type(options).__name__}")
    names = [f.name for f in fields(VerifyOptions)]
    unknown = [k for k in overrides if k not in names]
    if unknown:
        raise TypeError(f"verify(): expected options among {', '.join(names)}; found {', '.join(map(repr, unknown))}")
    opts = replace(options or VerifyOptions(), **overrides)
    return problem, plan, replace(opts, fcl=FclMode(opts.fcl))


def _check_stated(problem: Problem, plan: Plan, ver: Verification) -> None:
    """The plan's figures as its motion bears them out (``ver.measured``: the makespan, the last
    place of a fruit it harvests within its samples -- a truncated plan's events after its end
    are not; the fruit harvested), and the plan file's own figures (its ``metrics``) against them:
    a warning per figure that differs (an edited plan.json stated 90 s and 200 fruit beside a
    186 s motion)."""
    left = set(ver.unharvested)
    end = plan.duration + 1e-9
    places = [e.t_end for e in plan.events or [] if e.kind == EventKind.PLACE and e.fruit not in left and e.t_end <= end]
    harvested = len(set(problem.reachable_ids())) - len(ver.unharvested)
    ver.measured = {"makespan": max(places) if places else 0.0, "harvested": harvested}
    # (an inferred place ends its dwell and two samples after its hold's first sample, which may come
    # a sample after the true start: up to three samples late -- a plan.json stripped of its events
    # was called 'makespan 6.22316 stated, 6.23 measured')
    ver.stated_figures = _verdict.stated_figures(plan.metrics, ver.measured["makespan"], harvested,
                                                 3.0 * plan.dt if ver.inferred_events is not None else 0.0)
    if ver.stated_figures:
        ver.warnings.append(Finding(WarningKind.STATED_FIGURES, (), None, message=(
            "the plan file's own figures are not what the verifier finds (its events, each borne out by its motion, "
            "and the motion's end; the verdict is the verifier's): " + "; ".join(
                f"{k} {v['stated']:g} stated, {v['measured']:g} measured" for k, v in ver.stated_figures.items()))))


def verify(problem: Problem | str | os.PathLike, plan: Plan | str | os.PathLike, options: VerifyOptions | None = None,
           **overrides: Any) -> Verification:
    """Verify ``plan`` against ``problem``; keyword overrides replace :class:`VerifyOptions` fields.

    ``problem`` and ``plan`` may be paths (read with :func:`coplan.problem.load_problem` and
    :func:`coplan.plan.load_plan`); ``options`` may be a mapping of :class:`VerifyOptions` fields.

    Raises :class:`PlanFileError` when the plan does not fit the problem (other arms, a
    non-uniform grid, wrong shapes). Every other finding is in the returned object.
    """
    problem, plan, opts = _arguments(problem, plan, options, overrides)
    _check_inputs(problem, plan)
    check_row_inputs(problem, plan)
    # (the problem it is checked against; a plan naming another is a warning below)
    ver = Verification(problem.name, plan.planner_name, plan.duration, problem.task.clearance, opts)
    record = plan.problem_file
    ver.problem_file = {"sha256": problem.digest, "planned_from": None if record is None else dict(record),
                        "same_text": None if record is None or problem.digest is None else record["sha256"] == problem.digest}
    if plan.problem and plan.problem != problem.name:  # (a plan.csv names no problem)
        ver.warnings.append(Finding(WarningKind.PROBLEM_NAME, (), None, message=f"plan is for {plan.problem!r}, problem is {problem.name!r}"))
    t0 = _time.perf_counter()
    motions = arm_motions(problem, plan)
    # (a live run's executed plan says what it did too: one that picked nothing was inferred a pick where a
    # probe hovered over a fruit, and failed "picked but never placed")
    planned_nothing = plan.planner in {k.value for k in PlannerKind} | {LIVE_PLANNER} and bool(plan.allocation) \
        and not any(plan.allocation.values())
    if not plan.events and opts.infer_events and not planned_nothing:  # (a plan.csv, or another tool's plan without
        # events; not coplan's own plan that allocated no fruit: nothing to infer, and the warning read as a fault)
        plan = replace(plan, events=infer_events(problem, plan, motions, opts))
        ver.inferred_events = list(plan.events)
        n_pick = sum(e.kind == EventKind.PICK for e in plan.events)
        ver.warnings.append(Finding(WarningKind.EVENTS_INFERRED, (), None, message=(
            f"the plan declares no events: {n_pick} pick{'s' if n_pick != 1 else ''} and {len(plan.events) - n_pick} "
            f"place{'s' if len(plan.events) - n_pick != 1 else ''} were inferred from its motion (tip within "
            f"{opts.position_tolerance * 1000:g} mm and still for the dwell over a fruit, then over the arm's bin)")))
    samples = _check_clearance(problem, plan, motions, opts, ver)
    t1 = _time.perf_counter()
    if opts.fcl != FclMode.OFF:
        ver.fcl = cross_check(motions, samples, opts.fcl, opts.fcl_tolerance)
        for d in ver.fcl.disagreements:
            ver.violations.append(Violation(ViolationKind.CROSS_CHECK, d.arms, d.t, abs(d.fcl - d.numpy), d.fcl, d.numpy,
                                            message=f"FCL and NumPy disagree ({d.kind.value}) on links {d.links}"))
    t2 = _time.perf_counter()
    _check_limits(problem, motions, np.asarray(plan.time, float), opts, ver)
    check_home(problem, plan, motions, np.asarray(plan.time, float), opts.home_tolerance, ver)
    if problem.gantry is not None:
        check_carriage(problem, plan, opts, ver)
    _check_events(problem, plan, motions, opts, ver)
    _check_stated(problem, plan, ver)
    t3 = _time.perf_counter()
    ver.timings = {"clearance": t1 - t0, "fcl": t2 - t1, "limits_events": t3 - t2, "total": t3 - t0}
    ver.violations.sort(key=lambda v: (v.t, v.kind.value))
    return ver
