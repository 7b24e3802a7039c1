"""Error types shared by every stage. User-facing errors carry every issue found."""

from __future__ import annotations

import dataclasses
import difflib
import enum
import functools
import math
import numbers
import re
from dataclasses import dataclass

__all__ = ["special_file", "Issue", "InputError", "ProblemError", "PlanFileError", "OptionsError", "CoplanError", "printable", "plural",
           "found", "finite_number", "field_issue", "plain_scalars", "check_fields", "known_fields"]


class CoplanError(Exception):
    """Base class of coplan's own errors."""


@dataclass(frozen=True)
class Issue:
    """One problem in an input: where (key path, line), what was expected and found."""

    path: str
    message: str
    line: int | None = None

    def format(self, source: str | None) -> str:
        where = source or "<input>"
        if self.line is not None:
            where = f"{where}:{self.line}"
        return f"{where}: {self.path or '<top>'}: {self.message}"


class InputError(CoplanError, ValueError):
    """A bad input file; ``issues`` holds every problem found, ``source`` the file.

    The message lists every issue, one per line (at most ``MAX_SHOWN``; ``issues`` always
    holds them all).
    """

    kind = "input"
    MAX_SHOWN = 200
    #: the file could not be read (permissions, a device error), not its contents: the CLI's exit
    #: 8 (io_error), as for a plan file (an unreadable problem file exited 3, "fix its contents")
    unreadable = False

    def __init__(self, issues: list[Issue], source: str | None = None):
        self.issues = list(issues)
        self.source = source
        n = len(self.issues)
        head = f"{source or '<input>'}: {n} problem{'s' if n != 1 else ''} found"
        shown = ["  " + i.format(source) for i in self.issues[: self.MAX_SHOWN]]
        if n > self.MAX_SHOWN:
            shown.append(f"  ... and {n - self.MAX_SHOWN} more")
        super().__init__(head + "\n" + "\n".join(shown))

    def __reduce__(self):
        # (pickled or copied -- a worker process's error handed back, copy.copy -- it was rebuilt
        # from its message alone, each character an issue: "<input>: 200 problems found  c  r  o ...")
        return type(self), (self.issues, self.source), self.__dict__


class ProblemError(InputError):
    kind = "problem"


class PlanFileError(InputError):
    kind = "plan"


class OptionsError(InputError):
    """Bad solver options: from an options file (its path, lines), or built in Python (the class)."""

    kind = "options"


def plural(n: int, word: str, many: str | None = None) -> str:
    """``n`` and ``word`` agreeing in number: ``plural(1, "arm") == "1 arm"``, ``plural(3, "arm") == "3 arms"``."""
    return f"{n} {word if n == 1 else (many or word + 's')}"


def printable(text) -> str:
    """Untrusted text (a name, id or message from an input file) with every control character
    (escape sequences included) shown as its ``\\x..`` code, so it cannot drive a terminal."""
    return "".join(c if c.isprintable() else repr(c)[1:-1] for c in str(text))


def found(v, list_length: bool = False) -> str:
    """How a message names a value it found in a YAML file: ``null``, ``boolean true``,
    ``number 3``, ``string 'x'``, ``a mapping``, ``a list`` (``a list of 3`` with ``list_length``)."""
    if v is None:
        return "null"
    if isinstance(v, bool):
        return f"boolean {v}"
    if isinstance(v, (int, float)):
        return f"number {v}"
    if isinstance(v, str):
        return f"string {v!r}"
    if isinstance(v, dict):
        return "an empty mapping" if not v else "a mapping"
    if isinstance(v, list):
        return "an empty list" if not v else f"a list of {len(v)}" if list_length else "a list"
    return type(v).__name__


