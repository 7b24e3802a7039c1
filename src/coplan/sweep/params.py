"""A sweep's parameters: what each is (:data:`PARAMETERS`), the checks of their values and
ranges (the sweep file's ``fixed`` and ``vary``), how a range expands or is drawn from, and the
generated problem a set of values makes (:func:`generate_problem`).

:mod:`coplan.sweep.spec` reads the sweep file with these.
"""

from __future__ import annotations

import difflib
import json
import math
from typing import Any

from ..errors import Issue, finite_number, found
from ..kinds import GantryMode, PlannerKind, SweepBase
from ..problem.model import MAX_ARMS
from ..problem.yamlsafe import line_of

__all__ = ["MAX_VALUES", "PARAMETERS", "TASK_KEYS", "INTEGER_KINDS", "kind_of", "draw", "step_of", "count_values",
           "values_of", "tidy", "pair", "generate_problem", "check_value", "check_option", "same_value", "range_values",
           "key_path"]

MAX_VALUES = 10_000  # values one range may expand to

# parameter -> (kind, bases it applies to, what it is)
_ROWS = (SweepBase.ROW, SweepBase.OVERLAP)
_GEN = (SweepBase.ROW, SweepBase.OVERLAP, SweepBase.RANDOM, SweepBase.CELL, SweepBase.GANTRY)
_GANTRY = (SweepBase.GANTRY,)
_ALL = tuple(SweepBase)
PARAMETERS: dict[str, tuple[str, tuple, str]] = {
    "n_arms": ("arms", _GEN, "number of arms"),
    "n_fruits": ("count0", _GEN[:4], "number of fruit (instead of density)"),
    "density": ("positive", _ROWS + _GANTRY, "fruit per metre of row"),
    "spacing": ("positive", _ROWS + _GANTRY, "distance between neighbouring bases, m"),
    "length": ("positive", _GANTRY, "length of the row the gantry travels, m"),
    "trusses": ("bool", _GANTRY, "fruit hang in trusses (default true) or uniformly"),
    "gantry": ("gantry", _GANTRY, "stop-and-go | continuous | auto (both, the better kept)"),
    "seed": ("seed", _GEN, "seed of the generator"),
    "links": ("pair", (SweepBase.ROW,), "link lengths, m (a pair, or one number for both)"),
    "link_radius": ("positive", (SweepBase.ROW,), "capsule radius of the links, m"),
    "max_velocity": ("pair", (SweepBase.ROW,), "joint velocity limits, rad/s"),
    "max_acceleration": ("pair", (SweepBase.ROW,), "joint acceleration limits, rad/s^2"),
    "max_jerk": ("pair", (SweepBase.ROW,), "joint jerk limits, rad/s^3"),
    "y_range": ("box", _ROWS, "fruit box: lowest and highest fruit, m"),
    "x_pad": ("nonneg", (SweepBase.ROW,), "fruit box: how far past the end bases fruit grow, m (default spacing/2)"),
    "zone_halfwidth": ("positive", (SweepBase.OVERLAP,), "half width of the shared zones, m"),
    "bin_offset": ("number", _ROWS, "the bin's height relative to its base, m (signed: the default -0.5 is half a metre below; a positive value puts the bin above the base, among the fruit)"),
    "reachable_only": ("bool", (SweepBase.ROW,), "redraw fruit no arm can reach (default true)"),
    "pick_dwell": ("nonneg", _ROWS + _GANTRY, "dwell at each fruit, s"),
    "place_dwell": ("nonneg", _ROWS + _GANTRY, "dwell at the bin, s"),
    "clearance": ("positive", _ROWS + _GANTRY, "required clearance between links, m"),
    "planner": ("planner", _ALL, "heuristic | coordinated | optimal"),
}
TASK_KEYS = ("pick_dwell", "place_dwell", "clearance")
INTEGER_KINDS = ("count0", "count1", "arms", "seed")  # kinds of whole numbers (arms: 1 to MAX_ARMS; seed: to MAX_SEED)

#: the largest seed a generator takes (NumPy's): a larger one passed the spec's check and failed row by row
MAX_SEED = 2**32 - 1


def kind_of(name: str) -> str:
    return "option" if name.startswith("options.") else PARAMETERS[name][0]


def draw(rng, values: list | dict, kind: str):
    if isinstance(values, list):
        return values[int(rng.integers(0, len(values)))]
    lo, hi, step = values["from"], values["to"], values.get("step")
    if step is not None:
        return tidy(lo + step * int(rng.integers(0, count_values(values, kind))), kind)
    if kind in INTEGER_KINDS or (kind == "option" and isinstance(lo, int) and isinstance(hi, int)):
        return int(rng.integers(lo, hi + 1))
    return round(float(rng.uniform(lo, hi)), 6)


