"""Rest spread over the moves: the same events, gentler moves (the widening stage's start).

Entry point: :func:`ease`. A plan at its makespan leaves most arms some rest -- a wait for a
neighbour, an early finish. A move stretched by ``s`` (its S-curve slowed uniformly) keeps
every limit and has ``1/s^5`` of its jerk integral, so rest is worth most spread thinly over
every move of the arm. The widening program (:mod:`coplan.planners.optimal.widen`) shares its
knot times among all arms, so by itself it can slow a move only into rest on the same knots,
while an arm's rest usually falls where a neighbour is moving; it starts from these schedules.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from ...problem.model import Problem
from ..coordinated.schedule import ArmSchedule, Step, StepKind
from .windows import link_pair_distances

__all__ = ["ease", "jerk_integral"]


def jerk_integral(curve) -> float:
    """The move's jerk integral over both joints, ``sum_i int j_i^2 dt`` (rad^2/s^5): each
    joint's time-optimal profile slowed by ``k = T_i / duration`` has jerk ``j k^3`` over phases
    ``dt / k``, so its integral is ``k^5 sum j^2 dt``."""
    out = 0.0
    for durs, jerks in curve.profiles:
        if durs and curve.duration > 0:
            k = float(sum(durs)) / curve.duration
            out += k**5 * float(sum(j * j * d for d, j in zip(durs, jerks)))
    return out


def _moves_jerk(steps: list[Step]) -> float:
    """The sum of the jerk integrals of the moves among ``steps``."""
    return sum(jerk_integral(s.curve) for s in steps if s.kind == StepKind.MOVE and s.curve is not None)


def _record(report: dict, name: str, before: list[Step], after: list[Step]) -> None:
    """Arm ``name`` eased: in the report, with the square root of its moves' jerk integral after over before."""
    j0, j1 = _moves_jerk(before), _moves_jerk(after)
    report["arms"].append(name)
    report["rms_jerk_ratio"][name] = float(np.sqrt(j1 / j0)) if j0 > 0 else 1.0


def _order_bounds(t: float, others: np.ndarray, gap: float = 0.03) -> tuple[float, float]:
    """The times an event starting at ``t`` may move to and keep its place among ``others``
    (the other arms' event starts, sorted): strictly between its neighbours there."""
    i = int(np.searchsorted(others, t - 1e-9, side="left"))
    j = int(np.searchsorted(others, t + 1e-9, side="right"))
    if j > i:  # starts together with another arm's event: it stays where it is
        return t, t
    lo = others[i - 1] + gap if i > 0 else 0.0
    hi = others[i] - gap if i < others.size else np.inf
    return min(lo, t), max(hi, t)


#: the grid (s; a power of two, so exact) SLSQP's start times are snapped to (:func:`_eased_arm`)
SNAP = 2.0**-30


