"""Where the carriage stops, and which fruit each stop harvests: three rules.

* ``fixed`` (:func:`fixed_stops`) -- a stop every *carriage span* (the median width of row
  over which a fruit stays in the arms' reach), the first one as far along as still serves the
  first fruit; fruit no stride stop serves get extra stops (fewest-stops rule on them). The
  analogue of a camera-frame rule: advance by what the cell sees.
* ``fewest`` (:func:`fewest_stops`) -- the fewest stops that serve every fruit: greedy
  interval stabbing (at the last position that still serves the fruit whose window closes
  first), exact for fruit whose serving positions are intervals; where a fruit several arms
  serve breaks that and the greedy takes more than a packing bound, a set-cover MILP.
* ``optimised`` (:func:`optimised_stops`) -- chosen with the arms, segment by segment along
  the rail (a receding horizon: the carriage starts once the first segment is decided). In each
  segment strides of 0.3 to 1 carriage span are tried from the last stop kept; the segment's
  fruit go to stops and arms by a balance (fewest options first, each where it lengthens its
  stop's cell least, then each moved where it shortens the stops' sum: :func:`price_stops`,
  :func:`coplan.row.balance.rebalance`) priced by a cell-time estimate -- per-joint time-optimal
  bin -> fruit -> bin round trips with both dwells at that carriage position
  (:func:`round_trips`), each used arm's way out of home and back, the carriage's moves less
  what they overlap -- and the stride with the least estimated time per fruit wins. Its stops
  are then polished (:func:`_polish`: move one, drop one, add one between two or merge two
  while the estimate per fruit falls), which moves stops onto uneven fruit. The segment that
  reaches the row's end takes every fruit left (per fruit, leaving the hardest out looked
  cheaper, and they then cost a stop of their own). Segments are 4 carriage
  spans (3, 3.5, 4, 4.5 and 5 were measured on the shipped rows; with 4 the most rows gain 10 %
  on the better baseline, and none uses more stops than the fixed stride but dense_row). Why not a
  solver over all stops at once: a HiGHS MILP of one 12 m window (stops x fruit x arms, 1,400-
  7,000 binaries) ran into its 20-30 s limits without closing its gap, and CP-SAT within half
  a second returned the fewest-stops hint it was given; a row planner must stay ahead of the
  carriage, so the search is over strides, each priced in milliseconds.

A live row, which knows only the fruit the camera has reported, chooses its stops by the rules
of :mod:`coplan.row.livestops`, priced as these are (:class:`TripCosts`, :func:`price_stops`).

Each rule returns :class:`Stop` objects in carriage order; which arm takes which fruit at a
stop is the cell planner's to decide (the rules' arm choice only prices the stop).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, replace

import numpy as np

from ..errors import Issue, OptionsError, check_fields, known_fields
from ..kinematics.timing import Move1D, scurve_times
from ..problem.model import Problem
from ..ties import quantised
from .balance import rebalance
from .reach import RowReach

__all__ = ["Stop", "fixed_stops", "fewest_stops", "optimised_stops", "carriage_span", "round_trips", "StopWindow",
           "TripCosts", "price_stops", "quantised_trips", "arrival_time", "move_time", "arm_overheads", "retry_stops"]


@dataclass(frozen=True)
class Stop:
    """A carriage stop: its grid index ``k``, position ``x`` (m) and the fruit it harvests."""

    k: int
    x: float
    fruit: tuple[str, ...]


def carriage_span(reach: RowReach) -> float:
    """The median width of row (m) over which a fruit stays within the arms' reach."""
    widths = [(b - a + 1) * reach.resolution for a, b in (reach.span(f) for f in reach.cover)]
    return float(np.median(widths)) if widths else reach.resolution


def _stops_from(reach: RowReach, ks: list[int], fruit: list[str]) -> list[Stop]:
    """Stops at grid indices ``ks`` (sorted), each fruit to the first one that serves it."""
    owner: dict[int, list[str]] = {k: [] for k in ks}
    for f in fruit:
        cov = reach.cover[f].any(axis=0)
        k = next((k for k in ks if cov[k]), None)
        if k is not None:
            owner[k].append(f)
    order = {f.id: i for i, f in enumerate(reach.problem.fruits)}
    return [Stop(k, float(reach.grid[k]), tuple(sorted(owner[k], key=order.__getitem__))) for k in ks if owner[k]]


