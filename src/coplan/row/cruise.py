"""The carriage at a cruising speed, and each fruit's pick windows: when each arm can pick it.

Continuous mode (:mod:`coplan.row.continuous`) keeps the carriage moving: from rest at
``gantry.start`` it ramps to a cruising speed -- one for the row, or one per stretch of rail --
within the gantry's acceleration and jerk limits, and comes to rest at ``x1`` (:class:`Cruise`).

A fruit at row ``x`` seen from carriage position ``c`` sits at ``x - c`` in the carriage frame,
so the row's screen (:func:`coplan.row.reach.row_reach`: from which carriage positions each arm
harvests each fruit, on a grid) becomes, through the carriage's motion ``c(t)``, a set of
**pick windows**: the times at which an arm can *start* a pick such that the carriage stays in
a run of serving positions for the whole dwell (the arm's tip holds still over the fruit in row
coordinates while the joints follow the carriage). Entry points: :class:`Cruise` and
:func:`pick_windows` -> ``{fruit: [Window]}``.
"""

from __future__ import annotations

import bisect
import functools
import math
from dataclasses import dataclass
from enum import Enum

import numpy as np

from ..kinematics.timing import Move1D
from ..problem.model import Problem
from .reach import RowReach

__all__ = ["Cruise", "Window", "pick_windows", "EndRest", "cruise_end", "last_place_bound", "demand_stretches", "ramp_time", "stop_from", "STRETCH"]

#: Length of rail with one speed in a shaped cruise, m.
STRETCH = 1.0


def _ramp(v0: float, v1: float, a: float, j: float) -> list[tuple[float, float]]:
    """Phases ``(duration, jerk)`` of the fastest jerk-limited change of speed from ``v0`` to
    ``v1`` starting and ending at zero acceleration (a symmetric S ramp: its mean speed is
    ``(v0 + v1) / 2``)."""
    dv = v1 - v0
    if abs(dv) < 1e-12:
        return []
    s = 1.0 if dv > 0 else -1.0
    if abs(dv) >= a * a / j:
        return [(a / j, s * j), (abs(dv) / a - a / j, 0.0), (a / j, -s * j)]
    tj = math.sqrt(abs(dv) / j)
    return [(tj, s * j), (tj, -s * j)]


def ramp_time(v0: float, v1: float, a: float, j: float) -> float:
    """How long :func:`_ramp` takes, s."""
    return sum(d for d, _ in _ramp(v0, v1, a, j))