def _eased_arm(sch: ArmSchedule, others: np.ndarray, end: float, makespan: float, hold: bool = False) -> list[Step] | None:
    """One arm's steps with its rest spread over its moves so that the sum of their jerk
    integrals is least (a convex programme in the step start times, SciPy's SLSQP): every
    move at least as long as it is, every pick and place as long and in the same order among
    the other arms' event starts (``others``), the last place by ``makespan``, the arm home by
    ``end``. None when nothing changes (no rest, or the solver fails)."""
    from scipy.optimize import minimize

    steps = [s for s in sch.steps if s.kind != StepKind.WAIT]
    moves = [i for i, s in enumerate(steps) if s.kind == StepKind.MOVE and s.curve is not None and s.duration > 0]
    if not moves or any(s.kind == StepKind.MOVE and s.curve is None for s in steps):
        return None
    n = len(steps)
    t0 = np.array([s.t0 for s in steps])
    nxt = lambda t, i: t[i + 1] if i + 1 < n else end  # noqa: E731 (a step lasts to the next one's start)
    if sum(nxt(t0, i) - t0[i] - steps[i].duration for i in range(n)) + t0[0] < 1e-3:
        return None
    c = np.array([jerk_integral(steps[i].curve) for i in moves])
    d0 = np.array([steps[i].duration for i in moves])
    scale = max(float(c.sum()), 1e-12)

    def cost(t):
        d = np.array([nxt(t, i) - t[i] for i in moves])
        return float(np.sum(c * (d0 / np.maximum(d, 1e-9)) ** 5)) / scale

    def grad(t):
        g = np.zeros(n)
        for m, i in enumerate(moves):
            d = max(nxt(t, i) - t[i], 1e-9)
            dd = -5.0 * c[m] * d0[m] ** 5 / d**6 / scale
            g[i] -= dd
            if i + 1 < n:
                g[i + 1] += dd
        return g

    A, lb = [], []  # A t >= lb
    for i in range(n):
        row = np.zeros(n)
        row[i] = -1.0
        if i + 1 < n:
            row[i + 1] = 1.0
            A.append(row), lb.append(steps[i].duration)
        else:
            A.append(row), lb.append(steps[i].duration - end)
    bounds = []
    for i, s in enumerate(steps):
        if s.kind in (StepKind.PICK, StepKind.PLACE):
            lo, hi = (s.t0, s.t0) if hold else _order_bounds(s.t0, others)
            if s.kind == StepKind.PLACE:
                hi = min(hi, max(makespan - s.duration, s.t0))
            bounds.append((lo, hi))
        else:
            bounds.append((0.0, None))
    A, lb = np.array(A), np.array(lb)
    res = minimize(cost, t0, jac=grad, method="SLSQP", bounds=bounds,
                   constraints=[{"type": "ineq", "fun": lambda t: A @ t - lb, "jac": lambda t: A}],
                   options={"maxiter": 200, "ftol": 1e-10})
    # snapped to a grid, within the bounds: SLSQP's linear algebra runs on SciPy's OpenBLAS, whose
    # kernel is the CPU's own where SciPy was loaded before coplan pinned it; its answer's last bits
    # then differed (8e-15 s), IPOPT started the widening elsewhere and the plan's poses differed by
    # 1e-5 rad (crossing_paths, SciPy imported first on an AVX-512 machine)
    t = np.clip(np.round(np.asarray(res.x, float) / SNAP) * SNAP, [b[0] for b in bounds],
                [np.inf if b[1] is None else b[1] for b in bounds])
    if not np.all(np.isfinite(t)) or np.any(A @ t - lb < -1e-9) or cost(t) > cost(t0) - 1e-6:
        return None
    t = np.maximum(t, 0.0)
    return _steps_at(steps, t, end)


def _steps_at(steps: list[Step], t: np.ndarray, end: float) -> list[Step]:
    """``steps`` (no waits) started at times ``t``: each move stretched (its S-curve slowed
    uniformly) to the next step's start, a wait after each pick or place up to the next step."""
    out = []
    for i, s in enumerate(steps):
        if s.kind == StepKind.MOVE:
            dur = max((t[i + 1] if i + 1 < len(steps) else end) - t[i], s.duration)
            out.append(replace(s, t0=float(t[i]), duration=float(dur), curve=replace(s.curve, duration=float(dur))))
        else:
            out.append(replace(s, t0=float(t[i])))
    return _with_waits(out)


def _blend(a: list[Step], b: list[Step], lam: float, end: float) -> list[Step]:
    """The steps (no waits in ``a``'s non-wait order) at starts ``(1 - lam) a + lam b``."""
    sa = [s for s in a if s.kind != StepKind.WAIT]
    sb = [s for s in b if s.kind != StepKind.WAIT]
    t = (1.0 - lam) * np.array([s.t0 for s in sa]) + lam * np.array([s.t0 for s in sb])
    return _steps_at(sa, t, end)


def _arm_room(problem: Problem, schedules: dict[str, ArmSchedule], name: str, t: np.ndarray, cache: dict) -> float:
    """Least link-to-link distance (m) between arm ``name`` and its neighbours at times ``t``
    (the neighbours' poses kept in ``cache`` by schedule: they do not change while one arm is eased)."""
    names = [a.name for a in problem.arms]
    i = names.index(name)
    out = np.inf
    mine = schedules[name].state(t)[0]
    for ia, ib in problem.neighbour_pairs():
        if i in (ia, ib):
            j = ib if ia == i else ia
            sj = schedules[names[j]]
            if cache.get(names[j], (None,))[0] is not sj:
                cache[names[j]] = (sj, sj.state(t)[0])
            qj = cache[names[j]][1]
            qa, qb = (mine, qj) if ia == i else (qj, mine)
            out = min(out, float(link_pair_distances(problem, qa, qb, ia, ib).min()))
    return out