def finite_number(v) -> bool:
    """Whether a value read from YAML is a finite int or float (not a boolean)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)


#: The most a planner's ``margin`` (m, a planning buffer beyond ``task.clearance``) may be: more
#: leaves neighbouring arms (bases 1-2 m apart, links of about a metre) no room to work, and the
#: planners then spend their whole budget finding that out.
MAX_MARGIN = 0.5


#: The most the optimal planner's ``tolerance`` may be, s: one sample at 100 Hz. A makespan within
#: it of the lower bound is called proven optimal; a wider one would call a plan optimal that
#: is not (a trial's ``tolerance: 10`` called 6.50 s against a 5.66 s bound proven).
MAX_TOLERANCE = 0.01


#: the largest whole-number option (work budgets, iterations, counts; not a seed): 1e9 conflict
#: checks of the search are days of one core
MAX_COUNT = 1_000_000_000

#: options whose plausible range is narrower than their sign (``h_target`` 1e-9 s built billions
#: of knots: 23 GB of memory before any check could skip the stage)
OPTION_RANGES = {
    "h_target": (0.005, 1.0, "a knot spacing of the NLP's grid, s,"),
    "check_rate": (100.0, 100_000.0, "a rate of the planner's dense clearance check, Hz,"),
}


def field_issue(name: str, kind: str, v, positive: bool) -> str | None:
    """The message for a bad value ``v`` of an options field ``name`` annotated ``kind``
    (``int``, ``float``, ``bool``, ``dict``, ``... | None``; others are not judged here), or None
    if it is good: a finite number, an integer where ``int``, > 0 where ``positive``, else >= 0;
    a ``margin`` at most :data:`MAX_MARGIN`, a ``tolerance`` at most :data:`MAX_TOLERANCE`."""
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
    base = kind.removesuffix("| None").strip()
    if base not in ("int", "float"):
        return None
    if nullable and v is None:
        return None
    want = f"expected {'a positive' if positive else 'a non-negative'} {'integer' if base == 'int' else 'number'}" \
           f"{' or null' if nullable else ''}"
    if isinstance(v, bool) or not isinstance(v, numbers.Real):
        return f"{want}, found {found(v)}"
    x = float(v)
    if math.isinf(x):  # (.inf as written, or from Python: a number written beyond a float's range, 1e400, is
        # refused as written when the file is read -- coplan.problem.yamlsafe -- not read as inf)
        return f"{want}, found number {x} (not finite)"
    if (base == "int" and not x.is_integer()) or not math.isfinite(x) or x < 0 or (positive and x <= 0):
        return f"{want}, found {found(x if base == 'float' else v)}"
    if name == "margin" and x > MAX_MARGIN:  # (every planner's margin, from a file or from Python)
        return (f"expected a planning margin of at most {MAX_MARGIN:g} m beyond task.clearance (more leaves neighbouring "
                f"arms no room to work), found {v!r}")
    if base == "int" and name not in ("seed",) and x > MAX_COUNT:  # (search_work: 1e30 was taken as 10^30 checks)
        return (f"expected an integer of at most {MAX_COUNT:,} (a budget or count that large never ends: "
                f"a typo in the exponent?), found {found(v)}")
    if base == "int" and isinstance(v, float) and abs(v) > 2.0 ** 53:  # (seed: 1e40 was kept as 1000...0752)
        return (f"{want}, found number {v!r}: a number with an exponent is not exact beyond 2^53 (about 9e15); "
                "write the integer out in full")
    if name in OPTION_RANGES and not OPTION_RANGES[name][0] <= x <= OPTION_RANGES[name][1]:
        lo, hi, what = OPTION_RANGES[name]
        return f"expected {what} within [{lo:g}, {hi:g}], found {v!r}"
    if name == "tolerance" and x > MAX_TOLERANCE:
        return (f"expected a tolerance of at most {MAX_TOLERANCE:g} s (one sample: a makespan further from the lower bound "
                f"is not proven optimal), found {v!r}")
    return None


def plain_scalars(obj) -> None:
    """Each field of the frozen options dataclass ``obj`` that holds a NumPy scalar set to the
    Python value it holds (``numpy.bool_`` was refused: "expected true or false, found bool"; an
    ``int64`` was kept, no JSON value). Called first in an options class's checks (its own range
    checks too: ``LiveOptions(max_open=np.int64(40))`` was refused, a ``float32`` gate skipped)."""
    for f in dataclasses.fields(obj):
        v = getattr(obj, f.name)
        if type(v).__module__ == "numpy" and hasattr(v, "item") and getattr(v, "shape", None) == ():
            object.__setattr__(obj, f.name, v.item())


def check_fields(obj, positive=frozenset(), source: str | None = None, found: list | None = None) -> None:
    """Check every numeric, boolean and choice field of a frozen options dataclass ``obj`` built in
    Python, by its annotation (:func:`field_issue`; ``positive``: the fields that must be > 0);
    a choice (an enumeration default) given as its value is turned into it. Raises
    :class:`OptionsError` listing every bad field, named by ``source`` (default: the class), after
    the issues already ``found`` (their fields are not checked again)."""
    plain_scalars(obj)
    issues = list(found or ())
    seen = {i.path for i in issues}
    for f in dataclasses.fields(obj):
        if f.name in seen:
            continue
        v = getattr(obj, f.name)
        if isinstance(f.default, enum.Enum):
            try:
                object.__setattr__(obj, f.name, type(f.default)(v))
            except ValueError as e:
                issues.append(Issue(f.name, str(e)))
            continue
        msg = field_issue(f.name, str(f.type), v, f.name in positive)
        if msg is not None:
            issues.append(Issue(f.name, msg))
    if issues:
        raise OptionsError(issues, source or type(obj).__name__)


def coplan_file_kind(data) -> str | None:
    """The kind a decoded coplan file names in its ``format`` (``coplan.<kind>/<version>``:
    ``plan``, ``feed``, ``verification``, ...), or None: how a loader tells a file of another
    kind given in its place."""
    fmt = data.get("format") if isinstance(data, dict) else None
    return fmt.split(".", 1)[1].split("/", 1)[0] if isinstance(fmt, str) and fmt.startswith("coplan.") else None


def is_joint_csv(data) -> bool:
    """Whether a document read as text is a CSV of joint samples (``t,<arm>_q1,...``): coplan's
    plan.csv replay or an export, given where another file is expected."""
    return isinstance(data, str) and re.match(r"t,[^,\s]+_q1,", data) is not None


def special_file(p) -> str | None:
    """What ``p`` is when it is a device or a socket (``"a character device"``: ``/dev/zero``
    would be read for ever), else None (a regular file, a pipe)."""
    import stat
    from pathlib import Path

    try:
        mode = Path(p).stat().st_mode
    except OSError:
        return None
    for test, name in ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISSOCK, "a socket")):
        if test(mode):
            return name
    return None


def known_fields(cls):
    """Class decorator for an options dataclass (put above ``@dataclass``): a keyword that is none
    of its fields is an :class:`OptionsError` naming it, with the field it most resembles, as an
    options file's unknown key is (Python's own TypeError said only "unexpected keyword argument
    'serch_work'")."""
    init = cls.__init__
    names = [f.name for f in dataclasses.fields(cls)]

    @functools.wraps(init)
    def __init__(self, *args, **kw):
        unknown = [k for k in kw if k not in names]
        if unknown:
            def hint(k: str) -> str:
                near = difflib.get_close_matches(k, names, n=1)
                return f"did you mean {near[0]!r}?" if near else f"its fields: {', '.join(names)}"
            raise OptionsError([Issue(k, f"expected a field of {cls.__name__}, found {k!r}; {hint(k)}") for k in unknown],
                               cls.__name__)
        init(self, *args, **kw)

    cls.__init__ = __init__
    return cls