@dataclass(frozen=True)
class Cruise:
    """The carriage from ``x0`` (at rest at t = 0) to rest at ``x1``: a chain of constant-jerk
    phases (each ``(t, x, v, a, j)`` at its start), within the gantry's limits.

    ``speed`` is the top cruising speed; :meth:`of` cruises at one speed, :meth:`shaped` at a
    speed per stretch of rail (slower where the fruit are dense). Changes of speed are S ramps
    (jerk-limited, acceleration from zero back to zero)."""

    x0: float
    x1: float
    speed: float
    phases: tuple  # ((t, x, v, a, j), ...) and a final rest phase

    @classmethod
    def of(cls, problem: Problem, speed: float, x1: float, start_hold: float = 0.0) -> "Cruise":
        """At one cruising ``speed`` from ``gantry.start`` to rest at ``x1`` (``start_hold``: see :meth:`shaped`)."""
        return cls.shaped(problem, [(math.inf, speed)], x1, start_hold)

    @classmethod
    def shaped(cls, problem: Problem, stretches, x1: float, start_hold: float = 0.0) -> "Cruise":
        """``stretches``: ``[(x_end, speed), ...]`` or ``(x_end, speed, hold)`` in rail order:
        cruise at ``speed`` until the carriage reaches ``x_end`` (the next stretch's speed is
        reached by a ramp that starts there), the last until it must slow down to come to rest
        at ``x1``. A ``hold`` (s) > 0: at ``x_end`` the carriage ramps down to rest, waits that
        long, and ramps up to the next stretch's speed. ``start_hold`` (s): the carriage first rests
        that long where it starts (fruit only the start serves are picked meanwhile)."""
        g = problem.gantry
        a, j = g.max_acceleration, g.max_jerk
        x1 = min(max(float(x1), g.start), g.end)
        stretches = [(float(s[0]), float(s[1]), float(s[2]) if len(s) > 2 else 0.0) for s in stretches]
        for _, v, _ in stretches:
            if not 0.0 < v <= g.max_velocity * (1 + 1e-12):
                raise ValueError(f"speed: expected a cruising speed in (0, {g.max_velocity:g}] m/s (the gantry's "
                                 f"limit), found {v:g}")
        out: list[tuple[float, float, float, float, float]] = []
        t, x, v, acc = 0.0, g.start, 0.0, 0.0

        def run(dur: float, jerk: float) -> None:
            nonlocal t, x, v, acc
            if dur <= 0:
                return
            out.append((t, x, v, acc, jerk))
            x += v * dur + acc * dur ** 2 / 2 + jerk * dur ** 3 / 6
            v += acc * dur + jerk * dur ** 2 / 2
            acc += jerk * dur
            t += dur

        def ramp_to(v1: float) -> None:
            nonlocal acc
            for d, jk in _ramp(v, v1, a, j):
                run(d, jk)
            acc = 0.0

        top = max((v for _, v, _ in stretches), default=g.max_velocity)  # (none: a carriage that never leaves)
        run(float(start_hold), 0.0)  # (at rest where it starts)
        for k, (x_end, vk, hold) in enumerate(stretches):
            # the stop must begin where a ramp from this speed to rest ends exactly at x1
            stop_at = x1 - vk * ramp_time(vk, 0.0, a, j) / 2
            if x + (v + vk) * ramp_time(v, vk, a, j) / 2 > stop_at:
                break  # no room to reach this speed before stopping
            ramp_to(vk)
            v = vk
            end = min(x_end, stop_at)
            if end > x:
                run((end - x) / vk, 0.0)
            if x >= stop_at - 1e-12:
                break
            if hold > 0:  # come to rest here (the ramp ends before stop_at: it is shorter than the final stop's)
                ramp_to(0.0)
                v = 0.0
                run(hold, 0.0)
        # come to rest at x1: the fastest stop from v, after cruising at v to where it must begin
        if v > 0:
            stop_at = x1 - v * ramp_time(v, 0.0, a, j) / 2
            if stop_at > x + 1e-12:
                run((stop_at - x) / v, 0.0)
            ramp_to(0.0)
        elif x1 > x + 1e-12:  # never got going (a rail too short for any stretch): one rest-to-rest move
            mv = Move1D.between(x, x1, top, a, j)
            for d, jk in zip(mv.durs, mv.jerks):
                run(d, jk)
        out.append((t, x1, 0.0, 0.0, 0.0))  # at rest (x is x1 up to rounding)
        return cls(g.start, x1, float(top), tuple(out))

    @classmethod
    def hops(cls, problem: Problem, legs) -> "Cruise":
        """Stop and go: ``legs`` ``[(t_depart, x_to), ...]`` in time order; the carriage rests at
        ``gantry.start`` until the first departure, then each leg is a time-optimal jerk-limited
        rest-to-rest move (at the gantry's limits) to ``x_to``, where it rests until the next
        departure (no earlier than its arrival) -- and after the last, for good.

        A leg ``(t, x_to, True)`` changes the hop under way at ``t`` (during the previous leg's
        move): from the carriage's state then, the time-optimal jerk-limited move to rest at
        ``x_to`` (:func:`stop_from`; never back along the rail: ValueError)."""
        g = problem.gantry
        out: list[tuple[float, float, float, float, float]] = []
        t, x = 0.0, g.start
        moving = (math.inf, -math.inf)  # the last leg's move: (departure, arrival)
        for leg in legs:
            t_dep, x_to = leg[0], leg[1]
            x_to = min(max(float(x_to), g.start), g.end)
            if len(leg) > 2 and leg[2]:
                if not moving[0] < float(t_dep) < moving[1]:
                    raise ValueError(f"a hop changed at t = {float(t_dep):g} s: expected a time during the previous "
                                     f"leg's move ({moving[0]:g}, {moving[1]:g}) s")
                out, t, x = _retarget(problem, out, float(t_dep), x_to)
                moving = (float(t_dep), t)
                continue
            if x_to < x - 1e-9:
                raise ValueError(f"a hop back along the rail: from {x:g} to {x_to:g} m")
            t_dep = max(t, float(t_dep))
            if t_dep > t:
                out.append((t, x, 0.0, 0.0, 0.0))
            t = t_dep
            mv = Move1D.between(x, x_to, g.max_velocity, g.max_acceleration, g.max_jerk)
            for d, jk in zip(mv.durs, mv.jerks):
                if d > 0:
                    p, v, acc = (float(u[0]) for u in mv.state(np.array([t - t_dep])))
                    out.append((t, p, v, acc, jk))
                    t += d
            moving = (t_dep, t)
            x = x_to
        out.append((t, x, 0.0, 0.0, 0.0))
        return cls(g.start, x, float(g.max_velocity), tuple(out))

    @property
    def duration(self) -> float:
        """When the carriage comes to rest at ``x1``, s."""
        return float(self.phases[-1][0])

    @functools.cached_property
    def _table(self) -> np.ndarray:
        return np.array(self.phases, float)

    def state(self, t) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position, velocity and acceleration of the carriage at times ``t`` (any shape); at
        rest at ``x0`` before 0 and at ``x1`` after :attr:`duration`."""
        t = np.asarray(t, float)
        tf, (_, x0, v0, a0, j0), d = self._phases_at(t)
        x = x0 + v0 * d + a0 * d ** 2 / 2 + j0 * d ** 3 / 6
        v = v0 + a0 * d + j0 * d ** 2 / 2
        acc = a0 + j0 * d
        rest = tf >= self.duration
        x, v, acc = np.where(rest, self.x1, x), np.where(rest, 0.0, v), np.where(rest, 0.0, acc)
        return x.reshape(t.shape), v.reshape(t.shape), acc.reshape(t.shape)

    def _phases_at(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """For times ``t`` (flattened, clipped to ``[0, duration]``: ``tf``): each one's phase
        ``(t0, x, v, a, j)`` as five rows, and the time into it ``d``."""
        tab = self._table
        tf = np.clip(t.ravel(), 0.0, self.duration)
        k = np.clip(np.searchsorted(tab[:, 0], tf, side="right") - 1, 0, len(tab) - 1)
        phase = tab[k].T
        return tf, phase, tf - phase[0]

    @functools.cached_property
    def _starts(self) -> list[float]:
        return [float(p[0]) for p in self.phases]

    def state_one(self, t: float) -> tuple[float, float, float]:
        """:meth:`state` at one time in plain floats, the same bits (the same arithmetic in the
        same order; the cube through NumPy's array kernel, as :meth:`state` computes it), at a
        fraction of its cost: the booking asks it of every pick it tries."""
        tf = min(max(float(t), 0.0), self.duration)
        if tf >= self.duration:
            return float(self.x1), 0.0, 0.0
        return _at(self.phases[min(max(bisect.bisect_right(self._starts, tf) - 1, 0), len(self.phases) - 1)], tf)

    def x(self, t) -> np.ndarray:
        """:meth:`state`'s positions alone (the same arithmetic: the same bits), at about half its
        cost: :meth:`time_at` bisects on it."""
        t = np.asarray(t, float)
        tf, (_, x0, v0, a0, j0), d = self._phases_at(t)
        x = x0 + v0 * d + a0 * d ** 2 / 2 + j0 * d ** 3 / 6
        return np.where(tf >= self.duration, self.x1, x).reshape(t.shape)

    def time_at(self, x) -> np.ndarray:
        """The first time the carriage is at ``x`` (``x0 <= x <= x1``); 0 before ``x0``, inf
        beyond ``x1``. Bisection on the monotone motion, to 10 microseconds."""
        x = np.atleast_1d(np.asarray(x, float))
        if x.size == 1:  # (a live row asks one window's end at a time: the same steps in plain floats)
            return self._time_at_one(x)
        lo, hi = np.zeros(x.shape), np.full(x.shape, self.duration)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            before = self.x(mid) < x
            lo, hi = np.where(before, mid, lo), np.where(before, hi, mid)
            if float(np.max(hi - lo, initial=0.0)) < 1e-5:
                break
        out = np.where(x <= self.x0 + 1e-12, 0.0, hi)
        return np.where(x > self.x1 + 1e-9, math.inf, out)

    def _time_at_one(self, x: np.ndarray) -> np.ndarray:
        """:meth:`time_at` of one position (``x`` of size 1), the same bisection on
        :meth:`state_one` (the same bits as :meth:`x`) at a tenth of its cost."""
        xv = float(x.ravel()[0])
        lo, hi = 0.0, float(self.duration)
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            if self.state_one(mid)[0] < xv:
                lo = mid
            else:
                hi = mid
            if hi - lo < 1e-5:
                break
        out = math.inf if xv > self.x1 + 1e-9 else (0.0 if xv <= self.x0 + 1e-12 else hi)
        return np.full(x.shape, out)

    @property
    def leaves_start(self) -> float:
        """When the carriage first moves, s (0: at once; > 0 after a start hold)."""
        for phase in self.phases:
            if _moving(phase):
                return float(phase[0])
        return math.inf  # (never: it rests where it starts for good)

    def arrivals(self) -> list[float]:
        """When the carriage comes to rest after a move, s (in time order; the start's rest is
        not one)."""
        out, moving = [], False
        for phase in self.phases:
            now = _moving(phase)
            if moving and not now:
                out.append(float(phase[0]))
            moving = now
        return out

    @property
    def moving_seconds(self) -> float:
        """The carriage's time in motion, s: its duration less its rests (the start hold, holds
        on the way)."""
        ends = [p[0] for p in self.phases[1:]] + [self.duration]
        return float(sum(max(t1 - p[0], 0.0) for p, t1 in zip(self.phases, ends) if _moving(p)))

    @property
    def mean_speed(self) -> float:
        """The carriage's distance over its time in motion (:attr:`moving_seconds`), m/s."""
        t = self.moving_seconds
        return (self.x1 - self.x0) / t if t > 0 else 0.0