def _ease_moves(problem: Problem, out: dict[str, ArmSchedule], name: str, end: float, need: float, t: np.ndarray,
                report: dict, cache: dict) -> dict[str, ArmSchedule]:
    """Arm ``name``'s moves one at a time, each stretched over the rest just before and after
    it (all of it, else half, else a quarter) where the arm keeps ``min(what it had, need)``
    of distance to its neighbours; every pick and place where it was."""
    sch = out[name]
    cur = [s for s in sch.steps if s.kind != StepKind.WAIT]
    old = _arm_room(problem, out, name, t, cache)
    changed = False
    for i, st in enumerate(cur):
        if st.kind != StepKind.MOVE or st.curve is None:
            continue
        prev = cur[i - 1].t1 if i > 0 else 0.0
        nxt = cur[i + 1].t0 if i + 1 < len(cur) else end
        before, after = max(st.t0 - prev, 0.0), max(nxt - st.t1, 0.0)
        if before + after < 1e-3:
            continue
        for f in (1.0, 0.5, 0.25):
            dur = st.duration + f * (before + after)
            trial = list(cur)
            trial[i] = replace(st, t0=st.t0 - f * before, duration=dur, curve=replace(st.curve, duration=dur))
            cand = dict(out)
            cand[name] = ArmSchedule(sch.arm, _with_waits(trial))
            if _arm_room(problem, cand, name, t, cache) >= min(old, need) - 1e-9:
                cur, out, changed = trial, cand, True
                break
    if changed:
        _record(report, name, sch.steps, cur)
    return out


def _with_waits(steps: list[Step]) -> list[Step]:
    """``steps`` (no waits, in order) with a wait wherever the arm rests between two of them."""
    out = []
    for i, s in enumerate(steps):
        out.append(s)
        nxt = steps[i + 1].t0 if i + 1 < len(steps) else None
        if nxt is not None and nxt - s.t1 > 1e-9:
            out.append(Step(StepKind.WAIT, s.t1, nxt - s.t1, s.q1, s.q1))
    return out


def ease(problem: Problem, schedules: dict[str, ArmSchedule], makespan: float, keep: float,
         rate: float = 1000.0) -> tuple[dict[str, ArmSchedule], dict]:
    """Each arm's rest spread over its moves, the least jerk for the time it has.

    Arms in order, each seeing the others' eased schedules; per arm, the first of these that
    keeps its least distance to its neighbours at least ``min(what it was, clearance + keep)``
    (checked at ``rate`` Hz over the plan):

    1. the start times that minimise the sum of its moves' jerk integrals (:func:`_eased_arm`,
       SciPy's SLSQP): no move shorter, every pick and place as long and in the same order among
       the other arms' event starts, the last place by ``makespan``, home by the plan's end --
       else half and a quarter of the way there;
    2. the same with every pick and place where it is (each move takes the rest beside it);
    3. each move alone into the rest beside it (:func:`_ease_moves`).

    Returns the schedules and ``{"arms": the eased arms, "rms_jerk_ratio": per eased arm, the
    square root of its moves' jerk integral after over before}``."""
    end = max((s.end for s in schedules.values()), default=0.0)
    out = dict(schedules)
    t = np.arange(0.0, end + 0.5 / rate, 1.0 / rate)
    need = problem.task.clearance + keep
    names = [a.name for a in problem.arms]
    report: dict = {"arms": [], "rms_jerk_ratio": {}}
    cache: dict = {}  # arm -> (its schedule, its poses at t)
    for name in names:
        sch = out[name]
        others = np.sort(np.array([e.t_start for n in names if n != name for e in out[n].events()], float))
        old = None
        for hold in (False, True):
            best = _eased_arm(sch, others, end, makespan, hold)
            if best is None:
                continue
            old = _arm_room(problem, out, name, t, cache) if old is None else old
            for lam in (1.0, 0.5, 0.25):
                steps = best if lam == 1.0 else _blend(sch.steps, best, lam, end)
                cand = dict(out)
                cand[name] = ArmSchedule(sch.arm, steps)
                if _arm_room(problem, cand, name, t, cache) >= min(old, need) - 1e-9:
                    _record(report, name, sch.steps, steps)
                    out = cand
                    break
            if out[name] is not sch:
                break
        if out[name] is sch:  # each move alone, into the rest beside it (no event moves)
            out = _ease_moves(problem, out, name, end, need, t, report, cache)
    return out, report
