"""Large-neighbourhood search over allocation, order, elbow branches and priorities, with the
fast coordinator as its evaluator (used by the anytime optimal planner, :mod:`coplan.optimal`).

Entry point: :func:`improve`. A state is which arm takes which fruit in which order, which
elbow-branch rule builds the poses, and the arms' priority order. A move changes one of them:

* ``first``    -- put one of an arm's fruit first (the only trip that starts from home),
* ``relocate`` -- give one fruit to another arm that reaches it (where that arm's decoupled
  finish is earliest),
* ``swap``     -- exchange two fruit between two arms that reach both,
* ``exchange`` / ``move`` / ``twoopt`` / ``reverse`` -- reorder within an arm (swap two fruit;
  move one to another place; reverse a stretch; reverse the whole sweep),
* ``flip``     -- force the other elbow branch at one fruit (or release a forced one),
* ``variant``  -- the :class:`BranchRule`: elbow branches chosen for speed, or for keeping out
  of the neighbours' way at one of a few prices per pose in their way,
* ``priority`` -- which arm goes first when two want the same space.

Moves mostly touch the critical arm (the one placing last). Each candidate is first bounded
from below by its arms' decoupled finish times (the per-arm dynamic programme over elbow
branches, cached per sequence): one that cannot beat the current state is rejected without
coordinating. The others are coordinated (:func:`coplan.coordinate.coordinate`, sharing one
cache of routes and moves) and kept when their makespan is lower, or equal with less total
work. After ``stall`` evaluations without progress the search restarts from the best state
with a few random moves (an iterated local search). After ``patience`` evaluations without a
new best it starts afresh, alternately from an *anchor* (the lower bound's own allocation,
each arm's fruit in their fastest order, which arm takes which fruit held for that start)
and from the start state.

When the whole state space is small (a few fruit), it is searched exhaustively instead: every
state, cheapest estimate first, until the estimate alone cannot beat the best -- a branch and
bound whose result is the best plan the coordinator can make (``StopReason.EXHAUSTED``).

Every budget is work -- coordinator runs, proposals -- and the random moves come from a seeded
generator, so the same problem and options give the same plan on any machine and under any
load. Only an explicit ``deadline`` depends on the clock. It stops at once when the makespan
meets the lower bound (``tolerance``): the plan is then proven optimal.
"""

from __future__ import annotations

import itertools
import math
import time as _time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from ...allocate.allocation import arm_configs, choose_branches as fastest_branches
from ..coordinated.budget import attempt_checks
from ..coordinated.coordinate import coordinate
from ..coordinated.planner import Coordinated, makespan_of
from ...problem.model import Problem
from ..coordinated.routing import choose_branches as clear_branches
from ..coordinated.schedule import ConflictError, decoupled_schedules
from ..coordinated.trace import Trace
from ...ties import first_max_index, first_min, quantised
from .search_setup import BranchRule, Move, SearchOptions, StopReason

__all__ = ["BranchRule", "Move", "Neighbourhood", "SearchOptions", "SearchStats", "State", "StopReason", "improve"]


@dataclass
class SearchStats:
    evaluations: int = 0
    checks: int = 0  # conflict checks as if every run started from scratch (the work budget)
    checks_made: int = 0  # the checks really made (runs resume recent ones, see coordinated.trace)
    proposals: int = 0
    pruned: int = 0
    failed: int = 0
    improvements: int = 0
    restarts: int = 0
    fresh_starts: int = 0
    anchored: int = 0  # starts from the anchor (the first one included)
    anchor_makespan: float | None = None  # the anchor coordinated (None: no anchor, or it could not be)
    stop: StopReason = StopReason.BUDGET
    moves: dict | None = None  # move kind -> [tried, improved]
    best_state: State | None = None  # the state of the best candidate (where a refinement goes on from)
    local_bests: list = field(default_factory=list)  # (candidate, state): the best of each start, in turn

    def summary(self) -> dict:
        return {"evaluations": self.evaluations, "checks": self.checks, "checks_made": self.checks_made,
                "proposals": self.proposals, "pruned_by_bound": self.pruned, "coordination_failed": self.failed,
                "improvements": self.improvements, "restarts": self.restarts, "fresh_starts": self.fresh_starts,
                "anchored": self.anchored, "anchor_makespan": self.anchor_makespan,
                "stopped_by": self.stop.value, "moves": self.moves}


