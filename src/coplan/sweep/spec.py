"""The sweep file: what to solve, validated like problem files, and its expansion into problems.

A sweep file (YAML)::

    name: spacing-arms-density
    base: row                 # row | overlap | random | cell | files | gantry
    fixed:                    # parameters every problem gets
      links: [1.0, 0.8]
    vary:                     # parameters to vary: a list of values or a range
      spacing: {from: 1.2, to: 2.6, step: 0.2}
      n_arms: [2, 3, 4, 5]
      density: [0.8, 1.2, 1.6]          # fruit per metre of row
      seed: {from: 0, to: 4}
      options.search_work: [5000, 20000]  # any solver option, as options.<name>
    mode: grid                # grid (every combination) | random (``samples`` distinct problems drawn, seeded;
                              #   the whole grid when it holds no more)
    planner: optimal          # heuristic | coordinated | optimal (can be varied too; default optimal,
                              #   base gantry, or a row file of base files: coordinated, each stop's
                              #   cell planner, as coplan solve ROW)
    options: {polish: false}  # solver options (coplan.optimal.OptimalOptions fields)
    time_limit: 60            # per problem, s (the planner's clock limit; a hard stop later)
    retries: 2                # extra attempts when a worker process dies

``base: files`` takes ``problems:`` -- a file, a folder or a glob (or a list of them),
relative to the sweep file. Every mistake is reported at once as ``file:line: key.path:
expected X, found Y`` (:class:`SweepError`); a generated problem that turns out invalid is not
a sweep-file error but a row with exit class "bad input".
"""

from __future__ import annotations

import glob
import hashlib
import itertools
import json
import math
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import InputError, Issue, ProblemError, coplan_file_kind, found
from ..kinds import GantryMode, PlannerKind, SweepBase, SweepMode
from ..problem.yamlsafe import MAX_FILE_BYTES, line_of, read_input_text, read_yaml
from .params import (PARAMETERS, check_option, check_value, count_values, draw, generate_problem, key_path, kind_of,
                     range_values, same_value, values_of)

__all__ = ["SweepError", "SweepItem", "SweepSpec", "load_sweep", "parse_sweep", "is_row_text", "PARAMETERS", "TOP_KEYS", "MAX_ITEMS"]

MAX_ITEMS = 200_000  # problems one sweep may expand to


class SweepError(InputError):
    kind = "sweep"


TOP_KEYS = {"name", "description", "base", "problems", "fixed", "vary", "mode", "samples", "seed", "planner",
        "options", "time_limit", "retries"}


#: a problem file with a gantry section (a row): its top-level key
_ROW_FILE = re.compile(r"^gantry\s*:", re.MULTILINE)


def is_row_text(text: str | None) -> bool:
    """Whether a problem file's text is a row's (a top-level ``gantry`` key), as the sweep tells
    them apart; False for no text (a file that could not be read: its row says why)."""
    return text is not None and bool(_ROW_FILE.search(text))


@dataclass(frozen=True)
class SweepItem:
    """One problem of a sweep: the parameters that made it, its YAML text and how to solve it."""

    index: int
    key: str  # hash of problem text + planner + options + time limit
    params: dict[str, Any]
    planner: str
    options: dict[str, Any]
    time_limit: float
    source: str  # the problem file, or the generator that made the problem
    problem_text: str | None = None
    row_length: float | None = None  # m of row the problem covers, when the generator knows it
    error: str | None = None  # the problem could not be made or read: a "bad input" row