def fewest_stops(reach: RowReach, fruit: list[str] | None = None, exact: bool = False) -> list[Stop]:
    """The fewest stops serving every fruit (greedy stabbing, see the module docstring).

    ``exact``: the fewest for any fruit. A fruit several arms serve has several stretches of
    rail it is served from, where the greedy may take more stops than needed (4 where 2 do, and
    more than the fixed stride). Its count is checked against a packing of fruit no one position
    serves two of (a lower bound; equal on every shipped row, so their stops are the greedy's);
    where they differ, a HiGHS set-cover MILP over the ends of the stretches (an optimal cover
    can use only those: a stop moves along the rail until some fruit it serves is about to leave
    its reach) takes over if it needs fewer."""
    todo = list(reach.cover) if fruit is None else [f for f in fruit if f in reach.cover]
    cov = {f: reach.cover[f].any(axis=0) for f in todo}
    first_end = {}
    for f, c in cov.items():  # the end of the first run of serving positions
        k = int(np.argmax(c))
        run = np.flatnonzero(~c[k:])
        first_end[f] = k + (int(run[0]) - 1 if run.size else c.size - 1 - k)
    left = sorted(todo, key=lambda f: (first_end[f], f))
    ks: list[int] = []
    done: set[str] = set()
    for f in left:
        if f in done:
            continue
        k = first_end[f]
        ks.append(k)
        done |= {g for g in left if cov[g][k]}
    ks = sorted(set(ks))
    if exact and len(ks) > _packing(cov):
        fewer = _set_cover(cov, len(ks))
        if fewer is not None:
            ks = fewer
    return _stops_from(reach, ks, todo)


def _packing(cov: dict[str, np.ndarray]) -> int:
    """How many fruit no one position serves two of (greedy, by where each last is served): no
    set of stops serving them all is smaller."""
    last = {f: int(np.flatnonzero(c)[-1]) for f, c in cov.items()}
    used, n = None, 0
    for f in sorted(cov, key=lambda f: (last[f], f)):
        if used is None or not (cov[f] & used).any():
            used = cov[f].copy() if used is None else used | cov[f]
            n += 1
    return n


def _set_cover(cov: dict[str, np.ndarray], than: int) -> list[int] | None:
    """Grid indices of fewer than ``than`` stops serving every fruit of ``cov`` (a HiGHS MILP
    over the ends of each fruit's serving stretches), or None when it finds none within its work
    budget (branch-and-bound nodes, the allocation MILPs': the same answer on any machine; their
    clock limit only as a safety net behind it -- it had only 10 s of clock)."""
    from scipy.optimize import Bounds, LinearConstraint, milp
    from scipy.sparse import csr_matrix

    from ..allocate.allocation import MILP_NODES, MILP_SECONDS

    cands = sorted({int(k) for c in cov.values() for k in np.flatnonzero(c & ~np.r_[c[1:], False])})
    at = np.asarray(cands)
    rows, cols = [], []
    for r, c in enumerate(cov.values()):
        hit = np.flatnonzero(c[at])
        rows += [r] * hit.size
        cols += hit.tolist()
    a = csr_matrix((np.ones(len(rows)), (rows, cols)), shape=(len(cov), len(cands)))
    res = milp(np.ones(len(cands)), constraints=LinearConstraint(a, lb=1), integrality=np.ones(len(cands)),
               bounds=Bounds(0, 1), options={"node_limit": MILP_NODES, "time_limit": MILP_SECONDS})
    if res.x is None:
        return None
    chosen = [cands[i] for i in np.flatnonzero(res.x > 0.5)]
    return chosen if len(chosen) < than else None


def fixed_stops(reach: RowReach, stride: float | None = None) -> list[Stop]:
    """A stop every ``stride`` m (default :func:`carriage_span`), see the module docstring."""
    if not reach.cover:
        return []
    stride = carriage_span(reach) if stride is None else stride
    step = max(1, int(round(stride / reach.resolution)))
    ends = [reach.span(f)[1] for f in reach.cover]
    k0 = min(ends)
    last = max(reach.span(f)[0] for f in reach.cover)
    ks = list(range(k0, max(last, k0) + step, step))
    ks = [k for k in ks if k < reach.grid.size]
    served = {f for f in reach.cover if reach.cover[f].any(axis=0)[ks].any()}
    extra = fewest_stops(reach, [f for f in reach.cover if f not in served])
    return _stops_from(reach, sorted(set(ks) | {s.k for s in extra}), list(reach.cover))


