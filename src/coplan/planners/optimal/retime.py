"""Retiming by constraint programming: a coordinated plan's moves, picks and places kept, all
their start times chosen together (OR-Tools CP-SAT) instead of leg by leg.

Entry point: :func:`retime`. The coordinator books each leg at the earliest time at which it is
clear of what is already booked, and never revises a booking: a greedy that is exact for one
leg but can leave an arm waiting where an earlier neighbour could have waited a little instead.
Here every wait is free at once:

* **Data**: each arm's moves in order (its rest-to-rest S-curves, as they are), each followed by
  its pick or place dwell, and between two moves an arm *rests* at its pose for as long as it
  must (at least the dwell). The start of every move is an integer variable (ms).
* **Constraints**, for every pair of arms that can touch (:meth:`Problem.neighbour_pairs`), all
  sampled at ``rate`` with the coordinator's ``clearance + margin``:

  - two moves: the start offsets at which some pair of their samples comes too close are
    forbidden (padded by ``pad`` samples), the rest allowed -- one domain constraint per pair;
  - a move and a rest pose of the other arm: the stretch of the move that comes too close to
    the pose must lie wholly before or after the other arm rests there;
  - two rest poses too close: the two rests do not overlap in time.

* **Objective**: the makespan (the last place of every arm), then the sum of the arms' ends.

The solver runs single-threaded with a deterministic time limit (``work``), from the
coordinator's own times as a hint, so the same input gives the same plan on any machine. Its
sampled constraints are not a certificate: the optimal planner keeps a retimed plan only if
the independent verifier passes it and it is faster.
"""

from __future__ import annotations

from dataclasses import dataclass, replace
from functools import cached_property

import numpy as np

from ...problem.model import Problem
from ..coordinated.candidate import Coordinated
from ..coordinated.schedule import (ArmSchedule, LinkPoints, Step, StepKind, arm_points, curve_eval, links_too_close,
                                   links_too_close_pairs)

__all__ = ["RetimeResult", "RetimeModel", "retime", "build_retime_model", "solve_retime_model", "retimed_candidate",
           "retime_rounds", "bounded_rounds"]

_MS = 1000  # time unit of the model: 1 ms


@dataclass
class _Move:
    step: Step
    dwell: list[Step]  # the pick/place steps right after the move
    T: np.ndarray  # sample times from the move's start
    pts: tuple  # arm_points at T
    links: LinkPoints  # the same, ready for links_too_close

    @cached_property
    def sample_boxes(self) -> tuple[np.ndarray, ...]:
        return _sample_boxes(self.pts)

    @property
    def dur(self) -> int:
        return int(np.ceil(self.step.duration * _MS - 1e-6))

    @property
    def hold(self) -> int:
        return int(np.ceil(sum(s.duration for s in self.dwell) * _MS - 1e-6))


@dataclass
class RetimeResult:
    """What :func:`retime` found: ``schedules`` (None when the model has no solution or the
    plan's shape is not one it retimes), the solver's status name, the retimed makespan (s)
    and how many pair constraints the model had."""

    schedules: dict[str, ArmSchedule] | None
    status: str
    makespan: float | None
    constraints: int


def retimed_candidate(c: Coordinated, r: RetimeResult) -> Coordinated:
    """Candidate ``c`` with the schedules ``r`` retimed from it (makespan and waits updated)."""
    waits = sum(1 for sch in r.schedules.values() for st in sch.steps if st.kind == StepKind.WAIT)
    return replace(c, schedules=r.schedules, makespan=r.makespan, waits=waits)


def bounded_rounds(fruit: int, opts) -> tuple[int, float | None]:
    """``(rounds, shift)`` for a candidate of ``fruit`` fruit under ``opts`` (an
    :class:`~coplan.planners.optimal.options.OptimalOptions`): beyond ``refine_fruit`` a plan is
    long, its retiming bounded (each move at most ``retime_shift`` later) in up to
    ``retime_rounds`` rounds; otherwise one unbounded round. The optimal planner's retime stage
    and a row's cells both ask this."""
    long = fruit > opts.refine_fruit
    return (opts.retime_rounds, opts.retime_shift) if long else (1, None)