def step_of(v: dict, kind: str):
    """A range's step: its own, 1 for a range of whole numbers, else None."""
    lo, hi, step = v["from"], v["to"], v.get("step")
    if step is None and (kind in INTEGER_KINDS or (kind == "option" and isinstance(lo, int) and isinstance(hi, int))):
        step = 1
    return step


def count_values(v: list | dict, kind: str) -> int | None:
    """How many values a list or a range holds (None: a range of real numbers without a step)."""
    if isinstance(v, list):
        return len(v)
    step = step_of(v, kind)
    return None if step is None else int(math.floor((v["to"] - v["from"]) / step + 1e-9)) + 1


def values_of(v: list | dict, kind: str) -> list | None:
    """The values a list or a range (random mode's ``{from, to[, step]}``) holds, None for a
    range of real numbers without a step (integers: every one between)."""
    if isinstance(v, list):
        return v
    step = step_of(v, kind)
    if step is None:
        return None
    return [tidy(v["from"] + i * step, kind) for i in range(count_values(v, kind))]


def tidy(x: float, kind: str):
    if kind in INTEGER_KINDS:
        return int(round(x))
    x = round(float(x), 9)
    return int(x) if kind == "option" and x.is_integer() else x


def pair(v) -> tuple[float, float]:
    return (float(v), float(v)) if isinstance(v, (int, float)) else (float(v[0]), float(v[1]))


def generate_problem(base: SweepBase, p: dict[str, Any]) -> tuple[str, float | None, str]:
    """(problem YAML, row length in m or None, source description) for one parameter set."""
    from ..problem import generate as gen

    task = dict(gen.LESSON_TASK, **{k: float(p[k]) for k in TASK_KEYS if k in p})
    if base in (SweepBase.RANDOM, SweepBase.CELL):
        fn = gen.random_problem if base == SweepBase.RANDOM else gen.cell_problem
        d = fn(int(p.get("seed", 0)), n_arms=p.get("n_arms"), n_fruits=p.get("n_fruits"))
        return gen.to_yaml(d), None, f"{fn.__name__}(seed={int(p.get('seed', 0))})"
    n_arms, spacing, seed = int(p.get("n_arms", 3)), float(p.get("spacing", 2.0)), int(p.get("seed", 0))
    if base == SweepBase.GANTRY:
        length = float(p.get("length", 20.0))
        d = gen.gantry_row(length=length, n_arms=n_arms, density=float(p.get("density", 6.0)), seed=seed, spacing=spacing,
                           trusses=bool(p.get("trusses", True)))
        d["task"] = dict(d["task"], **{k: float(p[k]) for k in TASK_KEYS if k in p})
        return gen.to_yaml(d), round(length, 6), "gantry_row"
    if base == SweepBase.ROW:
        x_pad = float(p.get("x_pad", spacing / 2.0))
        length = (n_arms - 1) * spacing + 2.0 * x_pad
    else:
        length = n_arms * spacing
    n_fruits = int(p["n_fruits"]) if "n_fruits" in p else int(round(float(p.get("density", 1.0)) * length))
    kw: dict[str, Any] = {}
    if "y_range" in p:
        kw["y_range"] = pair(p["y_range"])
    if "bin_offset" in p:
        kw["bin_offset"] = float(p["bin_offset"])
    name = f"{base.value}-{n_arms}arms-{spacing:g}m-{n_fruits}fruit-seed{seed}"
    if base == SweepBase.ROW:
        for k in ("links", "max_velocity", "max_acceleration", "max_jerk"):
            if k in p:
                kw[k] = pair(p[k])
        if "link_radius" in p:
            kw["link_radius"] = float(p["link_radius"])
        links = kw.get("links", (1.0, 0.8))
        y_lo = kw.get("y_range", (0.5, 1.8))[0]
        reachable_only = bool(p.get("reachable_only", True))
        if reachable_only and y_lo >= links[0] + links[1] - 0.02:
            raise ValueError(f"no fruit box point is within reach: y_range starts at {y_lo:g} m, reach {links[0] + links[1]:g} m")
        d = gen.row_problem(n_arms, n_fruits, spacing=spacing, seed=seed, x_pad=x_pad, reachable_only=reachable_only,
                            task=task, name=name, **kw)
    else:
        if "zone_halfwidth" in p:
            kw["zone_halfwidth"] = float(p["zone_halfwidth"])
        d = gen.overlap_problem(n_arms, n_fruits, spacing=spacing, seed=seed, name=name, **kw)
        d["task"] = task
    return gen.to_yaml(d), round(length, 6), f"{base.value}_problem"