def retry_stops(reach: RowReach, failed: dict[str, list[float]], taken: set[int], away: float) -> list[Stop]:
    """Stops for a second chance: fruit a stop's cell planner left out (``failed``: fruit id ->
    the positions, m, of the stops where it was tried), each to another position that serves it
    -- none within ``away`` m of where it was tried, nor a stop already ``taken`` (grid indices),
    and ahead of where it was tried where one there serves it (the carriage has not passed it
    yet) -- the fewest such stops (:func:`fewest_stops`). A fruit no such position serves gets none."""
    from dataclasses import replace

    masked = {}
    for f, xs in failed.items():
        c = reach.cover.get(f)
        if c is None:
            continue
        off = np.zeros(reach.grid.size, dtype=bool)
        for x in xs:
            off |= np.abs(reach.grid - x) <= away + 1e-9
        off[sorted(taken)] = True
        ahead = off | (reach.grid <= max(xs) + away + 1e-9)
        if (c & ~ahead).any():
            masked[f] = c & ~ahead
        elif (c & ~off).any():
            masked[f] = c & ~off
    if not masked:
        return []
    return fewest_stops(replace(reach, cover=masked), list(masked))


# --------------------------------------------------------------------------- the optimised rule
def round_trips(problem: Problem, reach: RowReach, fruit: list[str], ks: np.ndarray) -> dict:
    """``(fruit, k, arm index) -> s``: the time-optimal bin -> fruit -> bin round trip with both
    dwells, for every arm serving the fruit at grid index ``k`` in ``ks`` (best IK branches).
    Per-joint S-curve times (no motion is faster): a lower bound on that fruit's cycle."""
    dw = problem.task.pick_dwell + problem.task.place_dwell
    out: dict = {}
    kset = np.zeros(reach.grid.size, dtype=bool)
    kset[ks] = True
    for a, arm in enumerate(problem.arms):
        qb, vb = arm.ik(np.asarray(arm.bin, float), 0.0)
        bins = qb[vb]
        if bins.size == 0:
            continue
        keys, pts = [], []
        for f in fruit:
            on = np.flatnonzero(reach.cover[f][a] & kset)
            if on.size == 0:
                continue
            fx, fy = problem.fruit(f).position
            pts.append(np.c_[fx - reach.grid[on], np.full(on.size, fy)])
            keys += [(f, int(k), a) for k in on]
        if not keys:
            continue
        q, valid = arm.ik(np.concatenate(pts), problem.task.reach_margin)  # (n, 2, 2): one call per arm
        best = np.full(len(keys), np.inf)
        for b in range(2):
            legs = np.stack([_lb(arm, qq, q[:, b]) for qq in bins])  # (bins, n)
            t = 2.0 * legs.min(axis=0)
            best = np.where(valid[:, b], np.minimum(best, t), best)
        for key, t in zip(keys, best):
            if np.isfinite(t):
                out[key] = float(t) + dw
    return out


def _lb(arm, q0: np.ndarray, q1: np.ndarray) -> np.ndarray:
    """Per-joint time-optimal rest-to-rest time from ``q0`` (2,) to each of ``q1`` (n, 2)."""
    d = np.abs(np.nan_to_num(q1) - q0[None, :])
    return np.maximum(*(scurve_times(d[:, i], arm.max_velocity[i], arm.max_acceleration[i], arm.max_jerk[i]) for i in range(2)))


def arm_overheads(problem: Problem) -> list[float]:
    """Per arm, what a stop adds beyond its round trips: leaving home and coming back to it
    (the time-optimal home -> bin move, twice: a lower-bound estimate)."""
    out = []
    for arm in problem.arms:
        qb, vb = arm.ik(np.asarray(arm.bin, float), 0.0)
        home = np.asarray(arm.home, float)
        t = min((float(_lb(arm, home, qb[b][None, :])[0]) for b in range(2) if vb[b]), default=0.0)
        out.append(float(quantised(2.0 * t)))
    return out


#: the most a stop may be priced beyond its time (s; ``--stop-price``): ten minutes is already
#: more than any stop takes, so the rule then takes the fewest stops each segment allows
MAX_STOP_PRICE = 600.0


