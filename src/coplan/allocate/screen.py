"""Static feasibility screen: which arms and fruit are certainly impossible, before any planning.

Entry point: :func:`screen` returns a :class:`Screen`. Pure NumPy, no solver, milliseconds.

The rule (necessary conditions only -- it never rules out anything a plan could do):

* Only the **bases** never move. Arm *j*'s base is the root of its link-1 capsule, so any
  link of another arm *i* must keep ``dist(base_j, link segment) >= clearance + r_i + r_j``
  at all times (``r`` the link radii) or the verifier reports a breach.
* **Link 1 sweeps.** The shoulder q1 is a limited joint: moving from q1 = a to q1 = b sweeps
  link 1 (base -> elbow, length l1) through every angle in between, whatever the elbow does.
  The angles at which link 1 comes too close to base *j* form one arc around the direction
  of *j* (computed exactly: half-width ``asin(R / D)`` when the tangent point lies on the
  link, otherwise from the law of cosines at the elbow; none when ``D >= l1 + R``). So arm
  *i* can only ever use the connected interval of q1 around its home q1 that stays inside
  the joint limits ``[lim[0,0], lim[0,1]]`` and meets no such arc (no wrap-around past a
  limit). ``q1_range`` is that closed interval; it is empty (None) when link 1 already
  violates the clearance at home.
* **Link 2 is checked only at the static poses.** The elbow can fold and link 2 can swing
  anywhere during a move, so link 2 constrains nothing in between; but while the tip holds
  still at a pick or a place, link 2 must also keep clear of every other base.
* A pose (an IK branch of the bin or of a fruit) is **usable** when some 2-pi equivalent of
  its q1 within the joint limits lies in ``q1_range`` and its link 2 keeps clear of the
  other bases. The verifier accepts the tip anywhere within ``tip_tolerance`` (5 mm) of the
  target, so a branch counts as usable when the exact IK pose *or* the same branch's pose
  for a point on a ring of that radius around the target passes (``tip_tolerance=0``: the
  exact poses only).
* An arm with no usable bin pose is **locked**: it can place nothing, so it takes no fruit.
  The screened reach is ``problem.reach_matrix()`` and a usable pick pose and an unlocked
  arm; a fruit no arm screens in is **unharvestable**.

Every rule-out gets a sentence in ``reasons`` naming the blocking neighbour and, for a sweep,
what closes the other way round (a joint limit or another neighbour's base).
"""

from __future__ import annotations

import functools
import math
import weakref
from dataclasses import dataclass

import numpy as np

from ..kinematics import arm as kin
from ..errors import plural
from ..problem.gantry import standing_reach
from ..problem.model import Arm, Problem

__all__ = ["Screen", "screen", "screened", "usable_picks", "reach_reason", "TIP_TOLERANCE"]

#: The verifier's default pick/place position tolerance (``VerifyOptions.position_tolerance``).
TIP_TOLERANCE = 0.005
_EPS = 1e-9  # numerical slack, always in favour of feasibility
_RING = 12  # points on the tip-tolerance ring
_BRANCH = ("elbow up", "elbow down")
_TWO_PI = 2.0 * math.pi


