"""A live row stop by stop (:func:`stop_and_go`; the rules are :mod:`coplan.row.live`'s
docstring's): at each stop, book its share of the fruit reported, then hop to the next once the
last pick is over. :class:`StopAndGo` holds the run's state between stops; each of its methods
is one step of a stop: what the planner knows of the faults, how far the camera has seen, where
the carriage may hop, the stop's windows and share, a false burst, the hop."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from ..plan import EventKind
from ..problem.model import Fruit
from .cruise import Cruise, pick_windows
from .liverun import LiveRun
from .livestops import last_stop, next_to_last, stop_share
from .reach import row_reach
from .sensing import FaultDraws, front_base
from .stopcell import book_cell
from .stranded import StoppedCover, why_left_at_rest
from .track import AT_REST_CYCLE_SHARE, AT_REST_SHARE

__all__ = ["STOP_PATIENCE", "StopAndGo", "stop_and_go"]

#: Stop and go: a stop's picks may start up to this long per fruit in reach (and one more) after it arrives, s.
STOP_PATIENCE = 10.0


def stop_and_go(run: LiveRun, faults: FaultDraws) -> tuple[dict[str, str], list[dict]]:
    """Run the row stop by stop. Returns why each fruit left was left, and the stops (position,
    arrival, departure, picks)."""
    return StopAndGo(run, faults).run()


class StopAndGo:
    """The state of one stop-and-go live row between its stops."""

    def __init__(self, run: LiveRun, faults: FaultDraws):
        self.live, self.faults = run, faults
        self.problem, self.opts, self.g = run.problem, run.opts, run.problem.gantry
        self.reach, self.grid = run.reach, run.reach.grid
        problem = self.problem
        # the rear arm that harvests: an arm the screen locks (it cannot reach its bin) serves no fruit,
        # and a hop capped by its base carried the working arms past fruit just reported (arms 1 m apart)
        locked = self.reach.locked  # (the screen's, computed with the row's reach)
        self.front = front_base(problem)
        self.rear = min([a.base[0] for a in problem.arms if a.name not in locked] or [a.base[0] for a in problem.arms])
        self.far = self.g.end + max(a.base[0] + a.reach for a in problem.arms)  # no arm reaches a fruit beyond this
        self.legs: list[tuple] = []
        self.inset = int(math.ceil(2.0 * self.opts.sigma / self.reach.resolution - 1e-9))
        run.booker.leg_share = AT_REST_SHARE  # every pick with the carriage at rest: no tracking seam to allow for
        run.booker.cycle_shares = (AT_REST_CYCLE_SHARE,) * 3
        run.booker.probe_rests = True  # a probe finds nothing with the carriage at rest: the arm goes on from there
        self.stops: list[dict] = []
        self.rested: list[int] = []  # the stops' grid indices
        self.cell_picks: dict[int, int] = {}  # stop (grid index) -> picks booked as a cell (:meth:`as_cell`)
        self.cell_lead: dict[int, float] = {}  # stop (grid index) -> s from its arrival to the cell's first motion
        self.masked = StoppedCover(run.booker, self.reach)  # once an arm stops: the screen with it an obstacle where it rests

    # ------------------------------------------------------------------ what is known at t
    def learn(self, t: float) -> None:
        """What the planner knows of the faults by ``t``: the arms stopped then, obstacles."""
        self.masked.update({a for a, t_h in self.faults.halt.items() if t_h <= t}, self.live.taken)

    def edge_at(self, t: float) -> float:
        """How far along the row the camera has seen by ``t``: its view then (or when it went dark)."""
        dark = self.faults.dark
        t_view = t if dark is None or not dark[0] <= t < sum(dark) else dark[0]
        return float(self.live.booker.cruise.x(np.array([t_view]))[0]) + self.front + self.opts.look_ahead

    def cap_at(self, t: float) -> int:
        """The farthest stop (grid index) a hop decided at ``t`` may reach: an unseen fruit lies
        at or beyond the edge, and the rear arm serves it at least until the carriage puts that
        arm's base under it, so a hop up to there passes none. Once an arm has stopped, an
        obstacle, the arms beside it may not reach what the screen says: the front arm's base
        then, the camera's look-ahead."""
        base = self.rear if all(t_h > t for t_h in self.faults.halt.values()) else self.front
        return min(self.grid.size - 1, int(math.floor((self.edge_at(t) - base - self.g.start) / self.reach.resolution + 1e-9)))

    def working_at(self, t: float) -> list[int]:
        return [a for a in range(len(self.problem.arms)) if a not in self.faults.halt or self.faults.halt[a] > t]

    def remaining(self, k: int, t: float) -> list[str]:
        """The fruit reported by ``t``, not taken, that a working arm serves from grid index ``k`` or beyond."""
        working, run, cover = self.working_at(t), self.live, self.reach.cover
        return [f for f, t_s in run.seen.items() if t_s <= t and f not in run.taken and f in cover
                and cover[f][working][:, k:].any()]

    def next_stop(self, k: int, t_dep: float, here: bool = False) -> tuple[int, float]:
        """Where to hop from grid index ``k`` leaving at ``t_dep`` (``k``: nowhere), and when:
        no farther than the first place where a fruit reported by then, not taken, would leave
        every arm's reach (``here``: the carriage may also stay), nor than :meth:`cap_at`."""
        run, faults, grid, cover = self.live, self.faults, self.grid, self.reach.cover
        while True:
            self.learn(t_dep)
            cap, edge = self.cap_at(t_dep), self.edge_at(t_dep)
            working = self.working_at(t_dep)
            ends = []
            for f, t in run.seen.items():
                if t > t_dep or f in run.taken or f not in cover:
                    continue
                ks = np.flatnonzero(cover[f][working].any(axis=0))  # (a stopped arm serves nothing)
                ahead = ks[ks >= k] if here else ks[ks > k]
                if ahead.size:
                    gaps = np.flatnonzero(np.diff(ahead) > 1)
                    run_end = int(ahead[gaps[0]] if gaps.size else ahead[-1])
                    # inside the run's end by two sigma of the camera's noise (the close-range
                    # measurement may move the fruit by that much), if the run is that long
                    ends.append(run_end if run_end == grid.size - 1 else max(int(ahead[0]), run_end - self.inset))
            # (the camera has seen the rest of the row: to its end, or, where it has reported
            # fruit past the rail's end, as far as any arm could reach from the rail)
            beyond = any(run.reports[f].position[0] > self.g.end for f, t in run.seen.items() if t <= t_dep)
            if k >= grid.size - 1 or (not ends and edge >= (self.far if beyond else self.g.end)):
                return k, t_dep  # the end of the rail, or nothing left anywhere ahead
            if min(ends + [cap]) > k or here:
                return min(ends + [cap]), t_dep
            if faults.dark is not None and t_dep < sum(faults.dark):
                faults.log["camera_dark"]["carriage_waits_at"] = round(float(grid[k]), 3)
                t_dep = sum(faults.dark)  # nothing seen ahead: wait for the camera
            else:
                return k + 1, t_dep

    # ------------------------------------------------------------------ the row
    def run(self) -> tuple[dict[str, str], list[dict]]:
        """Every stop in turn (the first from what the camera sees at the start), then every
        working arm home; why each fruit left was left, and the stops."""
        run, grid = self.live, self.grid
        k, _ = self.next_stop(0, 0.0, here=True)
        if self.edge_at(0.0) >= self.g.end:  # the camera sees the whole row from the start: one stop may serve it all, nearer
            best = last_stop(run.seen_problem, self.reach, self.remaining(0, 0.0), range(0, k + 1), self.working_at(0.0),
                             self.g.start)
            k = k if best is None else best
        if k > 0:
            self.legs.append((0.0, float(grid[k])))
        cruise = Cruise.hops(self.problem, self.legs)  # at rest at the stop for good, until the next hop is decided
        t_arr = cruise.duration
        while True:
            self.burst_on_arrival(k, t_arr)
            self.learn(t_arr)
            run.set_cruise(cruise)
            self.stop_windows(t_arr)
            before = len(run.booker.events)
            planned = self.book_stop(k, t_arr)
            picks = [e for e in run.booker.events[before:] if e.kind == EventKind.PICK]
            t_dep = max([t_arr] + [e.t_end for e in picks])
            picks, t_dep = self.burst_during(k, t_arr, t_dep, picks, cruise)
            self.stops.append({"x": round(float(grid[k]), 4), "arrive": round(t_arr, 3), "depart": round(t_dep, 3),
                               "picks": len(picks), "cell_picks": self.cell_picks.get(k, 0),
                               "cell_lead": self.cell_lead.get(k)})
            self.rested.append(k)
            nxt, t_dep = self.next_stop(k, t_dep)
            if nxt == k:
                break
            k, cruise, t_arr = self.hop(k, nxt, t_dep, planned)
        for i in range(len(self.problem.arms)):
            if i not in self.faults.halt:
                run.booker.go_home(i)
        windows = pick_windows(run.seen_problem, self.reach, run.booker.cruise, self.problem.task.pick_dwell)
        run.booker.windows = windows
        left = {f: why_left_at_rest(run, f, self.rested, self.faults.halt) for f in windows if f not in run.taken}
        return left, self.stops

    # ------------------------------------------------------------------ one stop
    def burst_on_arrival(self, k: int, t_arr: float) -> None:
        """A false burst due by the arrival at stop ``k`` is reported there."""
        faults = self.faults
        if faults.burst_at is not None and not faults.burst and faults.burst_at <= t_arr:
            faults.burst = faults.burst_reports(self.problem, self.opts, float(self.grid[k]), t_arr)
            faults.log["false_burst"].update(at_stop_x=round(float(self.grid[k]), 3), reported_at=round(t_arr, 3))
            self.live.add_reports(faults.burst)

    def stop_windows(self, t_arr: float) -> None:
        """Picks only with the carriage at rest here: windows from the arrival on, for as long as
        the arms could need to harvest everything in reach (a fruit none can book by then waits
        for the next stop, or is left out)."""
        booker = self.live.booker
        here = {f: [w for w in ws if w.hi >= t_arr] for f, ws in booker.windows.items()}
        until = t_arr + STOP_PATIENCE * (1 + sum(bool(ws) for ws in here.values()))
        # a late decision makes its arm wait: the stop waits for it too (the carriage holds, as the
        # fault is specified), whether it came before this stop or comes during it
        late = self.faults.log.get("late_replan") or {}
        if "waits_until" in late:
            until += max(0.0, late["waits_until"] - t_arr)
        elif late and late["t"] <= until:
            until += late["seconds"]
        booker.windows = {f: [replace(w, lo=max(w.lo, t_arr), hi=min(w.hi, until)) for w in ws] for f, ws in here.items()}

    def book_stop(self, k: int, t_arr: float) -> int | None:
        """Book stop ``k``'s share: what the carriage would pass before it can next stop -- as far
        as the camera lets it go now -- and what the arms can add in the time those take. Returns
        the next stop chosen as the next to last (:func:`coplan.row.livestops.next_to_last`), or None."""
        run, reach, grid, g, faults = self.live, self.reach, self.grid, self.g, self.faults
        todo = [f for f, t in run.seen.items() if t <= t_arr and f not in run.taken]
        stopped = {a for a, t in faults.halt.items() if t <= t_arr}  # (the planner learns of a fault when it happens)
        rest = self.remaining(k, t_arr)
        last = self.edge_at(t_arr) >= g.end and all(reach.cover[f][self.working_at(t_arr)][:, k].any() for f in rest)
        # (the rest of the row in view and in reach here: this stop takes it all)
        open_ = {f: ws for f, ws in run.booker.windows.items() if f not in run.taken}  # (a fruit taken loads no arm)
        k_plan = k if last else self.cap_at(t_arr)
        k_see = int(np.searchsorted(grid, g.end - self.front - self.opts.look_ahead - 1e-9))
        planned = None
        if not last and not stopped and k_plan == grid.size - 1 and max(k + 1, k_see) <= k_plan:
            planned = self.next_to_last(k, t_arr, todo, range(max(k + 1, k_see), k_plan + 1))
            k_plan = k_plan if planned is None else planned
        order, keep = stop_share(run.seen_problem, reach, open_, todo, k, k_plan, stopped, self.inset)
        run.booker.windows = {f: ws for f, ws in run.booker.windows.items() if f in keep}
        run.policy(order=order, halt=faults.halt, delay=faults.delay, make_way=True, explain=False)
        self.as_cell(k, t_arr, order)
        return planned

    def as_cell(self, k: int, t_arr: float, order: dict[int, list[str]]) -> None:
        """The stop's share (``order``) the live booking left -- a neighbour in the way of every
        direct move, where arms stand close -- planned as the offline planner plans a stop: a cell
        whose coordinator tucks an arm round its neighbour (:func:`coplan.row.stopcell.book_cell`),
        once every arm's booked motion is over. A report never tried is looked at now (merged
        with another: dropped; false: left to a probe); a second report of a fruit the cell picks
        first is a probe. The decision's wall time is one of the run's decisions."""
        run = self.live
        if run.booker.halted:
            return  # (the cell plan does not model an arm that stops: book_cell declines; nothing looked at)
        left = []
        for i, fs in sorted(order.items()):
            for f in fs:
                if f in run.taken or f in left or f in run.booker.probes:
                    continue
                if f not in run.measured:  # never tried: the close-range camera looks now
                    if not run.on_book(i, f, t_arr):
                        run.taken.add(f)  # (merged with another report: dropped for good, as the booking drops it)
                        continue
                    if f in run.booker.probes:
                        continue  # (nothing there: left to a probe, as the booking leaves it)
                left.append(f)
        if not left:
            return
        claimed = {run.reports[e.fruit].truth for e in run.booker.events}

        def found(f: str) -> bool:  # (the close-range camera, as the arm comes: a second report of a fruit just picked finds nothing)
            truth = run.reports[f].truth
            if truth is None or truth in claimed:
                return False
            claimed.add(truth)
            return True

        done = book_cell(run.booker, left, float(self.grid[k]), t_arr, found)
        run.cells.append((done.seconds, done.lead))  # (a decision; the time it has: until the stop's booked motion ends)
        run.taken.update(done.picked + done.probed)  # (a report the cell found empty was probed: done with, as a probe's)
        self.cell_picks[k] = len(done.picked)
        self.cell_lead[k] = round(done.lead, 3)

    def next_to_last(self, k: int, t_arr: float, todo: list[str], options: range) -> int | None:
        """The next stop may be one from which the camera sees to the rail's end (the rest of the
        row then in the front arm's reach): the one of ``options`` that with this stop serves
        what is known in the least time, not the rail's end, where the arms beyond the last
        fruit would idle (all arms working: after a fault, as far as allowed)."""
        run, reach = self.live, self.reach
        work = {f for f in todo if f in reach.cover and reach.cover[f][:, k:].any()}
        # the stretch the camera has not seen yet, priced as the one before it (its reports, shifted)
        edge = self.edge_at(t_arr)
        u = self.g.end - edge
        like = [Fruit(f"~{r.id}", (r.position[0] + u, r.position[1])) for r in run.reports.values()
                if run.seen.get(r.id, math.inf) <= t_arr and edge - u <= r.position[0] < edge]
        est = replace(run.seen_problem, fruits=tuple(f for f in run.seen_problem.fruits if f.id in work) + tuple(like))
        r2 = row_reach(est, reach.resolution)
        return next_to_last(est, r2, r2.harvestable(), k, options, float(self.grid[k]))

    def burst_during(self, k: int, t_arr: float, t_dep: float, picks: list, cruise: Cruise) -> tuple[list, float]:
        """A burst while the arms work at stop ``k`` (it fell at no stop's arrival: on a row of
        one stop, none at all): its reports are booked at its time, after the cycles booked
        already, and the carriage stays until they are probed. Returns the stop's picks and
        departure."""
        run, faults = self.live, self.faults
        t_b = faults.burst_at
        if t_b is None or faults.burst or not t_arr < t_b < t_dep:
            return picks, t_dep
        faults.burst = faults.burst_reports(self.problem, self.opts, float(self.grid[k]), t_b)
        faults.log["false_burst"].update(at_stop_x=round(float(self.grid[k]), 3), reported_at=t_b)
        run.add_reports(faults.burst)
        self.learn(t_b)
        run.set_cruise(cruise, since=t_b)
        ids = {r.id for r in faults.burst}
        until_b = t_b + STOP_PATIENCE * (1 + len(ids))
        run.booker.windows = {f: [replace(w, lo=max(w.lo, t_b), hi=min(w.hi, until_b)) for w in ws if w.hi >= t_b]
                              for f, ws in run.booker.windows.items() if f in ids}
        more = len(run.booker.events)
        run.policy(halt=faults.halt, delay=faults.delay, make_way=True, explain=False)
        picks = picks + [e for e in run.booker.events[more:] if e.kind == EventKind.PICK]
        return picks, max([t_dep] + [e.t_end for e in picks])

    def hop(self, k: int, nxt: int, t_dep: float, planned: int | None) -> tuple[int, Cruise, float]:
        """The hop from stop ``k`` towards ``nxt`` leaving at ``t_dep``; returns the stop it ends
        at, the carriage's motion and the arrival. Once the rest of the row is in view, one stop
        may serve it all, nearer; an arm that stops during the hop leaves its share of the next
        stop to the others: from then the hop goes no farther than they need (the nearest stop
        it can still brake to)."""
        run, grid, problem = self.live, self.grid, self.problem
        if planned is not None:
            nxt = min(nxt, planned)
        if self.edge_at(t_dep) >= self.g.end:
            rest = self.remaining(k + 1, t_dep)
            best = last_stop(run.seen_problem, self.reach, rest, range(k + 1, nxt + 1), self.working_at(t_dep), float(grid[k]))
            nxt = nxt if best is None else best
        self.legs.append((t_dep, float(grid[nxt])))
        cruise = Cruise.hops(problem, self.legs)
        t_arr = cruise.duration
        t_h = min((t for t in self.faults.halt.values() if t_dep < t < t_arr), default=None)
        if t_h is not None:
            self.learn(t_h)
            run.set_cruise(cruise)  # what the planner knows then: the hop under way (the camera moved with it)
            want, _ = self.next_stop(k, t_h)
            for kk in range(max(want, k + 1), nxt):
                try:
                    cruise = Cruise.hops(problem, self.legs + [(t_h, float(grid[kk]), True)])
                except ValueError:
                    continue  # nearer than it can stop from its speed then
                self.legs.append((t_h, float(grid[kk]), True))
                self.faults.log["arm_stop"].update({"hop_changed_at": round(t_h, 3), "stop_at": round(float(grid[kk]), 4),
                                                    "instead_of": round(float(grid[nxt]), 4)})
                nxt, t_arr = kk, cruise.duration
                break
        return nxt, cruise, t_arr
