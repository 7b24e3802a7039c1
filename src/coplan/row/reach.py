"""Where the carriage can stand to harvest each fruit: the row's screen.

For each fruit and arm, the carriage positions (on a grid of ``resolution`` m along the rail)
from which that arm can harvest that fruit under the cell screen's rules
(:func:`coplan.allocate.screen.usable_picks`: the reach annulus less ``task.reach_margin``,
joint limits, the shoulder's free sweep past the neighbours' bases, link 2 clear of them; an
arm that can never reach its bin harvests nothing). The arms' geometry relative to each other
is fixed on the carriage, so this is one cell's screen evaluated at shifted fruit: a fruit at
row x seen from carriage position c sits at x - c in the carriage frame.

Entry point: :func:`row_reach` -> :class:`RowReach`. A fruit no grid position serves gets a
sentence saying why (:attr:`RowReach.reasons`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..allocate.screen import screened, usable_picks
from ..errors import Issue
from ..problem.gantry import RESOLUTION_RANGE, cell_at
from ..problem.model import Problem

__all__ = ["RowReach", "row_reach", "robust_end", "locked_arms", "screened_out", "DEFAULT_RESOLUTION",
           "RESOLUTION_RANGE", "resolution_issues"]

#: Spacing of the candidate carriage positions, m.
DEFAULT_RESOLUTION = 0.05


def resolution_issues(value) -> list[Issue]:
    """An options class's ``resolution`` out of :data:`RESOLUTION_RANGE` as an :class:`Issue`
    (empty otherwise, or when it is not a number: its type is the field check's)."""
    lo, hi = RESOLUTION_RANGE
    if isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value) and not lo <= value <= hi:
        return [Issue("resolution", f"expected a spacing of the carriage positions from {lo:g} to {hi:g} m, found {value:g}")]
    return []


@dataclass
class RowReach:
    """Candidate carriage positions and, per fruit, which arms harvest it from which.

    grid : (K,) carriage positions from ``gantry.start`` to ``gantry.end``
    resolution : the grid's spacing as asked (m; ``grid[1] - grid[0]`` differs from it in the
        last bits far from 0 -- a rail from -2000 m -- and a grid rebuilt from that had one point more)
    cover : fruit id -> (A, K) bool (only fruit some position serves)
    reasons : fruit id -> why no position serves it
    locked : arm name -> why it harvests nothing from any position (it cannot reach its bin: the
        bins ride with the carriage, so the cell screen's verdict holds all along the rail)
    """

    problem: Problem
    grid: np.ndarray
    resolution: float
    cover: dict[str, np.ndarray] = field(default_factory=dict)
    reasons: dict[str, str] = field(default_factory=dict)
    locked: dict[str, str] = field(default_factory=dict)
    done_to: float = -math.inf  # fruit up to this row x have been screened (a lazy reach grows as it is asked)

    def ensure(self, x: float = math.inf) -> list[str]:
        """Screen every fruit up to row position ``x`` not screened yet; returns the newly
        harvestable ones (file order). A receding planner asks for the next stretch only."""
        if x <= self.done_to:
            return []
        new = [f.id for f in self.problem.fruits if self.done_to < f.position[0] <= x]
        self.done_to = x
        if not new:
            return []
        more = row_reach(self.problem, self.resolution, new)
        self.cover.update(more.cover)
        self.reasons.update(more.reasons)
        return [f for f in new if f in more.cover]

    def stops_of(self, fid: str) -> np.ndarray:
        """Grid indices from which some arm harvests ``fid`` (sorted)."""
        return np.flatnonzero(self.cover[fid].any(axis=0))

    def span(self, fid: str) -> tuple[int, int]:
        """First and last grid index serving ``fid``."""
        k = self.stops_of(fid)
        return int(k[0]), int(k[-1])

    def harvestable(self) -> list[str]:
        """Fruit some carriage position serves, in file order."""
        return [f.id for f in self.problem.fruits if f.id in self.cover]

    def at(self, k: int) -> list[str]:
        """Fruit some arm harvests with the carriage at grid index ``k``, in file order."""
        return [f.id for f in self.problem.fruits if f.id in self.cover and self.cover[f.id][:, k].any()]


