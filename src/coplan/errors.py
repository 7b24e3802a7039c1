"""Error types shared by every stage. User-facing errors carry every issue found."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["Issue", "InputError", "ProblemError", "PlanFileError", "CoplanError"]


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
    """A bad input file; ``issues`` holds every problem found, ``source`` the file."""

    kind = "input"

    def __init__(self, issues: list[Issue], source: str | None = None):
        self.issues = list(issues)
        self.source = source
        n = len(self.issues)
        head = f"{source or self.kind}: {n} problem{'s' if n != 1 else ''} found"
        super().__init__(head + "\n" + "\n".join("  " + i.format(source) for i in self.issues))


class ProblemError(InputError):
    kind = "problem"


class PlanFileError(InputError):
    kind = "plan"
