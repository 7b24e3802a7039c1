"""Rest-to-rest timing laws: the course's cubic and the jerk-limited S-curve.

All functions are pure and work on plain floats / NumPy arrays.

* :func:`cubic_min_time` -- shortest duration of the course's cubic ``s = 3 tau^2 - 2 tau^3``
  that keeps every joint inside its velocity and acceleration limits
  (peak velocity ``1.5 D / T``, peak acceleration ``6 D / T^2``).
* :func:`scurve_time` -- time-optimal rest-to-rest duration of one joint under velocity,
  acceleration and jerk limits (the classical 7-phase S-curve).
* :class:`SCurve` -- a rest-to-rest move between two joint poses in which every joint runs
  its own time-optimal S-curve, the faster ones slowed to end with the slowest: its
  duration equals :func:`move_lower_bound`, so it is the fastest possible move.
* :func:`move_lower_bound` -- ``max_i scurve_time(|dq_i|, v_i, a_i, j_i)``: no motion of any
  shape between the two poses can be faster.
* :func:`scurve_times` -- :func:`scurve_time` over an array of distances at once.
* :func:`accel_time` -- the fastest jerk-limited speed-up from rest to a speed (both its ends at
  zero acceleration): the first third of an S-curve that reaches that speed.
* :class:`Move1D` -- one axis's time-optimal rest-to-rest move (a gantry's carriage).
* :func:`ruckig_move` -- the time-optimal jerk-limited move between two full states (position,
  velocity, acceleration per joint), joints synchronised (Ruckig): the moves that start or end
  in motion (a live re-planned approach, a pick on a moving carriage).
"""

from __future__ import annotations

import functools
import itertools
import math
from dataclasses import dataclass

import numpy as np

__all__ = ["trajectory_states", "phase_starts", "sync_duration", "cubic_min_time", "cubic_eval", "scurve_time", "scurve_times", "SCurve", "Move1D", "move_lower_bound",
           "MoveError", "ruckig_move", "accel_time"]


def cubic_min_time(dq, vmax, amax) -> float:
    """Shortest cubic duration keeping ``|qd| <= vmax`` and ``|qdd| <= amax`` on every joint."""
    d = np.abs(np.asarray(dq, dtype=float))
    v = np.asarray(vmax, dtype=float)
    a = np.asarray(amax, dtype=float)
    if not (np.all(np.isfinite(d)) and np.all(np.isfinite(v)) and np.all(np.isfinite(a)) and np.all(v > 0) and np.all(a > 0)):
        raise ValueError(f"cubic_min_time: expected finite steps and limits > 0, found dq {dq!r:.60}, vmax {vmax!r:.60}, "
                         f"amax {amax!r:.60}")
    t = np.maximum(1.5 * d / v, np.sqrt(6.0 * d / a))
    return float(np.max(t)) if t.size else 0.0


def cubic_eval(q0, q1, T: float, t):
    """Course cubic from ``q0`` to ``q1`` over ``T`` seconds at times ``t`` (K,) -> (K, 2)."""
    q0, q1 = np.asarray(q0, float), np.asarray(q1, float)
    if q0.shape != (2,) or q1.shape != (2,):  # (one number gave "invalid index to scalar variable")
        raise ValueError(f"cubic_eval: expected q0 and q1 of shape (2,), the two joints, found {q0.shape} and {q1.shape}")
    if not (math.isfinite(float(T)) and float(T) >= 0):
        raise ValueError(f"cubic_eval: T: expected a duration >= 0 in s, found {T!r}")
    t = np.atleast_1d(np.asarray(t, float))
    tau = np.clip(t / T, 0.0, 1.0) if T > 0 else np.ones_like(t)
    s = 3 * tau**2 - 2 * tau**3
    return q0 + s[:, None] * (q1 - q0)


_NEGLIGIBLE = 1e-12  # s: a phase shorter than this is round-off


def accel_time(vp, a: float, j: float):
    """The fastest speed-up from rest to ``vp`` (>= 0; a float or an array) under the
    acceleration and jerk limits ``a``, ``j``, starting and ending at zero acceleration, s:
    ``vp / a + a / j`` where it reaches ``a`` (``vp >= a^2 / j``), else ``2 sqrt(vp / j)``. Its
    acceleration's profile is symmetric, so it covers ``vp`` times half that time."""
    if np.ndim(vp) == 0:
        vp = float(vp)
        return vp / a + a / j if vp >= a * a / j else 2.0 * math.sqrt(max(vp, 0.0) / j)
    vp = np.asarray(vp, float)
    return np.where(vp >= a * a / j, vp / a + a / j, 2.0 * np.sqrt(np.maximum(vp, 0.0) / j))


