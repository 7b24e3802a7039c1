"""Solver options from a YAML file (``coplan solve --options FILE``), validated like problem files.

Every field of :class:`coplan.optimal.OptimalOptions` may be set; keys left out keep their
defaults. The coordinated planner takes its margin, budget (``coordination_checks``) and time
limit from the same file. ``ipopt`` is a mapping of IPOPT settings passed through to CasADi
(e.g. ``ipopt.max_iter: 500``). Example::

    search_work: 60000        # more search than the default
    search_temperature: 0.5
    polish: false
    ipopt: {ipopt.tol: 1.0e-7}

Bad values raise :class:`OptionsError` naming the file, line and key, what was expected and what
was found ("did you mean" for a misspelt key) -- never a traceback.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import fields, replace
from pathlib import Path
from typing import Any

from .errors import InputError, Issue, ProblemError, found
from .optimal import OptimalOptions
from .yamlsafe import MAX_FILE_BYTES, line_of, read_input_text, read_yaml

__all__ = ["OptionsError", "load_options", "parse_options"]

# fields that must be > 0 (the others of their type must be >= 0)
_POSITIVE = {"h_target", "window", "check_rate", "time_limit", "window_time_limit"}


class OptionsError(InputError):
    kind = "options"


def _check(name: str, kind: str, v: Any) -> str | None:
    """The message for a bad value of field ``name`` (type ``kind``), or None if it is good."""
    low = 0 if name not in _POSITIVE else None
    bound = "a positive" if low is None else "a non-negative"
    if kind == "bool":
        return None if isinstance(v, bool) else f"expected true or false, found {found(v)}"
    if kind == "dict":
        if not isinstance(v, dict):
            return f"expected a mapping of IPOPT settings (e.g. ipopt.max_iter: 500), found {found(v)}"
        for k, x in v.items():
            if not isinstance(k, str) or isinstance(x, (dict, list)) or x is None:
                return f"expected setting: number or string, found {k!r}: {found(x)}"
        return None
    nullable = kind.endswith("| None")
    if nullable and v is None:
        return None
    want = f"expected {bound} {'integer' if kind == 'int' else 'number'}{' or null' if nullable else ''}"
    if isinstance(v, bool) or not isinstance(v, (int, float)):
        return f"{want}, found {found(v)}"
    if (kind == "int" and not float(v).is_integer()) or not math.isfinite(v) or v < 0 or (low is None and v <= 0):
        return f"{want}, found {found(v)}"
    return None


def parse_options(text: str, source: str | None = None, base: OptimalOptions | None = None) -> OptimalOptions:
    """Options from YAML text (the keys given replace ``base``'s, default the defaults)."""
    n = len(text.encode("utf-8", errors="replace"))
    if n > MAX_FILE_BYTES:
        raise OptionsError([Issue("", f"expected at most {MAX_FILE_BYTES} bytes of YAML, found {n} bytes")], source)
    if all(not ln.strip() or ln.lstrip().startswith("#") for ln in text.splitlines()):
        return base or OptimalOptions()  # nothing but comments: the defaults
    try:
        data, lines = read_yaml(text, source)
    except ProblemError as e:  # the YAML itself: the same checks as for problem files
        raise OptionsError(e.issues, source) from None
    if not isinstance(data, dict):
        raise OptionsError([Issue("", f"expected a mapping of option names to values, found {found(data)}", line_of(lines, ()))],
                           source)
    kinds = {f.name: str(f.type) for f in fields(OptimalOptions)}
    issues, values = [], {}
    for key, v in data.items():
        if key not in kinds:
            near = difflib.get_close_matches(str(key), list(kinds), n=1, cutoff=0.5)
            hint = f"; did you mean {near[0]!r}?" if near else f"; allowed keys: {', '.join(kinds)}"
            issues.append(Issue(str(key), f"expected a known option, found unknown key {key!r}{hint}", line_of(lines, (key,))))
            continue
        msg = _check(key, kinds[key], v)
        if msg is not None:
            issues.append(Issue(str(key), msg, line_of(lines, (key,))))
            continue
        values[key] = (int(v) if kinds[key] == "int" else float(v) if kinds[key].startswith("float") and v is not None
                       else dict(v) if kinds[key] == "dict" else v)
    if issues:
        raise OptionsError(issues, source)
    return replace(base or OptimalOptions(), **values)


def load_options(path: str | Path, base: OptimalOptions | None = None) -> OptimalOptions:
    """Load and validate an options file (raises :class:`OptionsError`)."""
    return parse_options(read_input_text(path, OptionsError), str(Path(path)), base)