@dataclass(frozen=True, eq=False)
class Screen:
    """The verdict of :func:`screen`. ``reach`` rows follow ``arms``, columns ``fruits``."""

    arms: tuple[str, ...]
    fruits: tuple[str, ...]
    q1_range: dict[str, tuple[float, float] | None]  # None: empty (link 1 violates at home)
    arm_ok: dict[str, bool]  # has a usable bin pose
    reach: np.ndarray  # (A, F) bool: reach_matrix & usable pick pose & arm_ok
    bin_branches: dict[str, list[int]]
    fruit_branches: dict[tuple[str, str], list[int]]  # every (arm, fruit) of reach_matrix; ignores arm_ok
    reasons: dict[str, str]  # arm name or fruit id -> sentence (locked arms, unharvestable fruit)
    unharvestable: tuple[str, ...]  # fruit no unlocked arm can pick (out-of-reach fruit included)

    @property
    def locked(self) -> tuple[str, ...]:
        return tuple(a for a in self.arms if not self.arm_ok[a])

    def summary(self) -> dict:
        """JSON-ready digest."""
        arms = {}
        for i, a in enumerate(self.arms):
            rng = self.q1_range[a]
            arms[a] = {
                "q1_range": None if rng is None else [round(rng[0], 6), round(rng[1], 6)],
                "ok": bool(self.arm_ok[a]),
                "bin_branches": list(self.bin_branches[a]),
                "fruit": [f for j, f in enumerate(self.fruits) if self.reach[i, j]],
            }
        return {
            "arms": arms,
            "locked": list(self.locked),
            "unharvestable": list(self.unharvestable),
            "reasons": dict(self.reasons),
        }

    def lines(self) -> list[str]:
        """What a command line prints (coplan's vocabulary: reachable, harvestable, screened out)."""
        n = len(self.fruits)
        harvestable = int(self.reach.any(axis=0).sum())
        out = [
            f"screen: {len(self.locked)} of {plural(len(self.arms), 'arm')} locked"
            + (f" ({', '.join(self.locked)})" if self.locked else "")
            + f"; {harvestable} of {plural(n, 'fruit', 'fruit')} harvestable"
            + (f", {n - harvestable} not ({', '.join(self.unharvestable)})" if self.unharvestable else "")
        ]
        for i, a in enumerate(self.arms):
            rng = self.q1_range[a]
            span = ("its shoulder cannot move from home without hitting a neighbour" if rng is None else
                    f"shoulder q1 free in [{rng[0]:.4f}, {rng[1]:.4f}] rad" if rng[1] - rng[0] < 2 * math.pi - 1e-6
                    else "shoulder q1 free all round")
            state = "LOCKED: takes no fruit" if not self.arm_ok[a] else f"{plural(int(self.reach[i].sum()), 'fruit', 'fruit')} it can harvest"
            out.append(f"  {a}: {state}; {span}")
        out += [f"  - {r}" for r in self.reasons.values()]
        return out