@known_fields
@dataclass(frozen=True)
class StopWindow:
    """The optimised rule's receding segments: ``spans`` carriage spans of rail per segment;
    the strides tried, as ``fractions`` of a carriage span; ``polish``: the pricings each
    segment's polish may spend; ``first_work``: the row's first segment's polish budget in
    fruit priced (pricings x the segment's fruit; the carriage waits for that segment: on
    6-arm rows of 10.5 fruit per metre, 25 to 200 m long, this keeps the first stop known
    within 0.9 s); ``stop_price``: seconds the rule charges each stop on top of its estimated
    time (0: time alone), for a grower who counts stops too (each one a settle, the camera's
    look, wear on the drive): on the shipped rows 2 s brings dense_row from 11 stops to 9
    (662.9 -> 674.8 s) and sparse_row from 9 to 8 (180.2 -> 183.6 s), no more than the fixed
    stride's 9 and 8, but course_row from 10 to 8 (395.1 -> 416.6 s); six_arm_row keeps its 6.
    ``pace_price``: seconds charged to each stop of a segment that starts with the rule ahead of
    the fixed stride's pace -- more stops kept than a stop every carriage span from the first
    fruit's last chance would have made by the last stop kept -- so that it falls back to that
    pace where it can, and is free where it is behind (0: off). On the shipped rows 3 or 4 s
    keep every row within the fixed stride's count and 10 % faster than the better baseline
    (docs/benchmarks.md); it prices pace, it does not bound the count."""

    spans: float = 4.0
    fractions: tuple = tuple(round(0.3 + 0.05 * i, 2) for i in range(15))
    polish: int = 600
    first_work: int = 40_000
    stop_price: float = 0.0
    pace_price: float = 0.0

    def __post_init__(self) -> None:
        check_fields(self, {"spans"})  # built in Python: every value checked (OptionsError: what was expected, found)
        for name in ("stop_price", "pace_price"):
            if getattr(self, name) > MAX_STOP_PRICE:  # (as --stop-price, --pace-price)
                raise OptionsError([Issue(name, f"expected a price per stop of at most {MAX_STOP_PRICE:g} s, found "
                                                f"{getattr(self, name):g}")], "StopWindow")
        if self.stop_price + self.pace_price > MAX_STOP_PRICE:  # (a segment ahead of pace charges both)
            raise OptionsError([Issue("pace_price", f"expected stop_price + pace_price of at most {MAX_STOP_PRICE:g} s, "
                                                    f"found {self.stop_price:g} + {self.pace_price:g}")], "StopWindow")
        fr = self.fractions
        if not (isinstance(fr, (tuple, list)) and fr and all(isinstance(x, (int, float)) and not isinstance(x, bool)
                                                             and math.isfinite(x) and 0 < x <= 1 for x in fr)):
            # (a stride longer than the span a fruit stays in reach skips fruit: each then a stop of its own)
            raise OptionsError([Issue("fractions", f"expected strides as fractions of a carriage span, each above 0 and "
                                                   f"at most 1, e.g. (0.5, 0.75, 1.0), found {fr!r}")], "StopWindow")


class TripCosts:
    """The round trips of one segment, by fruit then grid index: ``{f: {k: [(s, arm), ...]}}``,
    each time whole microseconds (so that every comparison below is the same on any CPU);
    priced on demand for grid indices not seen yet."""

    def __init__(self, problem: Problem, reach: RowReach, fruit: list[str]):
        self.problem, self.reach, self.fruit = problem, reach, fruit
        self.by_fruit: dict[str, dict[int, list[tuple[float, int]]]] = {}
        self.priced: set[int] = set()

    def add(self, ks) -> None:
        need = sorted(set(int(k) for k in ks) - self.priced)
        if not need:
            return
        trips = round_trips(self.problem, self.reach, self.fruit, np.asarray(need, int))
        for (f, k, a), t in quantised_trips(trips).items():
            self.by_fruit.setdefault(f, {}).setdefault(k, []).append((t, a))
        self.priced |= set(need)