@dataclass(frozen=True)
class SweepSpec:
    name: str
    base: SweepBase
    mode: SweepMode
    fixed: dict[str, Any]
    vary: dict[str, list | dict]  # lists of values, or (random mode) ranges to draw from
    planner: PlannerKind
    options: dict[str, Any]
    time_limit: float
    retries: int
    samples: int | None = None
    seed: int = 0
    problems: tuple[str, ...] = ()  # base files: the resolved problem files
    source: str | None = None
    description: str = ""
    sizes: dict[str, int] = field(default_factory=dict)
    planner_given: bool = True  # False: the default (a row file of a files sweep then takes coordinated)

    @property
    def gives_options(self) -> bool:
        """Whether the file gives solver options (``options``, or ``options.*`` fixed or varied)."""
        return bool(self.options) or any(str(k).startswith("options.") for k in {**self.fixed, **self.vary})

    def items(self, planner: PlannerKind | str | None = None, time_limit: float | None = None) -> list[SweepItem]:
        """The concrete problems (duplicates, by key, dropped); ``planner`` / ``time_limit``
        replace the file's (the command line's ``--planner`` and ``--time-limit``)."""
        if planner is not None and self.base == SweepBase.GANTRY and PlannerKind(planner) == PlannerKind.HEURISTIC:
            raise ValueError("planner: expected coordinated or optimal with base gantry (the course's heuristic plans a "
                             "stationary cell, not a row), found heuristic")
        out: list[SweepItem] = []
        seen: set[str] = set()
        limit = float(time_limit) if time_limit is not None else self.time_limit
        # random mode: ``samples`` distinct problems (a draw that repeats one is drawn again), or
        # the whole grid when it holds no more
        grid = self.grid_size() if self.mode == SweepMode.RANDOM else None
        want = (None if self.mode == SweepMode.GRID or (grid is not None and grid <= (self.samples or 0)) else
                (self.samples or 0) * max(1, len(self.problems)))
        for params in self._combinations(whole=want is None):
            if want is not None and len(out) >= want:
                break
            if planner is not None:
                params["planner"] = PlannerKind(planner).value
            for item in self._make(len(out), params, limit):
                if item.key not in seen:
                    seen.add(item.key)
                    out.append(item)
        return out

    # ------------------------------------------------------------------ expansion
    def _combinations(self, whole: bool):
        """The parameter sets, one at a time: every combination (``whole``: grid mode, or a
        random sweep whose grid is no larger than ``samples``), else seeded draws, each set once,
        up to 50 x ``samples`` draws (the caller stops at ``samples`` problems)."""
        names = list(self.vary)
        if whole:
            lists = [values_of(self.vary[n], kind_of(n)) for n in names]
            for combo in itertools.product(*lists):
                yield dict(self.fixed, **dict(zip(names, combo)))
            return
        import numpy as np

        rng = np.random.default_rng(self.seed)
        seen: set[str] = set()
        for _ in range(50 * (self.samples or 0)):
            p = dict(self.fixed)
            for n in names:
                p[n] = draw(rng, self.vary[n], kind_of(n))
            key = json.dumps(p, sort_keys=True, default=str)
            if key not in seen:  # (a repeated set would make the same problem again)
                seen.add(key)
                yield p

    def grid_size(self) -> int | None:
        """How many distinct parameter sets ``vary`` holds, counted (None: a range of real
        numbers without a step, which random mode draws from freely)."""
        n = 1
        for name, v in self.vary.items():
            k = count_values(v, kind_of(name))
            if k is None:
                return None
            n *= k
        return n

    def _make(self, index: int, params: dict[str, Any], limit: float) -> list[SweepItem]:
        given = self.planner_given or "planner" in params
        planner = str(params.pop("planner", self.planner.value))
        options = dict(self.options)
        for k in [k for k in params if k.startswith("options.")]:
            options[k.removeprefix("options.")] = params.pop(k)
        if planner == PlannerKind.HEURISTIC.value:  # (it takes no options: one row, not one per option value)
            options = {}
        elif planner == PlannerKind.COORDINATED.value:  # only those it takes (search_work made rows of the same plan)
            from ..planners.optimal.options import COORDINATED_FIELDS

            options = {k: v for k, v in options.items() if k in COORDINATED_FIELDS}
        shown = dict(params, **{f"options.{k}": v for k, v in options.items() if k not in self.options})
        if self.base == SweepBase.FILES:
            items = []
            for i, path in enumerate(self.problems):
                try:
                    text, error = read_input_text(path, ProblemError), None
                except ProblemError as e:
                    text, error = None, str(e)
                # a row file, the planner not given: each stop's cell planner is coplan solve ROW's (coordinated);
                # it takes no solver options, as coplan solve ROW takes none: one row per file, not one per
                # option value (two keys and 110 s for the same plan, the report showing an axis that did nothing)
                row = is_row_text(text)
                mine = PlannerKind.COORDINATED.value if row and not given else planner
                mine_opts = {} if row else options
                mine_shown = {k: v for k, v in shown.items() if not (row and k.startswith("options."))}
                items.append(self._item(index + i, dict(mine_shown, problem=path), mine, mine_opts,
                                        limit, path, text, None, error))
            return items
        text, row_length, error, source = None, None, None, f"{self.base.value} generator"
        try:
            text, row_length, source = generate_problem(self.base, params)
        except (ValueError, RuntimeError, TypeError) as e:  # the generator refused these values
            error = f"could not generate the problem ({', '.join(f'{k}={v}' for k, v in params.items())}): {e}"
        return [self._item(index, shown, planner, options, limit, source, text, row_length, error)]

    def _item(self, index, params, planner, options, limit, source, text, row_length, error) -> SweepItem:
        how = {"problem": text if text is not None else f"{source}|{error}", "planner": planner, "options": options,
               "time_limit": limit}
        if "gantry" in params:  # the same row stop and go or on the move: two problems to solve
            how["gantry"] = params["gantry"]
        blob = json.dumps(how, sort_keys=True, default=str)
        key = hashlib.sha256(blob.encode()).hexdigest()[:16]
        return SweepItem(index, key, params, planner, options, limit, source, text, row_length, error)


