"""Problem generators for sweeps, benchmarks and tests.

Pure, deterministic functions (same arguments, same problem) returning plain problem
dicts in the problem-file format; :func:`to_yaml` turns one into commit-ready YAML text.
Every generated problem validates with :func:`coplan.problem.parse_problem`.

* :func:`row_problem` -- the lesson's cell stretched to any number of arms on a straight
  gantry: bases ``spacing`` apart, centred on x = 0, bins below the bases, fruit uniform
  along the row.
* :func:`overlap_problem` -- a row whose fruit all sit in the zones where neighbouring arms'
  workspaces overlap (the hardest case for coordination).
* :func:`random_problem` -- 2-5 arms with random spacing (1.2-2.4 m), link lengths, joint,
  velocity, acceleration and jerk limits, home pose, bins and fruit count; draws again
  (deterministically) until the problem validates.
* :func:`gantry_row` -- a greenhouse *row*: the lesson's arms on a mobile gantry (a
  ``gantry`` section: bases and bins on the carriage) and fruit along ``length`` m of row at
  ``density`` fruit per metre, uniform or clustered in trusses.
* :func:`cell_problem` -- a harder, less regular distribution: 2-5 arms with each gap drawn
  on its own (1.0-2.6 m), every arm its own link lengths and limits, bins off-centre,
  4-30 fruit; tight gaps lock arms or leave fruit only one arm can take.
"""

from __future__ import annotations

import json
import math
import re
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..kinematics import arm as kin

__all__ = ["row_problem", "overlap_problem", "random_problem", "cell_problem", "gantry_row", "to_yaml", "problem_dict", "LESSON_DEFAULTS",
           "LESSON_TASK", "LESSON_GANTRY"]

#: The arm of the course's cell (``greenhouse_row.yaml``): every field of ``defaults``. The lesson
#: gives the links, joint limits and home; the link radius and the velocity, acceleration and
#: jerk limits are coplan's (the lesson asks for smooth, jerk-limited motion and gives no numbers).
LESSON_DEFAULTS: dict[str, Any] = {
    "links": [1.0, 0.8],
    "link_radius": 0.04,
    "joint_limits": [[-3.1416, 3.1416], [-3.0416, 3.0416]],
    "max_velocity": [3.0, 4.0],
    "max_acceleration": [8.0, 12.0],
    "max_jerk": [80.0, 120.0],
    "home": [1.0472, 0.7854],
}
#: The course cell's task: coplan's dwells and clearance (the lesson gives none).
LESSON_TASK: dict[str, float] = {"pick_dwell": 0.3, "place_dwell": 0.2, "clearance": 0.05}

_REACH_MARGIN = 0.01  # the lesson's IK margin, also coplan's default ``task.reach_margin``


def _r4(x: float) -> float:
    return round(float(x), 4)


def _bases(n_arms: int, spacing: float) -> list[float]:
    """x of ``n_arms`` bases ``spacing`` apart, centred on 0 (exact to 4 decimals)."""
    return [_r4((i - (n_arms - 1) / 2.0) * spacing) for i in range(n_arms)]


def _real(x: Any) -> bool:
    """Whether ``x`` is a finite number (NumPy's too; not a bool)."""
    return isinstance(x, (int, float, np.number)) and not isinstance(x, bool) and math.isfinite(x)


def _finite(**values: Any) -> None:
    """ValueError naming the first argument that is not a finite number (or pair of them)."""
    for k, v in values.items():
        xs = np.ravel(np.asarray(v, dtype=object))
        if not all(_real(x) for x in xs):
            raise ValueError(f"{k}: expected finite numbers, found {v!r}")