@dataclass(frozen=True)
class Window:
    """Arm ``arm`` (index) can start picking the fruit at any time in ``[lo, hi]`` (s): the
    carriage stays within ``[c_lo, c_hi]``, a run of serving positions, for the whole dwell."""

    arm: int
    lo: float
    hi: float
    c_lo: float
    c_hi: float


def _moving(phase) -> bool:
    """Whether the carriage moves during a constant-jerk phase ``(t0, x, v, a, j)``."""
    _, _, v, a, j = phase
    return abs(v) > 1e-12 or abs(a) > 1e-12 or abs(j) > 1e-12


def _at(phase, t: float) -> tuple[float, float, float]:
    """Position, velocity and acceleration at ``t`` of one constant-jerk phase ``(t0, x, v, a, j)``,
    in plain floats with :meth:`Cruise.state`'s bits (its arithmetic in its order; the cube through
    NumPy's array kernel: the scalar ``pow`` may differ in the last bit)."""
    t0, x0, v0, a0, j0 = phase
    d = t - t0
    d2 = d * d
    d3 = float(np.power(np.array([d]), 3)[0])
    return x0 + v0 * d + a0 * d2 / 2 + j0 * d3 / 6, v0 + a0 * d + j0 * d2 / 2, a0 + j0 * d