def _phases(D: float, v: float, a: float, j: float):
    """Durations and jerks of the 7 phases of a rest-to-rest S-curve over distance D >= 0."""
    if D <= 0:
        return [], []
    # peak velocity: v if reachable, else the largest with no cruise phase
    if D >= v * accel_time(v, a, j):
        vp = v
    else:
        vp = (-a / j + math.sqrt((a / j) ** 2 + 4.0 * D / a)) * a / 2.0
        if vp < a * a / j:
            vp = (D * math.sqrt(j) / 2.0) ** (2.0 / 3.0)
    ap = min(a, math.sqrt(vp * j))
    tj = ap / j
    ta = max(0.0, vp / ap - ap / j)
    tc = max(0.0, (D - vp * accel_time(vp, a, j)) / vp)
    # a constant-acceleration or cruise phase left by round-off (~1e-16 s) is no phase: it would
    # be reported as two jerk switches around a jerk that never changes
    ta, tc = (x if x > _NEGLIGIBLE else 0.0 for x in (ta, tc))
    durs = [tj, ta, tj, tc, tj, ta, tj]
    jerks = [j, 0.0, -j, 0.0, -j, 0.0, j]
    return durs, jerks


def scurve_time(D: float, v: float, a: float, j: float) -> float:
    """Time-optimal rest-to-rest duration for distance ``|D|`` under limits v, a, j (> 0); a
    ValueError, what was expected and found, for a distance that is not a finite number or a limit
    that is not a positive one (NaN gave 4.0 s, a zero limit a ZeroDivisionError)."""
    D, v, a, j = float(D), float(v), float(a), float(j)
    if not (v > 0 and a > 0 and j > 0 and math.isfinite(D + v + a + j)):
        raise ValueError(f"scurve_time: expected a finite distance and finite limits v, a, j > 0, found "
                         f"D={D:g}, v={v:g}, a={a:g}, j={j:g}")
    return float(sum(_phases(abs(D), v, a, j)[0]))


def move_lower_bound(q0, q1, vmax, amax, jmax) -> float:
    """No motion between rest poses q0 and q1 respecting the limits is faster than this; every
    argument one value per joint (a joint count that differs is a ValueError: zip cut it short)."""
    dq = np.abs(np.asarray(q1, float) - np.asarray(q0, float))
    if not (dq.ndim == 1 and len(vmax) == len(amax) == len(jmax) == dq.size):
        raise ValueError(f"move_lower_bound: expected one value per joint in q0, q1 and each limit, found "
                         f"{np.shape(q0)}, {np.shape(q1)}, {len(vmax)}, {len(amax)}, {len(jmax)}")
    return max((scurve_time(d, v, a, j) for d, v, a, j in zip(dq, vmax, amax, jmax)), default=0.0)