def _whole(what: str, **values: Any) -> None:
    """ValueError naming the first count or seed that is not a whole number in its range:
    ``seed`` 0 to 2**32 - 1 (NumPy's seeds), ``n_arms`` 1 to MAX_ARMS, ``n_fruits`` 0 to
    MAX_FRUITS (a problem file's limits), ``max_tries`` >= 1; None passes (drawn), but for ``seed``:
    every problem is drawn from its seed."""
    from .model import MAX_ARMS, MAX_FRUITS

    ranges = {"seed": (0, 2**32 - 1), "n_arms": (1, MAX_ARMS), "n_fruits": (0, MAX_FRUITS), "max_tries": (1, 10**6)}
    for k, v in values.items():
        if v is None and k != "seed":  # (a seed of None drew another problem at every call)
            continue
        lo, hi = ranges[k]
        if isinstance(v, bool) or not isinstance(v, (int, np.integer)) or not lo <= v <= hi:
            raise ValueError(f"{what}: {k}: expected a whole number from {lo} to {hi}, found {v!r}")


def _pair(what: str, **values: Any) -> None:
    """ValueError naming the first argument that is not a pair of positive finite numbers."""
    for k, v in values.items():
        xs = list(np.ravel(np.asarray(v, dtype=object)))
        if len(xs) != 2 or not all(_real(x) and x > 0 for x in xs):
            raise ValueError(f"{what}: {k}: expected two positive finite numbers, found {v!r}")


def _low_high(what: str, name: str, v: Any) -> None:
    """ValueError unless ``v`` is (low, high), two finite numbers with low < high (one number
    gave "'float' object is not subscriptable" or "has no len()")."""
    xs = list(np.ravel(np.asarray(v, dtype=object)))
    if len(xs) != 2 or not all(_real(x) for x in xs) or not xs[0] < xs[1]:
        raise ValueError(f"{what}: {name}: expected (low, high), two finite numbers with low < high, found {v!r}")


def _fruit_ids(n: int) -> list[str]:
    width = max(3, len(str(n)))
    return [f"f{i:0{width}d}" for i in range(1, n + 1)]


def _reachable(point: np.ndarray, bases: Sequence[float], links: Sequence[float], margin: float) -> bool:
    """Whether some arm (base on y = 0, any IK branch, lesson-like limits) can reach ``point``."""
    return any(bool(kin.in_workspace(point, links, (bx, 0.0), margin)) for bx in bases)


def _assemble(
    name: str,
    description: str,
    defaults: dict[str, Any],
    arms: list[dict[str, Any]],
    fruit_xy: Sequence[tuple[float, float]],
    task: dict[str, float],
) -> dict[str, Any]:
    ids = _fruit_ids(len(fruit_xy))
    return {
        "name": name,
        "description": description,
        "defaults": defaults,
        "arms": arms,
        "fruits": [{"id": fid, "position": [_r4(x), _r4(y)]} for fid, (x, y) in zip(ids, fruit_xy)],
        "task": dict(task),
    }


def _arm_entries(bases: Sequence[float], bin_offset: float, names: Sequence[str] | None) -> list[dict[str, Any]]:
    names = list(names) if names is not None else [f"arm{i + 1}" for i in range(len(bases))]
    if len(names) != len(bases):
        raise ValueError(f"expected {len(bases)} arm names, found {len(names)}")
    return [{"name": n, "base": [bx, 0.0], "bin": [bx, _r4(bin_offset)]} for n, bx in zip(names, bases)]


