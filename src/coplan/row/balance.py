"""How a stop's fruit are balanced over its arms when a stop rule prices stops
(:func:`coplan.row.stops.price_stops`): :func:`rebalance` moves fruit between the (stop, arm)
options each has while that shortens the stops' sum, each stop as long as its busiest arm --
single moves, and where none shortens it a two-step chain. Pure bookkeeping over lists: no
problem, no geometry."""

from __future__ import annotations

__all__ = ["rebalance"]


def rebalance(load, peak, at, chosen, over, passes: int = 8, chains: bool = True) -> None:
    """Move single fruit to another of their (stop, arm) options while that lowers the sum of
    the stops' cells (each its busiest arm), in place; at most ``passes`` sweeps. The greedy
    balance piles fruit onto the non-busiest arms of stops already open (adding there costs
    nothing until that arm is the busiest) and leaves a stop between them nearly empty, which
    priced a stop set 2-5 % above the assignment its own stops end up with; moving a fruit
    wherever that shortens the sum undoes that. Only a fruit of a stop's busiest arm can
    shorten anything (taking any other leaves the stop as long).

    ``load[i][a]``: arm ``a``'s seconds at stop ``i`` (its round trips, plus ``over[a]`` once
    it has a fruit there); ``peak[i]``: ``max(load[i])``; ``at[i]``: the ``(j, fruit)`` at stop
    ``i``; ``chosen``: one ``[j, fruit, s, i, a, options]`` per fruit placed, ``options`` its
    ``(s, i, a)`` choices (``s``: the round trip). All are updated together."""
    A = len(load[0]) if load else 0
    cnt = [[0] * A for _ in load]
    for _, _, _, i, a, _ in chosen:
        cnt[i][a] += 1
    for _ in range(passes):
        better = False
        for ch in chosen:
            j, f, c, i, a, o = ch
            li = load[i]
            if li[a] < peak[i]:
                continue
            out = li[a] - c - (over[a] if cnt[i][a] == 1 else 0.0)
            rest = max((li[b] for b in range(A) if b != a), default=0.0)
            if max(out, rest) >= peak[i] - 1e-9:
                continue  # another arm is as busy: the stop stays as long
            for c2, i2, a2 in o:
                if (i2, a2) == (i, a):
                    continue
                add = load[i2][a2] + c2 + (0.0 if cnt[i2][a2] else over[a2])
                if i2 == i:
                    others = max((li[b] for b in range(A) if b not in (a, a2)), default=0.0)
                    delta = max(out, add, others) - peak[i]
                else:
                    delta = max(out, rest) - peak[i] + max(peak[i2], add) - peak[i2]
                if delta < -1e-9:
                    li[a] = out
                    load[i2][a2] = add
                    peak[i] = max(li)
                    peak[i2] = max(load[i2])
                    cnt[i][a] -= 1
                    cnt[i2][a2] += 1
                    at[i].remove((j, f))
                    at[i2].append((j, f))
                    ch[2:5] = [c2, i2, a2]
                    better = True
                    break
        if not better and not (chains and _chain(load, peak, at, chosen, over, cnt)):
            return


def _chain(load, peak, at, chosen, over, cnt) -> bool:
    """One two-step move (an ejection chain) that lowers the sum of the stops' cells where no
    single move does: a fruit of a stop's busiest arm goes to another (stop, arm) option, and
    to make room there one of that arm's fruit goes to one of its own other options (dense_row's
    stop at 28.7 m: its rear arm idle at 38.8 s beside 55.0 and 56.7, the front arm's fruit
    cheaper for the middle arm, the middle arm's for the rear one; priced 56.7 s, its cell took
    48.9). Applies the first such move found, in place; whether there was one."""
    A = len(load[0]) if load else 0
    by = {}
    for ch in chosen:
        by.setdefault((ch[3], ch[4]), []).append(ch)

    def cost_of(i, a, c_in, c_out, n_in, n_out):  # arm a's load at stop i with one fruit in/out
        n = cnt[i][a] + n_in - n_out
        base = load[i][a] - (over[a] if cnt[i][a] else 0.0)
        return base + c_in - c_out + (over[a] if n else 0.0) if n else 0.0

    for ch in chosen:
        j, f, c, i, a, o = ch
        if load[i][a] < peak[i]:
            continue
        for c2, i2, a2 in o:
            if (i2, a2) == (i, a):
                continue
            for g in by.get((i2, a2), ()):
                if g is ch:
                    continue
                for c3, i3, a3 in g[5]:
                    if (i3, a3) in ((i2, a2),):
                        continue
                    delta_in: dict = {}
                    for (si, sa, cin, cout, nin, nout) in ((i, a, 0.0, c, 0, 1), (i2, a2, c2, g[2], 1, 1),
                                                           (i3, a3, c3, 0.0, 1, 0)):
                        k = (si, sa)
                        d = delta_in.setdefault(k, [0.0, 0.0, 0, 0])
                        d[0] += cin
                        d[1] += cout
                        d[2] += nin
                        d[3] += nout
                    new = {k: cost_of(k[0], k[1], *v) for k, v in delta_in.items()}
                    stops = {k[0] for k in new}
                    delta = 0.0
                    for si in stops:
                        top = max(new.get((si, b), load[si][b]) for b in range(A))
                        delta += top - peak[si]
                    if delta < -1e-9:
                        for (si, sa), v in new.items():
                            load[si][sa] = v
                            cnt[si][sa] += delta_in[(si, sa)][2] - delta_in[(si, sa)][3]
                        for si in stops:
                            peak[si] = max(load[si])
                        at[i].remove((j, f))
                        at[i2].append((j, f))
                        at[i2].remove((g[0], g[1]))
                        at[i3].append((g[0], g[1]))
                        ch[2:5] = [c2, i2, a2]
                        g[2:5] = [c3, i3, a3]
                        return True
    return False