def _state_in(phases, t: float) -> tuple[float, float, float]:
    """Position, velocity and acceleration at ``t`` of a chain of constant-jerk phases."""
    return _at(max((p for p in phases if p[0] <= t), key=lambda p: p[0]), t)


def stop_from(problem: Problem, state: tuple[float, float, float], x_to: float):
    """The time-optimal jerk-limited move of the carriage from ``state`` (position, velocity,
    acceleration) to rest at ``x_to``, within the gantry's limits: its phases ``[(duration,
    (x, v, a, jerk) at its start), ...]``; ValueError if it would run back along the rail
    (``x_to`` is nearer than the carriage can stop)."""
    from ..kinematics.timing import MoveError, ruckig_move

    g = problem.gantry
    back = ValueError(f"a hop back along the rail: from {state[0]:g} m at {state[1]:g} m/s to rest at {x_to:g} m")
    if x_to < state[0] - 1e-9:
        raise back
    try:
        tr = ruckig_move(np.array([[state[0]], [state[1]], [state[2]]]), np.array([[x_to], [0.0], [0.0]]),
                         [g.max_velocity], [g.max_acceleration], [g.max_jerk])
    except MoveError as exc:
        raise ValueError(f"no move of the carriage from {state[0]:g} m at {state[1]:g} m/s to rest at {x_to:g} m: {exc}") from exc
    out = []
    main = tr.profiles[0][0]
    for prof in (main.brake, main):  # (a brake pre-profile only from a state past the limits)
        for k, d in enumerate(prof.t):
            if d > 0:
                out.append((float(d), (float(prof.p[k]), float(prof.v[k]), float(prof.a[k]), float(prof.j[k]))))
    for d, (_, v, a, j) in out:  # the velocity at each phase's start, and its turning point inside
        turn = -a / j if j != 0.0 else -1.0
        if v < -1e-9 or (0.0 < turn < d and v + a * turn + j * turn * turn / 2 < -1e-9):
            raise back
    return out


