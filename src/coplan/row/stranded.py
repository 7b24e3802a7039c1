"""After an arm stops: which fruit a working arm can still harvest (a live row's plan and report).

A live row (:mod:`coplan.row.live`) counts the fruit it missed though a working arm could still
reach them: the true fruit, from a carriage position the carriage had not yet passed (stop and
go: one it could still brake to -- picks are made at rest), under the screen's rules
(:func:`coplan.allocate.screen.usable_picks`) -- before an arm stopped, by any arm; after, by
the working arms with a pick pose that keeps the clearance from every stopped arm where it
rests. Entry point: :func:`still_reachable`.

The same test plans a stop-and-go row after the fault: :class:`StoppedCover` masks the row's
screen so that each working arm keeps only the carriage positions with such a pose
(:func:`clear_cover`), and the stops are chosen on that; :func:`why_left_at_rest` says why a
stop-and-go row missed a fruit after the fault (the stops it was left to).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

from ..problem.model import Problem
from .booking import Booker
from .policy import why_left
from .cruise import stop_from

if TYPE_CHECKING:
    from .liverun import LiveRun

__all__ = ["still_reachable", "clear_cover", "StoppedCover", "why_left_at_rest"]


def _cannot_stop_at(problem: Problem, state, x_to: float) -> bool:
    try:
        stop_from(problem, state, x_to)
    except ValueError:
        return True
    return False


def _positions(booker: Booker, grid: np.ndarray, t: float, at_rest: bool) -> np.ndarray:
    """Grid positions at or ahead of where the carriage is at ``t`` (it never goes back; with
    ``at_rest``, where it can still come to rest from its motion then), up to where it rests."""
    cruise = booker.cruise
    state = tuple(float(u[0]) for u in cruise.state(np.array([min(t, cruise.duration)])))  # x, v, a then
    cs = grid[(grid >= state[0] - 1e-9) & (grid <= cruise.x1 + 1e-9)]
    if at_rest and abs(state[1]) + abs(state[2]) > 1e-12:  # picks only at rest: where it can still come to rest
        while cs.size and _cannot_stop_at(booker.problem, state, float(cs[0])):
            cs = cs[1:]
    return cs


def _clear_at(booker: Booker, xy, cs: np.ndarray, arm: int, halt) -> np.ndarray:
    """(len(cs),) bool: whether arm ``arm`` picks the fruit at row point ``xy`` with the carriage
    at each of ``cs`` under the screen's rules, with a pose clear of every arm in ``halt`` where
    it rests (either elbow branch)."""
    from ..allocate.screen import usable_picks
    from ..planners.coordinated.schedule import arm_points, points_too_close

    out = np.zeros(cs.size, dtype=bool)
    if cs.size == 0:
        return out
    cell = booker.cell  # the carriage frame
    pts = np.c_[xy[0] - cs, np.full(cs.size, xy[1])]
    use = usable_picks(cell, pts, arms=(arm,))[arm]  # (len(cs), 2)
    me = cell.arms[arm]
    q, _ = me.ik(pts)
    for b in (0, 1):
        idx = np.flatnonzero(use[:, b] & ~out)
        if not idx.size:
            continue
        pa = arm_points(me, q[idx, b])
        for j in halt:
            rest = booker.arms[j].q[booker.arms[j].k_free]
            clear = ~points_too_close(pa, arm_points(cell.arms[j], rest), me.link_radius + cell.arms[j].link_radius,
                                      booker.problem.task.clearance)
            pa, idx = tuple(p[clear] for p in pa), idx[clear]
        out[idx] = True
    return out


def _reaches(booker: Booker, xy, cs: np.ndarray, arms: list[int], halt) -> bool:
    """Whether one of ``arms`` picks the fruit at ``xy`` from a position in ``cs`` under the
    screen's rules, with a pose clear of every arm in ``halt`` where it rests."""
    return any(_clear_at(booker, xy, cs, a, halt).any() for a in arms)


def clear_cover(booker: Booker, grid: np.ndarray, xy, cover: np.ndarray, halt) -> np.ndarray:
    """A fruit's row cover (``(A, K)`` bool, :class:`coplan.row.reach.RowReach`) once the arms in
    ``halt`` have stopped: each working arm keeps only the carriage positions from which it has
    a pick pose clear of every stopped arm where it rests (the screen knows nothing of an arm
    left out over its neighbours' fruit); a stopped arm's row is kept as it was (who could have
    reached it: the reason a fruit is left)."""
    out = cover.copy()
    for a in range(cover.shape[0]):
        if a in halt:
            continue
        ks = np.flatnonzero(cover[a])
        if ks.size:
            out[a, ks] = _clear_at(booker, xy, grid[ks], a, halt)
    return out