def row_reach(problem: Problem, resolution: float = DEFAULT_RESOLUTION, fruit_ids=None, lazy: bool = False) -> RowReach:
    """Screen every fruit (or ``fruit_ids``) against every carriage position of the grid; with
    ``lazy`` none yet (:meth:`RowReach.ensure` screens them stretch by stretch)."""
    g = problem.gantry
    # (max(1, ...) put a position at start + resolution on a rail shorter than that: a stop off the
    # rail, a plan the verifier refused, and fruit called harvestable from there)
    n = int(math.floor(g.length / resolution + 1e-9))
    grid = g.start + resolution * np.arange(n + 1)
    if grid[-1] < g.end - 1e-9:
        grid = np.append(grid, g.end)
    cell = cell_at(problem, 0.0, ())  # the carriage frame: bases and bins as written
    out = RowReach(problem, grid, float(resolution), locked=locked_arms(cell),
                   done_to=math.inf if not lazy else -math.inf)
    if lazy:
        return out
    reach = np.array([a.reach for a in problem.arms])
    bx = np.array([a.base[0] for a in problem.arms])
    keep = None if fruit_ids is None else set(fruit_ids)
    fruits = [f for f in problem.fruits if keep is None or f.id in keep]
    if not fruits:
        return out
    # carriage positions within reach of each fruit: |x_f - c - bx_a| <= reach_a
    xs = np.array([f.position[0] for f in fruits])
    lo = np.searchsorted(grid, xs[:, None] - bx[None, :] - reach[None, :] - 1e-9)  # (F, A)
    hi = np.searchsorted(grid, xs[:, None] - bx[None, :] + reach[None, :] + 1e-9, side="right")
    cover = np.zeros((len(fruits), len(problem.arms), grid.size), dtype=bool)
    for a in range(len(problem.arms)):  # per arm, only the positions within its reach of each fruit
        n_k = hi[:, a] - lo[:, a]
        if n_k.max(initial=0) <= 0:
            continue
        rows = np.repeat(np.arange(len(fruits)), np.maximum(n_k, 0))
        cols = np.concatenate([np.arange(l, h) for l, h in zip(lo[:, a], hi[:, a])])
        pts = np.c_[xs[rows] - grid[cols], np.array([f.position[1] for f in fruits])[rows]]
        ok = usable_picks(cell, pts, arms=(a,))[a].any(axis=-1)
        cover[rows, a, cols] = ok
    for j, f in enumerate(fruits):
        if cover[j].any():
            out.cover[f.id] = cover[j]
        else:
            out.reasons[f.id] = _why(problem, f, resolution, cell)
    return out


def screened_out(problem: Problem, reach: RowReach) -> list[str]:
    """The fruit the screen found no carriage position for (file order): a row plan's
    ``unreachable``, as a cell plan's lists what its screen left out."""
    return [f.id for f in problem.fruits if f.id in reach.reasons]


def locked_arms(cell: Problem) -> dict[str, str]:
    """Arm name -> why it harvests nothing, for a carriage-frame cell (:func:`cell_at` at 0, no
    fruit): the cell screen's locked arms -- an arm that cannot reach its bin places nothing,
    wherever the carriage stands (the bins ride with it)."""
    scr = screened(cell)
    return {a: scr.reasons[a] for a in scr.locked}