def _retarget(problem: Problem, out: list, t: float, x_to: float):
    """``out`` (phases, in order) cut at ``t`` and continued by :func:`stop_from` to rest at
    ``x_to``: (phases, arrival time, ``x_to``)."""
    kept = [p for p in out if p[0] < t - 1e-12]
    if not kept:
        raise ValueError(f"no hop under way at t = {t:g} s to change")
    moves = stop_from(problem, _state_in(kept, t), x_to)
    for d, (x, v, a, j) in moves:
        kept.append((t, x, v, a, j))
        t += d
    return kept, t, x_to


class EndRest(str, Enum):
    """Where the carriage on the move comes to rest at the row's end (:func:`cruise_end`)."""

    REACH = "reach"  # half the front arm's reach past the furthest first serving position of any fruit
    EARLY = "early"  # at that position: where the last fruit first comes into some arm's reach
    RAIL = "rail"  # at the rail's end: every arm, the rear ones too, passes over the row's tail

    def __str__(self) -> str:
        return self.value


def cruise_end(problem: Problem, reach: RowReach, rest: EndRest = EndRest.REACH) -> float:
    """Where the carriage comes to rest, on the rail (``rest``, :class:`EndRest`): by default
    half the front arm's reach past the furthest first serving position of any fruit; early, at
    that position (past it every fruit can still be picked with the carriage at rest); or at
    the rail's end. Resting where the last fruit only just comes into the front arm's reach
    left the front arm to pick the row's tail alone from the edge of its reach: on the shipped
    rows the search's plans took 1.7-7.4 % longer (sparse_row 136.5 s against 127.2 s; on 12
    generated rows of 1-6 arms, 3.6 % longer on average, 3 of them faster). Resting at the
    rail's end lets the rear arms share the tail where the front ones would pick it alone while
    the others idle (six_arm_row 324.59 -> 305.89 s), but costs where the rows end otherwise
    (course_row +3.0 %): the search tries the early rest and the rail's end at the level it
    chooses, the fastest kept."""
    g = problem.gantry
    rest = EndRest(rest)
    if rest == EndRest.RAIL:
        return g.end
    firsts = _first_serving(reach)
    x = max(firsts, default=g.start)
    if firsts and rest == EndRest.REACH:
        x += max(problem.arms, key=lambda a: (a.base[0], a.name)).reach / 2.0
    return min(g.end, x)


def last_place_bound(problem: Problem, reach: RowReach, cruise: Cruise) -> float:
    """No plan on ``cruise`` booked on ``reach`` places every harvestable fruit sooner than this,
    s: a fruit's pick starts no sooner than the carriage passes the last grid position before the
    first that serves it, and its pick and place dwells follow (the latest such fruit; 0 for a
    row with none)."""
    firsts = _first_serving(reach, back=1)
    if not firsts:
        return 0.0
    return float(np.max(cruise.time_at(np.array(firsts)))) + problem.task.pick_dwell + problem.task.place_dwell


def _first_serving(reach: RowReach, back: int = 0) -> list[float]:
    """Each harvestable fruit's first carriage position that serves it, m (``back`` grid steps
    before it), in file order."""
    return [float(reach.grid[max(reach.span(f)[0] - back, 0)]) for f in reach.harvestable()]


def _runs(ok: np.ndarray) -> list[tuple[int, int, int]]:
    """Index runs ``[a, b]`` of True in each row ``r`` of a 2-D bool array: ``(r, a, b)``, row
    by row, each row's runs in order (all rows' in a few NumPy calls: a row's own took as many)."""
    pad = np.zeros((ok.shape[0], ok.shape[1] + 2), np.int8)
    pad[:, 1:-1] = ok
    d = np.diff(pad, axis=1)
    rows, starts = np.nonzero(d == 1)
    ends = np.nonzero(d == -1)[1] - 1
    return list(zip(rows.tolist(), starts.tolist(), ends.tolist()))


