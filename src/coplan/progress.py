"""How far a long run is: the ticks a progress display draws.

Every long entry point (``solve``, ``plan_optimal``, ``compare``, ``animate_plan``,
``simulate``) takes ``progress``: a callable that receives lines of text (``progress("...")``),
as it always has -- ``print`` will do. A progress *display* also wants to know how far the
run is; it says so by having a ``tick`` method as well (a :class:`Reporter`), which then
receives :class:`Tick` objects: the stage, the share of that stage's work budget done, and
for a planner the incumbent makespan and the lower bound. A plain callable receives no ticks,
so a script printing every message gets no flood of them.

Import-free (the CLI's progress bars live in :mod:`coplan.cli.console`).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, replace
from typing import Protocol, runtime_checkable

__all__ = ["Tick", "Reporter", "ProgressCallbackError", "speaker", "ticker", "nested", "check_progress", "guarded"]


@dataclass(frozen=True)
class Tick:
    """Where a long run is.

    stage : what it is doing ("search", "refine", "frames", "runs", ...)
    done, total : work done and the stage's budget, in ``unit`` (``total`` None: unknown)
    unit : what ``done`` counts ("checks", "retimings", "frames", ...)
    incumbent : a planner's best verified makespan so far (s), if any
    bound : the makespan lower bound (s), if known
    note : a short free text (the problem and planner of a comparison run, say)
    level : 0 for a run's own stages, 1 for a run inside another (a solve inside ``compare``)
    """

    stage: str
    done: float = 0.0
    total: float | None = None
    unit: str = ""
    incumbent: float | None = None
    bound: float | None = None
    note: str = ""
    level: int = 0

    @property
    def share(self) -> float | None:
        """The share of the stage's budget done (0..1), None when the budget is unknown."""
        if not self.total:
            return None
        return min(1.0, max(0.0, self.done / self.total))

    @property
    def gap(self) -> float | None:
        """The incumbent's excess over the bound (0.037 = 3.7 %), None when either is unknown."""
        if self.incumbent is None or not self.bound:
            return None
        return max(0.0, self.incumbent / self.bound - 1.0)

    def text(self) -> str:
        """One line: the stage, its share, the incumbent and its gap."""
        parts = [self.stage]
        if self.share is not None:
            parts.append(f"{self.share:.0%} of its budget")
        if self.incumbent is not None:
            gap = f", {self.gap:.1%} over the bound {self.bound:.3f} s" if self.gap is not None else ""
            parts.append(f"incumbent {self.incumbent:.3f} s{gap}")
        if self.note:
            parts.append(self.note)
        return ": ".join(parts[:1]) + (" -- " + ", ".join(parts[1:]) if len(parts) > 1 else "")


@runtime_checkable
class Reporter(Protocol):
    """A progress callable that also draws :class:`Tick` objects."""

    def __call__(self, message: str) -> None: ...

    def tick(self, tick: Tick) -> None: ...


def check_progress(progress, where: str = "") -> None:
    """TypeError, before any work, unless ``progress`` is a callable or None (``where``: the entry
    point, said first): a bad one failed minutes in, at the first message."""
    if progress is not None and not callable(progress):
        raise TypeError(f"{where + ': ' if where else ''}progress: expected a callable taking one message (str), or None; "
                        f"found {type(progress).__name__}")


class ProgressCallbackError(Exception):
    """The caller's ``progress`` callable raised (the original is ``__cause__``): a planner that
    keeps what it has when one of its own stages fails lets this through, so that a bug in the
    caller's callback is the caller's error, never a plan reported as found with an 'error'."""


def guarded(progress):
    """``progress`` (None, a callable or a :class:`Reporter`) with any exception it raises turned
    into :class:`ProgressCallbackError`; None stays None."""
    if progress is None:
        return None

    def call(fn, arg):
        try:
            fn(arg)
        except ProgressCallbackError:
            raise  # (guarded twice: once is enough)
        except Exception as e:  # noqa: BLE001 -- re-raised, marked as the caller's
            raise ProgressCallbackError(f"the progress callable raised {type(e).__name__}: {e}") from e

    class _Guarded:
        def __call__(self, message: str) -> None:
            call(progress, message)

    tick = getattr(progress, "tick", None)
    if callable(tick):
        _Guarded.tick = lambda self, t: call(tick, t)
    return _Guarded()


def speaker(progress: Callable[[str], None] | None) -> Callable[[str], None]:
    """``progress`` itself, or a callable that drops every message."""
    return progress if progress is not None else (lambda message: None)


def ticker(progress) -> Callable[[Tick], None]:
    """``progress.tick`` when ``progress`` is a :class:`Reporter`, else a callable that drops ticks."""
    tick = getattr(progress, "tick", None)
    return tick if callable(tick) else (lambda t: None)


class _Nested:
    def __init__(self, outer: Reporter):
        self.outer = outer

    def __call__(self, message: str) -> None:
        self.outer(message)

    def tick(self, t: Tick) -> None:
        self.outer.tick(replace(t, level=t.level + 1))


def nested(progress):
    """``progress`` for a run inside another: the same messages, its ticks one level down."""
    return _Nested(progress) if isinstance(progress, Reporter) else progress
