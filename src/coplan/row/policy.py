"""The booking policy: which fruit each arm books next, in time order (:func:`run_policy`), and
why a fruit was left (:func:`why_left`). The arm free first takes, among the fruit it can still
reach, the one whose window closes first (earliest deadline; interval scheduling's greedy), or
follows a given order per arm (the CP-SAT assignment of :mod:`coplan.row.assign`). The motion
itself -- each cycle planned, checked clear of the neighbours and committed -- is
:class:`coplan.row.booking.Booker`'s."""

from __future__ import annotations

import heapq
import math

from ..plan import EventKind
from .booking import PATIENCE, RETRY, Booker
from .cruise import Window

__all__ = ["run_policy", "why_left"]

_GIVE_UP = 3  # tries without a clear cycle on one fruit, PATIENCE s apart, the carriage at rest for good, before an arm leaves it


def run_policy(booker: Booker, order: dict[int, list[str]] | None = None, seen=None, on_book=None,
               halt: dict[int, float] | None = None, delay=None, until: float | None = None,
               taken: set[str] | None = None, make_way: bool = False, explain: bool = True,
               wait_on=None) -> dict[str, str]:
    """Book cycles in time order (module docstring; each cycle by :class:`Booker`); returns fruit left out -> why
    (``explain=False``: an empty mapping, for a phase whose caller goes on booking -- a live row's
    phases asked why for every fruit not yet booked, ahead of the carriage too). ``order``:
    each arm's fruit in turn (any it cannot fit are left to the greedy afterwards).

    A live row (:mod:`coplan.row.live`): ``seen`` (fruit id -> the time the camera first reports
    it) keeps every decision to the fruit seen by then -- an arm with nothing seen yet waits for
    the next report -- and ``on_book(arm, fruit, now)`` may veto a fruit at the moment it is chosen
    (returns False: dropped, e.g. a detection already harvested under another id).

    Faults: ``halt`` (arm index -> time of a controller fault): the arm finishes the motion in
    progress and, from its next rest, books nothing more -- an obstacle where it rests; its fruit
    are left to the neighbours. A cycle or move decided before the fault whose motion would
    start at or after it (the arm waiting for the carriage or a neighbour) is not made. ``delay(arm, now)`` -> seconds a decision runs late: the arm
    rests that much longer before the cycle it decides.

    In phases: ``until`` stops deciding at that time (each arm left free at or after it, at rest);
    ``taken`` (fruit already booked) carries over to the next phase, whose booker may have a new
    carriage motion from then on; ``make_way=True`` sends an arm that finds no clear cycle home
    before it tries again (with the carriage at rest, two arms each resting where the other
    would pick would otherwise wait for each other for good). An arm a probe left where it found
    nothing (``probe_rests``) decides its next move at once: a cycle from there, else back to its
    bin (an arm held out over its neighbours' fruit would block them). ``wait_on(arm, fruit, now)``
    -> seconds the arm waits, rather than try its next fruit, where its try on ``fruit`` found no
    clear cycle (0: it goes on): a live row on the move says so for a fruit no other arm can take
    any more; the arm then tries it with its ways tucked (as :func:`_tucked` at the rail's end)
    and, if that finds no clear cycle either, waits for the decision to hold the carriage -- a
    cycle booked on another fruit would put the hold off past the fruit's window (:mod:`coplan.row.live`)."""
    windows = booker.windows
    taken = taken if taken is not None else set()
    arms = booker.problem.arms
    booker.halted.update(halt or {})
    by_arm: dict[int, list[tuple[str, Window]]] = {i: [] for i in range(len(arms))}
    for fid, ws in windows.items():
        for w in ws:
            by_arm[w.arm].append((fid, w))
    n_arms_of = {fid: len({w.arm for w in ws}) for fid, ws in windows.items()}
    # a guard, never reached by a plan that progresses (from the carriage's rest, or from when the
    # busiest arm is free: one waiting out a late decision made before this phase)
    start = max([booker.cruise.duration] + [booker.free_time(i) for i in range(len(arms))])
    horizon = start + PATIENCE + 10.0 * len(windows)
    queue = [(0.0, i) for i in range(len(arms))]
    heapq.heapify(queue)
    pending = {i: list((order or {}).get(i, [])) for i in range(len(arms))}
    failed: dict[tuple[int, str], tuple[int, float]] = {}  # (arm, fruit) -> (tries counted, when the last was)

    def take(i: int, cyc) -> None:  # a cycle booked: the arm's fruit taken, its given order moved on
        booker.commit(cyc)
        taken.add(cyc.fruit)
        if pending[i] and pending[i][0] == cyc.fruit:
            pending[i].pop(0)

    while queue:
        _, i = heapq.heappop(queue)
        now = booker.free_time(i)
        if halt is not None and i in halt and now >= halt[i]:
            booker.arms[i].done = True  # stopped: it stays where it rests
            continue
        late = delay(i, now) if delay is not None else 0.0
        if late > 0:
            horizon += late  # (the guard waits for a late decision too: its arm's fruit are not given up)
            booker.wait(i, late)
            heapq.heappush(queue, (booker.free_time(i), i))
            continue
        if until is not None and now >= until:
            continue  # the next phase decides from here
        if now > horizon:  # nothing fits any more: the rest is left out
            booker.go_home(i)
            continue
        # (kept for good: this arm's time only grows and a fruit taken stays taken, so what is
        # dropped here never comes back; the list shrinks as the row is harvested)
        cands = by_arm[i] = [(fid, w) for fid, w in by_arm[i] if fid not in taken and w.hi >= now]
        if seen is not None:
            later = [seen[f] for f, w in cands if seen[f] > now and w.hi >= seen[f]]
            cands = [(f, w) for f, w in cands if seen[f] <= now]
            if not cands and later:  # nothing in view yet: wait for the camera's next report
                if booker.rests_out(i) and booker.go_bin(i):
                    heapq.heappush(queue, (booker.free_time(i), i))
                    continue
                booker.wait(i, max(booker.dt, min(later) - now))
                heapq.heappush(queue, (booker.free_time(i), i))
                continue
        if not cands:
            if booker.rests_out(i) and booker.go_bin(i):
                heapq.heappush(queue, (booker.free_time(i), i))  # (at its bin: home next, clear of a probe's pose)
            else:
                booker.go_home(i)
            continue
        tries, given = _tries(cands, pending[i], now, n_arms_of)
        booked = stopped = False
        waits = 0.0
        for fid, w in tries:
            if on_book is not None and not on_book(i, fid, now):
                taken.add(fid)  # vetoed for good (not harvested: left out with the veto's reason)
                continue
            cyc = booker.plan_cycle(i, fid, w, now)
            if cyc is not None and booker.moves_after_halt(i, cyc.k0, cyc.q):
                stopped = True  # decided before the fault, it would start after it: never made
                break
            if cyc is not None:
                take(i, cyc)
                booked = True
                break
            if wait_on is not None and (waits := wait_on(i, fid, now)) > 0:
                # the fruit's last chance: its ways there and back tucked (:func:`_tucked`), else the wait
                cyc = booker.plan_cycle(i, fid, w, now, tuck=True)
                if cyc is not None and not booker.moves_after_halt(i, cyc.k0, cyc.q):
                    take(i, cyc)
                    booked, waits = True, 0.0
                break
        if waits > 0:
            booker.wait(i, waits)
            heapq.heappush(queue, (booker.free_time(i), i))
            continue
        if stopped:
            booker.arms[i].done = True  # it stays where it rests
            continue
        if booked and booker.rests_out(i):  # a probe that found nothing and rests there: its next move is decided now
            heapq.heappush(queue, (-math.inf, i))
            continue
        if not booked and now >= booker.cruise.duration:
            cyc = _tucked(booker, i, tries, now, failed)
            if cyc is not None:
                take(i, cyc)
                booked = True
        if not booked:
            if now >= booker.cruise.duration:
                by_arm[i] = _give_up(booker, i, tries, now, failed, by_arm[i])
            if given:
                pending[i].pop(0)  # the given order's next fruit does not fit: the greedy may take it
            elif not (make_way and not booker.at_home(i) and (booker.go_bin(i) if booker.rests_out(i) else booker.go_home(i))):  # (home: out of the way, it tries again)
                soonest = min((c[1].lo for c in cands if c[1].lo > now), default=now + RETRY)
                booker.wait(i, max(RETRY, min(soonest - now - 1.0, 1.0)))
        heapq.heappush(queue, (booker.free_time(i), i))
    if not explain:
        return {}
    return {fid: why_left(booker, fid, halt or {}) for fid in windows if fid not in taken}


