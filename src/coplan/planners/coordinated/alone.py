"""The coordinated planner's last resort: one arm works at a time while the others rest
(:func:`one_at_a_time`), moving a resting neighbour out of the way when it has to.

Used when leg-by-leg coordination deadlocks on every candidate and taking turns
(:mod:`coplan.planners.coordinated.serial`) spends its budget or leaves fruit out. It always
gives a conflict-free plan, at worst partial, and needs no search.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ...allocate.allocation import Allocation, arm_configs, choose_branches as fastest_branches
from ...problem.model import Problem
from .candidate import Coordinated, Fallback, makespan_of
from .routing import ArmGeometry, stow_poses
from .schedule import ArmSchedule, Step, StepKind, decoupled_schedules, pair_distances, scurve_move
from ...ties import quantised

__all__ = ["one_at_a_time"]


class _Alone:
    """The arms' timelines and where each one rests, as the arms take their turns."""

    def __init__(self, problem: Problem, margin: float, rate: float):
        # nothing moves but one arm, sampled so finely that no point of it moves more than
        # margin / 4 between samples: half the margin at the samples keeps a quarter between them
        self.problem, self.need = problem, problem.task.clearance + margin / 2
        self.geo = ArmGeometry(problem, self.need)
        self.stows: dict[int, np.ndarray] = {}
        self.nbrs = self.geo.nbrs
        self.rest = [tuple(float(x) for x in a.home) for a in problem.arms]
        self.timeline: list[list[Step]] = [[] for _ in problem.arms]
        self.t = 0.0
        self.rates = []
        for arm in problem.arms:
            l1, l2 = arm.links
            speed = (l1 + l2) * arm.max_velocity[0] + l2 * arm.max_velocity[1]  # fastest any point of the arm moves
            self.rates.append(max(rate, 4.0 * speed / margin) if margin > 0 else rate)

    def samples(self, i: int, steps: list[Step]) -> np.ndarray:
        """Arm i's poses along ``steps`` (times from their first start), densely (see :func:`one_at_a_time`)."""
        if not steps:
            return np.asarray(self.rest[i], float)[None]
        sch = ArmSchedule(self.problem.arms[i], [replace(s, t0=s.t0 - steps[0].t0) for s in steps])
        t = np.append(np.arange(0.0, sch.end, 1.0 / self.rates[i]), sch.end)
        return sch.state(t)[0]

    def first_hit(self, i: int, q: np.ndarray, rests: list | None = None) -> int | None:
        """The neighbour of arm i (at poses q) that some sample comes too close to, resting; None if none."""
        rests = self.rest if rests is None else rests
        for j in self.nbrs[i]:
            if (pair_distances(self.problem, q, np.asarray(rests[j], float)[None, :], i, j) < self.need).any():
                return j
        return None

    def clear_move(self, j: int, q0, q1, rests: list) -> Step | None:
        """Arm j's move from q0 to q1, if clear of every neighbour resting at ``rests``."""
        mv = scurve_move(self.problem.arms[j], 0.0, q0, q1)
        return mv if self.first_hit(j, self.samples(j, [mv]), rests) is None else None

    def stow(self, i: int, j: int, cycle: np.ndarray, later: np.ndarray, back_to, home_at) -> tuple | None:
        """Where neighbour j can rest while arm i does ``cycle``: a candidate rest pose clear of
        it, reached (and, if ``back_to`` is given, left again towards ``back_to`` once arm i
        rests at ``home_at``) without touching an arm at rest. The one clear of most of arm i's
        ``later`` work, then the quickest move. Returns ``(pose, move)`` or None."""
        if j not in self.stows:  # twice as many shoulder angles as the coordinator's: nothing else is moving
            self.stows[j] = stow_poses(self.problem.arms[j], n_shoulder=24)
        cand = self.stows[j]
        cand = cand[self.geo.static_hits(j, cand, i, cycle) == 0]
        if not len(cand):
            return None
        score = self.geo.static_hits(j, cand, i, later) if len(later) else np.zeros(len(cand), int)
        found = []
        for k in np.argsort(score, kind="stable"):
            c = tuple(float(x) for x in cand[k])
            mv = self.clear_move(j, self.rest[j], c, self.rest)
            if mv is None:
                continue
            if back_to is not None:
                after = list(self.rest)
                after[i] = home_at
                if self.clear_move(j, c, back_to, after) is None:
                    continue
            found.append((int(score[k]), mv.duration, c, mv))
            if len(found) >= 4:
                break
        if not found:
            return None
        _, _, c, mv = min(found, key=lambda x: (x[0], float(quantised(x[1]))))  # ties: the first found, on any CPU
        return c, mv

    def routed(self, i: int, cycle: list[Step]) -> tuple[list[Step], np.ndarray] | None:
        """``cycle`` with each move routed (:meth:`ArmGeometry.route`: a tucked transit where the
        straight move sweeps over a neighbour) and its samples; None when no move changes."""
        out, t, changed = [], cycle[0].t0, False
        for s in cycle:
            if s.kind != StepKind.MOVE:
                out.append(replace(s, t0=t))
                t = out[-1].t1
                continue
            q = s.q0
            vias = self.geo.route(i, s.q0, s.q1)
            changed |= len(vias) > 1
            for v in vias:
                out.append(scurve_move(self.problem.arms[i], t, q, v))
                t, q = out[-1].t1, v
        return (out, self.samples(i, out)) if changed else None

    def book(self, i: int, steps: list[Step]) -> None:
        """Arm i's ``steps`` from now (they start at 0), everyone else resting."""
        for s in steps:
            self.timeline[i].append(replace(s, t0=s.t0 - steps[0].t0 + self.t))
        if steps:
            self.t = self.timeline[i][-1].t1
            self.rest[i] = tuple(float(x) for x in steps[-1].q1)

    def go_home(self) -> int:
        """Once every arm's work is done: each arm not at home goes home alone, straight or by a
        tucked transit (:meth:`ArmGeometry.route`), when that is clear of every arm at rest; in
        passes until none can go (an arm parked in another's way goes once that one is home).
        Returns how many arms are left away from home."""
        home = [tuple(float(x) for x in a.home) for a in self.problem.arms]
        away = [i for i in range(len(home)) if not np.allclose(self.rest[i], home[i], atol=1e-12, rtol=0)]
        moved = True
        while away and moved:
            moved = False
            for i in list(away):
                for vias in ([home[i]], self.geo.route(i, self.rest[i], home[i])):
                    steps, q = [], self.rest[i]
                    for v in vias:
                        steps.append(scurve_move(self.problem.arms[i], steps[-1].t1 if steps else 0.0, q, v))
                        q = v
                    if self.first_hit(i, self.samples(i, steps)) is None:
                        self.book(i, steps)
                        away.remove(i)
                        moved = True
                        break
        return len(away)

    def schedules(self) -> dict[str, ArmSchedule]:
        out = {}
        for arm, line in zip(self.problem.arms, self.timeline):
            steps, t, pose = [], 0.0, tuple(float(x) for x in arm.home)
            for s in line:
                if s.t0 > t + 1e-12:
                    steps.append(Step(StepKind.WAIT, t, s.t0 - t, pose, pose))
                steps.append(s)
                t, pose = s.t1, s.q1
            out[arm.name] = ArmSchedule(arm, steps)
        return out