def _param_ok(name: str, base: SweepBase | None, loc: tuple, lines: dict, issues: list) -> bool:
    import difflib

    if name.startswith("options.") and base == SweepBase.GANTRY:  # (as the key 'options': the same plan solved twice)
        issues.append(Issue(key_path(loc), f"expected no solver option with base gantry: a gantry row's solve takes no cell "
                                        f"planner options, found {name!r}", line_of(lines, loc)))
        return False
    if name.startswith("options."):
        return True
    if name not in PARAMETERS:
        near = difflib.get_close_matches(name, list(PARAMETERS) + ["options.search_work"], n=1, cutoff=0.5)
        hint = f"; did you mean {near[0]!r}?" if near else f"; known: {', '.join(PARAMETERS)}, options.<name>"
        issues.append(Issue(key_path(loc), f"expected a sweep parameter, found unknown parameter {name!r}{hint}", line_of(lines, loc)))
        return False
    if base is not None and base not in PARAMETERS[name][1]:  # (a bad base: the values are still checked)
        allowed = ", ".join(b.value for b in PARAMETERS[name][1])
        issues.append(Issue(key_path(loc), f"expected a parameter of base {base.value!r}, found {name!r} ({PARAMETERS[name][2]}), "
                                        f"which only applies to base {allowed}", line_of(lines, loc)))
        return False
    return True


def _one(name: str, v: Any, loc: tuple, lines: dict, issues: list) -> bool:
    kind = kind_of(name)
    msg = check_option(name.removeprefix("options."), v) if kind == "option" else check_value(kind, v)
    if msg:
        issues.append(Issue(key_path(loc), msg, line_of(lines, loc)))
    return msg is None