def retime_rounds(problem: Problem, c: Coordinated, margin: float, *, rounds: int, shift: float | None, work: float,
                  tables: dict, memo: dict, deadline: float | None = None, linear: bool = True, gain: float = 0.01):
    """Retime candidate ``c`` round after round, each round from the last one's result (a
    bounded retiming -- ``shift`` -- can gain again from its own result: 12 arms x 600 fruit
    went 1.030, 1.022, 1.017 x the bound in three rounds). Yields ``(result, retimed candidate
    or None, gained, wall seconds)`` per round: ``gained`` when the round shortened the
    makespan by more than ``gain`` s; the next round starts from that candidate only then (the
    caller ends the rounds early by leaving its loop, e.g. where the round's plan fails to
    verify). ``deadline`` (``time.perf_counter()`` s): each round may use half what is left of it."""
    import time as _time

    for _ in range(rounds):
        t0 = _time.perf_counter()
        r = retime(problem, c.schedules, margin, work=work, tables=tables, memo=memo, shift=shift, linear=linear,
                   deadline=None if deadline is None else t0 + (deadline - t0) / 2)
        seconds = _time.perf_counter() - t0  # (the retiming's own time, as each caller reports it)
        rc = retimed_candidate(c, r) if r.schedules is not None else None
        gained = rc is not None and r.makespan < c.makespan - gain
        yield r, rc, gained, seconds
        if not gained:
            return
        c = rc


def _moves(sch: ArmSchedule, rate: float, tables: dict) -> tuple[list[_Move], int | None] | None:
    """The arm's moves with their dwells, and the index of the move its last place follows;
    None when a dwell comes before any move (a shape this model does not retime)."""
    out: list[_Move] = []
    last_place = None
    for st in sch.steps:
        if st.kind == StepKind.WAIT:
            continue
        if st.kind == StepKind.MOVE:
            T = np.append(np.arange(0.0, st.duration, 1.0 / rate), st.duration)
            pts = arm_points(sch.arm, curve_eval(st.curve, T, tables))
            out.append(_Move(st, [], T, pts, LinkPoints.of(pts)))
            continue
        if not out:
            return None
        out[-1].dwell.append(st)
        if st.kind == StepKind.PLACE:
            last_place = len(out) - 1
    return out, last_place


def _allowed(forbidden: np.ndarray, pad: int, horizon: int) -> list[list[int]]:
    """The complement in [-horizon, horizon] of the union of [x - pad, x + pad] over ``forbidden`` (sorted ints)."""
    out, cur = [], -horizon
    lo = hi = None
    for x in forbidden:
        if lo is None:
            lo, hi = x - pad, x + pad
        elif x - pad <= hi + 1:
            hi = x + pad
        else:
            if lo - 1 >= cur:
                out.append([cur, lo - 1])
            cur, lo, hi = hi + 1, x - pad, x + pad
    if lo is not None:
        if lo - 1 >= cur:
            out.append([cur, lo - 1])
        cur = hi + 1
    if cur <= horizon:
        out.append([cur, horizon])
    return out


def _box(pts: tuple) -> np.ndarray:
    xs, ys = np.concatenate(pts[0::2]), np.concatenate(pts[1::2])
    return np.array([xs.min(), ys.min(), xs.max(), ys.max()])


def _apart(a: np.ndarray, b: np.ndarray, gap: float) -> bool:
    return bool(a[0] > b[2] + gap or b[0] > a[2] + gap or a[1] > b[3] + gap or b[1] > a[3] + gap)


def _sample_boxes(pts: tuple) -> tuple[np.ndarray, ...]:
    """Per sample, the bounding box ``(x0, y0, x1, y1)`` of an arm given by ``arm_points``."""
    xs, ys = np.stack(pts[0::2]), np.stack(pts[1::2])
    return xs.min(axis=0), ys.min(axis=0), xs.max(axis=0), ys.max(axis=0)