def row_problem(
    n_arms: int,
    n_fruits: int,
    spacing: float = 2.0,
    seed: int = 0,
    links: tuple[float, float] = (1.0, 0.8),
    link_radius: float = 0.04,
    joint_limits: tuple[tuple[float, float], tuple[float, float]] = ((-3.1416, 3.1416), (-3.0416, 3.0416)),
    max_velocity: tuple[float, float] = (3.0, 4.0),
    max_acceleration: tuple[float, float] = (8.0, 12.0),
    max_jerk: tuple[float, float] = (80.0, 120.0),
    home: tuple[float, float] = (1.0472, 0.7854),
    y_range: tuple[float, float] = (0.5, 1.8),
    bin_offset: float = -0.5,
    x_pad: float = 1.5,
    reachable_only: bool = False,
    task: dict[str, float] | None = None,
    arm_names: Sequence[str] | None = None,
    name: str | None = None,
    description: str | None = None,
) -> dict[str, Any]:
    """A straight row of ``n_arms`` identical arms harvesting ``n_fruits`` fruit.

    Bases at y = 0, ``spacing`` m apart and centred on x = 0; each bin at height
    ``bin_offset`` m relative to its base (signed: the default -0.5 is half a metre below). Fruit are drawn as in the lesson -- ``np.random.seed(seed)``, all x
    uniform over the row's extent (first base - ``x_pad`` to last base + ``x_pad``; for the
    lesson's 3-arm cell exactly [-3.5, 3.5]), then all y uniform in ``y_range`` -- so
    ``row_problem(3, 12, seed=42)`` holds the lesson's twelve fruit. Positions are rounded
    to 4 decimals, ids ``f001``... in draw order. With ``reachable_only`` a fruit no arm
    could reach (lesson margin 0.01 m) is replaced by fresh draws from the same stream, so
    the row has no holes. Deterministic in ``seed``.
    """
    _whole("row_problem", n_arms=n_arms, n_fruits=n_fruits, seed=seed)
    _low_high("row_problem", "y_range", y_range)
    if n_arms is None or n_fruits is None:
        raise ValueError(f"row_problem: expected n_arms and n_fruits, found {n_arms!r} and {n_fruits!r}")
    _pair("row_problem", links=links)
    _finite(spacing=spacing, links=links, link_radius=link_radius, bin_offset=bin_offset, x_pad=x_pad)
    if spacing <= 0 and n_arms > 1:  # (a negative spacing swapped the arms' order; 0 stacked them, refused only at solve)
        raise ValueError(f"row_problem: expected spacing > 0 (m between neighbouring bases), found {spacing}")
    # the lesson's draw: np.random.seed(seed); all x, then all y
    rs = np.random.RandomState(seed)
    bases = _bases(n_arms, spacing)
    lo, hi = bases[0] - x_pad, bases[-1] + x_pad
    xs, ys = rs.uniform(lo, hi, n_fruits), rs.uniform(y_range[0], y_range[1], n_fruits)
    pts: list[tuple[float, float]] = []
    for x, y in zip(xs, ys):
        x, y = _r4(x), _r4(y)
        while reachable_only and not _reachable(np.array([x, y]), bases, links, _REACH_MARGIN + 1e-4):
            x, y = _r4(rs.uniform(lo, hi)), _r4(rs.uniform(y_range[0], y_range[1]))
        pts.append((x, y))
    defaults = {
        "links": [float(links[0]), float(links[1])],
        "link_radius": float(link_radius),
        "joint_limits": [[float(a), float(b)] for a, b in joint_limits],
        "max_velocity": [float(v) for v in max_velocity],
        "max_acceleration": [float(v) for v in max_acceleration],
        "max_jerk": [float(v) for v in max_jerk],
        "home": [float(v) for v in home],
    }
    name = name or f"row-{n_arms}arms-{n_fruits}fruit-seed{seed}"
    description = description or (
        f"{n_arms} 2R arms {spacing:g} m apart on a straight gantry, {n_fruits} fruit uniform along the row (seed {seed})."
    )
    return _assemble(name, description, defaults, _arm_entries(bases, bin_offset, arm_names), pts, task or LESSON_TASK)