@dataclass(frozen=True)
class State:
    """One point of the search space: which arm takes which fruit in which order, the elbow
    branch rule, the arms' priority order and any elbow branches forced at single fruit."""

    assign: tuple[tuple[str, ...], ...]  # per arm (problem order), fruit in harvesting order
    variant: BranchRule
    order: tuple[str, ...]  # priority
    forced: frozenset = frozenset()  # (arm index, fruit id, branch index): elbow branch forced at a fruit

    def forced_of(self, i: int) -> tuple:
        return tuple(sorted((f, b) for a, f, b in self.forced if a == i))


_MOVES = tuple(Move)  # (in this order: the weights below, and the seeded draws, follow it)
_WEIGHTS = np.array([3.0, 4.0, 3.0, 1.0, 1.5, 1.0, 0.5, 2.0, 0.5, 0.5])


class Neighbourhood:
    """The search space around a coordinated ``start``: :meth:`propose` a random move from a
    :class:`State`, :meth:`estimate` its decoupled bound, :meth:`evaluate` it with the
    coordinator (sharing ``cache``). Its random stream is seeded by ``opts.seed``."""

    def __init__(self, problem: Problem, start: Coordinated, margin: float, opts: SearchOptions, cache: dict):
        self.problem, self.margin, self.opts, self.cache = problem, margin, opts, cache
        self.names = [a.name for a in problem.arms]
        self.cfg = [arm_configs(problem, arm) for arm in problem.arms]
        self.pos = {f.id: f.position for f in problem.fruits}
        self.reach = {f.id: [i for i in range(len(self.names)) if f.id in self.cfg[i][1]] for f in problem.fruits}
        self.start = start
        self.rng = np.random.default_rng(opts.seed)
        self._dp: dict = {}
        self.traces: dict[State, Trace] = {}  # recent coordinator runs, to resume from (see coordinate)
        self.stats = SearchStats(moves={m.value: [0, 0] for m in _MOVES})
        self.deadline: float | None = None  # an explicit clock limit: a coordinator run stops there too
        self.hold(opts.fixed_assignment)

    def hold(self, assignment: bool) -> None:
        """Whether moves keep which arm takes which fruit (no relocate, no swap)."""
        w = _WEIGHTS * [not (assignment and m in (Move.RELOCATE, Move.SWAP)) for m in _MOVES]
        self.weights = w / w.sum()

    def state_of(self, c: Coordinated) -> State:
        order = tuple(c.order) if c.order else tuple(self.names)
        variant = c.variant if isinstance(c.variant, BranchRule) else BranchRule.BRANCHES
        return State(tuple(tuple(c.alloc.assignment[n]) for n in self.names), variant, order)

    def anchor(self, assignment: dict[str, tuple[str, ...]], order: tuple[str, ...]) -> State | None:
        """The state of ``assignment`` (arm -> fruit) with each arm's fruit in its fastest order
        (every order up to 6 fruit; else each fruit inserted where it finishes earliest), or
        None when it does not cover the start state's fruit."""
        given = sorted(f for n in self.names for f in assignment.get(n, ()))
        if given != sorted(f for seq in self.start.alloc.assignment.values() for f in seq):
            return None
        seqs = []
        for i, n in enumerate(self.names):
            if self.deadline is not None and _time.perf_counter() > self.deadline:
                return None  # (a long row's fastest orders take seconds: none under a spent clock limit)
            fr = tuple(assignment.get(n, ()))
            if len(fr) <= 6:
                seqs.append(first_min(itertools.permutations(fr), key=lambda p: self.dp(i, tuple(p))[2]) if fr else ())
            else:
                seq: list[str] = []
                for f in fr:
                    seq = self.insert_best(i, seq, f, ())
                seqs.append(tuple(seq))
        return State(tuple(seqs), BranchRule.BRANCHES, order)

    # ---- evaluation
    def dp(self, i: int, seq: tuple[str, ...], forced: tuple = ()):
        """The arm's fastest branches along ``seq`` (some fruit's branch forced): ``(fruit poses,
        place poses, finish)``, cached."""
        key = (i, seq, forced)
        hit = self._dp.get(key)
        if hit is None:
            bins, fq = self.cfg[i]
            if forced:
                fq = fq | {f: [fq[f][b]] for f, b in forced}
            hit = fastest_branches(self.problem, self.problem.arms[i], seq, bins, fq) if seq else ([], [], 0.0)
            self._dp[key] = hit
        return hit

    def estimate(self, s: State) -> float:
        return max((self.dp(i, seq, s.forced_of(i))[2] for i, seq in enumerate(s.assign)), default=0.0)

    def evaluate(self, s: State) -> Coordinated | None:
        """Coordinate state ``s`` (continuing the recent run whose legs agree longest with
        its own, see :mod:`coplan.planners.coordinated.trace`); None when coordination fails."""
        fruit_q, place_q, est = {}, {}, {}
        for i, seq in enumerate(s.assign):
            fs, ps, t = self.dp(i, seq, s.forced_of(i))
            n = self.names[i]
            fruit_q[n], place_q[n], est[n] = dict(zip(seq, fs)), dict(zip(seq, ps)), t
        al = replace(self.start.alloc, assignment=dict(zip(self.names, s.assign)), fruit_q=fruit_q, place_q=place_q,
                     estimate=est)
        if s.variant != BranchRule.FASTEST:
            al = clear_branches(self.problem, al, self.problem.task.clearance + self.margin, weight=s.variant.price,
                                 memo=self.cache.setdefault("branch_hits", {}))
            for i, f, b in s.forced:  # a forced branch stands
                al.fruit_q[self.names[i]][f] = self.cfg[i][1][f][b]
        base = decoupled_schedules(self.problem, al)
        self.stats.evaluations += 1
        work: dict = {}
        trace = Trace()
        try:
            sched, waits, _ = coordinate(self.problem, base, self.margin, priority=list(s.order),
                                         max_checks=attempt_checks(self.problem, self.opts.attempt_checks, self.opts.checks_per_fruit),
                                         cache=self.cache, work=work, deadline=self.deadline,
                                         trace=trace, resume=list(self.traces.values())[::-1])
        except ConflictError:
            self.stats.checks += work.get("checks", 0)
            self.stats.checks_made += work.get("checks_made", 0)
            self.stats.failed += 1
            return None
        self.stats.checks += work.get("checks", 0)
        self.stats.checks_made += work.get("checks_made", 0)
        self.traces[s] = trace
        if len(self.traces) > 8:  # the oldest goes
            del self.traces[next(iter(self.traces))]
        return Coordinated(al, sched, makespan_of(sched), list(s.order), s.variant, waits)

    def space(self, start: State, cap: int) -> list[tuple[float, State]] | None:
        """Every state (allocation, orders, forced elbow branches, variant, priority), with its
        estimate, cheapest first; None when there are more than ``cap`` of them."""
        fruits = [f for seq in start.assign for f in seq]
        if self.opts.fixed_assignment:
            owners = [[next(i for i, seq in enumerate(start.assign) if f in seq)] for f in fruits]
        else:
            owners = [self.reach[f] for f in fruits]
        per = len(BranchRule) * math.factorial(len(start.order))  # counted before any list is made:
        if per > cap:  # 12 arms have 479 million priority orders
            return None
        priorities = list(itertools.permutations(start.order))
        out: list[tuple[float, State]] = []
        for split in itertools.product(*owners):
            groups = [[f for f, a in zip(fruits, split) if a == i] for i in range(len(self.names))]
            # exact integers: these counts overflow any fixed-width type on a long row
            n_orders = math.prod(math.factorial(len(g)) for g in groups)
            n_branch = math.prod(len(self.cfg[a][1][f]) for f, a in zip(fruits, split))
            if len(out) + n_orders * n_branch * per > cap:
                return None
            for orders in itertools.product(*[itertools.permutations(g) for g in groups]):
                assign = tuple(tuple(o) for o in orders)
                for fb in itertools.product(*[range(len(self.cfg[a][1][f])) for f, a in zip(fruits, split)]):
                    forced = frozenset((a, f, b) for f, a, b in zip(fruits, split, fb))
                    est = self.estimate(State(assign, start.variant, start.order, forced))
                    out += [(est, State(assign, v, o, forced)) for v in BranchRule for o in priorities]
        out.sort(key=lambda x: float(quantised(x[0])))  # stable: ties keep the enumeration's order on any CPU
        return out

    # ---- moves
    def critical(self, c: Coordinated) -> int:
        last = [c.schedules[n].last_place for n in self.names]
        if self.rng.random() < 0.7:
            return first_max_index(last)
        busy = [i for i, seq in enumerate(c.alloc.assignment[n] for n in self.names) if seq]
        return int(self.rng.choice(busy)) if busy else 0

    def insert_sorted(self, seq: list[str], f: str) -> list[str]:
        x = self.pos[f][0]
        k = next((k for k, g in enumerate(seq) if self.pos[g][0] > x), len(seq))
        return seq[:k] + [f] + seq[k:]

    def insert_best(self, b: int, seq: list[str], f: str, forced: tuple) -> list[str]:
        """``seq`` with ``f`` inserted where arm b's decoupled finish is earliest (ties: the
        x-sorted place)."""
        ref = self.insert_sorted(seq, f)
        best, t_best = ref, self.dp(b, tuple(ref), forced)[2]
        for k in range(len(seq) + 1):
            trial = seq[:k] + [f] + seq[k:]
            if trial != ref:
                t = self.dp(b, tuple(trial), forced)[2]
                if t < t_best - 1e-9:
                    best, t_best = trial, t
        return best

    def propose(self, s: State, c: int) -> tuple[Move, State] | None:
        kind = _MOVES[int(self.rng.choice(len(_MOVES), p=self.weights))]  # (the same draw as choosing among the names)
        assign = [list(seq) for seq in s.assign]
        mine = assign[c]
        rng = self.rng
        if kind == Move.VARIANT:
            others = [v for v in BranchRule if v != s.variant]
            return kind, replace(s, variant=others[int(rng.integers(len(others)))])
        if kind == Move.PRIORITY:
            if len(s.order) < 2:
                return None
            i, j = rng.choice(len(s.order), 2, replace=False)
            order = list(s.order)
            order[i], order[j] = order[j], order[i]
            return kind, replace(s, order=tuple(order))
        if not mine:
            return None
        f = mine[int(rng.integers(len(mine)))]
        forced = s.forced
        if kind == Move.FLIP:
            branches = self.cfg[c][1][f]
            hit = [x for x in forced if x[0] == c and x[1] == f]
            if hit:
                return kind, replace(s, forced=forced - set(hit))
            if len(branches) < 2:
                return None
            now = self.dp(c, s.assign[c], s.forced_of(c))[0][s.assign[c].index(f)]
            b = 1 if np.allclose(now, branches[0]) else 0
            return kind, replace(s, forced=forced | {(c, f, b)})
        if kind == Move.FIRST:
            if mine[0] == f:
                return None
            assign[c] = [f] + [g for g in mine if g != f]
        elif kind == Move.REVERSE:
            if len(mine) < 2:
                return None
            assign[c] = mine[::-1]
        elif kind == Move.EXCHANGE:
            if len(mine) < 2:
                return None
            i, j = rng.choice(len(mine), 2, replace=False)
            mine[i], mine[j] = mine[j], mine[i]
        elif kind == Move.MOVE:  # one fruit to another place in the same arm's order
            if len(mine) < 2:
                return None
            rest = [g for g in mine if g != f]
            k = int(rng.integers(len(rest) + 1))
            if rest[:k] + [f] + rest[k:] == mine:
                return None
            assign[c] = rest[:k] + [f] + rest[k:]
        elif kind == Move.TWOOPT:  # reverse a stretch of the order
            if len(mine) < 3:
                return None
            i, j = sorted(rng.choice(len(mine) + 1, 2, replace=False))
            if j - i < 2:
                return None
            assign[c] = mine[:i] + mine[i:j][::-1] + mine[j:]
        elif kind == Move.RELOCATE:
            others = [b for b in self.reach[f] if b != c]
            if not others:
                return None
            b = int(rng.choice(others))
            assign[c] = [g for g in mine if g != f]
            forced = frozenset(x for x in forced if x[1] != f)
            assign[b] = self.insert_best(b, assign[b], f, tuple(sorted((g, k) for a, g, k in forced if a == b)))
        else:  # swap
            pairs = [(b, g) for b in self.reach[f] if b != c for g in assign[b] if c in self.reach[g]]
            if not pairs:
                return None
            b, g = pairs[int(rng.integers(len(pairs)))]
            assign[c] = [g if h == f else h for h in mine]
            assign[b] = [f if h == g else h for h in assign[b]]
            forced = frozenset(x for x in forced if x[1] not in (f, g))
        return kind, replace(s, assign=tuple(tuple(seq) for seq in assign), forced=forced)