def _meetings(xa: _Move, xb: _Move, radii: float, need: float) -> np.ndarray:
    """Sorted start offsets (ms, s_b - s_a) at which some sample of ``xa`` comes within
    ``need`` of one of ``xb`` (each other's links, capsules of ``radii``)."""
    # screen first: two samples whose arms' bounding boxes are further apart than radii + need
    # (along x or y) cannot be too close; only the other pairs are tested exactly (this also
    # keeps the temporaries small: na x nb pairs of link coordinates, allocated on every call,
    # had made a long row's retiming twice as slow in a process that had planned before)
    # ``xa``'s samples a block at a time, at most _PAIRS pairs each: two slow moves near each
    # other all along (thousands of samples each) had 38 million near pairs at once -- 24 GB
    g = radii + need
    (ax0, ay0, ax1, ay1), (bx0, by0, bx1, by1) = xa.sample_boxes, xb.sample_boxes
    rows = max(1, _PAIRS // max(1, bx0.size))
    found = []
    for i in range(0, ax0.size, rows):
        s = slice(i, i + rows)
        near = ((ax0[s, None] <= bx1[None] + g) & (bx0[None] <= ax1[s, None] + g)
                & (ay0[s, None] <= by1[None] + g) & (by0[None] <= ay1[s, None] + g))
        p, q = np.nonzero(near)
        if p.size:
            p += i
            close = links_too_close(xa.links[p], xb.links[q], radii, need)
            found.append(np.unique(np.round((xa.T[p[close]] - xb.T[q[close]]) * _MS).astype(int)))
    return np.unique(np.concatenate(found)) if found else np.zeros(0, int)


_PAIRS = 1_000_000  # sample pairs _meetings tests at once (memory: about 100 MB of link coordinates)


_LATE = "not retimed: the time limit came while building the model"


def _reach(per: list, shift: float | None, horizon: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """Per arm, the least and greatest start (ms) each move may take: from its earliest (every
    move and dwell before it back to back) to ``shift`` s after its start now; (0, horizon)
    without a ``shift``."""
    out = []
    for mv, _ in per:
        if shift is None:
            out.append((np.zeros(len(mv), int), np.full(len(mv), horizon)))
            continue
        t0 = np.array([int(round(x.step.t0 * _MS)) for x in mv], int)
        earliest = np.concatenate([[0], np.cumsum([x.dur + x.hold for x in mv])[:-1]]).astype(int) if mv else np.zeros(0, int)
        d = int(round(shift * _MS))
        out.append((np.minimum(earliest, t0), np.minimum(t0 + d, horizon)))
    return out


def retime(problem: Problem, schedules: dict[str, ArmSchedule], margin: float, rate: float = 100.0, pad: int = 1,
           work: float = 5.0, tables: dict | None = None, memo: dict | None = None,
           deadline: float | None = None, shift: float | None = None, linear: bool = True) -> RetimeResult:
    """Choose every move's start together (see the module docstring). ``schedules``: a
    coordinated plan's (waits anywhere, each arm's moves rest to rest); ``margin`` as the
    coordinator's; ``pad``: forbidden start offsets widened by this many samples either way;
    ``work``: CP-SAT's deterministic time limit; ``memo``: the forbidden offsets of move pairs
    already met (kept between calls on the same problem, e.g. by a search that retimes many
    plans sharing most of their moves). The returned schedules have the same steps in the same
    order, only other waits. ``deadline`` (``time.perf_counter()`` seconds; an explicit time
    limit): building the model stops there, and CP-SAT stops there too. ``linear=False``: no LP
    relaxation in the search (CP-SAT's ``linearization_level`` 0) -- on a row's big cells its
    LP took wall time its deterministic clock does not count (13.6 s for 0.04 units on a
    131-fruit stop of six arms; without it 0.2 s, the same optimum).

    ``shift`` (s; a long plan's bounded retiming): every move starts at most ``shift`` s later
    than it does now, and no earlier than its arm's moves and dwells before it allow. Two moves
    (or a move and a rest) that can then never overlap in time need no constraint: an arm's
    moves can only come forward by the waits before them, which are few, so the model grows
    with the plan's length instead of its square. A restriction of the unbounded model (the
    current times stay a solution): on 5 arms x 200 fruit the unbounded model was still
    unsolved after 13 s, the bounded one (1.5 s) solved in about 1 s."""
    tables = {} if tables is None else tables
    memo = {} if memo is None else memo
    model = build_retime_model(problem, schedules, margin, rate, pad, tables, memo, deadline, shift)
    if isinstance(model, RetimeResult):
        return model
    return solve_retime_model(model, work, deadline, linear)


@dataclass
class RetimeModel:
    """The CP-SAT model of one retiming (:func:`build_retime_model`): ``m`` the model, ``S`` each
    arm's move starts (ms), ``per`` each arm's moves (and the index of the move its last place
    follows), ``box`` each move's least and greatest start, ``busy`` when each move may be under
    way, ``constraints`` the pair constraints so far."""

    problem: Problem
    m: object
    S: list
    per: list
    box: list
    busy: list
    horizon: int
    pad: int
    step: int
    need: float
    M: object = None
    ends: list = None
    constraints: int = 0

    def meet(self, a: tuple[int, int], b: tuple[int, int]) -> bool:
        """Whether two spans of time (ms) may overlap (each widened by the padding)."""
        return a[0] <= b[1] + 2 * self.pad * self.step and b[0] <= a[1] + 2 * self.pad * self.step

    def rests(self, i: int) -> list:
        """Arm ``i``'s rests: (pose, start expr, end expr or None: for ever, (earliest start, latest end) ms)."""
        mv, _ = self.per[i]
        lo, hi = self.box[i]
        S, horizon = self.S, self.horizon
        out = [(np.asarray(self.problem.arms[i].home, float), 0, S[i][0] if mv else None, (0, int(hi[0]) if mv else horizon))]
        for k, x in enumerate(mv):
            last = k + 1 == len(mv)
            out.append((np.asarray(x.step.q1, float), S[i][k] + x.dur, None if last else S[i][k + 1],
                        (int(lo[k]) + x.dur, horizon if last else int(hi[k + 1]))))
        return out


def build_retime_model(problem: Problem, schedules: dict[str, ArmSchedule], margin: float, rate: float, pad: int,
                       tables: dict, memo: dict, deadline: float | None, shift: float | None) -> RetimeModel | RetimeResult:
    """The model of :func:`retime` (its arguments are that function's): variables, each arm's
    order, the makespan, then every neighbour pair's constraints (:func:`_moves_apart`,
    :func:`_moves_clear_of_rests`, :func:`_rests_apart`, in that order), the objective and the
    coordinator's times as a hint. A :class:`RetimeResult` instead where there is nothing to
    solve (a shape it does not retime, the deadline, two final rests too close)."""
    from ortools.sat.python import cp_model

    arms = problem.arms
    per = []
    for a in arms:
        got = _moves(schedules[a.name], rate, tables)
        if got is None:
            return RetimeResult(None, "not retimed: a dwell before any move", None, 0)
        per.append(got)
    span = max((s.end for s in schedules.values()), default=0.0)
    horizon = int(np.ceil(2.0 * span * _MS)) + 10 * _MS
    m = cp_model.CpModel()
    box = _reach(per, shift, horizon)
    S = [[m.NewIntVar(int(box[i][0][k]), int(box[i][1][k]), f"s{i}_{k}") for k in range(len(mv))]
         for i, (mv, _) in enumerate(per)]
    # when each move may be under way and each rest may be held (ms), to skip pairs that never meet
    busy = [(lo, hi + np.array([x.dur for x in mv], int)) for (mv, _), (lo, hi) in zip(per, box)]
    for i, (mv, _) in enumerate(per):
        for k in range(len(mv) - 1):
            m.Add(S[i][k + 1] >= S[i][k] + mv[k].dur + mv[k].hold)
    M = m.NewIntVar(0, horizon, "makespan")
    ends = []
    for i, (mv, lp) in enumerate(per):
        if lp is not None:
            m.Add(M >= S[i][lp] + mv[lp].dur + mv[lp].hold)
        if mv:
            ends.append(S[i][-1] + mv[-1].dur + mv[-1].hold)
    md = RetimeModel(problem, m, S, per, box, busy, horizon, pad, int(round(_MS / rate)), problem.task.clearance + margin, M, ends)
    for i, j in problem.neighbour_pairs():
        radii = arms[i].link_radius + arms[j].link_radius
        if not _moves_apart(md, i, j, radii, memo, rate, deadline):
            return RetimeResult(None, _LATE, None, md.constraints)
        for x, y in ((i, j), (j, i)):
            _moves_clear_of_rests(md, x, y, radii)
        if not _rests_apart(md, i, j, radii):
            return RetimeResult(None, "not retimed: two final rest poses too close", None, md.constraints)
    m.Minimize(M * (len(ends) * horizon + 1) + sum(ends))
    for i, (mv, _) in enumerate(per):  # the coordinator's own times: a hint
        for k, x in enumerate(mv):
            m.AddHint(S[i][k], int(round(x.step.t0 * _MS)))
    return md


def _moves_apart(md: RetimeModel, i: int, j: int, radii: float, memo: dict, rate: float, deadline: float | None) -> bool:
    """Move against move: the start offsets at which two moves of arms ``i`` and ``j`` come too
    close are forbidden. False when the deadline came first."""
    import time as _time

    from ortools.sat.python import cp_model

    per, busy, S = md.per, md.busy, md.S
    boxes = [[_box(x.pts) for x in per[a][0]] for a in (i, j)]
    for ka, xa in enumerate(per[i][0]):
        if deadline is not None and _time.perf_counter() > deadline:
            return False
        for kb, xb in enumerate(per[j][0]):
            if _apart(boxes[0][ka], boxes[1][kb], md.need + radii) or not md.meet(
                    (busy[i][0][ka], busy[i][1][ka]), (busy[j][0][kb], busy[j][1][kb])):
                continue
            key = (i, j, xa.step.q0, xa.step.q1, xa.step.duration, xb.step.q0, xb.step.q1, xb.step.duration,
                   rate, md.need)
            forbid = memo.get(key)
            if forbid is None:
                forbid = memo[key] = _meetings(xa, xb, radii, md.need)  # s_b - s_a at which they meet
            if forbid.size == 0:
                continue
            md.m.AddLinearExpressionInDomain(S[j][kb] - S[i][ka],
                                             cp_model.Domain.FromIntervals(_allowed(forbid, md.pad * md.step, md.horizon)))
            md.constraints += 1
    return True


def _moves_clear_of_rests(md: RetimeModel, x: int, y: int, radii: float) -> None:
    """A move of arm ``x`` against arm ``y``'s rests: the stretch of the move that comes too
    close to a rest pose lies wholly before or after ``y`` rests there."""
    arms, m, S = md.problem.arms, md.m, md.S
    ry = md.rests(y)
    poses = np.array([r[0] for r in ry])  # (R, 2)
    pp = LinkPoints.of(arm_points(arms[y], poses))
    pad = md.pad * md.step
    for k, xm in enumerate(md.per[x][0]):
        span = (md.busy[x][0][k], md.busy[x][1][k])
        rs = np.array([r for r in range(len(ry)) if md.meet(span, ry[r][3])], int)
        if rs.size == 0:
            continue
        close = links_too_close_pairs(xm.links, pp[rs], radii, md.need)  # (K samples, R rests)
        for c in np.flatnonzero(close.any(axis=0)):
            r = rs[c]
            _, r0, r1, _ = ry[r]
            hit = xm.T[close[:, c]]
            c0 = int(np.floor(hit.min() * _MS)) - pad
            c1 = int(np.ceil(hit.max() * _MS)) + pad
            md.constraints += 1
            if r1 is None:  # the other arm rests there from r0 on: this stretch before it
                m.Add(S[x][k] + c1 <= r0)
                continue
            before = m.NewBoolVar("")
            m.Add(S[x][k] + c1 <= r0).OnlyEnforceIf(before)
            m.Add(S[x][k] + c0 >= r1).OnlyEnforceIf(before.Not())


def _rests_apart(md: RetimeModel, i: int, j: int, radii: float) -> bool:
    """Rest against rest: two rest poses too close do not overlap in time (the pairs that may
    meet, tested at once). False when two final rests are too close (no retiming can part them)."""
    arms, m = md.problem.arms, md.m
    ri, rj = md.rests(i), md.rests(j)
    pairs = [(u, v) for u in range(len(ri)) for v in range(len(rj)) if md.meet(ri[u][3], rj[v][3])]
    close = np.zeros(0, bool)
    if pairs:
        u_, v_ = np.array(pairs).T
        close = links_too_close(LinkPoints.of(arm_points(arms[i], np.array([ri[u][0] for u in u_]))),
                                LinkPoints.of(arm_points(arms[j], np.array([rj[v][0] for v in v_]))), radii, md.need)
    for (u, v), c in zip(pairs, close):
        _, a0, a1, _ = ri[u]
        _, b0, b1, _ = rj[v]
        if not c:
            continue
        md.constraints += 1
        if a1 is None and b1 is None:
            return False
        if a1 is None:
            m.Add(b1 <= a0)
        elif b1 is None:
            m.Add(a1 <= b0)
        else:
            first = m.NewBoolVar("")
            m.Add(a1 <= b0).OnlyEnforceIf(first)
            m.Add(b1 <= a0).OnlyEnforceIf(first.Not())
    return True


def solve_retime_model(md: RetimeModel, work: float, deadline: float | None, linear: bool) -> RetimeResult:
    """Solve ``md`` (single-threaded, a deterministic limit ``work``; the ``deadline`` and
    ``linear`` of :func:`retime`) and rebuild each arm's schedule from the starts found."""
    import time as _time

    from ortools.sat.python import cp_model

    n = md.constraints
    solver = cp_model.CpSolver()
    solver.parameters.num_workers = 1  # single-threaded and a deterministic limit: the same plan anywhere
    solver.parameters.max_deterministic_time = work
    if deadline is not None:
        left = deadline - _time.perf_counter()
        if left <= 0:
            return RetimeResult(None, _LATE, None, n)
        solver.parameters.max_time_in_seconds = left
    solver.parameters.random_seed = 0
    if not linear:
        solver.parameters.linearization_level = 0
    # Ctrl-C is the planner's (it saves the incumbent): CP-SAT's own SIGINT handler would end
    # the solve as if at its limit, swallow the key and leave SIGINT at its default (a second
    # Ctrl-C would then kill the process without saving anything)
    solver.parameters.catch_sigint_signal = False
    status = solver.Solve(md.m)
    name = solver.StatusName(status)
    if status not in (cp_model.OPTIMAL, cp_model.FEASIBLE):
        return RetimeResult(None, name, None, n)
    out = {}
    for i, a in enumerate(md.problem.arms):
        mv, _ = md.per[i]
        steps: list[Step] = []
        t, pose = 0.0, tuple(map(float, a.home))
        for k, x in enumerate(mv):
            s0 = solver.Value(md.S[i][k]) / _MS
            if s0 > t + 1e-12:
                steps.append(Step(StepKind.WAIT, t, s0 - t, pose, pose))
            steps.append(replace(x.step, t0=s0))
            t = s0 + x.step.duration
            for d in x.dwell:
                steps.append(replace(d, t0=t))
                t += d.duration
            pose = tuple(map(float, x.step.q1))
        out[a.name] = ArmSchedule(a, steps)
    return RetimeResult(out, name, max((s.last_place for s in out.values()), default=0.0), n)
