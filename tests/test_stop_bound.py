"""The priced-stops bound (coplan.allocate.stop_bound): a lower bound for every stop-by-stop row
plan, checked against brute force over every set of stops on seeded random rows, against the
move-time properties its proof uses, and on the shipped rows against the plain bound and the
plans coplan makes."""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

from coplan.allocate.row_bound import row_bounds
from coplan.allocate.row_cycles import cell_cycles
from coplan.allocate.stop_bound import QUANTUM, fruit_cell_costs, stops_bound, stops_dp
from coplan.kinematics.timing import scurve_times
from coplan.problem import load_problem

ROWS = Path(__file__).resolve().parents[1] / "problems" / "rows"
LIMITS = [(0.5, 0.5, 5.0), (0.2, 1.0, 2.0), (1.0, 0.3, 50.0)]


def _random_bands(rng, N: int, F: int, width: int, holes: bool, clusters: bool = False):
    """Each fruit reachable over a band of up to ``width`` cells somewhere on ``N`` cells (with a
    hole inside where ``holes``: the annulus's inner circle; near either end where ``clusters``,
    an empty stretch between), costs 1-5 s."""
    first = np.zeros(F, dtype=int)
    w = np.full((F, width + 2), np.inf)
    for f in range(F):
        lo = int(rng.integers(0, N // 4) if f % 2 == 0 else rng.integers(N - N // 4 - 1, N)) if clusters else int(rng.integers(0, N))
        n = int(rng.integers(1, width + 1))
        first[f] = max(lo - 1, 0)
        cols = np.arange(lo - first[f], min(lo - first[f] + n, N - first[f]))
        w[f, cols] = rng.uniform(1.0, 5.0, cols.size)
        if holes and cols.size >= 3 and rng.random() < 0.5:
            w[f, cols[1:-1][rng.integers(cols.size - 2)]] = np.inf
    return first, w


def _exact(first, w, N, step, lim, cells, pos, per_stop=0.0):
    """A stop-by-stop plan's lower bound with stops at ``pos`` in ``cells`` (sorted): the moves
    from the start (0) through them, each fruit at its cheapest stop, ``per_stop`` for each
    stop a move ends at (not one where the carriage starts)."""
    moves = scurve_times(np.diff(np.concatenate([[0.0], pos])), *lim).sum() + per_stop * np.count_nonzero(np.asarray(pos) > 0)
    cols = np.asarray(cells)[None, :] - first[:, None]
    ok = (cols >= 0) & (cols < w.shape[1])
    c = np.where(ok, w[np.arange(w.shape[0])[:, None], np.clip(cols, 0, w.shape[1] - 1)], np.inf)
    return moves + c.min(axis=1).sum()


def _charged(first, w, step, lim, cells, span, per_stop=0.0):
    """What the programme's relaxation charges the set of stop ``cells`` (module docstring),
    written out directly: gaps of up to ``span`` cells priced in pairs (a half of each gap at a
    run's ends), a longer gap whole; each fruit the cheaper of its least up to the stop before
    its best cell and its least from the stop at or after it."""
    T = lambda k: float(scurve_times(np.array([max(k - 1, 0) * step]), *lim)[0])  # a gap of k cells: (k - 1) steps at least
    idx = [0] + [c + 1 for c in cells]  # 0: the start, cell c is c + 1
    gaps = np.diff(idx)
    moves, run = 0.0, []
    for k in list(gaps) + [None]:
        if k is None or k > span:  # a run of short gaps ends
            if run:
                moves += 0.5 * T(run[0]) + 0.5 * T(run[-1])
                moves += sum(0.5 * max(T(a) + T(b), T(a + b)) for a, b in zip(run, run[1:]))
            run = []
            if k is not None:
                moves += T(k)
        else:
            run.append(k)
    work = 0.0
    for f in range(w.shape[0]):
        c = first[f] + 1 + np.arange(w.shape[1])
        r = c[np.argmin(w[f])]
        i = int(np.searchsorted(idx, r, "left")) - 1  # r in (idx[i], idx[i + 1]]
        left = w[f][c <= idx[i]].min(initial=np.inf)
        right = w[f][c >= idx[i + 1]].min(initial=np.inf) if i + 1 < len(idx) else np.inf
        work += min(left, right)
    return moves + work + per_stop * sum(1 for c in cells if c >= 1)


@pytest.mark.parametrize("seed", range(10))
def test_the_programme_is_its_relaxation_s_least_and_below_every_set_of_stops_brute_force(seed):
    """Every set of stop cells on a seeded random row: the programme's value is the least its
    relaxation charges any set (written out directly, not by the programme), its witness
    attains it, and for every set what it charges is at most what a stop-by-stop plan with
    those stops costs, each stop anywhere in its cell (both ends, alternating ends --
    neighbours as close as cells allow -- and random points): the bound is valid set by set.
    Half the cases have wide cells and narrow bands, so gaps past the pair states occur."""
    rng = np.random.default_rng(seed)
    lim = LIMITS[seed % len(LIMITS)]
    long_gaps = seed % 2 == 1
    N = 11 if long_gaps else 9
    step = 1.2 if long_gaps else 0.05
    first, w = _random_bands(rng, N, int(rng.integers(3, 9)), 2 if long_gaps else 4, holes=not long_gaps, clusters=long_gaps)
    per_stop = 0.7 * (seed % 3 == 2)  # a settle floor on some rows: charged per stop past the first cell
    value, stops, work, span = stops_dp(first, w, N, step, *lim, per_stop=per_stop)
    grid = (len(w) + 3 * N + 3) * QUANTUM  # (its times rounded down to the grid: less by at most this)
    assert np.isfinite(value) and work <= value + 1e-9
    assert work >= np.nanmin(np.where(np.isfinite(w), w, np.nan), axis=1).sum() - grid
    least, long_used = np.inf, False
    for k in range(1, N + 1):
        for cells in itertools.combinations(range(N), k):
            charged = _charged(first, w, step, lim, cells, span, per_stop)
            least = min(least, charged)
            lo = np.asarray(cells) * step
            pats = [lo, lo + step, np.where(np.arange(k) % 2 == 0, lo + step, lo), np.where(np.arange(k) % 2 == 1, lo + step, lo)]
            pats += [lo + rng.uniform(0, step, k) for _ in range(2)]
            assert charged <= min(_exact(first, w, N, step, lim, cells, p, per_stop) for p in pats) + 1e-9, cells
            long_used |= np.isfinite(charged) and np.diff([-1, *cells]).max() > span
    assert least - grid <= value <= least
    assert _charged(first, w, step, lim, stops, span, per_stop) == pytest.approx(value, rel=0.0, abs=grid)
    # its sums are exact: the same value and stops, to the bit, whatever order the fruit come in
    perm = rng.permutation(len(w))
    again = stops_dp(first[perm], w[perm], N, step, *lim, per_stop=per_stop)
    assert again.value == value and again.stops == stops and again.work == work
    if long_gaps:
        assert long_used  # (some finite set has a gap past the pairs: that path is compared too)


def _arm_bands(rng, N: int, F: int, K: int):
    """Per arm ``(cells (F, N), cost (F, N))``: each arm reaches each fruit over a band of cells
    shifted by its place on the carriage (none for some), costs 1-5 s; every fruit reachable."""
    cells = np.broadcast_to(np.arange(N), (F, N))
    costs = [np.full((F, N), np.inf) for _ in range(K)]
    for f in range(F):
        x = int(rng.integers(0, N))
        for k in range(K):
            if k and rng.random() < 0.25:
                continue
            lo = min(max(x - k + int(rng.integers(-1, 1)), 0), N - 1)
            hi = min(lo + int(rng.integers(1, 4)), N)
            costs[k][f, lo:hi] = rng.uniform(1.0, 5.0, hi - lo)
    return [(cells, c) for c in costs]


def _busiest_arm_plans(bands, N, step, lim, per_stop):
    """The least over every set of stop cells (each stop at either end of its cell, or alternating
    ends) and every assignment of the fruit to those stops and arms of the moves from the start
    plus each stop's busiest arm's cycles plus ``per_stop`` for each stop a move ends at: what a
    stop-by-stop plan costs at least, stop by stop the busiest arm (brute force)."""
    F, K = bands[0][1].shape[0], len(bands)
    least = np.inf
    for k in range(1, N + 1):
        for cells in itertools.combinations(range(N), k):
            opts = [[(i, a, bands[a][1][f, c]) for i, c in enumerate(cells) for a in range(K)
                     if np.isfinite(bands[a][1][f, c])] for f in range(F)]
            if any(not o for o in opts):
                continue
            combos = np.array(list(itertools.product(*[range(len(o)) for o in opts])))
            loads = np.zeros((combos.shape[0], k, K))
            for f, o in enumerate(opts):
                st, ar, co = (np.array(v)[combos[:, f]] for v in zip(*o))
                np.add.at(loads, (np.arange(combos.shape[0]), st.astype(int), ar.astype(int)), co)
            work = loads.max(axis=2).sum(axis=1).min()
            lo = np.asarray(cells) * step
            for pos in (lo, lo + step, np.where(np.arange(k) % 2 == 0, lo + step, lo), np.where(np.arange(k) % 2 == 1, lo + step, lo)):
                moves = scurve_times(np.diff(np.concatenate([[0.0], pos])), *lim).sum() + per_stop * np.count_nonzero(pos > 0)
                least = min(least, moves + work)
    return least


@pytest.mark.parametrize("seed", range(8))
def test_the_weighted_programme_is_below_every_stop_by_stop_plan_s_busiest_arms_brute_force(seed):
    """Weights per cell over the arms (module docstring, *Weights*): for the weights the rounds
    find and for random ones, the programme is below the least over every set of stop cells and
    every assignment of the fruit to its stops and arms of the moves plus each stop's *busiest*
    arm (not their mean); the rounds never end below the equal weights' value, which is the mean
    over the arms' programme (``fruit_cell_costs``'s). On these rows the rounds raise it."""
    from coplan.allocate.stop_bound import weighted_bound

    rng = np.random.default_rng(100 + seed)
    lim = LIMITS[seed % len(LIMITS)]
    N, F, K, step = 5, 4, 2 + seed % 2, 0.05
    per_stop = 0.7 * (seed % 3 == 2)
    bands = _arm_bands(rng, N, F, K)
    exact = _busiest_arm_plans(bands, N, step, lim, per_stop)
    equal = weighted_bound(bands, N, step, *lim, per_stop, rounds=0)
    mean = np.min([np.where(np.isfinite(c), c, np.inf) for _, c in bands], axis=0) / K
    assert equal.value == pytest.approx(stops_dp(np.zeros(F, dtype=int), mean, N, step, *lim, per_stop=per_stop).value, rel=1e-12)
    found = weighted_bound(bands, N, step, *lim, per_stop, rounds=30)
    assert found.uniform == pytest.approx(equal.value, rel=1e-12) and found.value >= equal.value - 1e-12
    assert found.value <= exact + 1e-9
    assert np.allclose(found.weights.sum(axis=1), 1.0) and (found.weights >= 0).all()
    for _ in range(5):
        lam = rng.dirichlet(np.full(K, 0.5), size=N)
        assert weighted_bound(bands, N, step, *lim, per_stop, rounds=0, start=lam).value <= exact + 1e-9
    if seed < 4:
        assert found.value > equal.value + 1e-6, (found.value, equal.value, exact)  # (it does raise it here)


@pytest.mark.parametrize("lim", LIMITS + [(0.5, 0.5, 5.0)])
def test_the_carriage_move_times_are_what_the_proof_uses(lim):
    """T (the rest-to-rest move over a distance) is increasing, subadditive (two moves make one
    over the sum), and past the distance where it reaches its top speed grows by exactly
    d / v_max: what pricing pairs of gaps, and long gaps cell by cell, rely on."""
    v, a, j = lim
    d = np.linspace(0.0, 6.0, 601)
    T = scurve_times(d, v, a, j)
    assert np.all(np.diff(T) > 0)
    assert np.all(T[:, None] + T[None, :] >= scurve_times(d[:, None] + d[None, :], v, a, j) - 1e-12)
    cruise = v * ((v / a + a / j) if v >= a * a / j else 2.0 * np.sqrt(v / j))
    far = d[d >= cruise]
    assert np.allclose(np.diff(scurve_times(far, v, a, j)), np.diff(far) / v)


@pytest.mark.parametrize("name", ["sparse_row", "course_row"])
def test_the_priced_bound_on_a_shipped_row_is_above_the_plain_one_and_below_its_plan(name):
    """Pricing the stops raises the stop-by-stop bound above the carriage's one move plus the
    busiest arm's best-position work, and the row's stop_and_go is the larger; a fine grid and
    the default one both bound (the fine one's cells price positions closer)."""
    prob = load_problem(ROWS / f"{name}.yaml")
    b = row_bounds(prob)
    plain = b.moves + b.work
    assert b.priced > plain + 1.0 and b.stop_and_go == pytest.approx(max(b.any_plan, plain, b.priced))
    assert b.priced_stops >= 2
    sb, equal = stops_bound(prob), stops_bound(prob, rounds=0)
    assert sb.value == b.priced and sb.uniform == equal.value == equal.uniform and equal.rounds == 0
    assert sb.value > 1.02 * equal.value  # the weights (module docstring): the shipped rows' rose 3.3-4.7 %
    fine = stops_bound(prob, 0.05, rounds=0)
    assert fine.value >= plain and fine.moves > 0 and fine.work > 0
    assert all(prob.gantry.start <= x <= prob.gantry.end for x in fine.stops)
    assert row_bounds(prob, priced=False).priced == 0.0


def test_the_cell_costs_are_the_cheapest_arm_s_over_the_harvesting_arms():
    """w_f(c) is min over arms of the cycle bound from cell c, divided by the arms that harvest;
    its least over cells is the per-fruit cycle bound's least over arms, divided the same way."""
    from coplan.allocate.row_cycles import cycle_bounds

    prob = load_problem(ROWS / "sparse_row.yaml")
    cc = cell_cycles(prob, 0.1)
    first, w, arms = fruit_cell_costs(cc)
    cost, reach, _ = cycle_bounds(prob, 0.1)
    assert arms == len(prob.arms)
    np.testing.assert_allclose(w.min(axis=1), cost.min(axis=0) / arms)


def test_a_settling_gantry_raises_the_stop_by_stop_bound_by_its_floor_per_stop_and_stays_below_the_plan():
    """gantry.settle: no arm picks until the carriage has settled after a move; within the settle
    an arm can only end the last stop's cycle and make its way to its first fruit -- each stop
    after a move adds the settle less two such ways and a place (settle_floor). On sparse_row
    with a 20 s settle the floor is 20 s less under 5 s; the bound rises by at least the floor per
    stop of its witness past the start and stays below the verified plan the optimised rule makes."""
    from dataclasses import replace

    from coplan.allocate.stop_bound import settle_floor
    from coplan.pipeline import solve

    prob = load_problem(ROWS / "sparse_row.yaml")
    slow = replace(prob, gantry=replace(prob.gantry, settle=20.0))
    floor = settle_floor(slow, cell_cycles(slow, 0.1))
    assert 15.0 < floor < 20.0 and settle_floor(prob, cell_cycles(prob, 0.1)) == 0.0
    b0, b1 = row_bounds(prob), row_bounds(slow)
    assert b1.priced >= b0.priced + floor * (b1.priced_stops - 1) - 1e-6
    assert b1.moves == pytest.approx(b0.moves + settle_floor(slow, cell_cycles(slow, 0.05)))  # (row_bounds' cells)
    res = solve(slow, planner="coordinated")
    assert res.verification.passed and res.plan.metrics["makespan"] >= b1.stop_and_go
    # the arms at home while the carriage settles wait for it ("carriage"), not for each other
    # ("others": 46-72 % of the row time before, on this row and a 15 m one)
    idle = res.plan.metrics["row"]["idle_share"]
    settling = 20.0 * (res.plan.metrics["row"]["stops"] - 1) / res.plan.metrics["makespan"]
    for a, causes in idle.items():
        assert causes["others"] < 0.05 and causes["carriage"] > 0.5 * settling, (a, causes)


def test_the_settle_floor_leaves_room_for_the_last_stops_place_and_this_stops_way_out():
    """A reviewer's counter-example to a floor that subtracted only the way to the first fruit:
    one arm, two fruit 2 m apart, a fast carriage and a 3 s settle. A stop-by-stop plan that
    picks f1 at the start, leaves at once, and within the move and the settle takes f1 to the bin,
    places it and goes out to f2 -- then picks f2 and places it -- is a valid plan (no pick
    within the settle) taking 6.85 s; the bound must stay below it (it was 8.03 s)."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.kinematics.timing import Move1D, scurve_times
    from coplan.problem import parse_problem

    d = gantry_row(length=3, density=2, n_arms=1, seed=1,
                   gantry={"settle": 3.0, "max_velocity": 4.0, "max_acceleration": 40.0, "max_jerk": 2000.0})
    d["fruits"] = [{"id": "f1", "position": [0.3, 1.72]}, {"id": "f2", "position": [2.3, 1.72]}]
    row = parse_problem(to_yaml(d))
    arm, g, tk = row.arms[0], row.gantry, row.task
    qb, vb = arm.ik(np.asarray(arm.bin, float), 0.0)

    def way(fx, fy, cx):  # the time-optimal bin -> fruit move with the carriage at cx (best branches)
        qf, vf = arm.ik(np.array([fx - cx, fy]), 0.0)
        return min(max(float(scurve_times(np.array([abs(np.angle(np.exp(1j * (q[i] - b[i]))))]), arm.max_velocity[i],
                                          arm.max_acceleration[i], arm.max_jerk[i])[0]) for i in range(2))
                   for b in qb[vb] for q in qf[vf])

    a1, a2 = way(0.3, 1.72, 0.0), way(2.3, 1.72, 2.0)
    hop = Move1D.between(0.0, 2.0, g.max_velocity, g.max_acceleration, g.max_jerk).duration
    assert a1 + tk.place_dwell + a2 <= hop + g.settle  # (the plan's tail and way out fit in the move and the settle)
    plan = a1 + tk.pick_dwell + hop + g.settle + tk.pick_dwell + a2 + tk.place_dwell
    assert row_bounds(row).stop_and_go <= plan + 1e-9


# --------------------------------------------------------------------------- the first cycle, from home
def _short_rail_row():
    """A verified plan beat the any-plan bound on it (found by a new-user trial): two arms on a
    5 cm rail, one of them harvesting five of six fruit, its first cycle from home."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem

    doc = gantry_row(length=4.0, n_arms=2, density=2.0, seed=3)
    doc["gantry"]["end"] = 0.05
    return parse_problem(to_yaml(doc))


def test_no_plan_beats_the_any_plan_bound_where_an_arm_s_first_cycle_from_home_is_shorter():
    from coplan import solve
    from coplan.allocate.allocation import min_max_bound
    from coplan.allocate.row_cycles import cycle_bounds, home_savings

    row = _short_rail_row()
    b = row_bounds(row)
    res = solve(row, planner="coordinated")
    assert res.verification.passed
    span = res.plan.metrics["makespan"]
    assert span >= b.any_plan - 1e-9
    cost, reach, _ = cycle_bounds(row)
    without = min_max_bound(np.where(reach, cost, 0.0), reach, relax=True)
    assert without > span  # the bound that left out the start at home was beaten by this plan
    saving = home_savings(cell_cycles(row, 0.05))
    assert b.work == pytest.approx(without - saving.max())
    assert (saving > 0).all()


@pytest.mark.parametrize("seed", range(3))
def test_the_ways_from_home_and_from_the_bin_are_below_every_sampled_way(seed):
    """The enclosed ways (per arm, fruit and rail cell) against the exact per-joint S-curve time
    from home and from each bin pose to both elbow branches of the fruit, the carriage at
    seeded random positions of the cell."""
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem
    from coplan.problem.gantry import cell_at

    row = parse_problem(to_yaml(gantry_row(length=3.0, n_arms=2, density=4.0, seed=seed)))
    cc = cell_cycles(row, 0.05)
    rng = np.random.default_rng(seed)
    checked = 0
    for x in rng.uniform(row.gantry.start, row.gantry.end, 40):
        c = min(int(np.searchsorted(cc.hi, x)), cc.lo.size - 1)
        cell = cell_at(row, float(x))
        for a, arm in enumerate(cell.arms):
            if cc.ways[a] is None:
                continue
            cells, _ = cc.band(a)
            qb, vb = arm.ik(np.asarray(arm.bin, float))
            for f, fruit in enumerate(cell.fruits):
                col = np.flatnonzero(cells[f] == c)
                q, valid = arm.ik(np.asarray(fruit.position, float), row.task.reach_margin)
                if not col.size or not valid.any():
                    continue
                lim = [(arm.max_velocity[i], arm.max_acceleration[i], arm.max_jerk[i]) for i in range(2)]

                def t(q0, q1):
                    return max(float(scurve_times(abs(q1[i] - q0[i]), *lim[i])) for i in range(2))

                poses = [q[b] for b in range(2) if valid[b]]
                home = min(t(np.asarray(arm.home, float), p) for p in poses)
                from_bin = min(t(qb[k], p) for k in range(2) if vb[k] for p in poses)
                assert home >= cc.home_ways[a][f, col].min() - 1e-9
                assert from_bin >= cc.ways[a][f, col].min() - 1e-9
                checked += 1
    assert checked > 50


def test_the_priced_bound_takes_off_the_most_the_first_cycle_saves_at_one_stop():
    """Regression (a reviewer): the priced bound charges each fruit its cycle at the cell of the
    stop that picks it, where starting at home may save more than the difference of the least
    ways over the whole rail; taking off only that left the bound above a verified plan (one
    fruit: 3.186 s against 2.798 s)."""
    from coplan import solve
    from coplan.allocate.row_cycles import home_savings
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem

    doc = gantry_row(length=2.0, n_arms=1, density=3.0, seed=62)
    doc["fruits"] = [{"id": "f1", "position": [0.0635, 0.8495]}]
    row = parse_problem(to_yaml(doc))
    cc = cell_cycles(row, 0.1, limits=False)  # (the enclosure the reviewer found it with; within the limits 0.85 s against 0.72 s)
    assert home_savings(cc, per_cell=True)[0] > home_savings(cc)[0] + 0.3
    cc = cell_cycles(row, 0.1)
    assert home_savings(cc, per_cell=True)[0] > home_savings(cc)[0] + 0.1
    res = solve(row, planner="coordinated")
    assert res.verification.passed and res.success
    assert stops_bound(row).value <= res.plan.metrics["makespan"] + 1e-9
    assert row_bounds(row).stop_and_go <= res.plan.metrics["makespan"] + 1e-9


def test_the_bound_gap_benchmark_splits_a_row_plan_s_time_and_its_cycle_bounds_hold_on_the_plan(tmp_path, capsys, monkeypatch):
    """``benchmarks/bench_bound_gap.py`` (docs/benchmarks.md: where a row plan's time goes against
    the stop-by-stop bound) on a short generated row: one verified table row whose parts add up,
    and the cycle bounds it charges where the plan picked are below what the plan's arms took
    (each arm's cycles run one after another, each at least its bound at the carriage's cell,
    its first from home by at most the home saving)."""
    import importlib

    import coplan
    from coplan.allocate.row_cycles import home_savings
    from coplan.allocate.stop_bound import STEP
    from coplan.generate import gantry_row, to_yaml

    bench = Path(__file__).resolve().parents[1] / "benchmarks"
    monkeypatch.syspath_prepend(str(bench))
    mod = importlib.import_module("bench_bound_gap")
    path = tmp_path / "row.yaml"
    path.write_text(to_yaml(gantry_row(length=6, n_arms=3, density=4, seed=1)))
    assert mod.main(["--rows", str(path)]) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if ln.startswith(f"| {path}")]
    assert len(lines) == 1 and lines[0].rstrip().endswith("| yes |")
    cells = [c.strip().removesuffix(" s").lstrip("+") for c in lines[0].strip("|").split("|")]
    row_time, bound, moves, moving, work, stop_time, at_picks = map(float, [cells[1], cells[2], cells[4], cells[5], cells[6],
                                                                           cells[7], cells[8]])
    assert row_time - bound == pytest.approx((moving - moves) + (stop_time - work), abs=0.3)
    problem = load_problem(path)
    plan = coplan.solve(problem).plan
    cc = cell_cycles(problem, STEP)
    at, _ = mod._charges(problem, plan, [], stops_bound(problem).weights)  # (the table's: at the bound's weights)
    assert at == pytest.approx(at_picks, abs=0.06)
    arms = [a for a in range(len(cc.cost)) if cc.cost[a] is not None]
    even, _ = mod._charges(problem, plan, [], np.full((cc.lo.size, len(arms)), 1.0 / len(arms)))
    took = sum(max(e.t_end for e in plan.events if e.arm == problem.arms[a].name) for a in arms)
    assert even * len(arms) - float(home_savings(cc, per_cell=True).sum()) <= took


def test_the_cycle_bound_turns_a_joint_within_its_limits_not_round_past_one():
    """(The enclosure let the shoulder's way wrap by 2 pi: from a bin at -150 degrees to a fruit at
    +150, 1.05 rad the short way, through its +-pi limits; the arm must turn 5.2 rad the long
    way.) One arm, the bin below and behind it, one fruit that the carriage at 3.0 m puts
    above and behind: the way there is within the exact time-optimal way at that position,
    the old enclosure (``limits=False``) far below it; a verified plan stays above the row's bounds."""
    from coplan.allocate.row_cycles import cycle_bounds
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem
    from coplan.problem.gantry import cell_at

    d = gantry_row(length=5.0, n_arms=1, density=1.0, seed=0)
    d["arms"][0]["bin"] = [-1.5155, -0.875]  # 1.75 m from the base at -150 degrees
    d["fruits"] = [{"id": "f1", "position": [1.4845, 0.875]}]  # the same, at +150 degrees, the carriage at 3.0 m
    row = parse_problem(to_yaml(d))
    cell = cell_at(row, 3.0)
    arm = cell.arms[0]
    qb, vb = arm.ik(np.asarray(arm.bin, float))
    q, v = arm.ik(np.asarray(cell.fruits[0].position, float), row.task.reach_margin)
    lim = [(arm.max_velocity[i], arm.max_acceleration[i], arm.max_jerk[i]) for i in range(2)]
    exact = min(max(float(scurve_times(abs(q[j][i] - qb[k][i]), *lim[i])) for i in range(2))
                for k in range(2) if vb[k] for j in range(2) if v[j])
    ways = {}
    for limits in (True, False):
        cc = cell_cycles(row, 0.05, limits=limits)
        cells, _ = cc.band(0)
        col = np.flatnonzero(cells[0] == int(np.searchsorted(cc.hi, 3.0)))
        ways[limits] = float(cc.ways[0][0, col].min())
    assert ways[True] <= exact + 1e-9 and ways[True] >= 0.9 * exact
    assert ways[False] < 0.4 * exact
    assert cycle_bounds(row)[0][0, 0] > cycle_bounds(row, limits=False)[0][0, 0] + 1.0
    import coplan  # and a verified plan of the row stays above both of its bounds

    res = coplan.solve(row)
    b = row_bounds(row)
    assert res.verification.passed and res.plan.metrics["harvested"] == 1
    assert b.stop_and_go <= res.plan.metrics["makespan"] + 1e-9 and b.any_plan <= b.stop_and_go


@pytest.mark.parametrize("bad", [-1, 2.5, True, "60", None])
def test_the_weight_rounds_must_be_a_whole_number_at_least_zero(bad):
    prob = load_problem(ROWS / "sparse_row.yaml")
    with pytest.raises(ValueError, match="rounds: expected a whole number"):
        stops_bound(prob, rounds=bad)


def test_a_row_s_bounds_are_computed_once_per_process_and_again_for_a_changed_row():
    """``coplan compare`` solves one row with every stop rule and on the move: the bounds (with
    their weight rounds, seconds on a long row) are remembered for the same row, read again or
    not, and computed anew when anything in it changes."""
    from dataclasses import replace

    prob = load_problem(ROWS / "sparse_row.yaml")
    b = row_bounds(prob)
    assert row_bounds(load_problem(ROWS / "sparse_row.yaml")) is b
    slow = replace(prob, gantry=replace(prob.gantry, max_velocity=prob.gantry.max_velocity / 2))
    b2 = row_bounds(slow)
    assert b2 is not b and b2.stop_and_go > b.stop_and_go and b2.travel > b.travel
    assert row_bounds(prob, priced=False) is not b and row_bounds(prob, priced=False).priced == 0.0


def test_the_rail_past_the_last_fruit_any_arm_reaches_changes_nothing():
    """The programme runs over the cells up to the last that some arm reaches some fruit from (a
    stop past it serves nothing and only adds a move): on a 40 m rail whose fruit lie in the
    first 6 m, the bound equals the programme over the whole rail, with equal weights and with
    the weights it finds (an 8 km rail for 8 m of fruit had `coplan check` take minutes)."""
    from coplan.allocate.row_cycles import home_savings
    from coplan.allocate.stop_bound import STEP, settle_floor, weighted_bound
    from coplan.generate import gantry_row, to_yaml
    from coplan.problem import parse_problem

    d = gantry_row(length=6.0, n_arms=3, density=4.0, seed=4)
    d["gantry"]["end"] = 40.0
    row = parse_problem(to_yaml(d))
    cc = cell_cycles(row, STEP)
    arms = [a for a in range(len(cc.cost)) if cc.cost[a] is not None]
    ok = cc.reach[arms].any(axis=0)
    bands = [tuple(x[ok] for x in cc.band(a)) for a in arms]
    g = row.gantry
    whole = weighted_bound(bands, cc.lo.size, STEP, g.max_velocity, g.max_acceleration, g.max_jerk,
                           settle_floor(row, cc), home_savings(cc, per_cell=True)[arms], 0)
    assert cc.lo.size == 400 and stops_bound(row, rounds=0).value == pytest.approx(whole.value, rel=1e-12)
    assert whole.stops and max(whole.stops) < 80
    found = stops_bound(row)
    assert found.value >= whole.value and max(found.stops) < g.start + 8.0
    lam = np.vstack([found.weights, np.full((cc.lo.size - found.weights.shape[0], len(arms)), 1.0 / len(arms))])
    again = weighted_bound(bands, cc.lo.size, STEP, g.max_velocity, g.max_acceleration, g.max_jerk,
                           settle_floor(row, cc), home_savings(cc, per_cell=True)[arms], 0, start=lam)
    assert again.value == pytest.approx(found.value, rel=1e-12)
