"""Error types shared by every stage. User-facing errors carry every issue found."""

from __future__ import annotations

import math
from dataclasses import dataclass

__all__ = ["Issue", "InputError", "ProblemError", "PlanFileError", "CoplanError", "printable", "plural", "found",
           "finite_number"]


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

    def __init__(self, issues: list[Issue], source: str | None = None):
        self.issues = list(issues)
        self.source = source
        n = len(self.issues)
        head = f"{source or '<input>'}: {n} problem{'s' if n != 1 else ''} found"
        shown = ["  " + i.format(source) for i in self.issues[: self.MAX_SHOWN]]
        if n > self.MAX_SHOWN:
            shown.append(f"  ... and {n - self.MAX_SHOWN} more")
        super().__init__(head + "\n" + "\n".join(shown))


class ProblemError(InputError):
    kind = "problem"


class PlanFileError(InputError):
    kind = "plan"


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
        return "a mapping"
    if isinstance(v, list):
        return f"a list of {len(v)}" if list_length else "a list"
    return type(v).__name__


def finite_number(v) -> bool:
    """Whether a value read from YAML is a finite int or float (not a boolean)."""
    return isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v)
