"""Plausibility of a problem: values far outside any real harvesting cell are bad input.

A problem file can be valid YAML with every number finite and positive and still describe
no real cell: joint limits of ``[-180, 180]`` (degrees where radians are meant), a joint speed
of ``1e-9`` rad/s (one move would take years), a dwell of days, a fruit at ``1e308`` m. Such
values used to end in a MemoryError, an overflow warning or hours of compute; they are now
refused when the file is loaded, each with its key path, line, the bound and the value found.

``BOUNDS`` is the table of what coplan accepts, per field (SI units). The bounds are
deliberately wide -- orders of magnitude around real arms -- so that they only catch units
mistakes and nonsense, never an unusual but real cell. ``MAX_PLAN_SECONDS`` caps the length
of a plan: every plan is sampled on a 100 Hz grid, so a problem whose plan would be longer
(estimated up front by :func:`plan_duration_bound`, a lower bound computed from the limits)
is refused before anything is planned; so is one whose plan file would be too large to read
back (:data:`coplan.plan.MAX_PLAN_BYTES`, at ``BYTES_PER_SAMPLE``), so the longest plan
allowed is shorter with more arms (5.5 h for one arm, 2.3 h for three, 7 min for 64).

The functions taking a ``problem`` are called by :mod:`coplan.problem.load` with its
:class:`~coplan.problem.Problem` (they use its ``arms``, ``task``, ``fruits``,
``fruit_positions`` and ``reach_matrix()``); this module does not import that one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from ..plan import DEFAULT_RATE, MAX_PLAN_ANGLE, MAX_PLAN_BYTES, MAX_PLAN_COORD
from .gantry import gantry_range_issues, off_rail

__all__ = ["Bound", "BOUNDS", "MAX_PLAN_ANGLE", "MAX_PLAN_COORD", "MAX_PLAN_SECONDS", "BYTES_PER_SAMPLE", "BYTES_PER_CARRIAGE_SAMPLE", "SAMPLE_RATE", "max_plan_seconds", "plan_seconds_limit", "DurationBound", "move_times", "field_issues", "plan_duration_bound",
           "duration_issues", "problem_issues", "fruit_position_issues", "row_travel", "slowest_speed", "row_duration_issues",
           "cruise_speed_issue", "live_speed_issue", "latest_report_time", "check_as_file"]

TAU = 2.0 * math.pi


@dataclass(frozen=True)
class Bound:
    """The closed range ``[low, high]`` a value must lie in, its unit and what it is."""

    low: float
    high: float
    unit: str
    what: str

    def holds(self, x: float) -> bool:
        return self.low <= x <= self.high



_COORD = Bound(-1000.0, 1000.0, "m", "a coordinate")
_ANGLE = Bound(-TAU, TAU, "rad", "a joint angle")

#: What a value of each problem field must lie in (per element for pairs and limits).
BOUNDS: dict[str, Bound] = {
    "links": Bound(1e-3, 100.0, "m", "a link length"),
    "link_radius": Bound(1e-4, 5.0, "m", "a link radius"),
    "joint_limits": _ANGLE,
    "home": _ANGLE,
    "max_velocity": Bound(1e-3, 1e3, "rad/s", "a joint velocity limit"),
    "max_acceleration": Bound(1e-3, 1e5, "rad/s^2", "a joint acceleration limit"),
    "max_jerk": Bound(1e-3, 1e7, "rad/s^3", "a joint jerk limit"),
    "base": _COORD,
    "bin": _COORD,
    "position": _COORD,
    "pick_dwell": Bound(0.0, 3600.0, "s", "a dwell"),
    "place_dwell": Bound(0.0, 3600.0, "s", "a dwell"),
    "clearance": Bound(0.0, 10.0, "m", "a clearance"),
    "reach_margin": Bound(0.0, 10.0, "m", "a reach margin"),
    # (manipulability |det J| = l1 l2 |sin q2|: 1e300 was accepted, and every pose reported singular)
    "singularity_threshold": Bound(0.0, 100.0, "m^2", "a manipulability threshold"),
}

#: The longest plan coplan makes (s): plans are sampled at ``SAMPLE_RATE``, so 12 h is
#: 4.3 million samples per arm.
MAX_PLAN_SECONDS = 12 * 3600.0
SAMPLE_RATE = DEFAULT_RATE
#: Bytes of a plan file per sample, an upper estimate for plan.json and plan.csv: the time
#: (plan.csv's ``43200.0000000,`` and its line end), per arm two angles of seven decimals within
#: joint limits (plan.json's ``[-6.2831853,-6.2831853],``), and a row's carriage position
#: (``-1000.0000000,``, coordinates within +-1000 m).
BYTES_PER_SAMPLE = (15, 24)  # (time, per arm): the widest values they can take
BYTES_PER_CARRIAGE_SAMPLE = 14


def max_plan_seconds(n_arms: int, carriage: bool = False) -> float:
    """The longest plan (s) of ``n_arms`` arms coplan makes (``carriage``: a row's, with the
    carriage's position too): :data:`MAX_PLAN_SECONDS`, or less where its file would not fit
    :data:`coplan.plan.MAX_PLAN_BYTES`."""
    per_sample = BYTES_PER_SAMPLE[0] + BYTES_PER_SAMPLE[1] * max(n_arms, 1) + (BYTES_PER_CARRIAGE_SAMPLE if carriage else 0)
    return min(MAX_PLAN_SECONDS, MAX_PLAN_BYTES / per_sample / SAMPLE_RATE)


def plan_seconds_limit(problem) -> float:
    """:func:`max_plan_seconds` for ``problem``'s plans (a row's carry the carriage's position)."""
    return max_plan_seconds(len(problem.arms), carriage=getattr(problem, "gantry", None) is not None)


def _leaves(value, loc: tuple):
    if isinstance(value, (tuple, list)):
        for i, v in enumerate(value):
            yield from _leaves(v, loc + (i,))
    else:
        yield loc, float(value)


def _hint(field: str, b: Bound, x: float) -> str:
    if b is _ANGLE and abs(x) <= 360.0 + 1e-9:
        return f" (it looks like degrees: {x:g} deg is {math.radians(x):.4f} rad; angles are in rad)"
    if b.unit.startswith("rad/s") and x < b.low:
        return " (a joint this slow would take days for one move)"
    if b.unit == "m" and (x > b.high or x < b.low) and b.holds(x / 1000.0):  # (clearance: 50, links: [900, 700]; -2435 too)
        return f" (it looks like millimetres: {x:g} mm is {x / 1000.0:g} m; lengths are in m)"
    if b is _COORD or field == "links":
        return " (a cell of this size is not a harvesting cell; coordinates are in m)"
    if b.unit == "s":
        return " (dwells are in s)"
    return ""


def field_issues(field: str, value, loc: tuple) -> list[tuple[tuple, str]]:
    """``(key path, message)`` for every element of ``value`` (a number, pair or pair of pairs
    of field ``field``, at key path ``loc``) outside its :data:`BOUNDS` entry."""
    b = BOUNDS.get(field)
    if b is None or value is None:
        return []
    out = []
    for where, x in _leaves(value, loc):
        if not b.holds(x):
            out.append((where, f"expected {b.what} within [{b.low:g}, {b.high:g}] {b.unit} (the plausible range, "
                               f"coplan.plausible.BOUNDS), found {x:g}{_hint(field, b, x)}"))
    return out


#: a row's fruit lie along its rail: their x as far as a rail may go (``gantry.start`` and ``end``,
#: :data:`coplan.problem.gantry.BOUNDS`), y as any coordinate ("gantry.end: 2000" was accepted and
#: a fruit at x 1500 on it refused as "a cell of this size")
_ROW_X = Bound(-10_000.0, 10_000.0, "m", "a position along the rail")


def fruit_position_issues(position, loc: tuple, row: bool = False) -> list[tuple[tuple, str]]:
    """:func:`field_issues` of a fruit's ``position`` at key path ``loc``; on a row (``row``)
    its x within the range of a rail's ends (whether it is on this row's rail is
    :func:`coplan.problem.gantry.off_rail`'s to say)."""
    if not row or position is None:
        return field_issues("position", position, loc)
    x, y = position
    out = [] if _ROW_X.holds(float(x)) else [
        (loc + (0,), f"expected {_ROW_X.what} within [{_ROW_X.low:g}, {_ROW_X.high:g}] {_ROW_X.unit} (the plausible range "
                     f"of a rail's ends, coplan.problem.gantry.BOUNDS), found {float(x):g}")]
    return out + [(loc + (1,), msg) for _, msg in field_issues("position", y, ())]


def move_times(dq: np.ndarray, v, a, j, cubic: bool = False) -> np.ndarray:
    """Rest-to-rest move times over joint displacements ``dq`` (..., 2), the slower joint; NaN
    (no pose) gives inf.

    Default: a lower bound for any motion, per joint ``max(D/v, 2 sqrt(D/a), (32 D/j)^(1/3))``
    (the velocity, acceleration and jerk limits each alone). ``cubic``: the course's cubic
    (:func:`coplan.kinematics.timing.cubic_min_time`), ``max(1.5 D/v, sqrt(6 D/a))``."""
    d = np.abs(dq)
    v, a, j = (np.asarray(x, float) for x in (v, a, j))
    if cubic:
        t = np.maximum(1.5 * d / v, np.sqrt(6.0 * d / a))
    else:
        t = np.maximum(np.maximum(d / v, 2.0 * np.sqrt(d / a)), np.cbrt(32.0 * d / j))
    t = np.where(np.isnan(t), np.inf, t)
    return t.max(axis=-1)


@dataclass(frozen=True)
class DurationBound:
    """A lower bound on the makespan of any plan (s); the fruit that costs most even on its
    cheapest arm (indices; -1 when no fruit is reachable) and that cost (s)."""

    seconds: float
    arm: int = -1
    fruit: int = -1
    fruit_seconds: float = 0.0


def plan_duration_bound(problem, baseline: bool = False) -> DurationBound:
    """A lower bound on the makespan of any plan of ``problem`` (``baseline``: of the course's
    baseline, :func:`coplan.planners.heuristic.plan_heuristic`, which every solve computes).

    Every harvested fruit costs its arm at least a move to it (from the bin or from home), the
    pick dwell, a move back to the bin and the place dwell, on its cheapest arm and elbow
    branches; the plan is at least as long as the dearest fruit and as the total shared evenly
    by all arms. The baseline moves each fruit home -> fruit -> bin -> home with cubics.
    Cheap (vectorised IK of every arm and fruit), so it runs when a file is loaded.
    """
    task = problem.task
    pts = problem.fruit_positions
    if not len(pts):
        return DurationBound(0.0)
    cost = np.full((len(problem.arms), len(pts)), np.inf)
    for i, arm in enumerate(problem.arms):
        qf, _ = arm.ik(pts, task.reach_margin)  # (F, 2 branches, 2)
        qb, _ = arm.ik(np.asarray(arm.bin, float))  # (2, 2)
        lim = (arm.max_velocity, arm.max_acceleration, arm.max_jerk)
        home = np.asarray(arm.home, float)[None]
        srcs = home if baseline else np.concatenate([qb, home], axis=0)  # (bin branches,) home
        t_in = move_times(qf[:, :, None, :] - srcs[None, None], *lim, cubic=baseline).min(axis=(1, 2))
        t_out = move_times(qf[:, :, None, :] - qb[None, None], *lim, cubic=baseline).min(axis=(1, 2))
        t_home = move_times(qb - home, *lim, cubic=True).min() if baseline else 0.0
        cost[i] = t_in + t_out + t_home + task.pick_dwell + task.place_dwell
    return _shared_bound(cost)


def _shared_bound(cost: np.ndarray) -> DurationBound:
    """The plan's least length from each fruit's least cost on each arm, ``cost`` (A, F), inf where
    the arm cannot take it: at least the dearest fruit on its cheapest arm, and the sum of those
    shared evenly by the arms."""
    best = cost.min(axis=0)
    ok = np.isfinite(best)
    if not ok.any():
        return DurationBound(0.0)
    f = int(np.argmax(np.where(ok, best, -np.inf)))
    seconds = max(float(best[f]), float(best[ok].sum()) / cost.shape[0])
    return DurationBound(seconds, int(np.argmin(cost[:, f])), f, float(best[f]))


def _hours(s: float) -> str:
    return f"{s:.0f} s" if s < 3600 else f"{s / 3600:.1f} h"


def latest_report_time(problem) -> tuple[float, str]:
    """The latest time (s) a live cell's feed may report a fruit, and why: the run's plan is at
    least that long, and then the problem's work (:func:`plan_duration_bound`), within
    :func:`plan_seconds_limit`."""
    limit = plan_seconds_limit(problem)
    work = plan_duration_bound(problem).seconds
    return limit - work, (f"the run's plan must fit in {_hours(limit)}, the longest coplan makes with {len(problem.arms)} "
                          f"arms (its file under {MAX_PLAN_BYTES >> 20} MiB), and the problem's work takes at least "
                          f"{work:.1f} s more")


def duration_issues(problem) -> list[tuple[tuple, str]]:
    """``(key path, message)`` when even a lower bound on the length of the baseline plan
    (which every solve computes first) exceeds :data:`MAX_PLAN_SECONDS` (the 100 Hz grid of
    such a plan is absurd); else nothing."""
    b = plan_duration_bound(problem, baseline=True)
    limit = plan_seconds_limit(problem)
    if b.seconds <= limit:
        return []
    arm = problem.arms[b.arm]
    n_reach = int(problem.reach_matrix().any(axis=0).sum())
    return [(_duration_cause(problem, b), (
        f"expected a problem whose plan fits in {_hours(limit)} (plans are sampled at {SAMPLE_RATE:g} Hz; "
        f"{'12 h' if limit == MAX_PLAN_SECONDS else f'with {len(problem.arms)} arms, longer plans make files over {MAX_PLAN_BYTES >> 20} MiB'}), "
        f"found one whose baseline plan (the course's planner, which every solve computes) lasts at least "
        f"{_hours(b.seconds)}, estimated from the limits before planning: {n_reach} reachable fruit; fruit "
        f"{problem.fruits[b.fruit].id!r} alone takes at least {_hours(b.fruit_seconds)} "
        f"on its fastest arm {arm.name!r} (max_velocity {list(arm.max_velocity)} rad/s, max_acceleration "
        f"{list(arm.max_acceleration)} rad/s^2, max_jerk {list(arm.max_jerk)} rad/s^3; pick_dwell "
        f"{problem.task.pick_dwell:g} s, place_dwell {problem.task.place_dwell:g} s)"
    ))]


def _duration_cause(problem, b: DurationBound) -> tuple:
    """The key path a too-long plan is reported at (:func:`duration_issues`): the longer dwell
    where the dwells are at least half of the slowest fruit's time; else the slowest fruit's
    fastest arm where its moves alone take more than :data:`SLOW_MOVES` (its joints' limits, which
    the message lists); else the fruit list (their number sets the bound)."""
    task = problem.task
    dwell = task.pick_dwell + task.place_dwell
    if dwell >= 0.5 * b.fruit_seconds:
        return ("task", "pick_dwell" if task.pick_dwell >= task.place_dwell else "place_dwell")
    if b.fruit_seconds - dwell > SLOW_MOVES or b.seconds <= b.fruit_seconds * (1.0 + 1e-9):
        return ("arms", b.arm)
    return ("fruits",)


#: s: moves to and from one fruit slower than this are the arm's limits' doing, not the fruit count's
SLOW_MOVES = 60.0


def problem_issues(problem) -> list[tuple[tuple, str]]:
    """``(key path, message)`` for what a problem file would be refused for beyond its structure
    (a problem built or changed in Python skips the file's checks): every field outside
    :data:`BOUNDS` (a row's gantry: :data:`coplan.problem.gantry.BOUNDS`, and each fruit on
    the rail's reach), else a plan longer than coplan makes (:func:`duration_issues`, for a row
    :func:`row_duration_issues`)."""
    found: list[tuple[tuple, str]] = []
    for i, a in enumerate(problem.arms):
        for f in ("links", "link_radius", "joint_limits", "home", "max_velocity", "max_acceleration", "max_jerk", "base", "bin"):
            found += field_issues(f, getattr(a, f), ("arms", i, f))
    for i, fr in enumerate(problem.fruits):
        found += fruit_position_issues(fr.position, ("fruits", i, "position"), row=problem.gantry is not None)
    for f in ("pick_dwell", "place_dwell", "clearance", "reach_margin", "singularity_threshold"):
        found += field_issues(f, getattr(problem.task, f), ("task", f))
    if problem.gantry is not None:  # (a file's section and fruit are refused for these in the reader)
        found += gantry_range_issues(problem.gantry)
        found += [(("fruits", j, "position", 0), msg) for j, msg in ([] if found else off_rail(problem))]
    if found:
        return found
    return row_duration_issues(problem) if problem.gantry is not None else duration_issues(problem)


def row_travel(problem) -> float:
    """The least distance (m) a row's carriage covers in any plan: from ``gantry.start`` to
    where its farthest fruit first comes within an arm's reach (0 when it is in reach from the
    start)."""
    g = problem.gantry
    if g is None or not problem.fruits:
        return 0.0
    ahead = max(a.base[0] + a.reach for a in problem.arms)
    far = min(max(float(problem.fruit_positions[:, 0].max()) - ahead, g.start), g.end)
    return far - g.start


def slowest_speed(problem) -> float:
    """The slowest constant carriage speed (m/s) whose plan can fit :func:`max_plan_seconds`
    (its 100 Hz grid, its file): :func:`row_travel` over that time."""
    return row_travel(problem) / plan_seconds_limit(problem)


def row_duration_issues(problem) -> list[tuple[tuple, str]]:
    """``(key path, message)`` when a row's carriage, at its speed limit, cannot even reach its
    farthest fruit within :func:`max_plan_seconds` (memory and file would run away); else nothing."""
    g = problem.gantry
    dist = row_travel(problem)
    limit = plan_seconds_limit(problem)
    if g is None:
        return []
    if dist / g.max_velocity <= limit:
        return row_dwell_issues(problem) or row_work_issues(problem)
    return [(("gantry", "max_velocity"), (
        f"expected a carriage that covers the row in a plan of at most {_hours(limit)} (plans are sampled at "
        f"{SAMPLE_RATE:g} Hz{'' if limit == MAX_PLAN_SECONDS else f'; with {len(problem.arms)} arms, longer plans make files over {MAX_PLAN_BYTES >> 20} MiB'}), "
        f"found max_velocity {g.max_velocity:g} m/s: the carriage alone takes at least {_hours(dist / g.max_velocity)} "
        f"to bring its farthest fruit within reach ({dist:g} m from gantry.start)"
    ))]


def row_dwell_issues(problem) -> list[tuple[tuple, str]]:
    """``(key path, message)`` when a row's dwells alone outlast :func:`max_plan_seconds`: every
    fruit on the rail (each within some arm's reach from it: the others are refused before) is
    picked and placed, each dwell held in full, and the arms share them at best evenly -- so the
    plan lasts at least the fruit times both dwells over the arms. Each of a row's cells is
    checked as it is made, but cells that each fit can add up to a row that does not (a 3600 s
    pick dwell on a 6 m row of 36 fruit planned 43242 s, a 347 MB plan.json that coplan verify
    refuses to read)."""
    task = problem.task
    n, arms = len(problem.fruits), max(len(problem.arms), 1)
    need = n * (task.pick_dwell + task.place_dwell) / arms
    limit = plan_seconds_limit(problem)
    if need <= limit:
        return []
    key = "pick_dwell" if task.pick_dwell >= task.place_dwell else "place_dwell"
    return [(("task", key), (
        f"expected a row whose plan fits in {_hours(limit)} (plans are sampled at {SAMPLE_RATE:g} Hz"
        f"{'' if limit == MAX_PLAN_SECONDS else f'; with {len(problem.arms)} arms, longer plans make files over {MAX_PLAN_BYTES >> 20} MiB'}), "
        f"found one whose dwells alone take at least {_hours(need)}: {n} fruit, each picked and placed "
        f"(pick_dwell {task.pick_dwell:g} s + place_dwell {task.place_dwell:g} s), shared by {len(problem.arms)} arms "
        f"(dwells are in s)"
    ))]


def row_work_bound(problem) -> DurationBound:
    """A lower bound on any row plan's length from its arms' work, wherever the carriage stands:
    each fruit costs its arm both dwells and two turns of the elbow -- from the bend that puts the
    tip over the bin (which rides with the carriage: the same bend at every carriage position) to
    a bend that reaches the fruit from some carriage position (the fruit's distance from the
    base ranges over ``[|dy|, outer reach]`` as the carriage moves: an interval of bends) and
    back -- on its cheapest arm; the plan is at least as long as the dearest fruit and as the
    total shared evenly by the arms. Cheap (closed form), so it runs when a file is loaded."""
    task = problem.task
    pts = problem.fruit_positions
    if not len(pts) or not problem.arms:
        return DurationBound(0.0)
    cost = np.full((len(problem.arms), len(pts)), np.inf)
    # (only fruit an arm reaches from some carriage position within its joint limits, and arms that
    # reach their bin: a fruit no arm can pick counted its arm's work, and a plannable row was refused)
    reach = problem.reach_matrix()
    for i, arm in enumerate(problem.arms):
        if not arm.ik(np.asarray(arm.bin, float), 0.0)[1].any():
            continue
        l1, l2 = (float(x) for x in arm.links)

        def bend(r):  # |elbow angle| of a tip at distance r from the base (decreasing in r)
            return np.arccos(np.clip((np.square(r) - l1 * l1 - l2 * l2) / (2.0 * l1 * l2), -1.0, 1.0))

        def lean(q2):  # how far the elbow's bend turns the tip from the shoulder's direction, rad
            return np.arctan2(l2 * np.sin(q2), l1 + l2 * np.cos(q2))

        def most_lean(a, b):  # the largest lean over bends in [a, b] (exact: it peaks once, if at all)
            peak = math.acos(-l2 / l1) if l1 > l2 else math.pi
            return np.where((a <= peak) & (peak <= b), lean(np.full(np.shape(a), peak)), np.maximum(lean(a), lean(b)))

        rel = pts[:, 1] - arm.base[1]
        dy = np.abs(rel)
        r_out, r_in = l1 + l2 - task.reach_margin, abs(l1 - l2) + task.reach_margin
        ok = (dy <= r_out) & reach[i]
        lo, hi = bend(np.full(dy.shape, r_out)), bend(np.maximum(dy, r_in))
        rb = math.dist(arm.bin, arm.base)
        b = float(bend(rb))
        turn = np.maximum(0.0, np.maximum(lo - b, b - hi))
        # the shoulder: the fruit's direction from the base lies between those of the farthest
        # points of its line in reach (either side), the tip leaning at most ``most_lean`` from it;
        # the bin's direction is fixed, its lean the bin's bend's (either elbow branch)
        w = np.sqrt(np.maximum(r_out * r_out - dy * dy, 0.0))
        up = rel >= 0
        d_lo, d_hi = np.where(up, np.arctan2(dy, w), -np.arctan2(dy, -w)), np.where(up, np.arctan2(dy, -w), -np.arctan2(dy, w))
        spread = most_lean(lo, hi)
        phi_b = math.atan2(arm.bin[1] - arm.base[1], arm.bin[0] - arm.base[0])
        sweep = np.full(dy.shape, np.inf)
        for q1b in (phi_b - float(lean(b)), phi_b + float(lean(b))):
            # circular distance from q1b to the arc [d_lo - spread, d_hi + spread]
            a0, a1 = d_lo - spread, d_hi + spread
            inside = np.mod(q1b - a0, 2 * math.pi) <= (a1 - a0)
            gap = np.minimum(np.abs(np.angle(np.exp(1j * (q1b - a0)))), np.abs(np.angle(np.exp(1j * (q1b - a1)))))
            sweep = np.minimum(sweep, np.where(inside | (a1 - a0 >= 2 * math.pi), 0.0, gap))
        t = move_times(np.stack([sweep, turn], axis=-1), arm.max_velocity, arm.max_acceleration, arm.max_jerk)
        cost[i] = np.where(ok, 2.0 * t + task.pick_dwell + task.place_dwell, np.inf)
    return _shared_bound(cost)


def row_work_issues(problem) -> list[tuple[tuple, str]]:
    """``(key path, message)`` when the arms' work alone (:func:`row_work_bound`) outlasts
    :func:`max_plan_seconds` (arms limited to 0.001 rad/s were accepted on a row: 42205 s planned
    in 99 s and 3 GB, a 244 MB plan.json that coplan verify refuses to read); else nothing."""
    b = row_work_bound(problem)
    limit = plan_seconds_limit(problem)
    if b.seconds <= limit:
        return []
    arm = problem.arms[b.arm]
    return [(_duration_cause(problem, b), (
        f"expected a row whose plan fits in {_hours(limit)} (plans are sampled at {SAMPLE_RATE:g} Hz"
        f"{'' if limit == MAX_PLAN_SECONDS else f'; with {len(problem.arms)} arms, longer plans make files over {MAX_PLAN_BYTES >> 20} MiB'}), "
        f"found one whose arms' work alone takes at least {_hours(b.seconds)}, estimated from the limits before "
        f"planning: {len(problem.fruits)} fruit, each picked and placed with the elbow turning from its bin's bend "
        f"to the fruit's and back; fruit {problem.fruits[b.fruit].id!r} alone takes at least {_hours(b.fruit_seconds)} "
        f"on its fastest arm {arm.name!r} (max_velocity {list(arm.max_velocity)} rad/s, max_acceleration "
        f"{list(arm.max_acceleration)} rad/s^2, max_jerk {list(arm.max_jerk)} rad/s^3; pick_dwell "
        f"{problem.task.pick_dwell:g} s, place_dwell {problem.task.place_dwell:g} s)"
    ))]


def too_long_row(problem, seconds: float, what: str) -> str:
    """The message of a row refused because ``what`` (its plan's length, bounded below) is
    ``seconds``, more than :func:`max_plan_seconds`: the arms' limits, which set it."""
    limit = plan_seconds_limit(problem)
    limits = "; ".join(f"{a.name} max_velocity {list(a.max_velocity)} rad/s, max_acceleration {list(a.max_acceleration)} "
                       f"rad/s^2" for a in problem.arms[:4]) + ("; ..." if len(problem.arms) > 4 else "")
    return (f"expected a row whose plan fits in {_hours(limit)} (plans are sampled at {SAMPLE_RATE:g} Hz"
            f"{'' if limit == MAX_PLAN_SECONDS else f'; with {len(problem.arms)} arms, longer plans make files over {MAX_PLAN_BYTES >> 20} MiB'}), "
            f"found one whose {what} {_hours(seconds)}: {len(problem.fruits)} fruit, its arms' limits {limits} "
            f"(pick_dwell {problem.task.pick_dwell:g} s, place_dwell {problem.task.place_dwell:g} s)")


def _speed_within(speed, lo: float, hi: float) -> bool:
    """Whether ``speed`` is a finite number (not a bool) in ``(0, hi]`` and at least ``lo``."""
    return isinstance(speed, (int, float)) and not isinstance(speed, bool) and math.isfinite(speed) and 0.0 < speed <= hi \
        and speed >= lo


def _shown(speed) -> str:
    if speed is None:  # (none given: the command line's --speed left out)
        return "nothing"
    return f"{speed:g}" if isinstance(speed, (int, float)) and not isinstance(speed, bool) else repr(speed)


def cruise_speed_issue(problem, speed) -> str | None:
    """What is wrong with ``speed`` (m/s) as a row's constant cruising speed, or None: above
    ``gantry.max_velocity``, or so slow that the plan would outgrow :func:`max_plan_seconds`
    (:func:`slowest_speed`: a 100 Hz grid of days, a file no verifier reads)."""
    g = problem.gantry
    lo = slowest_speed(problem)
    if _speed_within(speed, lo, g.max_velocity):
        return None
    limit = plan_seconds_limit(problem)
    low = (f"[{lo:.3g}, {g.max_velocity:g}] m/s (gantry.max_velocity at most; the row's screen may ask for a little more: "
           f"at least what brings the farthest fruit "
           f"within reach, {row_travel(problem):g} m along the rail, in a plan of {_hours(limit)}, the longest coplan makes"
           f"{'' if limit == MAX_PLAN_SECONDS else f' with {len(problem.arms)} arms (its file under {MAX_PLAN_BYTES >> 20} MiB)'})"
           if lo > 0 else f"(0, {g.max_velocity:g}] m/s (gantry.max_velocity)")
    return f"expected a cruising speed in {low}, found {_shown(speed)}"


def live_rail_issue(problem, stop_and_go: bool, look_ahead: float) -> str | None:
    """What makes a live row on ``problem``'s rail longer than the longest plan coplan makes
    (:func:`plan_seconds_limit`) whatever the cruising speed, or None. A live carriage does not
    know where the last fruit is: on the move it cruises the whole rail, at most at
    ``gantry.max_velocity``; stop and go it hops at most the camera's ``look_ahead`` plus the
    arms' spread (its rear base no farther than the camera has seen) until the camera sees the
    rail's end, and as a rest-to-rest move's time per metre falls with its length, those hops
    take at least the distance times the longest hop's time per metre. (A 3500 m rail ran 156 s
    to a 7700 s plan past that limit, 8000 m -- an end in mm -- ran for more than 15 minutes.)"""
    from ..kinematics.timing import scurve_time

    g = problem.gantry
    limit = plan_seconds_limit(problem)
    rail = g.end - g.start
    xs = [a.base[0] for a in problem.arms]
    if stop_and_go:
        hop = look_ahead + max(xs) - min(xs)
        far = max(0.0, g.end - max(xs) - look_ahead - g.start)  # (where the camera sees the rail's end)
        need = far * scurve_time(hop, g.max_velocity, g.max_acceleration, g.max_jerk) / hop if hop > 0 and far > 0 else 0.0
        how = (f"stop and go it hops at most {hop:.2f} m (the camera's {look_ahead:g} m look-ahead and the arms' spread, "
               f"{max(xs) - min(xs):g} m), so the {far:.0f} m it travels before the camera sees the rail's end take at least "
               f"{need:.0f} s")
    else:
        need = rail / g.max_velocity
        how = f"on the move it cruises the whole rail, {rail:g} m, taking {need:.0f} s even at gantry.max_velocity"
    if need <= limit:
        return None
    return (f"expected a rail a live carriage can cover in a plan of at most {_hours(limit)} (the longest coplan makes"
            f"{'' if limit == MAX_PLAN_SECONDS else f' with {len(problem.arms)} arms'}; it does not know where the last "
            f"fruit is): {how}; found a rail of {rail:g} m (gantry.start {g.start:g}, gantry.end {g.end:g}: in m?)")


def live_speed_issue(problem, speed) -> str | None:
    """What is wrong with ``speed`` (m/s) as a live row's cruising speed on the move, or None.
    The live carriage, not knowing where the last fruit is, cruises to the rail's end: the whole
    rail within :func:`max_plan_seconds` (more than :func:`cruise_speed_issue` asks of a plan
    that knows its last fruit), and the range quoted is the live one."""
    g = problem.gantry
    limit = plan_seconds_limit(problem)
    rail = g.end - g.start
    lo = max(slowest_speed(problem), rail / limit)
    if _speed_within(speed, lo, g.max_velocity):
        return None
    shown = _shown(speed)
    if lo <= 0:
        return f"expected a cruising speed in (0, {g.max_velocity:g}] m/s (gantry.max_velocity), found {shown}"
    return (f"expected a cruising speed in [{lo:.3g}, {g.max_velocity:g}] m/s (gantry.max_velocity at most; at least what "
            f"cruises the whole rail, {rail:g} m, in a plan of at most {_hours(limit)}, the longest coplan makes"
            f"{'' if limit == MAX_PLAN_SECONDS else f' with {len(problem.arms)} arms'}: a live carriage does not know "
            f"where the last fruit is), found {shown}")


def check_as_file(problem) -> None:
    """:class:`~coplan.errors.ProblemError` where a problem built or changed in Python
    (``dataclasses.replace``) breaks what a problem file is held to (:func:`problem_issues`, home
    poses the clearance apart, one fruit per position): a joint velocity limit of 1e-6 rad/s ran
    out of memory (27 GiB), a dwell of 8 h made a plan file no coplan command reads back, a
    carriage of 1 um/s took 21 GB in plan_row. Issues by key path. Run by :func:`coplan.solve`
    and the row planners on a problem they are given."""
    from ..errors import Issue, ProblemError
    from .poses import home_issues, position_issues
    from .yamlsafe import path_str

    found = [Issue(path_str(loc), msg) for loc, msg in problem_issues(problem)] + home_issues(problem) + position_issues(problem)
    if found:  # (home poses too close: a plan 'unsafe' at t = 0 s; a fruit twice: harvested twice -- where a file says why)
        raise ProblemError(found, f"{problem.source}, as changed in Python" if problem.source else "a problem built in Python")