def _why(problem: Problem, f, resolution: float, cell: Problem) -> str:
    """Why no grid position serves fruit ``f``. Where some arm harvests it from a carriage
    position between the grid's (a window narrower than the grid's spacing, found on a 1 mm
    scan), that window; else the screen's sentence with the carriage where the fruit comes
    nearest some arm's reach (the arm it misses by least, on the rail)."""
    g = problem.gantry
    fx, fy = f.position
    windows = []
    for a, arm in enumerate(problem.arms):
        lo, hi = max(fx - arm.base[0] - arm.reach, g.start), min(fx - arm.base[0] + arm.reach, g.end)
        if hi < lo:
            continue
        cs = np.linspace(lo, hi, max(2, int(math.ceil((hi - lo) / 1e-3)) + 1))
        d = np.hypot(fx - cs - arm.base[0], fy - arm.base[1])
        m = problem.task.reach_margin
        cs = cs[(d <= arm.reach - m) & (d >= arm.inner_radius + m)]  # (only where the annulus holds: a fruit too high costs nothing)
        if not cs.size:
            continue
        ok = usable_picks(cell, np.c_[fx - cs, np.full(cs.size, fy)], arms=(a,))[a].any(axis=-1)
        # each run of serving positions (1 mm apart on the scan) a window of its own
        cut = np.flatnonzero(~ok[:-1] & ok[1:] | (np.diff(cs) > 1.5e-3) & ok[1:]) + 1 if ok.size > 1 else np.zeros(0, int)
        for run_cs, run_ok in zip(np.split(cs, cut), np.split(ok, cut)):
            if run_ok.any():
                windows.append((arm.name, float(run_cs[run_ok][0]), float(run_cs[run_ok][-1])))
    rail = f"the rail [{g.start:g}, {g.end:g}] m"
    if windows:
        wide = max(hi - lo for _, lo, hi in windows)
        finer = math.floor(wide * 1000.0) / 1000.0
        hint = (f"candidate stops every {finer:g} m or closer put one in it: --resolution {finer:g}, RowOptions.resolution"
                if finer >= 0.01 else "narrower than the 0.01 m --resolution goes down to: RowOptions.resolution from Python")
        return (f"{f.id}: no candidate stop serves it: an arm harvests it only with the carriage within a "
                f"window narrower than the candidate stops' spacing ({resolution:g} m along {rail}): "
                f"{', '.join(f'{n} at {lo:.3f}-{hi:.3f} m' for n, lo, hi in windows)} ({hint})")

    def miss(arm, c):  # how far the fruit lies outside the arm's reach annulus (less the margin)
        d = math.hypot(fx - c - arm.base[0], fy - arm.base[1])
        m = problem.task.reach_margin
        return max(d - (arm.reach - m), (arm.inner_radius + m) - d, 0.0)

    c = min((miss(a, c), c) for a in problem.arms for c in [min(max(fx - a.base[0], g.start), g.end)])[1]
    why = screened(cell_at(problem, c, (f.id,))).reasons.get(f.id, f"{f.id}: blocked")
    return (f"{f.id}: no carriage position on {rail} lets an arm harvest it; "
            f"with the carriage at {c:.2f} m, {why.split(': ', 1)[1]}")


def robust_end(problem: Problem, reach: RowReach, xy, arm: int, k_lo: int, k_hi: int, radius: float) -> int | None:
    """The last grid index in ``[k_lo, k_hi]`` from which arm ``arm`` serves a fruit reported at
    ``xy`` wherever within ``radius`` of it the fruit truly is (eight points on that circle, and
    ``xy``, all usable); None if no index there does. A live planner's deadline for a fruit near
    the edge of an arm's reach: past that index the report's error may put it out of reach."""
    cell = cell_at(problem, 0.0, ())
    ang = np.linspace(0.0, 2.0 * math.pi, 8, endpoint=False)
    ring = np.r_[[[0.0, 0.0]], radius * np.c_[np.cos(ang), np.sin(ang)]] + np.asarray(xy, float)  # (9, 2)
    ks = np.arange(k_hi, k_lo - 1, -1)
    pts = (ring[None, :, :] - np.c_[reach.grid[ks], np.zeros(ks.size)][:, None, :]).reshape(-1, 2)  # (K * 9, 2)
    ok = usable_picks(cell, pts, arms=(arm,))[arm].any(axis=-1).reshape(ks.size, ring.shape[0]).all(axis=1)
    hit = np.flatnonzero(ok)
    return int(ks[hit[0]]) if hit.size else None