def overlap_problem(
    n_arms: int = 3,
    n_fruits: int = 15,
    spacing: float = 1.5,
    seed: int = 0,
    zone_halfwidth: float = 0.35,
    y_range: tuple[float, float] = (0.4, 1.5),
    bin_offset: float = -0.5,
    arm_names: Sequence[str] | None = None,
    name: str | None = None,
    description: str | None = None,
) -> dict[str, Any]:
    """Lesson arms ``spacing`` apart with every fruit in a zone shared by two neighbours.

    Each fruit picks a gap between neighbouring bases (round robin, so the gaps get equal
    shares), then x is uniform within ``zone_halfwidth`` of the gap's midpoint and y uniform
    in ``y_range``; a draw that is not reachable by *both* neighbours (lesson margin) is
    drawn again. Limits and task are the course cell's (:data:`LESSON_DEFAULTS`, :data:`LESSON_TASK`).
    """
    _whole("overlap_problem", n_arms=n_arms, n_fruits=n_fruits, seed=seed)
    _low_high("overlap_problem", "y_range", y_range)
    if n_arms is None or n_arms < 2 or n_fruits is None:
        raise ValueError(f"overlap_problem: expected at least 2 arms for overlap zones and a fruit count, found {n_arms!r} and {n_fruits!r}")
    if not isinstance(spacing, (int, float)) or isinstance(spacing, bool) or not spacing > 0:
        raise ValueError(f"overlap_problem: expected spacing > 0 (m between neighbouring bases), found {spacing!r}")
    rng = np.random.default_rng(seed)
    bases = _bases(n_arms, spacing)
    links = LESSON_DEFAULTS["links"]
    pts: list[tuple[float, float]] = []
    tries = 0
    while len(pts) < n_fruits:
        tries += 1
        if tries > 10_000 * max(n_fruits, 1):
            raise ValueError("overlap zones too small: no point reachable by both neighbours; widen y_range or spacing")
        gap = len(pts) % (n_arms - 1)
        mid = (bases[gap] + bases[gap + 1]) / 2.0
        x, y = _r4(mid + rng.uniform(-zone_halfwidth, zone_halfwidth)), _r4(rng.uniform(*y_range))
        p = np.array([x, y])
        m = _REACH_MARGIN + 1e-4
        if kin.in_workspace(p, links, (bases[gap], 0.0), m) and kin.in_workspace(p, links, (bases[gap + 1], 0.0), m):
            pts.append((x, y))
    name = name or f"overlap-{n_arms}arms-{n_fruits}fruit-seed{seed}"
    description = description or (
        f"{n_arms} 2R arms only {spacing:g} m apart; all {n_fruits} fruit in the zones that neighbouring arms share."
    )
    return _assemble(name, description, dict(LESSON_DEFAULTS), _arm_entries(bases, bin_offset, arm_names), pts, LESSON_TASK)


def random_problem(
    seed: int,
    n_arms: int | None = None,
    n_fruits: int | None = None,
    max_tries: int = 200,
) -> dict[str, Any]:
    """A random but valid problem: 2-5 arms (or ``n_arms``), spacing 1.2-2.4 m, link lengths,
    link radius, joint/velocity/acceleration/jerk limits, home pose, bin depth and fruit
    count (3-8 per arm, or ``n_fruits``) all drawn from ``seed``.

    Some arms get their own link lengths (an arm-level override of ``defaults``). Draws are
    repeated, deterministically, until the problem validates (e.g. home poses that respect
    the clearance at tight spacing); raises ``RuntimeError`` after ``max_tries``.
    """
    return _valid_draw(_draw_random, "random_problem", seed, n_arms, n_fruits, max_tries)


def cell_problem(seed: int, n_arms: int | None = None, n_fruits: int | None = None, max_tries: int = 200) -> dict[str, Any]:
    """A random cell unlike :func:`random_problem`'s: 2-5 arms (or ``n_arms``), each gap drawn on
    its own from 1.0-2.6 m, every arm its own link lengths (reach 1.4-2.1 m) and velocity,
    acceleration and jerk limits, bins off-centre (up to 0.4 m to either side), 4-30 fruit (or
    ``n_fruits``) anywhere over the row. Redrawn (deterministically) until it validates."""
    return _valid_draw(_draw_cell, "cell_problem", seed, n_arms, n_fruits, max_tries)


#: The gantry of the generated rows: a greenhouse pipe-rail carriage's limits (coplan's; the lesson has no gantry).
LESSON_GANTRY: dict[str, float] = {"max_velocity": 0.5, "max_acceleration": 0.5, "max_jerk": 5.0}