# ---------------------------------------------------------------------- validation
def check_value(kind: str, v: Any) -> str | None:
    """Why ``v`` is not a good value of a parameter of ``kind`` (None when it is)."""
    if kind in INTEGER_KINDS:
        low, high = {"count0": (0, math.inf), "seed": (0, MAX_SEED), "arms": (1, MAX_ARMS)}.get(kind, (1, math.inf))
        ok = finite_number(v) and float(v).is_integer() and low <= v <= high
        why = "what a generator's seed may be" if kind == "seed" else "what a problem may have"
        return None if ok else (f"expected an integer >= {low}" + (f" and <= {high} ({why})" if high < math.inf else "")
                                + f", found {found(v)}")
    if kind == "positive":
        return None if finite_number(v) and v > 0 else f"expected a positive number, found {found(v)}"
    if kind == "nonneg":
        return None if finite_number(v) and v >= 0 else f"expected a non-negative number, found {found(v)}"
    if kind == "number":
        return None if finite_number(v) else f"expected a number, found {found(v)}"
    if kind == "bool":
        return None if isinstance(v, bool) else f"expected true or false, found {found(v)}"
    if kind in ("gantry", "planner"):
        names = [m.value for m in (GantryMode if kind == "gantry" else PlannerKind)]
        if isinstance(v, str) and v in names:
            return None
        # (a mis-spelt key got a 'did you mean', a mis-spelt value -- gantry: [continous] -- none)
        near = difflib.get_close_matches(v, names, n=1, cutoff=0.6) if isinstance(v, str) else []
        return f"expected one of {', '.join(names)}, found {found(v)}" + (f"; did you mean {near[0]!r}?" if near else "")
    if kind == "pair":
        if finite_number(v) and v > 0:
            return None
        ok = isinstance(v, list) and len(v) == 2 and all(finite_number(x) and x > 0 for x in v)
        shown = f"[{', '.join(found(x) for x in v)}]" if isinstance(v, list) and len(v) == 2 else found(v, list_length=True)
        return None if ok else f"expected a positive number or a pair of them [a, b], found {shown}"
    if kind == "box":
        ok = isinstance(v, list) and len(v) == 2 and all(finite_number(x) for x in v) and v[0] < v[1]
        return None if ok else f"expected a pair [low, high] with low < high, found {found(v) if not isinstance(v, list) else v}"
    return None


def check_option(name: str, v: Any) -> str | None:
    """Validate one solver option value with coplan.planners.optimal.options (the same checks as --options)."""
    import yaml

    from ..planners.optimal.options import OptionsError, parse_options

    if name == "time_limit":  # (accepted, shown in the row, and replaced by the sweep's own: the same plan twice)
        return ("expected the sweep file's own time_limit key (top level: each problem's clock limit, which a sweep "
                f"gives its solver), found time_limit among the solver options ({found(v)})")
    if name == "workers" and v != 1:  # a sweep's parallelism is its Dask workers, one process per problem
        return f"expected 1 (a sweep runs each problem in one process; its Dask workers are the parallelism), found {found(v)}"
    try:
        parse_options(yaml.safe_dump({name: v}))
    except OptionsError as e:
        return "; ".join(i.message for i in e.issues)
    return None


def same_value(a, b) -> bool:
    """Two values of a list that make the same problems: equal numbers however written (2 and 2.0), else equal as JSON."""
    if finite_number(a) and finite_number(b):
        return float(a) == float(b)
    if isinstance(a, (list, tuple)) and isinstance(b, (list, tuple)):  # ([0.5, 1] and [0.5, 1.0])
        return len(a) == len(b) and all(same_value(x, y) for x, y in zip(a, b))
    if isinstance(a, dict) and isinstance(b, dict):
        return a.keys() == b.keys() and all(same_value(a[k], b[k]) for k in a)
    return json.dumps(a, sort_keys=True, default=str) == json.dumps(b, sort_keys=True, default=str)