def phase_starts(durs, jerks) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Each phase's start time and the position, velocity and acceleration there, of a 1-D
    rest-to-rest jerk profile from 0 (``durs``, ``jerks``: one per phase): four (P,) arrays,
    accumulated phase by phase in one order, which every evaluation of a profile shares."""
    starts, P, V, A = [], [], [], []
    p = v = acc = t0 = 0.0
    for d, jk in zip(durs, jerks):
        starts.append(t0), P.append(p), V.append(v), A.append(acc)
        p, v, acc = p + v * d + acc * d**2 / 2 + jk * d**3 / 6, v + acc * d + jk * d**2 / 2, acc + jk * d
        t0 += d
    return np.asarray(starts), np.asarray(P), np.asarray(V), np.asarray(A)


def _profile(durs, jerks, t):
    """Evaluate a 1-D rest-to-rest jerk profile (from 0) at times t: p, v, a, j arrays.

    Each time in the phase that starts last at or before it (the last phase to the end): the
    state at each phase's start is accumulated once, and the times are sorted into phases by one
    ``searchsorted`` (a phase of no duration holds no time)."""
    t = np.clip(np.asarray(t, float), 0.0, float(sum(durs)))
    if not len(durs):
        return [np.zeros_like(t) for _ in range(4)]
    starts, P, V, A = phase_starts(durs, jerks)
    k = np.maximum(np.searchsorted(starts, t, side="right") - 1, 0)
    tau = t - starts[k]
    pk, vk, ak, jk = P[k], V[k], A[k], np.asarray(jerks, float)[k]
    return [pk + vk * tau + ak * tau**2 / 2 + jk * tau**3 / 6, vk + ak * tau + jk * tau**2 / 2, ak + jk * tau, jk]


@dataclass(frozen=True)
class SCurve:
    """Rest-to-rest joint move where every joint runs its own time-optimal S-curve.

    The slowest joint sets the duration (which is therefore :func:`move_lower_bound`, the
    fastest possible); every other joint's time-optimal profile is slowed down uniformly
    in time to end at the same instant, which scales its velocity, acceleration and jerk
    down by k, k^2, k^3 (k <= 1), so all limits hold and all joints start and stop together.
    """

    q0: tuple[float, float]
    q1: tuple[float, float]
    profiles: tuple  # per joint: (durations, jerks) over distance |q1 - q0|
    duration: float

    @classmethod
    def between(cls, q0, q1, vmax, amax, jmax) -> "SCurve":
        """The time-optimal synchronised move from rest at q0 to rest at q1 (remembered: the
        planners ask for the same moves many times; an SCurve is immutable)."""
        try:
            args = [tuple(float(x) for x in v) for v in (q0, q1, vmax, amax, jmax)]
        except (TypeError, ValueError):  # ("'int' object is not iterable")
            raise ValueError(f"SCurve.between: expected q0, q1, vmax, amax and jmax as sequences of numbers, one per "
                             f"joint, found {q0!r:.40}, {q1!r:.40}, {vmax!r:.40}, {amax!r:.40}, {jmax!r:.40}") from None
        if len({len(v) for v in args}) != 1:  # (3 joints against 2 were cut to 2)
            raise ValueError(f"SCurve.between: expected one value per joint in q0, q1 and each limit, found "
                             f"{', '.join(str(len(v)) for v in args)}")
        if not all(math.isfinite(x) for v in args for x in v) or not all(x > 0 for v in args[2:] for x in v):
            raise ValueError(f"SCurve.between: expected finite poses and limits > 0, found q0 {args[0]}, q1 {args[1]}, "
                             f"vmax {args[2]}, amax {args[3]}, jmax {args[4]}")  # (a limit of -1: 'math domain error')
        return _between(*args)

    def derivatives(self, t):
        """Joint (pos, vel, acc, jerk), each (K, 2), at times ``t`` (K,) from the move's start."""
        t = np.asarray(t, float)
        if not np.all(np.isfinite(t)):  # (NaN gave the start's state)
            raise ValueError(f"SCurve.derivatives: t: expected finite times in s, found {t!r:.80}")
        out = np.zeros((4, t.size, 2))
        for i, (durs, jerks) in enumerate(self.profiles):
            d = self.q1[i] - self.q0[i]
            out[0, :, i] = self.q0[i]
            if not durs or self.duration <= 0:
                continue
            Ti = float(sum(durs))
            k = Ti / self.duration
            p, v, a, j = _profile(durs, jerks, np.clip(t, 0, self.duration) * k)
            sg = np.sign(d)
            out[0, :, i] = self.q0[i] + sg * p
            out[1, :, i] = sg * v * k
            out[2, :, i] = sg * a * k**2
            out[3, :, i] = sg * j * k**3
            end = t >= self.duration
            out[0, end, i] = self.q1[i]
            out[1:, end, i] = 0.0
        return out

    def switch_times(self) -> np.ndarray:
        """Phase boundaries of every joint, from the move's start, in (0, duration): (S,).

        These are the times where some joint's jerk changes, and the time where each joint
        reaches its peak velocity (acceleration back to zero: the end of its accelerating
        half, also when it has no cruise phase and its jerk stays -j across that instant).
        Between two of them (and the ends) every joint's jerk is constant, so a grid with a
        knot at each represents the move exactly with constant jerk per interval, and the
        accelerating and decelerating halves of each move are separate segments."""
        out = []
        for durs, jerks in self.profiles:
            if not durs or self.duration <= 0:
                continue
            k = float(sum(durs)) / self.duration
            if max(abs(j) for j in jerks) * k**3 < _NEGLIGIBLE:
                continue  # a joint slowed this much (it barely moves) has no jerk worth a knot
            ends = np.cumsum(durs)
            out.append(ends[2] / k)  # peak velocity: the accelerating half ends
            t, prev = 0.0, None
            for d, j in zip(durs, jerks):
                if d <= 0.0:
                    continue
                if prev is not None and j != prev:
                    out.append(t / k)
                t, prev = t + d, j
        t = np.unique(np.round(np.asarray(out, float), 12))
        return t[(t > 1e-9) & (t < self.duration - 1e-9)]

    def eval(self, t):
        """Joint positions (K, 2) at times ``t`` (K,) measured from the start of the move."""
        return self.derivatives(t)[0]