def gantry_row(
    length: float = 50.0,
    n_arms: int = 3,
    density: float = 6.0,
    seed: int = 0,
    spacing: float = 2.0,
    trusses: bool = True,
    y_range: tuple[float, float] = (0.5, 1.5),
    gantry: dict[str, float] | None = None,
    name: str | None = None,
) -> dict[str, Any]:
    """A row of ``length`` m harvested by ``n_arms`` of the lesson's arms on a gantry.

    The carriage carries the arms ``spacing`` m apart, centred on its origin, each bin 0.5 m
    below its base; it runs from ``start`` 0 to ``end`` = ``length`` with the limits of
    :data:`LESSON_GANTRY`, each key ``gantry`` gives in place of that default (``gantry={"settle":
    0.5}`` keeps these limits; ``start`` and ``end`` too: the fruit then lie along ``length`` m
    from ``start``, and ``end`` is at least that far). About ``density`` fruit per metre (Poisson count,
    seeded) lie along x in [``start``, ``start + length``] at heights in ``y_range`` (low, high): uniform, or with
    ``trusses`` in clusters (a truss every 0.25-0.45 m, its fruit within 6 cm of it and 12 cm
    of its height), as strawberries hang. Positions rounded to 4 decimals (two that round to one
    position are one fruit), ids ``f0001``... by x.
    Deterministic in its arguments.
    """
    _whole("gantry_row", n_arms=n_arms, seed=seed)
    _low_high("gantry_row", "y_range", y_range)
    _finite(length=length, density=density, spacing=spacing)
    if length <= 0 or n_arms < 1 or density < 0:
        raise ValueError(f"gantry_row: expected length > 0, n_arms >= 1 and density >= 0, found {length}, {n_arms}, {density}")
    if spacing <= 0 and n_arms > 1:  # (a negative spacing swapped the arms' order; 0 stacked them)
        raise ValueError(f"gantry_row: expected spacing > 0 (m between neighbouring bases), found {spacing}")
    if not isinstance(trusses, bool):  # ("no" was taken as true)
        raise ValueError(f"gantry_row: expected trusses True or False, found {trusses!r}")
    from .model import MAX_ARMS, MAX_FRUITS

    if density * length > MAX_FRUITS or n_arms > MAX_ARMS:  # (before drawing: 1e9 per metre asked for 149 GiB)
        raise ValueError(f"expected at most {MAX_FRUITS} fruit (density x length) and {MAX_ARMS} arms, a problem file's "
                         f"limits; found about {density * length:.4g} fruit ({density:g} per metre over {length:g} m) "
                         f"and {n_arms} arms")
    if gantry is not None and not isinstance(gantry, dict):
        raise TypeError(f"gantry: expected a mapping of gantry keys (e.g. {{'settle': 0.5}}), found {type(gantry).__name__} {gantry!r}")
    x0 = (gantry or {}).get("start", 0.0)
    _finite(**{"gantry start": x0})
    x0 = float(x0)
    if "end" in (gantry or {}):
        _finite(**{"gantry end": gantry["end"]})  # type: ignore[index]
        if float(gantry["end"]) < x0 + length - 1e-9:  # type: ignore[index]
            raise ValueError(f"gantry end: expected at least start + length = {x0 + length:g} (the fruit lie along "
                             f"length m from start), found {gantry['end']!r}")  # type: ignore[index]
    rng = np.random.default_rng(seed)
    n = int(rng.poisson(density * length))
    if trusses and n:
        xs = []
        x = float(rng.uniform(0.0, 0.3))
        while x < length:
            xs.append(x)
            x += float(rng.uniform(0.25, 0.45))
        xs = np.asarray(xs or [x * length / 0.3])  # (a row shorter than the first draw: that truss on it)
        inset = min(0.12, 0.5 * (y_range[1] - y_range[0]))  # (a truss's fruit within 12 cm of its height)
        heights = rng.uniform(y_range[0] + inset, y_range[1] - inset, xs.size)
        which = rng.integers(0, xs.size, n)
        px = np.clip(xs[which] + rng.uniform(-0.06, 0.06, n), 0.0, length)
        py = np.clip(heights[which] + rng.uniform(-0.12, 0.12, n), *y_range)
        pts = sorted(zip(px, py))
    else:
        pts = sorted(zip(rng.uniform(0.0, length, n), rng.uniform(*y_range, n)))
    bases = _bases(n_arms, spacing)
    g = {"start": 0.0, "end": _r4(x0 + length)} | LESSON_GANTRY | (gantry or {})  # (a key given replaces its default only)
    d = _assemble(
        name or f"row-{length:g}m-{n_arms}arms-{spacing:g}m-{density:g}perm-seed{seed}",
        f"{n_arms} of the lesson's arms {spacing:g} m apart on a gantry along a {length:g} m row, about {density:g} "
        f"fruit per metre ({'in trusses' if trusses else 'uniform'}, seed {seed}).",
        dict(LESSON_DEFAULTS), _arm_entries(bases, -0.5, None),
        # (one fruit per position: two clipped to a narrow band's edge can round to one, which a problem refuses)
        list(dict.fromkeys((_r4(x0 + x), _r4(y)) for x, y in pts)), LESSON_TASK)
    width = max(4, len(str(len(pts))))
    for i, f in enumerate(d["fruits"], 1):
        f["id"] = f"f{i:0{width}d}"
    from .gantry import parse_gantry

    issues: list = []
    if parse_gantry(g, {}, issues) is None:  # (as a file's gantry section: a typo fails here, not when loaded)
        raise ValueError("gantry_row: " + "; ".join(f"{i.path}: {i.message}" for i in issues))
    d["gantry"] = g
    return d