def _resolve_problems(pats: Any, here: Path, lines: dict, issues: list) -> tuple[str, ...]:
    if isinstance(pats, list) and not pats:  # (a sweep of nothing: "0 problems ... nothing to do", exit 0)
        issues.append(Issue("problems", "expected a file, folder or glob (or a list of them), found an empty list",
                            line_of(lines, ("problems",))))
        return ()
    pats_list = pats if isinstance(pats, list) else [pats]
    files: list[str] = []  # (named 'found', it hid found(): 'problems: 5' was an internal error)
    for i, pat in enumerate(pats_list):
        loc = ("problems", i) if isinstance(pats, list) else ("problems",)
        if not isinstance(pat, str) or not pat:
            issues.append(Issue(key_path(loc), f"expected a file, folder or glob, found {found(pat)}", line_of(lines, loc)))
            continue
        p = Path(pat) if Path(pat).is_absolute() else here / pat
        if p.is_dir():
            named = [q for q in p.iterdir() if q.suffix in (".yaml", ".yml")]
        elif p.is_file():
            named = [p]
        else:
            named = [Path(q) for q in glob.glob(str(p), recursive=True)]
        hits = sorted(str(q) for q in named if q.is_file())
        for q in sorted(str(q) for q in named if not q.is_file() and q.suffix in (".yaml", ".yml")):
            # (it was left out without a word: "1 problem")
            issues.append(Issue(key_path(loc), f"expected problem files, found a folder named like one among them: {q}",
                                line_of(lines, loc)))
        if not hits:
            issues.append(Issue(key_path(loc), f"expected at least one problem file, found none matching {pat!r} (relative to {here})",
                                line_of(lines, loc)))
        files += [h for h in hits if h not in files]
    return tuple(files)