@functools.lru_cache(maxsize=1 << 16)
def _between(q0, q1, vmax, amax, jmax) -> SCurve:
    profs = tuple(_phases(abs(b - a), v, ac, j) for a, b, v, ac, j in zip(q0, q1, vmax, amax, jmax))
    duration = max((float(sum(d)) for d, _ in profs), default=0.0)
    return SCurve(q0, q1, profs, duration)


def sync_duration(q0, q1, vmax: tuple, amax: tuple, jmax: tuple) -> float:
    """``SCurve.between(q0, q1, vmax, amax, jmax).duration`` for two-joint poses, remembered by
    the four joint values: the allocation's dynamic programmes ask for millions of these (a
    600-fruit row's search anchor: 6.3 million), and building ``between``'s key costs more
    than the answer. The limits must be tuples of floats (a problem's arms have them so)."""
    return _duration(float(q0[0]), float(q0[1]), float(q1[0]), float(q1[1]), vmax, amax, jmax)


@functools.lru_cache(maxsize=1 << 18)
def _duration(a0: float, a1: float, b0: float, b1: float, vmax, amax, jmax) -> float:
    return _between((a0, a1), (b0, b1), vmax, amax, jmax).duration


def scurve_times(D, v: float, a: float, j: float) -> np.ndarray:
    """:func:`scurve_time` for an array of distances ``D`` (any shape) at once: the same
    closed form, vectorised (equal to the scalar one to rounding)."""
    D = np.abs(np.asarray(D, float))
    v, a, j = float(v), float(a), float(j)

    full = D >= v * accel_time(v, a, j)
    vp_a = (-a / j + np.sqrt((a / j) ** 2 + 4.0 * D / a)) * a / 2.0
    vp_j = np.cbrt((D * math.sqrt(j) / 2.0) ** 2)
    vp = np.where(full, v, np.where(vp_a < a * a / j, vp_j, vp_a))
    ap = np.minimum(a, np.sqrt(vp * j))
    tj = ap / j
    ta = np.maximum(0.0, vp / np.where(ap > 0, ap, 1.0) - ap / j)
    tc = np.maximum(0.0, (D - vp * accel_time(vp, a, j)) / np.where(vp > 0, vp, 1.0))
    ta = np.where(ta > _NEGLIGIBLE, ta, 0.0)
    tc = np.where(tc > _NEGLIGIBLE, tc, 0.0)
    return np.where(D > 0, 4.0 * tj + 2.0 * ta + tc, 0.0)