def pick_windows(problem: Problem, reach: RowReach, cruise: Cruise, dwell: float) -> dict[str, list[Window]]:
    """Each harvestable fruit's pick windows, one per arm and run of serving positions (module
    docstring), in arm order (a fruit may have none at this motion); where ``gantry.settle`` is
    set, no window lets a pick's dwell come within it of the carriage coming to rest after a move."""
    grid = reach.grid
    runs = []  # (fid, arm, c_lo, c_hi)
    for fid in reach.harvestable():
        for a, i, j in _runs(reach.cover[fid]):
            c_lo, c_hi = float(grid[i]), float(grid[j])
            if c_hi < cruise.x0 - 1e-9 or c_lo > cruise.x1 + 1e-9:
                continue  # the carriage never passes there
            runs.append((fid, a, c_lo, c_hi))
    t_lo = cruise.time_at(np.array([max(r[2], cruise.x0) for r in runs]))  # all at once: one vectorised bisection
    c_his = np.array([r[3] for r in runs])
    # (a run that ends where the carriage starts lasts while the carriage rests there: a start hold)
    t_hi = np.where(c_his <= cruise.x0 + 1e-12, cruise.leaves_start, cruise.time_at(c_his))
    out: dict[str, list[Window]] = {fid: [] for fid in reach.harvestable()}
    settle = problem.gantry.settle
    # no dwell within ``settle`` of the carriage coming to rest after a move (its vibration dies out)
    bans = [(ta - dwell, ta + settle) for ta in cruise.arrivals()] if settle > 0 else []
    for (fid, a, c_lo, c_hi), lo, hi in zip(runs, t_lo.tolist(), t_hi.tolist()):
        # past x1 the carriage rests inside the run: no end to the window
        hi = math.inf if c_hi >= cruise.x1 - 1e-9 else hi - dwell
        for lo2, hi2 in _settled(lo, hi, bans):
            out[fid].append(Window(a, lo2, hi2, c_lo, c_hi))
    return out


def _settled(lo: float, hi: float, bans: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """``[lo, hi]`` less the open intervals ``bans`` (sorted): what is left, in pieces."""
    out = []
    for b0, b1 in bans:
        if b1 <= lo or b0 >= hi:
            continue
        if b0 >= lo:
            out.append((lo, b0))
        lo = max(lo, b1)
    if hi >= lo:
        out.append((lo, hi))
    return out


def demand_stretches(problem: Problem, reach: RowReach, x1: float, stretch: float = STRETCH) -> list[tuple[float, float]]:
    """``[(x_end, demand), ...]``: the arms' time the fruit ask of each stretch of rail (s per m).

    Each fruit asks for its cheapest harvest cycle (:func:`coplan.allocate.row_cycles.cycle_bounds`: the
    least over arms and carriage positions), spread evenly over the carriage positions from
    which some arm serves it. A carriage that spends ``demand / n_arms`` per metre of a stretch
    gives the arms, working side by side, as much time as its fruit need (if they balanced
    perfectly): :meth:`Cruise.shaped` speeds are ``pace * n_arms / demand``."""
    from ..allocate.row_cycles import cycle_bounds

    g = problem.gantry
    edges = np.arange(g.start, x1 + stretch, stretch)
    if edges.size < 2:  # the carriage need not move (every fruit served from where it starts): one stretch
        edges = np.array([g.start, g.start + stretch])
    edges[-1] = max(edges[-1], x1)
    need = np.zeros(edges.size - 1)
    cost = cycle_bounds(problem, limits=False)[0]  # (limits=False: the estimates the speed search was tuned on; the bounds take the limits)
    col = {f.id: k for k, f in enumerate(problem.fruits)}
    for fid in reach.harvestable():
        c = cost[:, col[fid]]
        c = float(np.min(c[np.isfinite(c)])) if np.isfinite(c).any() else 0.0
        lo, hi = (float(reach.grid[k]) for k in reach.span(fid))
        hi = max(hi, lo + 1e-6)
        share = np.clip(np.minimum(edges[1:], hi) - np.maximum(edges[:-1], lo), 0.0, None) / (hi - lo)
        if share.sum() <= 0:  # served only beyond x1 (the carriage rests there): the last stretch
            share[-1] = 1.0
        need += c * share / share.sum()
    return [(float(e), float(d) / stretch) for e, d in zip(edges[1:], need)]