def _tries(cands: list[tuple[str, Window]], pending: list[str], now: float,
           n_arms_of: dict[str, int]) -> tuple[list[tuple[str, Window]], bool]:
    """What an arm free at ``now`` tries to book (:func:`run_policy`), and whether it is the given
    order's next fruit: that fruit (its windows among ``cands``; fruit of the order no longer
    among them are dropped from ``pending``), else the greedy's first four -- of the fruit within
    reach in 2 s (all, if none), the earliest deadline first, then the fewest arms, then the
    earliest window."""
    while pending:
        hit = [c for c in cands if c[0] == pending[0]]
        if hit:
            return hit, True
        pending.pop(0)
    ready = [c for c in cands if c[1].lo <= now + 2.0]  # within reach soon
    pool = ready or cands
    pool.sort(key=lambda c: (c[1].hi, n_arms_of[c[0]], c[1].lo, c[0]))
    return pool[:4], False


def _tucked(booker: Booker, i: int, tries: list[tuple[str, Window]], now: float,
            failed: dict[tuple[int, str], tuple[int, float]]):
    """Arm ``i``'s last try, the carriage at rest for good as far as the booking knows (on the
    move: at the rail's end; live stop and go: at the stop being booked), on each fruit of
    ``tries`` it would give up now (:func:`_give_up`): a cycle whose ways to the fruit and back
    are tucked (:meth:`Booker.plan_cycle` with ``tuck``), or None. Where the arms stand close, the direct
    way back from a fruit high between two bases swings the whole arm over a neighbour's
    shoulder wherever that neighbour rests (a 12 m row live on the move, arms 1.2 m apart: every
    try of both arms that reach the fruit met a neighbour, and the fruit was left); folded, it
    passes. Only a fruit that would be left is tried so, so every plan that harvests without it
    is the plan it was; a cycle a fault would start after its time is not made."""
    for fid, w in tries:
        if not _counts(w, now) or _counted(failed, (i, fid), now) < _GIVE_UP:
            continue
        cyc = booker.plan_cycle(i, fid, w, now, tuck=True)
        if cyc is not None and not booker.moves_after_halt(i, cyc.k0, cyc.q):
            return cyc
    return None


