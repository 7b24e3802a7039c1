"""Checks and helpers the commands share: a usage failure, --time-limit, --workers and
--options, the budget hint and strict JSON (public, so that each command's module can use them)."""

from __future__ import annotations

import json
import math
import os
import stat
from pathlib import Path
from typing import Optional

import typer

from . import failures
from ..kinds import ExitCode, PlannerKind

__all__ = ["in_path", "fail", "strict_json", "between", "real", "whole", "check_time_limit", "check_workers", "solver_options", "budget_hint",
           "file_state", "check_still_read"]


def fail(code: ExitCode, message: str):
    raise failures.Failure(code, message)


def between(lo: float, hi: float = math.inf, unit: str = "", above: bool = False):
    """An option's check (``typer.Option(callback=between(...))``): a finite number in
    ``[lo, hi]`` (``above``: in ``(lo, hi]``; ``unit`` said with it), else a usage error that
    says what was expected and what was found (NaN included), not the bare bound typer's own
    ``min``/``max`` print."""
    def check(value: float) -> float:
        if value is not None and not (math.isfinite(value) and (lo < value if above else lo <= value) and value <= hi):
            want = (f"in {'(' if above else '['}{lo:g}, {hi:g}]" if math.isfinite(hi)
                    else f"{'>' if above else '>='} {lo:g}")
            shown = f"{value:d}" if isinstance(value, int) else f"{value:g}"  # (an integer option: 100000000, not 1e+08)
            raise typer.BadParameter(f"expected a number {want}{' ' + unit if unit else ''}, found {shown}")
        return value
    return check


def real(value) -> float:
    """``typer.Option(parser=real, metavar="<float>")``: a number option's value, refused as
    ``expected a number, found 'abc'`` (typer's own said "Input should be a valid number, unable
    to parse string as a number", without the value). NaN and infinity are numbers here: the
    option's own check (:func:`between`) says what range it takes."""
    if isinstance(value, (int, float)) and not isinstance(value, bool):
        return float(value)
    try:
        return float(str(value).strip())
    except ValueError:
        raise typer.BadParameter(f"expected a number, found {value!r}") from None


def whole(value) -> int:
    """``typer.Option(parser=whole, metavar="<int>")``: a whole number option's value, refused
    as ``expected a whole number, found '2.5'``."""
    if isinstance(value, int) and not isinstance(value, bool):
        return value
    try:
        return int(str(value).strip())
    except ValueError:
        raise typer.BadParameter(f"expected a whole number, found {value!r}") from None


def strict_json(doc) -> str:
    """Strict JSON (RFC 8259): a non-finite number (e.g. no clearance at all: infinity) is null."""
    from ..plan import jsonable

    return json.dumps(jsonable(doc), default=str, allow_nan=False)


def check_time_limit(time_limit: Optional[float], default: str = "the planner's own") -> None:
    """``--time-limit`` before any work: a positive, finite number of seconds (``default``: what
    leaving it out gives)."""
    if time_limit is not None and not (math.isfinite(time_limit) and time_limit > 0):
        fail(ExitCode.USAGE, f"--time-limit: expected a positive, finite number of seconds (leave it out for {default}), found {time_limit}")


def check_workers(workers: Optional[str]) -> Optional[int]:
    """``--workers``: a whole number from 1 to ``MAX_WORKERS``, or auto (this machine's cores, at
    most 8); None if not given."""
    from ..workers import MAX_WORKERS, default_workers

    if workers is None:
        return None
    if workers.strip().lower() == "auto":
        return default_workers()
    try:
        n = int(workers)
    except ValueError:
        n = 0
    if not 1 <= n <= MAX_WORKERS:
        fail(ExitCode.USAGE, f"--workers: expected a whole number of processes from 1 to {MAX_WORKERS}, or auto; found {workers!r}")
    return n


def choice(cls):
    """``typer.Option(parser=choice(Enum), metavar=choices(Enum))``: an enum option's value,
    refused as ``expected one of 'a', 'b'; found 'x'`` (typer's own said "Value error, 'x' is not
    one of ...", its validator's words)."""
    def parse(value):
        if isinstance(value, cls):
            return value
        try:
            return cls(value)
        except ValueError:
            raise typer.BadParameter(f"expected one of {', '.join(repr(m.value) for m in cls)}; found {value!r}") from None
    return parse


def choices(cls) -> str:
    """The metavar that lists an enum option's values, as typer's own did: ``[a|b|c]``."""
    return "[" + "|".join(m.value for m in cls) + "]"