def parse_sweep(text: str, source: str | None = None, here: Path | None = None) -> SweepSpec:
    """Validate a sweep file's text (raises :class:`SweepError` listing every problem)."""
    data, lines = _read(text, source)
    issues: list[Issue] = []
    import difflib

    for k in data:
        if k not in TOP_KEYS:
            near = difflib.get_close_matches(str(k), sorted(TOP_KEYS), n=1, cutoff=0.5)
            hint = f"; did you mean {near[0]!r}?" if near else f"; allowed keys: {', '.join(sorted(TOP_KEYS))}"
            issues.append(Issue(str(k), f"expected a known key, found unknown key {k!r}{hint}", line_of(lines, (k,))))

    def get(key, kind, default):
        v = data.get(key, default)
        if key in data:
            msg = check_value(kind, v) if kind != "str" else (None if isinstance(v, str) and v.strip() else
                                                              f"expected a non-empty string, found {found(v)}")
            if msg:
                issues.append(Issue(key, msg, line_of(lines, (key,))))
                return default
        return v

    stem = Path(source).stem if source else "sweep"
    name = get("name", "str", stem)
    description = get("description", "str", "")
    base = SweepBase.FILES if "problems" in data and "base" not in data else None
    if "base" in data:
        b = data["base"]
        if not isinstance(b, str) or b not in {x.value for x in SweepBase}:  # (base: [row] was an internal error)
            near = difflib.get_close_matches(b, [x.value for x in SweepBase], n=1, cutoff=0.6) if isinstance(b, str) else []
            issues.append(Issue("base", f"expected one of {', '.join(x.value for x in SweepBase)}, found {found(b)}"
                                        + (f"; did you mean {near[0]!r}?" if near else ""), line_of(lines, ("base",))))
        else:
            base = SweepBase(b)
    elif base is None:
        issues.append(Issue("base", f"expected a base: one of {', '.join(x.value for x in SweepBase)} "
                                    "(or 'problems:' for problem files), found none", line_of(lines, ())))
    mode_v = data.get("mode", SweepMode.GRID.value)
    mode = SweepMode.GRID
    if not isinstance(mode_v, str) or mode_v not in {m.value for m in SweepMode}:  # (mode: [grid] likewise)
        issues.append(Issue("mode", f"expected one of {', '.join(m.value for m in SweepMode)}, found {found(mode_v)}", line_of(lines, ("mode",))))
    else:
        mode = SweepMode(mode_v)
    samples = get("samples", "count1", None)
    if mode == SweepMode.RANDOM and samples is None and "samples" not in data:
        issues.append(Issue("samples", "expected 'samples' (how many problems to draw) with mode: random", line_of(lines, ("mode",))))
    seed = int(get("seed", "count0", 0))
    if mode == SweepMode.GRID:  # (seed: 5 in a grid looked like the generators' seed and was ignored: every problem seed 0)
        for key, what in (("seed", "the seed of the draws; a generator's seed is a parameter: fixed: {seed: 5}, or varied"),
                          ("samples", "how many problems to draw")):
            if key in data:
                issues.append(Issue(key, f"expected '{key}' only with mode: random ({what}), found it in a grid sweep",
                                    line_of(lines, (key,))))
    # (a row's default cell planner is `coplan solve ROW`'s: coordinated, the stops' cells retimed;
    # the optimal planner at every stop took 18-26 s on a 6 m row of 10-13 fruit)
    planner = PlannerKind(get("planner", "planner", (PlannerKind.COORDINATED if base == SweepBase.GANTRY else
                                                     PlannerKind.OPTIMAL).value))
    time_limit = float(get("time_limit", "positive", 120.0))
    retries = int(get("retries", "count0", 2))
    problems: tuple[str, ...] = ()
    here = here if here is not None else (Path(source).parent if source else Path.cwd())
    if base == SweepBase.FILES:
        if "problems" not in data:
            issues.append(Issue("problems", "expected 'problems': a file, folder or glob (base: files)", line_of(lines, ("base",))))
        else:
            problems = _resolve_problems(data["problems"], here, lines, issues)
    elif "problems" in data and base is not None:
        issues.append(Issue("problems", f"expected no 'problems' with base {base.value!r} (they are generated)", line_of(lines, ("problems",))))
    if base == SweepBase.GANTRY and "options" in data:  # (accepted, stored and not used: 'designs' alike but in name)
        issues.append(Issue("options", "expected no 'options' with base gantry: a gantry row's solve takes no cell "
                                       "planner options (stop and go plans each stop with the planner's defaults; on "
                                       f"the move books its own moves); found {found(data['options'])}",
                            line_of(lines, ("options",))))
    options: dict[str, Any] = {}
    if "options" in data:
        if not isinstance(data["options"], dict):
            issues.append(Issue("options", f"expected a mapping of solver options, found {found(data['options'])}", line_of(lines, ("options",))))
        else:
            for k, v in data["options"].items():
                if _one(f"options.{k}", v, ("options", k), lines, issues):
                    options[str(k)] = v
    fixed, vary = _parameters(data, base, mode, options, lines, issues)
    _cross_checks(data, base, fixed, vary, lines, issues)
    sizes = {k: len(v) for k, v in vary.items() if isinstance(v, list)}
    total = math.prod(sizes.values()) if mode == SweepMode.GRID else (samples or 0)
    if base == SweepBase.FILES:
        total *= max(1, len(problems))
    if total > MAX_ITEMS and mode == SweepMode.RANDOM and base != SweepBase.FILES:
        issues.append(Issue("samples", f"expected at most {MAX_ITEMS} problems, found samples: {samples}", line_of(lines, ("samples",))))
    elif total > MAX_ITEMS:
        issues.append(Issue("vary", f"expected at most {MAX_ITEMS} problems, found {total}"
                                    + (" combinations" if mode == SweepMode.GRID else " (samples x problem files)"), line_of(lines, ("vary",))))
    if issues:
        raise SweepError(sorted(issues, key=lambda i: -1 if i.line is None else i.line), source)
    return SweepSpec(name=str(name), base=base, mode=mode, fixed=fixed, vary=vary, planner=planner, options=options,
                     time_limit=time_limit, retries=retries, samples=samples, seed=seed, problems=problems,
                     source=source, description=str(description or ""), sizes=sizes, planner_given="planner" in data)