def _better(a: Coordinated, b: Coordinated) -> bool:
    """Whether ``a`` beats ``b``: a lower makespan, or the same with less total work."""
    if a.makespan < b.makespan - 1e-9:
        return True
    return abs(a.makespan - b.makespan) <= 1e-9 and a.total < b.total - 1e-9


def improve(
    problem: Problem,
    start: Coordinated,
    bound: float,
    margin: float,
    options: SearchOptions | None = None,
    on_improve: Callable[[Coordinated], None] | None = None,
    deadline: float | None = None,
    cache: dict | None = None,
    anchor: dict[str, tuple[str, ...]] | None = None,
    hood: Neighbourhood | None = None,
    tick: Callable[[float], None] | None = None,
) -> tuple[Coordinated, SearchStats]:
    """Improve a coordinated candidate by large-neighbourhood search (see the module docstring).

    ``on_improve`` is called with every new best (lower makespan). ``anchor`` (arm -> fruit,
    e.g. the lower bound's allocation): where every other fresh start begins, its assignment
    held for that start (none with ``fixed_assignment``). Returns the best candidate and the
    search's statistics (``stats.stop`` says what ended it; ``stats.best_state`` is the best
    candidate's state). Ctrl-C ends the search with what it has (``StopReason.INTERRUPTED``).
    ``hood``: the neighbourhood to search (made from the other arguments when None; pass one
    to go on from it afterwards, e.g. :func:`coplan.planners.optimal.refine.refine`).
    ``tick`` receives the share of the budget spent (the larger of work and evaluations) after
    every evaluation.
    """
    opts = options or SearchOptions()
    srch = hood if hood is not None else Neighbourhood(problem, start, margin, opts, {} if cache is None else cache)
    srch.deadline = deadline
    st = srch.stats
    best = cur = pbest = start  # pbest: the best of this start (the patience counts from it)
    s_cur = s_pbest = st.best_state = srch.state_of(start)
    seen = {s_cur}
    since_best = since_cur = idle = 0
    max_proposals = 50 * opts.evaluations + 100
    space = srch.space(s_cur, opts.exhaustive) if opts.exhaustive > 0 and best.makespan > bound + opts.tolerance else None
    if space is not None and sum(est < best.makespan - 1e-9 for est, _ in space) > opts.evaluations // 2:
        space = None  # branch and bound might not finish within half the budget: search instead
    try:
        if space is not None:
            best = _exhaust(srch, space, best, bound, seen, on_improve, deadline, tick)
            return best, st
        # the anchor: where every other fresh start begins -- and the first, when it beats the start
        a_state = a_cand = None
        a_turn = 1  # fresh starts with this parity begin at the anchor
        if deadline is not None and _time.perf_counter() > deadline:
            st.stop = StopReason.TIME_LIMIT
            return best, st
        if anchor is not None and not opts.fixed_assignment and best.makespan > bound + opts.tolerance:
            a_state, a_cand = _anchor_start(srch, anchor, s_cur, seen)
            if a_cand is not None and a_cand.makespan < best.makespan - 1e-9:
                a_turn = 0
                st.anchored = 1
                cur, s_cur, pbest, s_pbest = a_cand, a_state, a_cand, a_state
                srch.hold(True)
                best, st.best_state = a_cand, a_state
                st.improvements += 1
                if on_improve is not None:
                    on_improve(best)
        while True:
            why = _stop_reason(best.makespan, bound, st, opts, idle, since_best, max_proposals)
            if why is not None:
                st.stop = why
                break
            if since_best >= opts.patience:  # a fresh start: from the anchor (held) or the start
                st.local_bests.append((pbest, s_pbest))
                st.fresh_starts += 1
                since_best = since_cur = 0
                cur, s_cur = start, srch.state_of(start)
                srch.hold(opts.fixed_assignment)
                if a_state is not None and st.fresh_starts % 2 == a_turn:
                    st.anchored += 1
                    cur, s_cur = a_cand, a_state
                    srch.hold(True)
                pbest, s_pbest = cur, s_cur
                continue
            if deadline is not None and _time.perf_counter() > deadline:
                st.stop = StopReason.TIME_LIMIT
                break
            if since_cur >= opts.stall:  # restart from the best with a kick
                st.restarts += 1
                cur, s_cur, since_cur = pbest, srch.state_of(pbest), 0
                for _ in range(opts.kick):
                    mv = srch.propose(s_cur, srch.critical(cur))
                    if mv is not None:
                        s_cur = mv[1]
                trial = srch.evaluate(s_cur) if srch.estimate(s_cur) < best.makespan + 2.0 else None
                if trial is not None:
                    cur = trial
                else:
                    s_cur = srch.state_of(best)
                continue
            st.proposals += 1
            idle += 1
            mv = srch.propose(s_cur, srch.critical(cur))
            if mv is None:
                continue
            kind, s_new = mv
            if s_new in seen:
                continue
            seen.add(s_new)
            if srch.estimate(s_new) > cur.makespan + 1e-9:
                st.pruned += 1
                continue
            idle = 0
            st.moves[kind.value][0] += 1
            cand = srch.evaluate(s_new)
            if tick is not None:
                tick(max(st.checks / max(1, opts.work), st.evaluations / max(1, opts.evaluations)))
            since_best += 1
            since_cur += 1
            if cand is None:
                continue
            if not _better(cand, cur):
                temp = opts.temperature * max(0.0, 1.0 - st.checks / max(1, min(opts.work, opts.cooling)))
                worse = cand.makespan - cur.makespan
                if temp <= 0 or worse <= 1e-9 or srch.rng.random() >= np.exp(-worse / temp):
                    continue
                cur, s_cur = cand, s_new  # accepted uphill (annealing): the best stays
                continue
            cur, s_cur, since_cur = cand, s_new, 0
            if cand.makespan < pbest.makespan - 1e-9:
                pbest, s_pbest, since_best = cand, s_new, 0
            elif _better(cand, pbest):
                pbest, s_pbest = cand, s_new
            if cand.makespan < best.makespan - 1e-9:
                best, st.best_state = cand, s_new
                st.improvements += 1
                st.moves[kind.value][1] += 1
                if on_improve is not None:
                    on_improve(best)
            elif _better(cand, best):
                best, st.best_state = cand, s_new
    except KeyboardInterrupt:
        st.stop = StopReason.INTERRUPTED
    if space is None:
        st.local_bests.append((pbest, s_pbest))
    return best, st


