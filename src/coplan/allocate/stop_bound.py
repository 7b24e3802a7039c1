"""A lower bound for stop-by-stop row plans that prices where the carriage stops and what its
stops cost together: :func:`stops_bound`.

The plain stop-and-go bound (:mod:`coplan.allocate.row_bound`) charges every fruit its cycle
from its *best* carriage position and the carriage one move over the whole row: as if there
were a stop at every fruit's best position, for free. This one lets a plan choose its stops
and prices both: fewer stops cost each fruit more (it is picked further from its best
position), more stops cost the carriage more (each is a rest-to-rest move).

**The model.** A stop-by-stop plan, cell work only while the carriage stands still, stops at
positions ``p_1, p_2, ...`` (in any order, revisits allowed), starting at rest at ``start``:

* *Moves.* With ``T(d)`` the time-optimal rest-to-rest move over ``d`` (increasing, and
  subadditive: two moves make one over the sum), the moves of any visiting order take at least
  those of the sorted distinct positions, from ``start`` (by induction on the last-visited
  stop: inserting a position ``p`` between sorted neighbours ``q < p < q'`` adds
  ``T(p - q) + T(q' - p) - T(q' - q) <= min(T(p - q), T(q' - p))``, no more than the move that
  reached ``p``).
* *Work.* Each arm's cycles never overlap and each lasts at least its cycle bound with the
  carriage where it picks (:func:`coplan.allocate.row_cycles.cell_cycles`), so the stops last at
  least the busiest arm's cycles, at least their mean over the ``A`` arms that harvest: every
  fruit costs at least ``w_f(p) = min_a cost_a(f, p) / A`` at the stop that picks it. Every
  arm's first cycle starts at home, which may save it some of its cycle bound
  (:func:`coplan.allocate.row_cycles.home_savings`, per cell, as each fruit is charged at its
  stop's cell): the mean of those savings is taken off.

Positions are taken to rail cells of ``step`` m (stops in one cell merge: no move is added and
no fruit costs more, as a cell's cost is its least over the cell; fewer moves by
subadditivity). For sorted distinct cells ``c_0 = start < c_1 < ... < c_K`` the gaps are at
least ``(c_k - c_{k-1} - 1) step`` -- 0 for neighbouring cells, which alone would let a stop
in every cell cost nothing -- so each pair of consecutive gaps is priced too: ``T(g_k) +
T(g_{k+1}) >= max(T(lb_k) + T(lb_{k+1}), T(lb(c_{k-1}, c_{k+1})))`` (subadditivity), and the
moves are ``sum_k T(g_k) = T(g_1) / 2 + sum_k (T(g_k) + T(g_{k+1})) / 2 + T(g_K) / 2``. A
fruit whose reference cell ``r_f`` (its best) lies in ``(c_i, c_{i+1}]`` is picked at a stop
at or before ``c_i`` or at or after ``c_{i+1}``: it costs at least ``min(L_f(c_i),
R_f(c_{i+1}))``, the least of ``w_f`` over the cells up to ``c_i`` and from ``c_{i+1}`` on.

A dynamic programme over the cells minimises the sum -- a lower bound on every stop-by-stop
plan's row time. State: the last two stops' cells, for gaps of up to ``H`` cells (at least two
fruit reach bands and the distance at which a move reaches its top speed); a longer gap is one
move, charged whole: past that distance ``T`` grows by exactly ``d / v_max``, so the best stop
to come from is a running minimum, and no stop past it or before it can reach a fruit whose
best cell lies in its middle (none may), only the stop before it those just after it, only the
stop after it those just before it. Tested against brute force over every set of stops on
seeded random rows (``tests/test_stop_bound.py``).

*Settling.* Where the gantry settles after a move (``gantry.settle``), each stop past the
first cell adds :func:`settle_floor`: no arm picks before the settle is over, and within it an
arm can only end the last stop's cycle (back to the bin, the place) and make its way to its
first fruit here.

Work overlapping the carriage's moves (coplan's plans place and come out while it moves) can
beat it by at most that overlap, as for the plain bound.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from ..kinematics.timing import scurve_times
from ..problem.model import Problem
from .row_cycles import CellCycles, cell_cycles, home_savings

__all__ = ["Programme", "StopsBound", "stops_bound", "fruit_cell_costs", "stops_dp", "settle_floor"]

STEP = 0.1  # m: the rail cells of the programme (finer cells price a fruit's position closer, pairs of moves less)


@dataclass(frozen=True)
class StopsBound:
    """:func:`stops_bound`: ``value`` (s) the bound; ``moves`` and ``work`` its two parts at the
    relaxation's optimum (s); ``stops`` that optimum's stops (m, each its cell's lower end: where
    the bound's cheapest stop-by-stop plan would stop -- a witness, not a plan); ``arms`` the
    arms whose mean it charges; ``step`` the cell size (m); ``seconds`` its computing time."""

    value: float
    moves: float
    work: float
    stops: tuple
    arms: int
    step: float
    seconds: float = 0.0


def fruit_cell_costs(cc: CellCycles) -> tuple[np.ndarray, np.ndarray, int]:
    """``(first (F,), w (F, W), A)``: per fruit, ``w_f(c) = min_a cost_a(f, c) / A`` for the cells
    ``first[f] + 0 .. W - 1`` (inf where no arm reaches it from there), over the ``A`` arms
    that harvest (the others have no cycles in ``cc``)."""
    arms = [a for a in range(len(cc.cost)) if cc.cost[a] is not None]
    F, N = cc.reach.shape[1], cc.lo.size
    if not arms or F == 0:
        return np.zeros(F, dtype=int), np.full((F, 1), np.inf), len(arms)
    first = np.min([cc.first[a] for a in arms], axis=0)
    last = np.max([np.minimum(cc.first[a] + cc.cost[a].shape[1] - 1, N - 1) for a in arms], axis=0)
    w = np.full((F, int((last - first).max()) + 1), np.inf)
    for a in arms:
        cells, t = cc.band(a)
        np.minimum.at(w, (np.broadcast_to(np.arange(F)[:, None], t.shape), cells - first[:, None]), t)
    return first, w / len(arms), len(arms)


def stops_bound(problem: Problem, step: float = STEP) -> StopsBound:
    """The bound (module docstring) on ``problem``'s row (which has a gantry), with rail cells of
    ``step`` m; counts the fruit some arm reaches from some cell. Its value is inf where some
    fruit an arm reaches could be picked by no stop-by-stop plan (none here: a fruit within
    reach of some cell is within reach of a stop there)."""
    t0 = time.perf_counter()
    g = problem.gantry
    cc = cell_cycles(problem, step)
    first, w, arms = fruit_cell_costs(cc)
    ok = np.isfinite(w).any(axis=1)
    if not ok.any():
        return StopsBound(0.0, 0.0, 0.0, (), arms, step, time.perf_counter() - t0)
    value, stops, work, _ = stops_dp(first[ok], w[ok], cc.lo.size, step, g.max_velocity, g.max_acceleration, g.max_jerk,
                                     settle_floor(problem, cc))
    moves = value - work
    # each arm's first cycle, from home: charged at its stop's cell, so the most it saves in one cell
    work = max(0.0, work - float(home_savings(cc, per_cell=True).sum()) / max(1, arms))
    return StopsBound(moves + work, moves, work, tuple(float(g.start + c * step) for c in stops), arms, step,
                      time.perf_counter() - t0)


def settle_floor(problem: Problem, cc: CellCycles) -> float:
    """What each stop after a move adds at least, from ``gantry.settle`` (s): no arm picks until
    the carriage has settled. Within the settle an arm may still finish the last stop's cycle (its
    way from the fruit back to the bin and the place dwell: coplan's plans place as the carriage
    leaves) and make its way to this stop's first fruit -- each way at most the longest bin <->
    fruit move a cycle bound counts (half a cycle less its dwells, over every arm, fruit and cell;
    ``cc``). So the stops last at least ``settle`` less two such ways and a place dwell beyond
    the cycles they are charged. 0 where the settle is shorter."""
    settle = problem.gantry.settle
    dw = problem.task.pick_dwell + problem.task.place_dwell
    longest = max((float(np.max(c[np.isfinite(c)], initial=dw)) for c in cc.cost if c is not None), default=dw)
    way = 0.5 * (longest - dw)  # the longest bin -> fruit (or fruit -> bin) move a cycle bound counts
    return max(0.0, settle - (2.0 * way + problem.task.place_dwell))


class Programme(NamedTuple):
    """:func:`stops_dp`'s answer: ``value`` the least of moves plus charged work over every set of
    stop cells, ``stops`` the cells (0-based) of a set that attains it, ``work`` its work part,
    ``span`` the longest gap (cells) priced in pairs -- a longer one is one move, charged whole."""

    value: float
    stops: list
    work: float
    span: int


def stops_dp(first: np.ndarray, w: np.ndarray, N: int, step: float, v: float, acc: float, jerk: float,
             per_stop: float = 0.0) -> Programme:
    """The dynamic programme (module docstring) over ``N`` rail cells of ``step`` m from the
    start, the fruit's costs ``w`` (F, W) in the cells ``first + 0 .. W - 1`` (each fruit
    finite somewhere), the carriage's limits ``v``, ``acc``, ``jerk``; ``per_stop`` (s) is
    charged for each stop past the first cell (the settle floor, :func:`settle_floor`: a stop in
    the first cell may be where the carriage starts, with no move to settle from). Its value is
    inf if some fruit no set of stops can serve."""
    F, Wb = w.shape
    # index 0 is the start (the carriage at rest at the rail's start, the lower end of the first
    # cell), cells 1 .. N: a gap from index s to n is at least (n - s - 1) steps
    fin = np.isfinite(w)
    base = first + 1  # index of each fruit's column 0
    lo_f = base + fin.argmax(axis=1)  # first cell that reaches the fruit
    hi_f = base + Wb - 1 - fin[:, ::-1].argmax(axis=1)  # last
    r_f = base + np.where(fin, w, np.inf).argmin(axis=1)  # its best cell: the reference
    pre = np.minimum.accumulate(w, axis=1)  # least up to each column
    suf = np.minimum.accumulate(w[:, ::-1], axis=1)[:, ::-1]  # least from each column on

    def L(f, c):  # least w_f over cells <= c (inf before the band; the band's least after it)
        j = c - base[f]
        return np.where(j < 0, np.inf, pre[f, np.clip(j, 0, Wb - 1)])

    def R(f, c):  # least w_f over cells >= c
        j = c - base[f]
        return np.where(j >= Wb, np.inf, suf[f, np.clip(j, 0, Wb - 1)])

    cruise = v * ((v / acc + acc / jerk) if v >= acc * acc / jerk else 2.0 * math.sqrt(v / jerk))  # top speed reached
    Gl, Gr = int((r_f - lo_f).max()), int((hi_f - r_f).max())
    H = max(Gl + Gr + 2, int(math.ceil(cruise / step)) + 2)  # gaps of up to H cells: pair states
    K = N + 2 * H + 2
    T = scurve_times(np.arange(K) * step, v, acc, jerk)  # T[k]: the rest-to-rest move over k cells
    k_all = np.arange(1, H + 1)
    # both halves of a pair's price, P[d - 1, e - 1], gaps of d then e cells: (d-1), (e-1), (d+e-1) steps at least
    P = 0.5 * np.maximum(T[k_all[:, None] - 1] + T[k_all[None, :] - 1], T[k_all[:, None] + k_all[None, :] - 1])
    order = np.argsort(r_f, kind="stable")
    rs = r_f[order]
    cells = np.arange(N + 1)
    V = np.full((N + 1, H), np.inf)  # V[n, d-1]: stops at n - d and at n (a pair state), half of the last gap owed
    Bd = np.full(N + 1, np.inf)  # a stop at n after a gap of more than H cells (or the start): no half owed
    Bd[0] = 0.0
    arg_v = np.zeros((N + 1, H), dtype=np.int64)  # the previous pair state's gap index; -1: from Bd
    arg_b = np.zeros(N + 1, dtype=np.int64)  # the stop a long gap came from
    leave = np.full(N + 1, np.inf)  # the value at stop n with every half owed paid
    leave_from = np.full(N + 1, -1, dtype=np.int64)
    leave[0] = 0.0
    # a long gap s -> n (n - s > H) costs T((n-s-1) step) = (n-s-1) step / v + C (past the top speed's distance);
    # the fruit just past s their least up to s (no later stop is within their reach) and those just before n
    # their least from n; a fruit between those can be picked by neither: none may have r_f in (s + Gl, n - Gr - 1]
    step_v = step / v
    C = float(T[H] - H * step_v)
    near_s = np.array([L(order[np.searchsorted(rs, c, "right"):np.searchsorted(rs, c + Gl, "right")], c).sum() for c in cells])
    near_n = np.array([R(order[np.searchsorted(rs, c - Gr - 1, "right"):np.searchsorted(rs, c, "right")], c).sum()
                       for c in cells])
    nxt = np.append(rs, 2 * N + H + 10)[np.searchsorted(rs, cells + Gl, "right")]  # first reference past s + Gl

    def fruit_sum(s_arr, n):  # per s in s_arr: the fruit with s < r_f <= n, each min(L(s), R(n))
        fs = order[np.searchsorted(rs, s_arr.min(), "right"):np.searchsorted(rs, n, "right")]
        if fs.size == 0:
            return np.zeros(s_arr.size)
        m = np.minimum(L(fs[:, None], s_arr[None, :]), R(fs, n)[:, None])
        return np.where(r_f[fs][:, None] > s_arr[None, :], m, 0.0).sum(axis=0)

    for n in range(1, N + 1):
        k = np.arange(1, min(H, n) + 1)  # the gap to the previous stop, in cells
        s = n - k
        via = V[s] + P[:, k - 1].T  # (k, H): from the pair state (s - d, s)
        j = via.argmin(axis=1)
        via_pair = via[np.arange(k.size), j]
        via_b = Bd[s] + 0.5 * T[k - 1]
        here = per_stop if n >= 2 else 0.0
        V[n, k - 1] = np.minimum(via_pair, via_b) + fruit_sum(s, n) + here
        arg_v[n, k - 1] = np.where(via_b <= via_pair, -1, j)
        s_hi = n - H - 1  # a long gap from a stop s <= s_hi with nxt[s] > n - Gr - 1 (nxt rises with s: a range of s)
        if s_hi >= 0:
            s_lo = int(np.searchsorted(nxt[:s_hi + 1], n - Gr - 1, "right"))
            if s_lo <= s_hi:
                cand = leave[s_lo:s_hi + 1] + near_s[s_lo:s_hi + 1] - cells[s_lo:s_hi + 1] * step_v
                i = int(np.argmin(cand))
                Bd[n] = cand[i] + (n - 1) * step_v + C + near_n[n] + here
                arg_b[n] = s_lo + i
        owed = V[n] + 0.5 * T[:H]
        i = int(np.argmin(owed))
        leave[n], leave_from[n] = (owed[i], i) if owed[i] < Bd[n] else (Bd[n], -1)
    # the end: every fruit past the last stop is picked from it or before
    total = leave + np.array([L(order[np.searchsorted(rs, n, "right"):], n).sum() for n in cells])
    n_end = int(np.argmin(total))
    value = float(total[n_end])
    if not np.isfinite(value):
        return Programme(float("inf"), [], float("inf"), H)
    stops = _witness(n_end, leave_from, arg_v, arg_b)
    cs = np.array([0] + stops)  # the witness's work: each fruit at the cheaper side of its reference cell
    i = np.searchsorted(cs, r_f, "left") - 1  # r_f in (cs[i], cs[i + 1]]
    f = np.arange(F)
    right = np.where(i + 1 < cs.size, R(f, cs[np.minimum(i + 1, cs.size - 1)]), np.inf)
    work = float(np.minimum(L(f, cs[i]), right).sum())
    return Programme(value, [c - 1 for c in stops], work, H)


def _witness(n_end: int, leave_from, arg_v, arg_b) -> list[int]:
    """The programme's stops (indices, the start left out), back from ``n_end``."""
    stops, n, state = [], n_end, int(leave_from[n_end])  # state: a pair state's gap index, or -1 (after a long gap)
    while n > 0:
        stops.append(n)
        if state >= 0:
            n, state = n - (state + 1), int(arg_v[n, state])
        else:
            n = int(arg_b[n])
            state = int(leave_from[n])
    return sorted(stops)