def in_path(value: str) -> Path:
    """A file argument's value as a Path. An empty one (``coplan check "$F"`` with ``F`` unset)
    is refused (exit 2): typer made the current folder of it, said to be a folder, not a file."""
    if value == "":
        raise typer.BadParameter("expected a file name, found an empty string (an unset variable?)")
    return Path(value)


class FolderOut(type(Path())):  # type: ignore[misc]
    """An ``--out`` given with a trailing separator: a folder, whether or not it exists yet
    (``Path`` drops the separator: ``--out ex/`` wrote a file named ``ex``, ``plot -o new/`` new.png)."""


def out_path(value: str) -> Path:
    """``--out``'s value as a Path (a :class:`FolderOut` where it ends with a separator). An empty
    one (``--out "$DIR"`` with ``DIR`` unset, say) is refused (exit 2) rather than read as the
    current folder, which typer would make of it."""
    if value == "":
        raise typer.BadParameter("expected a file or folder name, found an empty string (an unset variable?)")
    if value == "-":  # (no command writes its files to stdout; it said --json did, which most have not)
        raise typer.BadParameter("expected a file or folder name, found '-': coplan writes files, not to stdout "
                                 "(a command with --json prints its summary on stdout)")
    return FolderOut(value) if isinstance(value, str) and value.endswith(("/", os.sep)) else Path(value)


def into_folder(out: Path | None) -> bool:
    """Whether ``--out`` names a folder to write into: one that exists, or one given with a
    trailing separator (made by the command)."""
    return out is not None and (isinstance(out, FolderOut) or out.is_dir())


def solver_options(path: Optional[Path], time_limit: Optional[float], applies: bool):
    """OptimalOptions from ``--options`` (validated; bad values exit 3 with the key and line)
    and ``--time-limit`` (which wins); None when neither is given."""
    if path is None and time_limit is None:
        return None
    if not applies:
        if path is not None:
            fail(ExitCode.USAGE, "--options: the heuristic planner has no solver options")
        return None
    from dataclasses import replace

    from ..planners.optimal.planner import OptimalOptions
    from ..planners.optimal.options import load_options

    opts = load_options(path) if path is not None else OptimalOptions()
    return replace(opts, time_limit=time_limit) if time_limit is not None else opts


def optimal_only_note(opts) -> Optional[str]:
    """For the coordinated planner: a note naming the fields of ``opts`` (OptimalOptions) set
    away from their defaults that it does not take, and the ones it does; None if there are none."""
    from dataclasses import fields

    from ..planners.optimal.options import COORDINATED_FIELDS, OptimalOptions

    base = OptimalOptions()
    unused = [f.name for f in fields(opts) if f.name not in COORDINATED_FIELDS and getattr(opts, f.name) != getattr(base, f.name)]
    if not unused:
        return None
    return (f"--options: {', '.join(unused)} appl{'ies' if len(unused) == 1 else 'y'} to the optimal planner only; "
            f"the coordinated planner takes {', '.join(COORDINATED_FIELDS)}")


def budget_hint(planner: PlannerKind, time_limit: Optional[float]) -> Optional[str]:
    """Shown once a long optimal solve has run a while without a clock limit."""
    if planner != PlannerKind.OPTIMAL or time_limit is not None:
        return None
    return ("the optimal planner stops on its work budget (so the plan is the same on any machine); "
            "--time-limit S returns its verified incumbent after S s, and Ctrl-C keeps it too")


def file_state(path: Path) -> tuple | None:
    """A regular file's identity now (device, inode, size, modification time), or None (a pipe,
    a device, no such file): what :func:`check_still_read` compares."""
    try:
        st = os.stat(path)
    except OSError:
        return None
    return (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns) if stat.S_ISREG(st.st_mode) else None


def check_still_read(plan: Path, state: tuple | None, written: tuple | list = ()) -> None:
    """Before (or after) a command writes from the plan file ``plan`` it read as ``state``
    (:func:`file_state`): where that file is another now -- a ``coplan solve`` into its folder
    put a new run there meanwhile -- the command fails (exit 8), saying so, and ``written`` (what
    it wrote from the earlier plan, files that were not there before) is removed. An export or a
    figure of the old plan was left in the new run's folder, exit 0."""
    if state is None or file_state(plan) == state:
        return
    for path in written:
        Path(path).unlink(missing_ok=True)
    gone = (f": what this command wrote from the earlier plan is removed ({', '.join(Path(p).name for p in written)})"
            if written else ": nothing written")
    fail(ExitCode.IO_ERROR, f"{plan} changed while it was read and drawn or exported (another run wrote into its "
                            f"folder?){gone}; run it again on the plan there now")