def _counts(w: Window, now: float) -> bool:
    """Whether a try at ``now`` that found no clear cycle in window ``w`` counts towards giving
    its fruit up (:func:`_give_up`): not where the window is not open yet -- the carriage settling."""
    return w.lo <= now + PATIENCE


def _counted(failed: dict[tuple[int, str], tuple[int, float]], key: tuple[int, str], now: float) -> int:
    """The tries without a clear cycle counted for ``key`` once one at ``now`` is: a try counts
    only ``PATIENCE`` s after the last one counted -- each covers that much waiting, and the tries
    of decisions 0.1 s apart see the same neighbours' bookings (an arm gave up every fruit left at
    the rail's end after three refusals in 0.3 s, its neighbour then picking them all alone)."""
    n, last = failed.get(key, (0, -math.inf))
    return n + 1 if now >= last + PATIENCE - 1e-9 else n


def _give_up(booker: Booker, i: int, tries: list[tuple[str, Window]], now: float,
             failed: dict[tuple[int, str], tuple[int, float]], mine: list[tuple[str, Window]]) -> list[tuple[str, Window]]:
    """Arm ``i``'s fruit (``mine``) less those it gives up, the carriage at rest for good and no
    cycle booked on ``tries``: a fruit no branch reaches from there (its close-range measurement
    moved it off the run's edge) never will be, and one that found no clear cycle ``_GIVE_UP``
    times, ``PATIENCE`` s apart (:func:`_counted`), is left to the next stop."""
    x1 = booker.cruise.x1
    for fid, w in tries:
        if _counts(w, now):
            n = _counted(failed, (i, fid), now)
            if n > failed.get((i, fid), (0, 0.0))[0]:
                failed[(i, fid)] = (n, now)
    gone = {(fid, w.arm) for fid, w in tries
            if failed.get((i, fid), (0, 0.0))[0] >= _GIVE_UP or not booker.branches(i, fid, x1, x1)}
    return [(fid, w) for fid, w in mine if (fid, w.arm) not in gone]


def why_left(booker: Booker, fid: str, halt: dict[int, float]) -> str:
    """Why ``fid`` was not booked, from its windows on the booker's carriage motion."""
    ws = booker.windows[fid]
    if not ws:
        return f"{fid}: at this speed the carriage never stays where an arm can hold its tip on it for the pick's dwell"
    # the working arm whose window closed last (a stopped arm's only if no working arm had one)
    w = max(ws, key=lambda w: (w.arm not in halt, min(w.hi, 1e9), w.arm))
    arm = booker.problem.arms[w.arm].name
    if w.arm in halt:
        return f"{fid}: only {arm} could reach it, and {arm} stopped at t = {halt[w.arm]:.1f} s"
    if not math.isfinite(w.hi):
        return f"{fid}: {arm} could still reach it, but no clear cycle was found, direct or tucked"
    busy = [e for e in booker.events if e.arm == arm and e.t_start <= w.hi and e.t_end + 1.5 >= w.lo]
    if not busy:  # free for the whole window: no cycle of its fitted, not a neighbour's turn
        return (f"{fid}: passed {arm}'s reach at t = {w.hi:.1f} s, {max(w.hi - w.lo, 0.0):.1f} s after it came into "
                f"reach, {arm} free all that time: no cycle fitted -- its direct moves between its bin and the fruit "
                f"come within the clearance of a neighbour, or past a limit, at every start tried (an arm tucks round a "
                f"neighbour, as the stop-and-go cell planner does, only once the carriage is at rest at the rail's end; "
                f"stop and go, --gantry stop-and-go, picks every fruit at rest)")
    doing = "held: no cycle fitted before the window closed (a neighbour in the way, or a limit)"
    for e in busy:
        if e.t_start <= w.hi <= e.t_end + 1.5:
            doing = f"{'picking' if e.kind == EventKind.PICK else 'placing'} {e.fruit}"
    return f"{fid}: passed {arm}'s reach at t = {w.hi:.1f} s while {arm} was {doing}"