def _valid_draw(draw, what: str, seed: int, n_arms, n_fruits, max_tries: int) -> dict[str, Any]:
    from ..errors import ProblemError
    from .load import parse_problem

    _whole(what, seed=seed, n_arms=n_arms, n_fruits=n_fruits, max_tries=max_tries)

    rng = np.random.default_rng(seed)
    last: Exception | None = None
    for _ in range(max_tries):
        d = draw(rng, seed, n_arms, n_fruits)
        try:
            parse_problem(to_yaml(d))
        except ProblemError as e:  # rare: redraw from the same stream
            last = e
            continue
        return d
    raise RuntimeError(f"{what}(seed={seed}): no valid problem in {max_tries} draws; last: {last}")


def _fruit_over_row(rng: np.random.Generator, x_first: float, x_last: float, reach: float, n: int) -> list:
    """``n`` fruit uniform over the row (0.8 ``reach`` past the end bases) at 0.25-0.95 ``reach`` high."""
    lo, hi = x_first - 0.8 * reach, x_last + 0.8 * reach
    return [(_r4(rng.uniform(lo, hi)), _r4(rng.uniform(0.25 * reach, 0.95 * reach))) for _ in range(n)]


def _draw_cell(rng: np.random.Generator, seed: int, n_arms: int | None, n_fruits: int | None) -> dict[str, Any]:
    A = int(n_arms) if n_arms is not None else int(rng.integers(2, 6))
    gaps = [_r4(rng.uniform(1.0, 2.6)) for _ in range(A - 1)]
    xs = np.concatenate([[0.0], np.cumsum(gaps)]) if gaps else np.zeros(1)
    xs = [_r4(x - xs[-1] / 2) for x in xs]
    q1 = _r4(rng.uniform(2.8, 3.1416))
    q2 = _r4(rng.uniform(2.8, 3.0416))
    defaults = {
        "link_radius": _r4(rng.uniform(0.03, 0.05)),
        "joint_limits": [[-q1, q1], [-q2, q2]],
        "home": [_r4(rng.uniform(1.0, 1.5)), _r4(rng.uniform(-0.4, 0.5))],
    }
    arms: list[dict[str, Any]] = []
    reaches = []
    for i, bx in enumerate(xs):
        l1 = _r4(rng.uniform(0.8, 1.15))
        l2 = _r4(rng.uniform(0.6, min(0.95, 2.1 - l1)))
        inner, outer = abs(l1 - l2), l1 + l2
        depth = _r4(rng.uniform(inner + 0.15, min(outer - 0.1, inner + 0.6)))
        arms.append({
            "name": f"r{i + 1}", "base": [bx, 0.0], "links": [l1, l2],
            "bin": [_r4(bx + rng.uniform(-0.4, 0.4)), -depth],
            "max_velocity": [_r4(rng.uniform(2.0, 3.5)), _r4(rng.uniform(2.5, 4.5))],
            "max_acceleration": [_r4(rng.uniform(6.0, 14.0)), _r4(rng.uniform(8.0, 16.0))],
            "max_jerk": [_r4(rng.uniform(60.0, 150.0)), _r4(rng.uniform(80.0, 160.0))],
        })
        reaches.append(outer)
    F = int(n_fruits) if n_fruits is not None else int(rng.integers(4, 31))
    pts = _fruit_over_row(rng, xs[0], xs[-1], min(reaches), F)
    task = {
        "pick_dwell": _r4(rng.uniform(0.15, 0.4)),
        "place_dwell": _r4(rng.uniform(0.1, 0.3)),
        "clearance": _r4(rng.uniform(0.03, 0.08)),
    }
    desc = f"Random cell (seed {seed}): {A} arms, gaps {', '.join(f'{g:g}' for g in gaps) or '-'} m, {F} fruit."
    return _assemble(f"cell-{seed}", desc, defaults, arms, pts, task)