def _read(text: str, source: str | None) -> tuple[dict, Any]:
    """The sweep file's mapping and its line table; raises :class:`SweepError` at once for text
    too large, YAML that does not parse, a value that is not a mapping, or another kind of file
    (a coplan plan, feed, run ... file; a problem file)."""
    n = len(text.encode("utf-8", errors="replace"))
    if n > MAX_FILE_BYTES:
        raise SweepError([Issue("", f"expected at most {MAX_FILE_BYTES} bytes of YAML, found {n} bytes")], source)
    try:
        data, lines = read_yaml(text, source, expected="a mapping with keys base, vary, planner, ...")
    except ProblemError as e:
        raise SweepError(e.issues, source) from None
    if not isinstance(data, dict):
        raise SweepError([Issue("", f"expected a mapping with keys base, vary, planner, ...; found {found(data)}", line_of(lines, ()))],
                         source)
    kind = coplan_file_kind(data)
    if kind is not None:  # a plan, feed, run ... file: fourteen unknown keys were listed
        raise SweepError([Issue("", f"expected a sweep file (keys base, vary, planner, ...), found a coplan {kind} file "
                                    f"(format {data.get('format')!r}); were the arguments swapped?", line_of(lines, ("format",)))], source)
    if {"arms", "fruits"} <= set(data) and not set(data) & {"base", "vary", "problems"}:  # (six unknown keys were listed)
        raise SweepError([Issue("", "expected a sweep file (keys base, vary, planner, ...), found a problem file (arms, "
                                    "fruits, task); to solve problem files as a sweep give their folder or a glob "
                                    "(coplan sweep 'problems/*.yaml'), or a sweep file with 'problems:'", 1)], source)
    return data, lines


def _parameters(data: dict, base: SweepBase | None, mode: SweepMode, options: dict, lines, issues: list[Issue]) -> tuple[dict, dict]:
    """The ``fixed`` and ``vary`` sections, each parameter checked for ``base`` (issues to
    ``issues``); returns the usable ``fixed`` and ``vary``."""
    fixed: dict[str, Any] = {}
    vary: dict[str, list | dict] = {}
    for section in ("fixed", "vary"):
        sec = data.get(section, {})
        if sec is None or not isinstance(sec, dict):
            issues.append(Issue(section, f"expected a mapping of parameter names to values, found {found(sec)}", line_of(lines, (section,))))
            continue
        if section == "vary" and "vary" in data and not sec:  # (as `vary:` left empty: refused alike)
            issues.append(Issue(section, "expected a mapping of parameter names to values (at least one to vary), "
                                         "found an empty mapping", line_of(lines, (section,))))
            continue
        for k, v in sec.items():
            k = str(k)
            loc = (section, k)
            if not _param_ok(k, base, loc, lines, issues):  # (with a bad base too: its errors hid every other)
                continue
            if k.startswith("options.") and k.removeprefix("options.") in options:  # (one of the two won without a word)
                issues.append(Issue(key_path(loc), f"expected each option once, found {k.removeprefix('options.')!r} both "
                                                   f"in options and {'fixed' if section == 'fixed' else 'varied'} as {k!r}",
                                    line_of(lines, loc)))
            if section == "fixed":
                if _one(k, v, loc, lines, issues):
                    fixed[k] = v
                continue
            if isinstance(v, dict):
                vals = range_values(v, kind_of(k), loc, lines, issues, keep_range=mode == SweepMode.RANDOM, name=k)
                if vals is not None:
                    vary[k] = vals
            elif isinstance(v, list) and v:
                unknown = kind_of(k) == "option" and (check_option(k.removeprefix("options."), v[0]) or "").startswith(
                    "expected a known option")
                if unknown:  # (said once, not once per value)
                    _one(k, v[0], loc, lines, issues)
                elif all([_one(k, x, loc + (i,), lines, issues) for i, x in enumerate(v)]):  # (every bad value said)
                    again = next((i for i, x in enumerate(v) if any(same_value(x, y) for y in v[:i])), None)
                    if again is not None:  # (seed: [0, 0] made one problem of two, silently)
                        issues.append(Issue(key_path(loc + (again,)), f"expected distinct values, found {found(v[again])} again "
                                                                   f"(the same value makes the same problems again, which the sweep runs once)",
                                            line_of(lines, loc + (again,))))
                    else:
                        vary[k] = list(v)
            else:
                issues.append(Issue(key_path(loc), f"expected a non-empty list of values or a range {{from, to, step}}, found {found(v)}",
                                    line_of(lines, loc)))
            if k in fixed:
                issues.append(Issue(key_path(loc), f"expected each parameter once, found {k!r} both fixed and varied", line_of(lines, loc)))
    return fixed, vary