def range_values(r: dict, kind: str, loc: tuple, lines: dict, issues: list, keep_range: bool, name: str = "") -> list | dict | None:
    where = line_of(lines, loc)
    path = key_path(loc)
    extra = set(r) - {"from", "to", "step", "count"}
    if extra:
        issues.append(Issue(path, f"expected a range {{from, to, step or count}}, found unknown key {sorted(extra)[0]!r}", where))
        return None
    if "from" not in r or "to" not in r:
        issues.append(Issue(path, "expected a range with both 'from' and 'to'", where))
        return None
    lo, hi, step, count = r["from"], r["to"], r.get("step"), r.get("count")
    if not (finite_number(lo) and finite_number(hi)) or lo > hi:
        issues.append(Issue(path, f"expected numbers with from <= to, found from {found(lo)}, to {found(hi)}", where))
        return None
    if step is not None and count is not None:
        issues.append(Issue(path, "expected either 'step' or 'count', found both", where))
        return None
    if step is not None and not (finite_number(step) and step > 0):
        issues.append(Issue(key_path(loc + ("step",)), f"expected a positive number, found {found(step)}", line_of(lines, loc + ("step",))))
        return None
    if count is not None and not (finite_number(count) and float(count).is_integer() and count >= 1):
        issues.append(Issue(key_path(loc + ("count",)), f"expected an integer >= 1, found {found(count)}", line_of(lines, loc + ("count",))))
        return None
    integer = kind in INTEGER_KINDS
    if integer and not all(float(x).is_integer() for x in (lo, hi) + ((step,) if step is not None else ())):
        issues.append(Issue(path, f"expected whole numbers for this integer parameter, found from {lo}, to {hi}"
                                  + (f", step {step}" if step is not None else ""), where))
        return None
    if count is None and step is None:
        if keep_range and not integer:
            values = None
        elif integer or (kind == "option" and isinstance(lo, int) and isinstance(hi, int)):
            step = 1
        else:
            issues.append(Issue(path, "expected 'step' or 'count' for a range of real numbers in a grid sweep", where))
            return None
    if step is not None:
        n = int(math.floor((hi - lo) / step + 1e-9)) + 1
        last = lo + (n - 1) * step
        if abs(last - hi) > 1e-9 * max(1.0, abs(hi)) and n <= MAX_VALUES:  # ('to' was dropped without a word)
            issues.append(Issue(path, f"expected a step that divides to - from (so that 'to' is one of the values), found from {lo}, "
                                      f"to {hi}, step {step}: the last value would be {tidy(last, kind)} (use a step that fits, "
                                      f"or 'count' for evenly spaced values)", where))
            return None
        if n > MAX_VALUES:
            issues.append(Issue(path, f"expected at most {MAX_VALUES} values, found a range of {n}", where))
            return None
        values = [tidy(lo + i * step, kind) for i in range(n)]
    elif count is not None:
        n = int(count)
        if n == 1 and hi != lo:  # (it kept 'from' alone and dropped 'to' without a word)
            issues.append(Issue(path, f"expected a count of at least 2 for a range from {lo} to {hi} (count 1 would keep "
                                      f"{lo} alone), or from equal to to", where))
            return None
        if n > MAX_VALUES:
            issues.append(Issue(path, f"expected at most {MAX_VALUES} values, found count {n}", where))
            return None
        exact = [lo + (hi - lo) * i / (n - 1) if n > 1 else lo for i in range(n)]
        if kind in INTEGER_KINDS and any(abs(x - round(x)) > 1e-9 for x in exact):  # (n_arms 2 to 3, count 5: 2 problems, silently)
            issues.append(Issue(path, f"expected a count that gives whole numbers for this integer parameter, found from "
                                      f"{lo}, to {hi}, count {n} (values {', '.join(f'{x:g}' for x in exact[:4])}"
                                      f"{' ...' if n > 4 else ''}): use a step, or count {int(hi - lo) + 1}", where))
            return None
        values = [tidy(x, kind) for x in exact]
    def why(x):  # (a solver option's values as an options file's: h_target 1e-9 came through a range)
        return check_option(name.removeprefix("options."), x) if kind == "option" else check_value(kind, x)

    bad = [x for x in (values or [lo, hi]) if why(x)]
    if bad:  # (the end the user wrote that leaves the allowed values: it said "found number 65" for to: 1000)
        ends = [(k, v) for k, v in (("from", lo), ("to", hi)) if why(v)]
        said = f"{why(bad[0]).split(', found')[0]}, found {ends[0][0]}: {ends[0][1]:g}" if ends and ", found" in why(bad[0]) \
            and isinstance(ends[0][1], (int, float)) else why(bad[0])
        issues.append(Issue(path, f"range: {said}", where))
        return None
    if keep_range and count is None:  # (random mode draws from it; a range with a count is its values)
        return {"from": lo, "to": hi, **({"step": step} if step is not None else {})}
    return values


def key_path(loc) -> str:
    out = ""
    for part in loc:
        out += f"[{part}]" if isinstance(part, int) else ("." if out else "") + str(part)
    return out