def still_reachable(booker: Booker, grid: np.ndarray, xy, t_seen: float, halt: dict[int, float], at_rest: bool) -> bool:
    """Whether a working arm could still pick the fruit at row point ``xy``, reported at
    ``t_seen``, from a carriage position it had not yet passed (``at_rest``: stop and go, where
    it could still come to rest), on the row screen's ``grid``, under the screen's rules:

    * with every arm working (none in ``halt``, arm -> the time it stopped): from any position
      after the report;
    * a fruit the carriage passed before the first arm stopped, out of every arm's reach by
      then: from a position after the report and before the stop, any arm;
    * otherwise (it was still ahead when the arm stopped): from a position after both, by an
      arm still working, with a pose clear of every stopped arm where it rests (what the stopped
      arm was to pick and no other arm can reach from there on is not counted: those fruit are
      the fault's, reported with their reasons)."""
    n = len(booker.problem.arms)
    every = list(range(n))
    if not halt:
        return _reaches(booker, xy, _positions(booker, grid, t_seen, at_rest), every, {})
    t_stop = min(halt.values())
    if t_seen < t_stop:
        c_stop = float(booker.cruise.x(np.array([min(t_stop, booker.cruise.duration)]))[0])
        ahead = grid[(grid >= c_stop - 1e-9) & (grid <= booker.cruise.x1 + 1e-9)]
        if not _reaches(booker, xy, ahead, every, {}):  # passed before the stop, every arm working
            before = _positions(booker, grid, t_seen, at_rest)
            return _reaches(booker, xy, before[before < c_stop - 1e-9], every, {})
    working = [a for a in every if a not in halt]
    return _reaches(booker, xy, _positions(booker, grid, max(t_seen, t_stop), at_rest), working, halt)


class StoppedCover:
    """A live row's screen once arms have stopped (stop and go, :mod:`coplan.row.live`): each
    fruit's cover in ``reach`` keeps, for every working arm, only the carriage positions with a
    pick pose clear of the stopped arms where they rest (:func:`clear_cover`) -- the screen alone
    sent the carriage on to stops from which a neighbour of the stopped arm could not reach a
    fruit without touching it, and the fruit was passed. :meth:`update` as the planner learns of
    a stop (and as new reports come): the covers as screened are kept to mask again."""

    def __init__(self, booker: Booker, reach) -> None:
        self.booker, self.reach = booker, reach
        self.whole: dict[str, np.ndarray] = {}  # fruit -> its cover as screened, once masked
        self.key: tuple = ()

    def update(self, stopped, skip=()) -> None:
        """Mask every fruit's cover (but those in ``skip``, e.g. taken) against the arms in
        ``stopped`` where they now rest; a fruit masked against the same rests is left as is."""
        if not stopped:
            return
        arms = self.booker.arms
        key = tuple((j, tuple(arms[j].q[arms[j].k_free].round(12))) for j in sorted(stopped))
        todo = [f for f in self.reach.cover if f not in skip and (key != self.key or f not in self.whole)]
        self.key = key
        if not todo:
            return
        halt = dict.fromkeys(stopped, 0.0)
        xy = {f.id: f.position for f in self.reach.problem.fruits}  # (as reported: what the screen saw)
        for f in todo:
            whole = self.whole.setdefault(f, self.reach.cover[f])
            self.reach.cover[f] = clear_cover(self.booker, self.reach.grid, xy[f], whole, halt)


def why_left_at_rest(run: "LiveRun", fid: str, rested: list[int], halt: dict[int, float]) -> str:
    """Why a stop-and-go row left ``fid``: picks happen only at the stops (grid indices
    ``rested``), so where only a stopped arm reached it from them, that is the reason (the
    carriage never goes back), not a window it passed while hopping; else :func:`why_left`."""
    cov = run.reach.cover[fid][:, rested] if rested else np.zeros((len(run.problem.arms), 0), bool)
    at_rest = [a for a in range(cov.shape[0]) if cov[a].any()]
    arms = run.problem.arms
    if at_rest and all(a in halt for a in at_rest):
        names = " or ".join(arms[a].name for a in at_rest)
        when = ", ".join(f"{arms[a].name} at t = {halt[a]:.1f} s" for a in at_rest)
        return (f"{fid}: from the carriage's stops only {names} could reach it, and it stopped ({when}); "
                "the carriage does not go back")
    # a working arm reached it from a stop, which left it to the next stop that reaches it, where
    # only a stopped arm did (the next one: the last such stop was named, not the one it was left to)
    working = [(i, a) for i in range(cov.shape[1]) for a in range(cov.shape[0]) if cov[a, i] and a not in halt]
    if working:
        i, a = working[-1]
        nxt = [j for j in range(i + 1, cov.shape[1]) if cov[:, j].any()]
        if nxt:
            j = nxt[0]
            later = [b for b in range(cov.shape[0]) if cov[b, j]]  # (all stopped: no working arm reaches it after i)
            x, xj = float(run.reach.grid[rested[i]]), float(run.reach.grid[rested[j]])
            names = " or ".join(arms[b].name for b in later)
            when = ", ".join(f"{arms[b].name} at t = {halt[b]:.1f} s" for b in later)
            return (f"{fid}: {arms[a].name} could reach it from the stop at x = {x:.2f} m, which left it to the stop "
                    f"at x = {xj:.2f} m; from there only {names} could reach it, and it stopped ({when}); the carriage does "
                    "not go back")
    return why_left(run.booker, fid, halt)