def _draw_random(rng: np.random.Generator, seed: int, n_arms: int | None, n_fruits: int | None) -> dict[str, Any]:
    A = int(n_arms) if n_arms is not None else int(rng.integers(2, 6))
    spacing = _r4(rng.uniform(1.2, 2.4))
    l1, l2 = _r4(rng.uniform(0.8, 1.2)), _r4(rng.uniform(0.6, 1.0))
    q1 = _r4(rng.uniform(2.6, 3.1416))
    q2 = _r4(rng.uniform(2.6, 3.0416))
    defaults = {
        "links": [l1, l2],
        "link_radius": _r4(rng.uniform(0.03, 0.05)),
        "joint_limits": [[-q1, q1], [-q2, q2]],
        "max_velocity": [_r4(rng.uniform(2.0, 4.0)), _r4(rng.uniform(2.5, 5.0))],
        "max_acceleration": [_r4(rng.uniform(6.0, 12.0)), _r4(rng.uniform(8.0, 16.0))],
        "max_jerk": [_r4(rng.uniform(50.0, 120.0)), _r4(rng.uniform(80.0, 160.0))],
        "home": [_r4(rng.uniform(0.8, 1.3)), _r4(rng.uniform(0.5, 1.1))],
    }
    bases = _bases(A, spacing)
    arms: list[dict[str, Any]] = []
    reaches = []
    for i, bx in enumerate(bases):
        links = [l1, l2]
        entry: dict[str, Any] = {"name": f"arm{i + 1}", "base": [bx, 0.0]}
        if rng.random() < 0.25:  # this arm has its own links
            links = [_r4(rng.uniform(0.8, 1.2)), _r4(rng.uniform(0.6, 1.0))]
        inner, outer = abs(links[0] - links[1]), links[0] + links[1]
        depth = _r4(rng.uniform(inner + 0.1, min(outer - 0.1, inner + 0.6)))
        entry["bin"] = [bx, -depth]
        if links != [l1, l2]:
            entry["links"] = links
        arms.append(entry)
        reaches.append(outer)
    F = int(n_fruits) if n_fruits is not None else int(rng.integers(3 * A, 8 * A + 1))
    pts = _fruit_over_row(rng, bases[0], bases[-1], min(reaches), F)
    task = {
        "pick_dwell": _r4(rng.uniform(0.1, 0.5)),
        "place_dwell": _r4(rng.uniform(0.1, 0.4)),
        "clearance": _r4(rng.uniform(0.02, 0.08)),
    }
    desc = f"Random problem (seed {seed}): {A} arms {spacing:g} m apart, {F} fruit."
    return _assemble(f"random-{seed}", desc, defaults, arms, pts, task)


# --------------------------------------------------------------------------- YAML text
_PLAIN = re.compile(r"[A-Za-z_][A-Za-z0-9_.\-]*")
_YAML11_WORDS = {"y", "n", "yes", "no", "true", "false", "on", "off", "null"}