def _cycles(sch: ArmSchedule) -> list[list[Step]]:
    """An arm's schedule cut into cycles: each from the move to a fruit to its place (a move
    home at the end, if any, is a cycle of its own)."""
    out, cur = [], []
    for s in sch.steps:
        cur.append(s)
        if s.kind == StepKind.PLACE:
            out.append(cur)
            cur = []
    if cur:
        out.append(cur)
    return out


def one_at_a_time(problem: Problem, alloc: Allocation, margin: float, say: Callable[[str], None] | None = None,
                  tried: list | None = None, rate: float = 1000.0):
    """The last resort, which always gives a conflict-free plan: one arm works at a time while
    every other arm rests (at home, or where it finished), in the arms' order.

    Each arm does its allocated work, fastest decoupled schedule, cycle by cycle (move to the
    fruit, pick, move to the bin, place), without going home at the end; once every arm is done,
    the arms go home one at a time (:meth:`_Alone.go_home`; one that cannot stays where it is,
    and the verifier warns that it does not end at home). When a cycle comes
    within ``clearance + margin / 2`` of a neighbour resting, the neighbour first moves (alone) to
    a candidate rest pose clear of that cycle -- home, over its bin, folded-elbow poses --
    reached without touching an arm at rest; a neighbour that still has its own work to do
    must also be able to go home again once this arm is done, and does so then. When no such
    pose exists the fruit is left out with the reason and the arm's schedule is made again;
    a fruit an earlier arm had to leave is offered to the next arm that reaches it.
    Checked densely: each arm is sampled at least at ``rate`` and often enough that no point of
    it moves more than ``margin / 4`` between samples (at its joint velocity limits), so the
    clearance between samples is at least ``clearance + margin / 4``.
    """
    st = _Alone(problem, margin, rate)
    left_out: dict[str, str] = {}
    assignment: dict[str, tuple[str, ...]] = {}
    fruit_q = {a: dict(v) for a, v in alloc.fruit_q.items()}
    place_q = {a: dict(v) for a, v in alloc.place_q.items()}
    x_of = {f.id: f.position[0] for f in problem.fruits}
    moved = 0
    for i, arm in enumerate(problem.arms):
        seq = list(alloc.assignment.get(arm.name, ()))
        bins, fq = arm_configs(problem, arm)
        extra = [f for f in left_out if f in fq and bins]  # fruit an earlier arm had to leave: this one may take them
        if extra:
            seq = sorted(seq + extra, key=lambda f: x_of[f])
            fs, ps, _ = fastest_branches(problem, arm, seq, bins, fq)
            fruit_q[arm.name] = dict(zip(seq, fs))
            place_q[arm.name] = dict(zip(seq, ps))
            for f in extra:
                del left_out[f]
        start = (st.t, [list(x) for x in st.timeline], list(st.rest))
        while True:
            st.t, st.timeline, st.rest = start[0], [list(x) for x in start[1]], list(start[2])
            solo = replace(alloc, assignment={a.name: tuple(seq) if a.name == arm.name else () for a in problem.arms},
                           fruit_q=fruit_q, place_q=place_q)
            cycles = _cycles(decoupled_schedules(problem, solo, return_home=False)[arm.name])
            samples = [st.samples(i, c) for c in cycles]
            home_at = tuple(float(x) for x in cycles[-1][-1].q1) if cycles else st.rest[i]
            away: dict[int, tuple] = {}  # neighbour -> (where it rested before it moved out of the way, cycle)
            blocked = None
            for k in range(len(cycles)):
                cyc, q = cycles[k], samples[k]
                j = st.first_hit(i, q)
                if j is not None and (alt := st.routed(i, cyc)) is not None:
                    cycles[k], samples[k] = cyc, q = alt  # moves tucked around the neighbours where they must be
                    j = st.first_hit(i, q)
                tries = 0
                while j is not None and tries < len(st.nbrs[i]) + 1:
                    tries += 1
                    later = np.vstack(samples[k + 1:]) if k + 1 < len(samples) else np.empty((0, 2))
                    back = start[2][j] if j > i else None  # an arm still to work must get home again
                    got = st.stow(i, j, q, later, back, home_at)
                    if got is None:
                        break
                    away.setdefault(j, (st.rest[j], k))
                    st.book(j, [got[1]])
                    j = st.first_hit(i, q)
                if j is not None:
                    blocked = (k, j)
                    break
                st.book(i, cyc)
            for j, (before, k) in away.items() if blocked is None else ():
                if j > i:  # an arm still to work goes back where it rested (its own work starts there)
                    mv = st.clear_move(j, st.rest[j], before, st.rest)
                    if mv is None:
                        blocked = (k, j)  # it cannot: the cycle that sent it away is left out
                        break
                    st.book(j, [mv])
            if blocked is None:
                moved += len(away)
                break
            k, j = blocked
            fid = next((s.fruit for s in cycles[k] if s.fruit is not None), seq[-1])
            seq.remove(fid)
            left_out[fid] = (f"with one arm working at a time, arm {arm.name!r} comes within {st.need:g} m of arm "
                             f"{problem.arms[j].name!r} resting while it harvests this fruit, and that arm has no "
                             "rest pose clear of it")
        assignment[arm.name] = tuple(seq)
    not_home = st.go_home()
    out = st.schedules()
    al = replace(alloc, assignment=assignment, fruit_q=fruit_q, place_q=place_q)
    span = makespan_of(out)
    if tried is not None:
        tried.append({"fallback": Fallback.ONE_AT_A_TIME.value, "feasible": True, "makespan": span, "left_out": left_out,
                      "moved_out_of_the_way": moved, "not_home": not_home})
    if say is not None:
        say(f"one arm at a time, the others resting: {span:.2f} s, {len(left_out)} fruit left out")
    return Coordinated(al, out, span, [], Fallback.ONE_AT_A_TIME, 0, fallback=True, left_out=left_out)