def price_stops(problem, reach, cost: TripCosts, fruit, ks, over, x_from, overlap, stop_price: float = 0.0):
    """Assign ``fruit`` to stops ``ks`` (sorted) and arms there, and estimate the time: the
    carriage's moves from ``x_from``, each with the gantry's ``settle`` (less what the arms' way
    home and out overlaps), and each
    stop's cell (its busiest arm: round trips plus its way out and home). Fruit with the fewest
    options first, each where it lengthens its stop's cell least (then where its cycle is
    cheapest): a balance across stops and arms. A fruit no stop serves is not taken. Returns
    (seconds, stops, fruit taken); ``stop_price`` s is added for each stop that takes fruit."""
    g = problem.gantry
    A = len(problem.arms)
    n = len(ks)
    load = [[0.0] * A for _ in range(n)]
    used = [[False] * A for _ in range(n)]
    peak = [0.0] * n
    at: list[list[str]] = [[] for _ in range(n)]
    opts = []
    for j, f in enumerate(fruit):
        cf = cost.by_fruit.get(f)
        if not cf:
            continue
        o = [(c, i, a) for i, k in enumerate(ks) for c, a in cf.get(k, ())]
        if o:
            opts.append((len(o), -min(o)[0], f, j, o))
    opts.sort(key=lambda x: x[:3])
    taken = []
    chosen = []  # [j, f, c, i, a, options] per fruit placed
    for _, _, f, j, o in opts:
        best = None
        for c, i, a in o:
            new = load[i][a] + c + (0.0 if used[i][a] else over[a])
            key = (new - peak[i] if new > peak[i] else 0.0, c, i, a)
            if best is None or key < best:
                best = key
        _, c, i, a = best
        load[i][a] += c + (0.0 if used[i][a] else over[a])
        used[i][a] = True
        peak[i] = max(peak[i], load[i][a])
        at[i].append((j, f))
        taken.append(f)
        chosen.append([j, f, c, i, a, o])
    rebalance(load, peak, at, chosen, over)
    total, x = 0.0, x_from
    stops = []
    for i, k in enumerate(ks):
        if not at[i]:
            continue
        xk = float(reach.grid[k])
        mv = arrival_time(g, x, xk)  # (with its settle: the arms' way out may overlap both)
        total += peak[i] + mv - min(mv, overlap)
        stops.append(Stop(k, xk, tuple(f for _, f in sorted(at[i]))))
        x = xk
    return total + stop_price * len(stops), stops, taken


def quantised_trips(trips: dict) -> dict:
    """Round trips in whole microseconds: compared with each other, the same on any CPU."""
    return dict(zip(trips, quantised(list(trips.values())).tolist())) if trips else {}


def arrival_time(g, x0: float, x1: float) -> float:
    """When a pick at ``x1`` may start after the carriage leaves ``x0`` at rest (s): its
    time-optimal rest-to-rest move, by distance (memoised), and after a move its ``settle``
    (each stop rule's price of a stop; 0 where it does not move)."""
    d = round(abs(x1 - x0), 9)
    t = _MOVES.get((d, g.max_velocity, g.max_acceleration, g.max_jerk))
    if t is None:
        t = Move1D.between(0.0, d, g.max_velocity, g.max_acceleration, g.max_jerk).duration
        t = _MOVES[(d, g.max_velocity, g.max_acceleration, g.max_jerk)] = float(quantised(t))
    return t + g.settle if t > 0 else t


move_time = arrival_time  # (its name before it counted the settle: kept for code that imports it)


_MOVES: dict = {}