def _stop_reason(makespan: float, bound: float, st: SearchStats, opts: SearchOptions, idle: int, since_best: int,
                 max_proposals: int) -> StopReason | None:
    """Why :func:`improve`'s search stops before its next step (None: it goes on): the best
    ``makespan`` at the lower bound (proven optimal), the budget spent (evaluations, conflict
    checks or proposals), or no progress (``idle`` proposals gave no new state; ``since_best``
    evaluations past the patience with every fresh start made)."""
    if makespan <= bound + opts.tolerance:
        return StopReason.PROVEN_OPTIMAL
    if st.evaluations >= opts.evaluations or st.checks >= opts.work or st.proposals >= max_proposals:
        return StopReason.BUDGET
    if idle >= 500 or (since_best >= opts.patience and st.fresh_starts >= opts.starts):
        return StopReason.STALLED  # no progress, or no new state left to try
    return None


def _anchor_start(srch: Neighbourhood, anchor: dict[str, tuple[str, ...]], s_cur, seen: set):
    """The anchor's state (``anchor``'s assignment, ``s_cur``'s order where it can) and its
    candidate, evaluated (added to ``seen``; its makespan in the stats); (None, None) when it is
    the start's own state or has no plan."""
    a_state = srch.anchor(anchor, s_cur.order)
    a_cand = srch.evaluate(a_state) if a_state is not None and a_state != s_cur else None
    if a_cand is None:
        return None, None
    seen.add(a_state)
    srch.stats.anchor_makespan = a_cand.makespan
    return a_state, a_cand


def _exhaust(srch: Neighbourhood, space, best: Coordinated, bound: float, seen: set, on_improve, deadline, tick=None) -> Coordinated:
    """Branch and bound over the whole (small) state space, cheapest estimate first."""
    st, opts = srch.stats, srch.opts
    st.stop = StopReason.EXHAUSTED
    for est, s in space:
        if best.makespan <= bound + opts.tolerance:
            st.stop = StopReason.PROVEN_OPTIMAL
            break
        if est >= best.makespan - 1e-9:  # nothing left can beat the best
            break
        if st.evaluations >= opts.evaluations or st.checks >= opts.work:
            st.stop = StopReason.BUDGET
            break
        if deadline is not None and _time.perf_counter() > deadline:
            st.stop = StopReason.TIME_LIMIT
            break
        if s in seen:
            continue
        seen.add(s)
        st.proposals += 1
        cand = srch.evaluate(s)
        if tick is not None:
            tick(max(st.checks / max(1, opts.work), st.evaluations / max(1, opts.evaluations)))
        if cand is not None and cand.makespan < best.makespan - 1e-9:
            best, st.best_state = cand, s
            st.improvements += 1
            if on_improve is not None:
                on_improve(best)
    return best
