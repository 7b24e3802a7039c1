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

*Weights.* A stop lasts at least its *busiest* arm's cycles, and the mean over the arms (each
fruit ``min_a cost_a / A``) forgets which arm a fruit needs: with stops close together each arm
reaches only the fruit in front of it, and one arm's share sets the stop. For any weights
``lam_a(c) >= 0`` summing to 1 in each cell, a stop in cell ``c`` lasts at least ``sum_a
lam_a(c) X_a`` (``X_a`` its arm ``a``'s cycles there) ``>= sum_f min_a lam_a(c) cost_a(f, c)``
over the fruit it picks: the programme with ``w_f(c) = min_a lam_a(c) cost_a(f, c)`` is a bound
for *every* choice of weights (two stops in one cell share its weights, so they still merge;
an arm's home saving is taken off at its heaviest weight). Equal weights give the mean. The
best weights make the programme's witness pay each cell's busiest arm (the dual of the
min-max assignment of its fruit); :func:`weighted_bound` climbs towards them by projected
subgradient steps -- a round's subgradient is each fruit's cycle bound, at the cell and by the
arm its witness charges -- on cells twice as coarse (a round there costs about an eighth), and
prices the best weights found on the bound's own cells; the bound is the larger of that and
the equal weights' value. Raised the shipped rows' bound by 3.3-4.7 % (course_row 343.9 ->
360.2 s; 359.8 s since the programme's sums are exact, below). Tested against brute force over
every set of stops and every assignment of fruit to stops and arms on seeded random rows, for
the weights it finds and for random ones.

*Exact sums.* The programme's times are rounded down to multiples of 2^-30 s (:data:`QUANTUM`:
each term less by at most a nanosecond, so still a bound); every sum it takes is then exact,
and the same value and witness come out whatever the order of the fruit or of the additions
(tested with the fruit permuted), which lets its sums be taken per reference cell, vectorised.

Work overlapping the carriage's moves (coplan's plans place and come out while it moves) can
beat it by at most that overlap, as for the plain bound.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from ..kinematics.timing import accel_time, scurve_times
from ..problem.model import Problem
from .row_cycles import CellCycles, cell_cycles, home_savings

__all__ = ["Programme", "StopsBound", "Weighted", "stops_bound", "fruit_cell_costs", "weighted_costs", "weighted_bound",
           "stops_dp", "settle_floor"]

STEP = 0.1  # m: the rail cells of the programme (finer cells price a fruit's position closer, pairs of moves less)
ROUNDS = 60  # rounds of arm weights after the equal ones (module docstring, *Weights*)
COARSE = 2  # the weight rounds run on cells this many times the bound's (each about an eighth of its programme)
ETA = 0.3  # the first round's step on the weights (each round's step: ETA / sqrt(round), the heaviest load 1)


@dataclass(frozen=True)
class StopsBound:
    """:func:`stops_bound`: ``value`` (s) the bound; ``moves`` and ``work`` its two parts at the
    relaxation's optimum (s); ``stops`` that optimum's stops (m, each its cell's lower end: where
    the bound's cheapest stop-by-stop plan would stop -- a witness, not a plan); ``arms`` the
    arms that harvest (whose weighted mean it charges); ``step`` the cell size (m); ``seconds`` its
    computing time; ``uniform`` its value with equal weights, ``rounds`` the weight rounds run,
    ``weights`` (cells, arms that harvest) the weights of its value, over the cells from the
    rail's start to the last that some arm reaches some fruit from."""

    value: float
    moves: float
    work: float
    stops: tuple
    arms: int
    step: float
    seconds: float = 0.0
    uniform: float = 0.0  # the value with equal weights over the arms (each fruit its cheapest arm's cycle over their number)
    rounds: int = 0  # the weight rounds run after the equal ones
    weights: np.ndarray | None = field(default=None, compare=False, repr=False)  # (N, K): per cell, over the harvesting arms


def fruit_cell_costs(cc: CellCycles) -> tuple[np.ndarray, np.ndarray, int]:
    """``(first (F,), w (F, W), A)``: per fruit, ``w_f(c) = min_a cost_a(f, c) / A`` for the cells
    ``first[f] + 0 .. W - 1`` (inf where no arm reaches it from there), over the ``A`` arms
    that harvest (the others have no cycles in ``cc``)."""
    arms = [a for a in range(len(cc.cost)) if cc.cost[a] is not None]
    F = cc.reach.shape[1]
    if not arms or F == 0:
        return np.zeros(F, dtype=int), np.full((F, 1), np.inf), len(arms)
    first, w, _, _ = weighted_costs([cc.band(a) for a in arms], cc.lo.size, np.full((cc.lo.size, len(arms)), 1.0 / len(arms)))
    return first, w, len(arms)


def stops_bound(problem: Problem, step: float = STEP, rounds: int = ROUNDS) -> StopsBound:
    """The bound (module docstring) on ``problem``'s row (which has a gantry), with rail cells of
    ``step`` m and ``rounds`` rounds of arm weights after the equal ones (0: the equal weights
    alone, ``uniform``); counts the fruit some arm reaches from some cell. Its value is inf where
    some fruit an arm reaches could be picked by no stop-by-stop plan (none here: a fruit within
    reach of some cell is within reach of a stop there)."""
    t0 = time.perf_counter()
    if isinstance(rounds, bool) or not isinstance(rounds, (int, np.integer)) or rounds < 0:
        raise ValueError(f"rounds: expected a whole number of weight rounds >= 0, found {type(rounds).__name__} {rounds!r}")
    g = problem.gantry
    lim = (g.max_velocity, g.max_acceleration, g.max_jerk)
    bands, savings, floor = _charges(problem, step)
    if not bands or bands[0][0].shape[0] == 0:
        return StopsBound(0.0, 0.0, 0.0, (), len(bands), step, time.perf_counter() - t0)
    N = _rail_used(bands)
    best = weighted_bound(bands, N, step, *lim, floor, savings, 0)  # equal weights
    uniform, done = best.value, 0
    if rounds and len(bands) > 1:  # the weights searched on coarser cells, then priced on these
        bands2, savings2, floor2 = _charges(problem, step * COARSE)
        N2 = _rail_used(bands2)
        coarse = weighted_bound(bands2, N2, step * COARSE, *lim, floor2, savings2, rounds)
        lam = coarse.weights[np.minimum(np.arange(N) // COARSE, N2 - 1)]
        found = weighted_bound(bands, N, step, *lim, floor, savings, 0, start=lam)
        best, done = (found if found.value > best.value else best), coarse.rounds
    return StopsBound(best.value, best.moves, best.work, tuple(float(g.start + c * step) for c in best.stops), len(bands),
                      step, time.perf_counter() - t0, uniform, done, best.weights)


def _rail_used(bands: list) -> int:
    """The cells the programme needs (and ``bands`` clipped to them, in place): up to the last
    that some arm reaches some fruit from. A stop past it serves no fruit, and leaving it out
    takes its move off and charges no fruit more (a fruit whose best cell lies before it is
    charged at the stops before, as it was), so every cheapest set of stops lies within: the
    same bound, in the time of the rail the fruit use (an 8 km rail for 8 m of fruit took
    minutes)."""
    n = max(int(np.max(np.where(np.isfinite(t), c, -1), initial=-1)) for c, t in bands) + 1
    for k, (c, t) in enumerate(bands):
        bands[k] = (np.minimum(c, max(n - 1, 0)), t)
    return max(n, 1)


def _charges(problem: Problem, step: float) -> tuple[list, np.ndarray, float]:
    """``(bands, savings, settle floor)`` of ``problem`` on cells of ``step`` m: per
    harvesting arm its band (:meth:`CellCycles.band`) over the fruit some arm reaches, its home
    saving at one cell, and the floor each stop after a move adds."""
    cc = cell_cycles(problem, step)
    arms = [a for a in range(len(cc.cost)) if cc.cost[a] is not None]
    ok = cc.reach[arms].any(axis=0) if arms else np.zeros(cc.reach.shape[1], dtype=bool)
    bands = [tuple(x[ok] for x in cc.band(a)) for a in arms]
    return bands, home_savings(cc, per_cell=True)[arms], settle_floor(problem, cc)


class Weighted(NamedTuple):
    """:func:`weighted_bound`'s answer: ``value`` the best bound over its rounds (s), ``moves`` and
    ``work`` its parts, ``stops`` its witness's cells, ``uniform`` the value with equal weights
    (round 0), ``rounds`` the rounds run after it, ``weights`` (N, K) the best round's."""

    value: float
    moves: float
    work: float
    stops: list
    uniform: float
    rounds: int
    weights: np.ndarray


def weighted_costs(bands: list, N: int, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``(first (F,), w (F, W), arm (F, W), raw (F, W))`` for the programme: per fruit,
    ``w_f(c) = min_k lam[c, k] cost_k(f, c)`` over the harvesting arms' ``bands`` (per arm ``(cells
    (F, W_k), cost (F, W_k))``, :meth:`CellCycles.band`) in the cells ``first + 0 .. W - 1`` (inf
    where no arm reaches it from there), the arm (index into ``bands``) that attains it and that
    arm's cycle bound there. ``lam`` (N, K): each cell's weights, each row summing to 1."""
    K = len(bands)
    F = bands[0][0].shape[0]
    first = np.min([c[:, 0] for c, _ in bands], axis=0)
    W = int((np.max([c[:, -1] for c, _ in bands], axis=0) - first).max()) + 1
    wk, rk = np.full((K, F, W), np.inf), np.full((K, F, W), np.inf)
    for k, (cells, t) in enumerate(bands):
        at = (np.broadcast_to(np.arange(F)[:, None], t.shape), cells - first[:, None])
        np.minimum.at(rk[k], at, t)  # (a cell's weight is one: its least weighted cost is its least cost's)
        np.minimum.at(wk[k], at, np.where(np.isfinite(t), lam[cells, k] * np.where(np.isfinite(t), t, 0.0), np.inf))
    arm = np.argmin(wk, axis=0)
    pick = arm[None]
    return first, np.take_along_axis(wk, pick, 0)[0], arm, np.take_along_axis(rk, pick, 0)[0]


def weighted_bound(bands: list, N: int, step: float, v: float, acc: float, jerk: float, per_stop: float = 0.0,
                   savings: np.ndarray | None = None, rounds: int = ROUNDS, start: np.ndarray | None = None) -> Weighted:
    """The programme (:func:`stops_dp`) with each fruit charged ``min_k lam_k(c) cost_k(f, c)`` at
    the cell ``c`` it is picked from, for weights ``lam`` per cell over the harvesting arms (module
    docstring, *Weights*): first equal (the mean over the arms), then ``rounds`` projected
    subgradient steps, each towards the arms the last witness loaded most in each cell; the best
    value over every round, each a valid bound. ``bands``: per harvesting arm, ``(cells (F, W_k),
    cost (F, W_k))`` over the fruit to charge (each finite somewhere); ``savings`` (K,): each arm's
    most a first cycle from home saves at one cell (:func:`coplan.allocate.row_cycles.home_savings`
    ``per_cell``), weighted by its heaviest cell's weight."""
    K = len(bands)
    savings = np.zeros(K) if savings is None else np.asarray(savings, float)
    lam = np.full((N, K), 1.0 / K) if start is None else np.asarray(start, float)
    best = None
    rounds = int(rounds) if K > 1 else 0  # (one arm: its weight is 1 everywhere)
    uniform = np.inf
    for r in range(rounds + 1):
        first, w, arm, raw = weighted_costs(bands, N, lam)
        value, stops, work, _ = stops_dp(first, w, N, step, v, acc, jerk, per_stop)
        if not np.isfinite(value):
            return Weighted(float("inf"), float("inf"), float("inf"), [], float("inf"), r, lam)
        moves = value - work
        work = max(0.0, work - float((lam.max(axis=0) * savings).sum()))
        if r == 0:
            uniform = moves + work
        if best is None or moves + work > best[0]:
            best = (moves + work, moves, work, stops, lam)
        if r == rounds:
            break
        # the subgradient: each fruit's cycle bound, by the arm and at the cell the witness charges it
        F, W = w.shape
        rows = np.arange(F)
        ref = first + np.where(np.isfinite(w), w, np.inf).argmin(axis=1)  # each fruit's reference (best) cell
        cs = np.asarray(stops, dtype=np.int64)
        i = np.searchsorted(cs, ref, "left") - 1  # cs[i] < ref <= cs[i + 1]
        left = np.where(i >= 0, cs[np.clip(i, 0, max(cs.size - 1, 0))] - first, -1) if cs.size else np.full(F, -1)
        right = np.where(i + 1 < cs.size, cs[np.clip(i + 1, 0, max(cs.size - 1, 0))] - first, W) if cs.size else np.full(F, W)
        cols = np.arange(W)[None, :]
        masked = np.where((cols <= left[:, None]) | (cols >= right[:, None]), w, np.inf)
        j = masked.argmin(axis=1)
        hit = np.isfinite(masked[rows, j])
        G = np.zeros((N, K))
        np.add.at(G, (first[hit] + j[hit], arm[rows[hit], j[hit]]), raw[rows[hit], j[hit]])
        top = G.max()
        if top <= 0:
            break
        lam = _onto_simplex(lam + (ETA / math.sqrt(r + 1)) * G / top)
    value, moves, work, stops, lam = best
    return Weighted(float(value), float(moves), float(work), [int(c) for c in stops], float(uniform), rounds, lam)


def _onto_simplex(V: np.ndarray) -> np.ndarray:
    """Each row of ``V`` projected (Euclidean) onto the probability simplex."""
    n = V.shape[1]
    U = -np.sort(-V, axis=1)
    css = np.cumsum(U, axis=1) - 1.0
    rho = n - 1 - np.argmax((U - css / np.arange(1, n + 1))[:, ::-1] > 0, axis=1)
    theta = css[np.arange(V.shape[0]), rho] / (rho + 1)
    return np.maximum(V - theta[:, None], 0.0)


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
    # every time on a grid of 2^-30 s, rounded down (the bound stays a bound, lower by at most a
    # nanosecond a term): its sums are then exact, the same in whatever order they are taken
    w, per_stop = _on_grid(w), float(_on_grid(per_stop))
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

    cruise = v * accel_time(v, acc, jerk)  # a rest-to-rest move that reaches its top speed covers this much
    Gl, Gr = int((r_f - lo_f).max()), int((hi_f - r_f).max())
    H = max(Gl + Gr + 2, int(math.ceil(cruise / step)) + 2)  # gaps of up to H cells: pair states
    K = N + 2 * H + 2
    T = _on_grid(scurve_times(np.arange(K) * step, v, acc, jerk))  # T[k]: the rest-to-rest move over k cells
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
    step_v = float(_on_grid(step / v))  # (k cells past H at most k step_v + C: T's slope on the grid, rounded down)
    C = float(T[H] - H * step_v)
    nxt = np.append(rs, 2 * N + H + 10)[np.searchsorted(rs, cells + Gl, "right")]  # first reference past s + Gl

    # S[n, k - 1]: the fruit with n - k < r_f <= n, each min(L(n - k), R(n)) -- the fruit between a
    # stop at n and the stop k cells before it, for every n and k at once (a fruit r_f - a, r_f + b)
    # Lm[f, a - 1] = L(f, r_f - a), a = 1 .. H; Rm[f, b] = R(f, r_f + b), b = 0 .. H - 1 (fruit in r_f order)
    fa = order[:, None]
    Lm, Rm = L(fa, rs[:, None] - np.arange(1, H + 1)[None, :]), R(fa, rs[:, None] + np.arange(H)[None, :])
    S, near_s, near_n = _sums(Lm, Rm, rs, N, Gl, Gr)

    PT = np.ascontiguousarray(P.T)  # PT[k - 1, d - 1]: a gap of k cells after one of d
    halfT = 0.5 * T[:H]
    via, ar = np.empty((H, H)), np.arange(H)
    for n in range(1, N + 1):
        m = min(H, n)  # the gap to the previous stop, k = 1 .. m cells: stops s = n - 1 .. n - m
        vk = via[:m]
        np.add(V[n - m:n][::-1], PT[:m], out=vk)  # (k, H): from the pair state (s - d, s)
        j = vk.argmin(axis=1)
        via_pair = vk[ar[:m], j]
        via_b = Bd[n - m:n][::-1] + halfT[:m]
        here = per_stop if n >= 2 else 0.0
        V[n, :m] = np.minimum(via_pair, via_b) + S[n, :m] + here
        arg_v[n, :m] = np.where(via_b <= via_pair, -1, j)
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
    # each fruit past the last stop n (r_f > n) at its least up to n: pre[f, n - base_f] (inf before its band)
    past = np.zeros(N + 1)
    j = np.arange(Wb)[None, :]
    at = base[:, None] + j
    ok = (at < r_f[:, None]) & (at <= N)
    np.add.at(past, at[ok], pre[np.broadcast_to(np.arange(F)[:, None], at.shape)[ok], np.broadcast_to(j, at.shape)[ok]])
    past[:min(N + 1, int(base.max()))] = np.inf  # (a fruit whose band starts past n: no stop serves it)
    total = leave + past
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


QUANTUM = 2.0 ** -30  # s: the programme's times are multiples of this (exact sums up to 2^23 s)


def _on_grid(x):
    """``x`` (s) rounded down to a multiple of :data:`QUANTUM` (inf stays inf)."""
    return np.floor(np.asarray(x, float) / QUANTUM) * QUANTUM


def _sums(Lm: np.ndarray, Rm: np.ndarray, rs: np.ndarray, N: int, Gl: int, Gr: int) -> tuple:
    """:func:`stops_dp`'s sums over the fruit (``rs`` (F,): their reference cells, ascending;
    ``Lm[f, a - 1]`` their least cost up to ``rs[f] - a``, ``Rm[f, b]`` from ``rs[f] + b`` on,
    both (F, H)), each fruit with the same reference cell adding to the same cells, summed
    group by group (exact: the costs are on :data:`QUANTUM`'s grid): ``S`` (N + 1, H), the fruit
    between a stop at ``n`` and one ``k`` cells before it, each at the cheaper of the two
    (``S[n, k - 1]``: ``n - k < r_f <= n``); ``near_s`` (N + 1,), the fruit with ``c < r_f <=
    c + Gl`` each at its least up to ``c``; ``near_n`` (N + 1,), those with ``c - Gr - 1 < r_f
    <= c`` each at its least from ``c`` on."""
    H = Lm.shape[1]
    starts = np.flatnonzero(np.r_[True, rs[1:] != rs[:-1]])
    ref = rs[starts]
    S = np.zeros((N + 1, H))
    for b in range(H):  # a fruit b cells before the stop at n = r_f + b, the one before it a cells before r_f:
        rows = ref + b  # S[n, a + b - 1] for a = 1 .. H - b
        ins = rows <= N
        if not ins.any():
            break
        S[rows[ins], b:] += np.add.reduceat(np.minimum(Lm[:, :H - b], Rm[:, b:b + 1]), starts, axis=0)[ins]
    near_s, near_n = np.zeros(N + 1), np.zeros(N + 1)
    for a in range(1, Gl + 1):
        at = ref - a
        ok = (at >= 0) & (at <= N)
        near_s[at[ok]] += np.add.reduceat(Lm[:, a - 1], starts)[ok]
    for b in range(Gr + 1):
        at = ref + b
        ok = at <= N
        near_n[at[ok]] += np.add.reduceat(Rm[:, b], starts)[ok]
    return S, near_s, near_n


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