@dataclass(frozen=True)
class Move1D:
    """A time-optimal jerk-limited rest-to-rest move of one axis (the gantry's carriage) from
    ``x0`` to ``x1`` under limits ``v``, ``a``, ``j``: :meth:`state` gives position, velocity,
    acceleration at times from its start."""

    x0: float
    x1: float
    durs: tuple
    jerks: tuple

    @classmethod
    def between(cls, x0: float, x1: float, v: float, a: float, j: float) -> "Move1D":
        durs, jerks = _phases(abs(float(x1) - float(x0)), float(v), float(a), float(j))
        return cls(float(x0), float(x1), tuple(durs), tuple(jerks))

    @property
    def duration(self) -> float:
        return float(sum(self.durs))

    def state(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration (each like ``t``) at times ``t`` from the start;
        at rest at ``x0`` before and at ``x1`` after."""
        t = np.asarray(t, float)
        if not self.durs:
            return np.full(t.shape, self.x0), np.zeros(t.shape), np.zeros(t.shape)
        p, v, a, _ = _profile(self.durs, self.jerks, np.clip(t, 0.0, self.duration).ravel())
        s = 1.0 if self.x1 >= self.x0 else -1.0
        end = (t >= self.duration).ravel()
        p = np.where(end, abs(self.x1 - self.x0), p)
        v = np.where(end, 0.0, v)
        a = np.where(end, 0.0, a)
        return (self.x0 + s * p).reshape(t.shape), (s * v).reshape(t.shape), (s * a).reshape(t.shape)


class MoveError(RuntimeError):
    """Ruckig could not compute a move (e.g. a target state beyond the limits)."""


def ruckig_move(start, end, vmax, amax, jmax):
    """The time-optimal move from state ``start`` to state ``end`` (each (3, n): position,
    velocity, acceleration per joint) under per-joint limits, joints synchronised: a
    ``ruckig.Trajectory`` (``duration``, ``at_time(t) -> (p, v, a)``). Raises :class:`MoveError`."""
    from ruckig import InputParameter, Result, Ruckig, RuckigError, Trajectory

    start, end = np.asarray(start, float), np.asarray(end, float)
    n = start.shape[1]
    inp = InputParameter(n)
    inp.current_position, inp.current_velocity, inp.current_acceleration = (list(map(float, r)) for r in start)
    inp.target_position, inp.target_velocity, inp.target_acceleration = (list(map(float, r)) for r in end)
    inp.max_velocity, inp.max_acceleration, inp.max_jerk = (list(map(float, x)) for x in (vmax, amax, jmax))
    traj = Trajectory(n)
    try:
        result = Ruckig(n).calculate(inp, traj)
    except RuckigError as exc:
        raise MoveError(f"ruckig: {str(exc).strip()}") from exc
    if result not in (Result.Working, Result.Finished):
        raise MoveError(f"ruckig: {result}")
    return traj


def _integrate(t, p0, v0, a0, j):
    """Ruckig's ``integrate`` (utils.hpp), term for term in its order: the same bits."""
    return p0 + t * (v0 + t * (a0 / 2 + t * j / 6)), v0 + t * (a0 + t * j / 2), a0 + t * j


def trajectory_states(traj, t) -> np.ndarray:
    """``(3, K, n)``: position, velocity and acceleration of a one-section ``ruckig.Trajectory``
    (:func:`ruckig_move`) at times ``t`` (K,), ``0 <= t < duration`` -- Ruckig's own
    ``Trajectory::at_time`` (its brake pre-trajectory, then the profile's phase by upper bound
    on the cumulative phase times, then constant acceleration past the profile's end), vectorised
    over the times: the same values, a few array operations per joint instead of a call per sample."""
    t = np.asarray(t, float).ravel()
    prs = traj.profiles[0]
    if t.size < 24:  # a few samples: Ruckig's own call each is quicker than the arrays
        return np.array([traj.at_time(float(x)) for x in t], float).reshape(t.size, 3, len(prs)).transpose(1, 0, 2)
    out = np.empty((3, t.size, len(prs)))
    for dof, pr in enumerate(prs):
        td = t
        br = pr.brake
        in_brake = None
        if br.duration > 0:
            in_brake = t < br.duration
            bi = (t >= br.t[0]).astype(np.intp)
            tb = np.where(bi > 0, t - br.t[0], t)
            pb, vb, ab, jb = (np.asarray(x, float)[bi] for x in (br.p, br.v, br.a, br.j))
            for m, x in enumerate(_integrate(tb, pb, vb, ab, jb)):
                out[m, :, dof] = x
            td = np.where(in_brake, t, t - br.duration)
        t_sum = list(itertools.accumulate(pr.t))  # as Profile::t_sum: summed in order
        i = np.searchsorted(t_sum, td, side="right")  # upper bound; len(t_sum): past the profile's end
        start = np.asarray([0.0] + t_sum)[i]
        tl = td - start  # (td - 0.0 is td: the first phase's offset is exact)
        states = _integrate(tl, np.asarray(pr.p)[i], np.asarray(pr.v)[i], np.asarray(pr.a)[i], np.asarray(list(pr.j) + [0.0])[i])
        for m, x in enumerate(states):
            if in_brake is None:
                out[m, :, dof] = x
            else:
                out[m, ~in_brake, dof] = x[~in_brake]
    return out