class UnwritableValue(TypeError):
    """A value :func:`to_yaml` cannot write, at ``path`` (a key path such as ``fruits[0].position``)."""

    def __init__(self, path: str, v: Any):
        self.path = path
        self.found = type(v).__name__
        super().__init__(f"{path or '<top>'}: cannot write {self.found} to a problem file (expected a number, string, "
                         f"boolean, null, list or mapping)")


def _scalar(v: Any, where: str = "") -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if v is None:
        return "null"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if math.isnan(x):
            return ".nan"
        if math.isinf(x):
            return ".inf" if x > 0 else "-.inf"
        s = repr(x)
        if "e" in s and "." not in s.split("e")[0]:  # YAML 1.1 floats need a dot: 1e-05 -> 1.0e-05
            m, e = s.split("e")
            s = f"{m}.0e{e if e[0] in '+-' else '+' + e}"
        return s
    if isinstance(v, str):
        if _PLAIN.fullmatch(v) and v.lower() not in _YAML11_WORDS:
            return v
        return json.dumps(v, ensure_ascii=False)  # a JSON string is a YAML double-quoted scalar
    raise UnwritableValue(where, v)


def _flow(v: Any, where: str = "") -> str:
    if isinstance(v, np.ndarray):  # (a notebook's positions: arrays, as Arm and Fruit take them)
        v = v.tolist()
    if isinstance(v, dict):
        return "{" + ", ".join(f"{_scalar(k, where)}: {_flow(x, f'{where}.{k}' if where else str(k))}" for k, x in v.items()) + "}"
    if isinstance(v, (list, tuple)):
        return "[" + ", ".join(_flow(x, f"{where}[{i}]") for i, x in enumerate(v)) + "]"
    return _scalar(v, where)


def problem_dict(problem) -> dict[str, Any]:
    """A :class:`coplan.problem.model.Problem` as the mapping its file holds (every arm field
    written out: no ``defaults``), for :func:`to_yaml` -- a problem made or changed in Python saved
    as a file that reads back equal."""
    from dataclasses import asdict, fields

    arm_keys = ("name", "base", "bin", "links", "link_radius", "joint_limits", "max_velocity", "max_acceleration",
                "max_jerk", "home")
    d: dict[str, Any] = {"name": problem.name}
    if problem.description:
        d["description"] = problem.description
    d["arms"] = [{k: getattr(a, k) for k in arm_keys} for a in problem.arms]
    d["fruits"] = [{"id": f.id, "position": f.position} for f in problem.fruits]
    d["task"] = asdict(problem.task)
    if problem.gantry is not None:
        d["gantry"] = {f.name: getattr(problem.gantry, f.name) for f in fields(problem.gantry)}
    return d


def to_yaml(d, header: str | None = None) -> str:
    """Problem dict -> YAML text in the shipped files' layout (one arm or fruit per line); a
    :class:`~coplan.problem.model.Problem` too (:func:`problem_dict`).

    ``header`` becomes leading ``#`` comment lines. ``yaml.safe_load(to_yaml(d))`` gives
    ``d`` back (tuples as lists).
    """
    if not isinstance(d, dict):
        if not all(hasattr(d, k) for k in ("arms", "fruits", "task", "gantry")):
            raise TypeError(f"d: expected a problem mapping (coplan.generate's) or a Problem, found {type(d).__name__}")
        d = problem_dict(d)
    out: list[str] = [f"# {ln}".rstrip() for ln in header.splitlines()] if header else []
    for key, value in d.items():
        if isinstance(value, dict):
            out.append(f"{_scalar(key)}:")
            out += [f"  {_scalar(k, str(key))}: {_flow(v, f'{key}.{k}')}" for k, v in value.items()]
        elif isinstance(value, (list, tuple)) and value and all(isinstance(x, dict) for x in value):
            out.append(f"{_scalar(key)}:")
            out += [f"  - {_flow(x, f'{key}[{i}]')}" for i, x in enumerate(value)]
        else:
            out.append(f"{_scalar(key)}: {_flow(value, str(key))}")
    return "\n".join(out) + "\n"