def optimised_stops(problem: Problem, reach: RowReach, window: StopWindow | None = None, on_stop=None) -> tuple[list[Stop], dict]:
    """The optimised rule, segment by segment along the rail (see the module docstring).

    In each segment (``window.spans`` carriage spans of rail from the last stop kept), every
    stride in ``window.fractions`` of a carriage span is tried, continuing from that stop; each
    fruit goes to the stop of its cheapest cycle among those that serve it, and the stride whose
    estimated time per fruit taken is least wins (a fruit no stop of the segment serves before
    its window closes gets a stop of its own). The segment's stops are kept but the last, where
    the next segment starts. ``on_stop(stop)`` is called with every stop as soon as it is kept
    (a caller plans it while the next segment is solved). Returns the stops and a report."""
    w = window or StopWindow()
    res = reach.resolution
    g = problem.gantry
    reach.ensure(reach.grid[0] + max(a.base[0] + a.reach for a in problem.arms) + 10.0)  # (lazy: the first stretch)
    todo = reach.harvestable()
    if not todo:
        reach.ensure(math.inf)
        todo = reach.harvestable()
    if not todo:
        return [], {"segments": 0}
    span_m = carriage_span(reach)
    step_of = {fr: max(1, int(round(span_m * fr / res))) for fr in w.fractions}
    seg_len = int(round(w.spans * span_m / res))
    over = arm_overheads(problem)
    overlap = max(over)  # the arms' way home and out that a carriage move can overlap (an estimate)
    ahead = max(a.base[0] + a.reach for a in problem.arms)
    spans = {f: reach.span(f) for f in todo}
    stops: list[Stop] = []
    info: dict = {"segments": 0, "strides": [], "seconds": []}
    x_now, k_last = g.start, None
    k_first, pace_step = None, max(1, int(round(span_m / res)))  # (the fixed stride's pace: fixed_stops)
    while True:
        first = min(spans[f][1] for f in todo) if todo else None
        lo = k_last if k_last is not None else first  # the segment starts at the last stop kept (else the first fruit's last chance)
        length = seg_len if k_last is not None else max(1, seg_len // 2)  # the first segment is short: the carriage starts sooner
        new = reach.ensure(float(reach.grid[min(lo + length, reach.grid.size - 1)]) + ahead) if lo is not None else reach.ensure(math.inf)
        todo += new
        spans.update({f: reach.span(f) for f in new})
        if not todo:
            if reach.done_to == math.inf:
                break
            new = reach.ensure(math.inf)  # nothing near: screen the rest of the row
            todo += new
            spans.update({f: reach.span(f) for f in new})
            continue
        t0 = time.perf_counter()
        if lo is None:
            lo = min(spans[f][1] for f in todo)
        if k_first is None:  # (the fixed stride's first stop: the first fruit's last chance)
            k_first = min(spans[f][1] for f in todo)
        ws = w
        if w.pace_price and k_last is not None and len(stops) > (k_last - k_first) // pace_step + 1:
            # ahead of the stride's pace: stops cost more (the price moved, not counted twice: each
            # within its limit, their sum was refused where it passed the one on the sum)
            ws = replace(w, stop_price=w.stop_price + w.pace_price, pace_price=0.0)
            info["paced"] = info.get("paced", 0) + 1
        fr, st = _best_stride(problem, reach, todo, spans, lo, length, k_last is None, step_of, ws, over, x_now, overlap)
        keep = st[:-1] if len(st) > 1 and (reach.done_to < math.inf or any(spans[f][1] > st[-1].k for f in todo)) else st
        keep = [s for s in keep if s.fruit] or st[:1] or fewest_stops(reach, todo)[:1]  # (always a stop: the row advances)
        for s in keep:
            stops.append(s)
            if on_stop is not None:
                on_stop(s)
        done = {f for s in keep for f in s.fruit}
        todo = [f for f in todo if f not in done]
        k_last, x_now = keep[-1].k, keep[-1].x
        late = [f for f in todo if spans[f][1] <= k_last]  # passed without a stop (kept stops did not take it)
        for s in fewest_stops(reach, late):
            stops.append(s)
            if on_stop is not None:
                on_stop(s)
        todo = [f for f in todo if f not in set(late)]
        info["segments"] += 1
        info["strides"].append(round(fr * span_m, 3))
        info["seconds"].append(time.perf_counter() - t0)
        if not todo and reach.done_to == math.inf:
            break
    stops.sort(key=lambda s: s.k)
    return stops, info


def _best_stride(problem, reach, todo, spans, lo, length, fresh, step_of, w, over, x_now, overlap):
    """One segment of ``length`` grid steps from ``lo``: the best stride (least estimated time
    per fruit taken), polished by :func:`_polish` (the row's first segment within
    ``w.first_work``: the carriage waits for it). Returns (the stride, the segment's stops)."""
    first = fresh
    floor = -1 if first else lo  # the polish may move stops back to the rail's start (the row's first segment), else to the last stop kept
    hi = lo + length
    inside = [f for f in todo if spans[f][0] <= hi]
    if not inside:  # a stretch of row without fruit: the segment starts at the next fruit's last chance
        lo, fresh = min(spans[f][1] for f in todo), True
        hi = lo + length
        inside = [f for f in todo if spans[f][0] <= hi]
    n = reach.grid.size
    evals = min(w.polish, w.first_work // len(inside)) if first else w.polish
    ks_all = sorted({k for fr in w.fractions for k in _stride(lo, step_of[fr], hi, n, fresh)})
    cost = TripCosts(problem, reach, inside)
    cost.add(ks_all)
    best = None
    for fr in w.fractions:
        ks = _stride(lo, step_of[fr], hi, n, fresh)
        must = [f for f in inside if spans[f][1] < (ks[-1] if ks else lo)]  # its last chance comes before the lookahead stop
        if hi >= n - 1:  # the row's end: no later segment takes what this one leaves
            must = list(inside)
        est, st, taken = price_stops(problem, reach, cost, inside, ks, over, x_now, overlap, w.stop_price)
        got = set(taken)
        missed = [f for f in must if f not in got]
        if missed:  # no stop of this stride serves them before their window closes: a stop of its own each
            extra = fewest_stops(reach, missed)
            cost.add([s.k for s in extra])
            ks = sorted(set(ks) | {s.k for s in extra})
            est, st, taken = price_stops(problem, reach, cost, inside, ks, over, x_now, overlap, w.stop_price)
        per = est / max(1, len(taken))
        if best is None or per < best[0] - 1e-9:
            best = (per, fr, st, must)
    if fresh and hi >= n - 1:
        # the whole row in its first segment: the strides start at the first fruit's last chance, as
        # a receding rule must where fruit lie ahead; here none do, and the fewest rule's stops, as
        # early as they serve, are priced beside them (a short row of two fruit, one at the edge of
        # reach: 17.80 s from a stop at 5.90 m, where the fewest rule's 2.20 m took 10.51 s)
        ks = sorted({s.k for s in fewest_stops(reach, inside)})
        cost.add(ks)
        est, st, taken = price_stops(problem, reach, cost, inside, ks, over, x_now, overlap, w.stop_price)
        if set(inside) <= set(taken) and est / max(1, len(taken)) < best[0] - 1e-9:
            best = (est / max(1, len(taken)), 1.0, st, list(inside))  # (recorded as a stride of one span)
    _, fr, st, must = best
    st = _polish(problem, reach, cost, inside, st, must, over, x_now, overlap, floor, evals, w.stop_price)
    return fr, st


def _polish(problem, reach, cost, inside, st, must, over, x_from, overlap, floor, evals, stop_price=0.0):
    """Local search on one segment's stops from the best stride's: move a stop by 0.1 to 1.6 m
    either way, drop one, add one halfway between two, or merge two neighbours into one a
    quarter, half or three quarters of the way between them, each priced by :func:`price_stops`;
    the best move that lowers the estimated time per fruit taken (and still takes every fruit
    whose window closes in the segment) is made, until none does or ``evals`` pricings are
    spent. Uniform strides leave stops with a handful of fruit where the fruit are uneven; this
    is what moves them onto the fruit, or merges them into their neighbours."""
    n = reach.grid.size
    must = set(must)

    def price(ks):
        est, s2, taken = price_stops(problem, reach, cost, inside, ks, over, x_from, overlap, stop_price)
        if not must <= set(taken):
            return math.inf, s2
        return est / max(1, len(taken)), s2

    ks = [s.k for s in st]
    cur, cur_st = price(ks)
    if not math.isfinite(cur):
        return st
    spent = 0
    while spent < evals:
        cands = []
        for i, k in enumerate(ks):
            if len(ks) > 1:
                cands.append(ks[:i] + ks[i + 1:])
            for d in (-32, -16, -8, -4, -2, 2, 4, 8, 16, 32):
                k2 = k + d
                if floor < k2 < n and k2 not in ks:
                    cands.append(sorted(ks[:i] + [k2] + ks[i + 1:]))
            if i + 1 < len(ks) and ks[i + 1] - k > 8:
                cands.append(sorted(ks + [(k + ks[i + 1]) // 2]))
            if i + 1 < len(ks):  # two neighbours merged into one between them
                for m in (1, 2, 3):
                    km = k + (ks[i + 1] - k) * m // 4
                    if km not in ks:
                        cands.append(ks[:i] + [km] + ks[i + 2:])
        cost.add({k for c in cands for k in c})
        best = None
        for c in cands:
            spent += 1
            v, s2 = price(c)
            if v < cur - 1e-9 and (best is None or v < best[0] - 1e-12):
                best = (v, c, s2)
            if spent >= evals:
                break
        if best is None:
            break
        cur, ks, cur_st = best
    return cur_st


def _stride(lo: int, step: int, hi: int, n: int, first: bool) -> list[int]:
    """Grid indices of a stride from ``lo`` (included on the first segment, else the last stop
    kept, so excluded) to one past ``hi`` (the lookahead stop)."""
    ks = list(range(lo if first else lo + step, hi + step + 1, step))
    return [k for k in ks if k < n] or [min(lo, n - 1)]