def _cross_checks(data: dict, base: SweepBase | None, fixed: dict, vary: dict, lines, issues: list[Issue]) -> None:
    """What the parameters mean together: the planners used against the base and the options,
    n_fruits with density, one arm in an overlap sweep."""
    # the planners that are used: varied, else fixed, else the key's (with where each is given)
    planners = ([(("vary", "planner", i), x) for i, x in enumerate(vary["planner"])] if isinstance(vary.get("planner"), list)
                else [(("fixed", "planner"), fixed["planner"])] if "planner" in fixed else [(("planner",), data.get("planner"))])
    modes = vary.get("gantry") or [fixed.get("gantry", GantryMode.STOP_AND_GO.value)]
    if base == SweepBase.GANTRY and modes != [GantryMode.CONTINUOUS.value] * len(modes):
        # the course's heuristic plans a stationary cell only (every row was an 'internal error'; a
        # row on the move uses no planner)
        for loc, v in planners:
            if v == PlannerKind.HEURISTIC.value:
                issues.append(Issue(key_path(loc), "expected coordinated or optimal with base gantry (each stop's cell planner; "
                                                 "the course's heuristic plans a stationary cell, not a row), found heuristic",
                                    line_of(lines, loc)))
    if planners and all(v == PlannerKind.HEURISTIC.value for _, v in planners):
        # (as coplan solve --planner heuristic --options: each option value solved the same plan again)
        given = [("options",)] if "options" in data else []
        given += [(sec, k) for sec, d in (("fixed", fixed), ("vary", vary)) for k in d if str(k).startswith("options.")]
        for loc in given:
            issues.append(Issue(key_path(loc), "expected no solver options with planner heuristic (the course's heuristic "
                                               "plans in one pass and takes none: each value would solve the same plan "
                                               f"again), found {loc[-1]!r}", line_of(lines, loc)))
    both = {"n_fruits", "density"} & (set(fixed) | set(vary))
    if len(both) == 2:
        issues.append(Issue("vary" if "density" in vary else "fixed", "expected either n_fruits or density, found both",
                            line_of(lines, ("vary" if "density" in vary else "fixed", "density"))))
    arm_counts = vary.get("n_arms", [fixed.get("n_arms")])
    if base == SweepBase.OVERLAP and (1 in arm_counts if isinstance(arm_counts, list) else arm_counts["from"] < 2):
        sec = "vary" if "n_arms" in vary else "fixed"
        issues.append(Issue(f"{sec}.n_arms", "expected at least 2 arms for base overlap, found 1", line_of(lines, (sec, "n_arms"))))


def load_sweep(path: str | Path) -> SweepSpec:
    """Load and validate a sweep file (raises :class:`SweepError`, never a bare traceback).

    A folder of problem files, or a glob of them (``'problems/*.yaml'``), is a sweep too: every
    file solved with the default planner and time limit."""
    p = Path(path)
    if p.is_dir() or (not p.exists() and glob.has_magic(str(path))):
        name = (p if p.is_dir() else p.parent).resolve().name or "problems"
        try:
            return parse_sweep(f"name: {json.dumps(name)}\nproblems: {json.dumps(str(path))}\n", str(path), Path.cwd())
        except SweepError as e:  # no file of its own: no line numbers
            raise SweepError([Issue("", i.message) for i in e.issues], str(path)) from None
    return parse_sweep(read_input_text(p, SweepError), str(p), p.parent)