# --------------------------------------------------------------------------- geometry
def _point_segment(p: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distance from point p (2,) to segments a-b (..., 2)."""
    ab = b - a
    den = np.einsum("...i,...i->...", ab, ab)
    t = np.clip(np.einsum("...i,...i->...", p - a, ab) / np.where(den > 0, den, 1.0), 0.0, 1.0)
    return np.linalg.norm(a + t[..., None] * ab - p, axis=-1)


def _blocked_arc(arm: Arm, other: Arm, need: float) -> tuple[float, float] | None:
    """(centre, half-width) of the q1 arc where link 1 of ``arm`` is within ``need`` of
    ``other``'s base; None if it never is; half-width pi if it always is."""
    dx, dy = other.base[0] - arm.base[0], other.base[1] - arm.base[1]
    d, l1 = math.hypot(dx, dy), arm.links[0]
    centre = math.atan2(dy, dx)
    if d < need:
        return centre, math.pi
    if d >= l1 + need:
        return None
    if d * d - need * need <= l1 * l1:  # the tangent point lies on the link
        half = math.asin(need / d)
    else:  # the elbow end decides
        half = math.acos(min(1.0, (d * d + l1 * l1 - need * need) / (2.0 * d * l1)))
    return centre, half


@dataclass
class _Sweep:
    lo: float  # reachable q1 interval (lo > hi: empty)
    hi: float
    lo_by: str | None  # neighbour blocking below lo (None: the joint limit)
    hi_by: str | None
    home_by: str | None  # neighbour violated at home


def _needs(arms: tuple[Arm, ...], arm: Arm, clearance: float) -> dict[str, float]:
    """How far ``arm``'s link axes must keep from each arm's base (its name -> m): the
    clearance and both link radii."""
    return {o.name: clearance + arm.link_radius + o.link_radius for o in arms}


def _sweep(arms: tuple[Arm, ...], arm: Arm, need: dict[str, float]) -> _Sweep:
    lim = arm.limits[0]
    h = arm.home[0]
    s = _Sweep(float(lim[0]), float(lim[1]), None, None, None)
    for other in arms:
        if other is arm:
            continue
        arc = _blocked_arc(arm, other, need[other.name])
        if arc is None:
            continue
        c, w = arc
        if w >= math.pi:
            s.home_by = s.home_by or other.name
            continue
        for k in range(math.floor((lim[0] - c - w) / _TWO_PI), math.ceil((lim[1] - c + w) / _TWO_PI) + 1):
            a, b = c + k * _TWO_PI - w, c + k * _TWO_PI + w
            if a < h < b:
                s.home_by = s.home_by or other.name
            elif a >= h and a < s.hi:
                s.hi, s.hi_by = a, other.name
            elif b <= h and b > s.lo:
                s.lo, s.lo_by = b, other.name
    if s.home_by is not None:
        s.lo, s.hi = math.inf, -math.inf
    return s


def _q1_ok(q1: np.ndarray, lim: np.ndarray, sw: _Sweep) -> np.ndarray:
    """Some 2-pi equivalent of q1 within the joint limits lies in the swept interval."""
    ok = np.zeros(np.shape(q1), dtype=bool)
    for k in range(-2, 3):
        t = q1 + k * _TWO_PI
        ok |= (t >= lim[0] - _EPS) & (t <= lim[1] + _EPS) & (t >= sw.lo - _EPS) & (t <= sw.hi + _EPS)
    return ok


def _poses(arms: tuple[Arm, ...], arm: Arm, targets: np.ndarray, margin: float, sw: _Sweep, need, tol: float):
    """For targets (N, 2): valid (N, 2) IK branches at the exact target, usable (N, 2), and
    for each branch the first base link 2 violates at the exact pose ('' if none)."""
    ang = np.linspace(0.0, _TWO_PI, _RING, endpoint=False) if tol > 0 else np.zeros(0)
    ring = np.vstack([[0.0, 0.0], tol * np.c_[np.cos(ang), np.sin(ang)]])  # the exact target first
    pts = targets[:, None, :] + ring[None]  # (N, K, 2)
    q, valid = arm.ik(pts, 0.0)  # (N, K, 2, 2), (N, K, 2)
    valid0 = arm.ik(targets, margin)[1]
    ok = valid & _q1_ok(q[..., 0], arm.limits[0], sw)
    elbow, tip = kin.fk(np.nan_to_num(q), arm.links, arm.base)
    hit = np.full(valid0.shape, "", dtype=object)
    for other in arms:
        if other is arm or math.dist(arm.base, other.base) > arm.reach + need[other.name] + _EPS:
            continue  # (a base beyond the arm's reach plus the clearance is never within it)
        bad = _point_segment(np.asarray(other.base, float), elbow, tip) < need[other.name] - _EPS
        ok &= ~bad
        first = bad[:, 0] & (hit == "")
        hit[first] = other.name
    return valid0, valid0 & ok.any(axis=1), hit, q[:, 0, :, 0]


def _why(sw: _Sweep, q1: float, lim: np.ndarray, link2_hit: str, pose: str) -> str:
    """Why one valid but unusable pose (``pose``: 'place' or 'pick') is unusable."""
    if sw.home_by is not None:
        return f"link 1 is already within the clearance of {sw.home_by}'s base at home"
    if not bool(_q1_ok(np.array(q1), lim, sw)):
        up = q1 > sw.hi
        by, other_by = (sw.hi_by, sw.lo_by) if up else (sw.lo_by, sw.hi_by)
        round_q = q1 - _TWO_PI if up else q1 + _TWO_PI
        if other_by is not None and lim[0] <= round_q <= lim[1]:
            closed = f"{other_by}'s base blocks the way round"
        else:
            closed = f"the joint limit q1 {'>=' if up else '<='} {lim[0] if up else lim[1]:g} blocks the way round"
        return f"link 1 would cross {by}'s base on the way to q1 = {{q}}; {closed}"
    if link2_hit:
        return f"link 2 would come within the clearance of {link2_hit}'s base at the {pose} pose"
    return f"the {pose} pose is blocked"  # not reached: a pose passing every check is usable


def _branch_text(reasons: list[tuple[int, str, float]]) -> str:
    """One phrase for the branches' reasons; branches with the same reason share it."""
    groups: dict[str, list[tuple[int, float]]] = {}
    for b, text, q1 in reasons:
        groups.setdefault(text, []).append((b, q1))
    if len(groups) == 1:
        text, bq = next(iter(groups.items()))
        return text.replace("{q}", " or ".join(f"{q:.3f}" for _, q in bq))
    return "; ".join(
        f"{_BRANCH[b]}: {text.replace('{q}', f'{q:.3f}').replace('; ', ' and ')}" for text, bq in groups.items() for b, q in bq
    )


def _join(names: list[str]) -> str:
    return names[0] if len(names) == 1 else ", ".join(names[:-1]) + " and " + names[-1]


# --------------------------------------------------------------------------- the screen
_SCREENS: "weakref.WeakKeyDictionary[Problem, Screen]" = weakref.WeakKeyDictionary()


def reach_reason(problem: Problem, point) -> str:
    """Why no arm reaches ``point``, from the arm it misses by least: beyond the outer reach,
    inside the inner one (the folded arm), on either boundary (which ``reach_margin`` keeps
    clear of, told apart from a point just beyond it), or out of the joint limits."""
    m = problem.task.reach_margin
    best = None
    for arm in problem.arms:
        d = math.dist(point, arm.base)
        R, r = arm.reach, arm.inner_radius
        if d > R - m:
            miss, side, edge = d - (R - m), "outer", R
        elif d < r + m:
            miss, side, edge = (r + m) - d, "inner", r
        else:
            miss, side, edge = 0.0, "limits", R
        # (a tie goes to the nearer base: a fruit on one arm's base missed the other's reach by as
        # much, 0.21 m, and was called 2.000 m from it, not inside the nearer arm's inner reach)
        if best is None or miss < best[0] - 1e-9 or (abs(miss - best[0]) <= 1e-9 and d < best[3]):
            best = (miss, side, edge, d, arm.name)
    _, side, edge, d, name = best
    if side == "limits":
        return f"within {name}'s reach ({d:.3f} m from its base), but no elbow branch there is within its joint limits"
    where = "outer reach (l1 + l2)" if side == "outer" else "inner reach (|l1 - l2|, the arm folded)"
    if abs(d - edge) <= 1e-9:
        return (f"exactly on {name}'s {where} boundary, {edge:.4g} m from its base; coplan keeps task.reach_margin "
                f"({m:g} m) inside it, away from the singular stretched/folded pose")
    if (side == "outer" and d < edge) or (side == "inner" and d > edge):
        # (the inner side said "within its inner reach" of a fruit outside the folded arm's hole)
        return (f"{d:.4f} m from {name}'s base: {'within its outer' if side == 'outer' else 'outside its inner'} reach "
                f"({'l1 + l2' if side == 'outer' else '|l1 - l2|, the arm folded'}) of {edge:.4g} m, but by less than "
                f"task.reach_margin ({m:g} m)")
    return (f"{d:.3f} m from {name}'s base, {'beyond' if side == 'outer' else 'inside'} its {where} of {edge:.4g} m"
            + (f" (task.reach_margin {m:g} m)" if m else ""))


@functools.lru_cache(maxsize=256)
def _arm_sweep(arms: tuple[Arm, ...], clearance: float, i: int, tip_tolerance: float) -> tuple[_Sweep, bool]:
    """Arm ``i``'s shoulder sweep (:func:`_sweep`) and whether it can place into its bin, which
    depend on the arms and the clearance alone: kept for the next call on the same arms (a row
    asks :func:`usable_picks` of the same carriage frame thousands of times)."""
    arm = arms[i]
    need = _needs(arms, arm, clearance)
    sw = _sweep(arms, arm, need)
    _, bin_use, _, _ = _poses(arms, arm, np.asarray([arm.bin], float), 0.0, sw, need, tip_tolerance)
    return sw, bool(bin_use[0].any())


def usable_picks(problem: Problem, points, tip_tolerance: float = TIP_TOLERANCE, arms=None) -> np.ndarray:
    """``(A, N, 2)`` bool: which IK branch of which arm can pick at each of ``points`` (N, 2)
    under the screen's rules -- the annulus less ``task.reach_margin``, joint limits, the
    shoulder's free sweep from home past the neighbours' bases, link 2 clear of them -- all
    False for an arm that can never reach its bin. Vectorised over the points (no Fruit objects):
    the row's screen asks it of every carriage position at once. ``arms``: only these arm
    indices (the others' rows stay False)."""
    pts = np.asarray(points, float).reshape(-1, 2)
    clear = problem.task.clearance
    out = np.zeros((len(problem.arms), pts.shape[0], 2), dtype=bool)
    for i, arm in enumerate(problem.arms):
        if arms is not None and i not in arms:
            continue
        need = _needs(problem.arms, arm, clear)
        sw, bin_ok = _arm_sweep(problem.arms, clear, i, float(tip_tolerance))
        if not bin_ok or pts.shape[0] == 0:
            continue
        # the exact target first (the ring's first point); the ring only where the exact pose is
        # valid but not usable: the same answer as the whole ring everywhere, at a fraction of its cost
        v0, use, _, _ = _poses(problem.arms, arm, pts, problem.task.reach_margin, sw, need, 0.0)
        redo = np.flatnonzero((v0 & ~use).any(axis=1))
        if redo.size and tip_tolerance > 0:
            use[redo] = _poses(problem.arms, arm, pts[redo], problem.task.reach_margin, sw, need, tip_tolerance)[1]
        out[i] = use
    return out


def screened(problem: Problem) -> Screen:
    """:func:`screen` with the default tolerance, computed once per problem (problems are immutable)."""
    hit = _SCREENS.get(problem)
    if hit is None:
        hit = _SCREENS[problem] = screen(problem)
    return hit


def screen(problem: Problem, tip_tolerance: float = TIP_TOLERANCE) -> Screen:
    """Screen ``problem`` for arms and fruit that no plan can serve (see the module docstring)."""
    arms, fruits = problem.arms, problem.fruits
    clear = problem.task.clearance
    pts = problem.fruit_positions
    base_reach = standing_reach(problem)  # (a row given here: its cell with the carriage at 0)
    A, F = len(arms), len(fruits)
    reach = np.zeros((A, F), dtype=bool)
    q1_range: dict[str, tuple[float, float] | None] = {}
    arm_ok: dict[str, bool] = {}
    bin_branches: dict[str, list[int]] = {}
    fruit_branches: dict[tuple[str, str], list[int]] = {}
    arm_reasons: dict[str, str] = {}
    pick_why: dict[tuple[int, int], str] = {}
    for i, arm in enumerate(arms):
        need = _needs(arms, arm, clear)
        sw = _sweep(problem.arms, arm, need)
        lim = arm.limits[0]
        q1_range[arm.name] = None if sw.home_by is not None else (sw.lo, sw.hi)
        v0, use, hit, q1 = _poses(problem.arms, arm, np.asarray([arm.bin], float), 0.0, sw, need, tip_tolerance)
        bin_branches[arm.name] = [b for b in range(2) if use[0, b]]
        arm_ok[arm.name] = bool(use[0].any())
        if not arm_ok[arm.name]:
            why = [(b, _why(sw, float(q1[0, b]), lim, hit[0, b], "place"), float(q1[0, b])) for b in range(2) if v0[0, b]]
            arm_reasons[arm.name] = f"{arm.name} cannot reach its bin: {_branch_text(why)}"
        if F == 0:
            continue
        v0, use, hit, q1 = _poses(problem.arms, arm, pts, problem.task.reach_margin, sw, need, tip_tolerance)
        for j, f in enumerate(fruits):
            if not base_reach[i, j]:
                continue
            fruit_branches[arm.name, f.id] = [b for b in range(2) if use[j, b]]
            reach[i, j] = arm_ok[arm.name] and bool(use[j].any())
            if not use[j].any():
                why = [(b, _why(sw, float(q1[j, b]), lim, hit[j, b], "pick"), float(q1[j, b])) for b in range(2) if v0[j, b]]
                pick_why[i, j] = f"{arm.name} cannot pick it: {_branch_text(why)}"
    reach.flags.writeable = False
    fruit_reasons: dict[str, str] = {}
    for j, f in enumerate(fruits):
        if reach[:, j].any():
            continue
        who = [i for i in range(A) if base_reach[i, j]]
        if not who:
            fruit_reasons[f.id] = f"{f.id}: out of every arm's reach: {reach_reason(problem, pts[j])}"
            continue
        names = [arms[i].name for i in who]
        if len(who) > 1 and not any(arm_ok[a] for a in names):
            why = f"{'neither' if len(who) == 2 else 'none of them'} can reach its bin"
        else:
            why = ", and ".join(f"{a} cannot reach its bin" if not arm_ok[a] else pick_why[i, j] for i, a in zip(who, names))
        fruit_reasons[f.id] = f"{f.id}: only {_join(names)} {'reaches' if len(who) == 1 else 'reach'} it and {why}"
    return Screen(
        arms=tuple(a.name for a in arms),
        fruits=tuple(f.id for f in fruits),
        q1_range=q1_range,
        arm_ok=arm_ok,
        reach=reach,
        bin_branches=bin_branches,
        fruit_branches=fruit_branches,
        reasons={**arm_reasons, **fruit_reasons},
        unharvestable=tuple(f.id for j, f in enumerate(fruits) if not reach[:, j].any()),
    )
