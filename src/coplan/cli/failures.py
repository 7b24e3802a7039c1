"""What the command line reports when a command fails: the exit code and message of every kind of
failure, and (with ``--json``) one JSON document on stdout describing it.

The document (``"format": "coplan.error/1"``)::

    {"format": "coplan.error/1", "command": "solve", "exit_code": 3, "error": "bad_input",
     "message": "problems/x.yaml: 2 problems found ...",
     "errors": [{"file": "problems/x.yaml", "path": "arms[0].links", "line": 7,
                 "expected": "a list of 2 numbers", "found": "a string 'abc'",
                 "message": "expected a list of 2 numbers, found a string 'abc'"}]}

``errors`` lists every issue of a bad input file (``path`` is the key path, ``line`` the line
in the file, ``expected``/``found`` split from the message when it has that form, else null);
for a usage error, one entry whose ``path`` is the option or argument it is about; for other
failures one entry with the message. Light: imports only coplan's enums and errors.
"""

from __future__ import annotations

import json
import math
import os
import re
import sys
from pathlib import Path
from typing import Any

from ..errors import CoplanError, InputError, Issue
from ..kinds import ExitCode
from ..output import OutputError, RunKept, check_folder

__all__ = ["Failure", "failure_of", "error_document", "issue_dict", "dumps", "TERMINATED", "INTERRUPTED", "CONSOLE", "work_done", "as_exited",
           "usage", "check_out_dir", "check_overwrite", "exit_fields", "file_kind"]

# set by the console entry point when SIGTERM arrived: an interruption then exits 143, not 130
TERMINATED: list[int] = []
STARTED: list[str] = []  # the command (its body: coplan.cli.commands.guarded) has begun: it says its own ending
# set by the console entry point when Ctrl-C arrived: an import it broke ("initialization failed") is that interruption
INTERRUPTED: list[int] = []
# set by the console entry point: this process is the ``coplan`` command (not a test's CliRunner),
# whose signal dispositions a command may change for the rest of its life
CONSOLE: list[bool] = []

_KIND = {
    ExitCode.USAGE: "usage",
    ExitCode.BAD_INPUT: "bad_input",
    ExitCode.INTERNAL: "internal",
    ExitCode.IO_ERROR: "io_error",
    ExitCode.INTERRUPTED: "interrupted",
    ExitCode.TERMINATED: "terminated",
}
_EXPECTED_FOUND = re.compile(r"^expected (?P<expected>.+?)[,;] found (?P<found>.+)$", re.DOTALL)
# a command's own usage message about an option: "--workers: expected ...", "--out x.txt: expected ...",
# "--arm-stop/--camera-dark: ..." (the value may hold colons: "--scheduler 'tcp://10.0.0.5:8786': expected ...")
_OPTION_SAID = re.compile(r"^(?P<option>--[a-z][\w-]*(?:/--[a-z][\w-]*)*)[ :/]")


class Failure(CoplanError):
    """A command refusing to go on (bad usage, a plan that does not fit its problem, ...): the
    exit code and the message the user sees."""

    def __init__(self, code: ExitCode, message: str):
        super().__init__(message)
        self.code = ExitCode(code)
        self.message = message

    def __reduce__(self):
        return type(self), (self.code, self.message), self.__dict__


def work_done() -> None:
    """The command's files are written whole: from here a Ctrl-C or SIGTERM changes nothing, and
    the command prints its summary and exits with its verdict (one landing here killed the
    process by the signal, printed Python's 'Exception ignored ... KeyboardInterrupt', or said
    'interrupted' after the files were written and the previous run moved aside). Main thread
    of the ``coplan`` command only (a test's CliRunner keeps its process's signals)."""
    import signal
    import threading

    if CONSOLE and threading.current_thread() is threading.main_thread():
        signal.signal(signal.SIGINT, signal.SIG_IGN)
        if hasattr(signal, "SIGTERM"):
            signal.signal(signal.SIGTERM, signal.SIG_IGN)


def as_exited(code: ExitCode) -> ExitCode:
    """The exit code the ``coplan`` command ends with for a run whose verdict is ``code``: an
    interrupted run stopped by SIGTERM exits 143, not 130 (its ``--json`` document said 130)."""
    code = ExitCode(code)
    return ExitCode.TERMINATED if code == ExitCode.INTERRUPTED and TERMINATED else code


def exit_fields(code: ExitCode) -> dict[str, Any]:
    """What a ``--json`` document of a command that ran says of how it ends: ``exit_code`` and
    ``verdict`` (the exit code's name: ``ok``, ``partial``, ``unsafe`` ...), as the command exits."""
    code = as_exited(code)
    return {"exit_code": int(code), "verdict": code.name.lower()}


def usage(message: str):
    """Refuse the command line: exit 2 (bad usage) with ``message``."""
    raise Failure(ExitCode.USAGE, message)


def check_out_dir(out, what: str = "--out", files_only: bool = False) -> None:
    """Before any work: ``out`` (a Path) must be a folder coplan can create or write into
    (:func:`coplan.output.check_folder`; ``files_only``: files go into it, not a run); else exit
    2 with what it found."""
    try:
        check_folder(out, what, files_only=files_only)
    except OutputError as exc:
        usage(str(exc))


def check_out_file(out, what: str = "--out") -> None:
    """Before any work: the folder ``out`` (a file's Path) goes into must be one coplan can
    create or write into, and ``out`` itself no folder."""
    if out.is_dir():
        usage(f"{what} {out}: expected a file name, found a folder")
    check_out_dir(out.parent, what=f"{what} {out}: its folder", files_only=True)


def check_overwrite(out, kind: str, what: str, option: str = "--out") -> None:
    """Before any work: an existing file ``out`` (a Path) is overwritten only when it is of the
    ``kind`` the command writes (as :func:`_file_kind` names it); any other file (a plan, a
    baseline, somebody's data) is refused, named, with exit 2: nothing is lost to a typo."""
    head = _head(out)
    if head is None:
        return  # (no such file; or unreadable: the write itself then says why)
    found = _file_kind(head)
    if found != kind:
        usage(f"{option} {out}: expected a new file or {what}, found {found}: it would be overwritten; "
              "give another file")


#: what a figure command may overwrite, by the suffix it writes: a file of that format (its first bytes)
_FIGURE_KINDS = {
    ".png": ("a PNG image", lambda h: h.startswith(b"\x89PNG")),
    ".svg": ("an SVG image", lambda h: b"<svg" in h),
    ".pdf": ("a PDF", lambda h: h.startswith(b"%PDF")),
    ".gif": ("a GIF animation", lambda h: h.startswith(b"GIF8")),
    ".mp4": ("an MP4 video", lambda h: h[4:8] == b"ftyp"),
    ".html": ("a coplan viewer page", lambda h: b'content="coplan viewer"' in h),
    ".htm": ("a coplan viewer page", lambda h: b'content="coplan viewer"' in h),
}


def check_figure_overwrite(out: Path, option: str = "--out") -> None:
    """Before any work: an existing file ``out`` that ``plot``, ``animate`` or ``view`` would
    write is overwritten only when it is a file of the format its suffix says (an earlier
    figure, animation or viewer page); anything else (notes, a plan, a problem) is refused,
    named, with exit 2 -- as ``feed``, ``verify`` and ``export`` refuse it."""
    kind = _FIGURE_KINDS.get(out.suffix.lower())
    head = None if kind is None else _head(out)
    if head is None:
        return  # (no such file; or unreadable: the write itself then says why)
    if not kind[1](head):
        found = _file_kind(head)
        usage(f"{option} {out}: expected a new file or {kind[0]} (an earlier one), found {found}: it would be "
              "overwritten; give another file")


def file_kind(path: Path) -> str | None:
    """What an existing file says it is (:func:`_file_kind`'s words), None if it cannot be read."""
    head = _head(path)
    return None if head is None else _file_kind(head)


def _head(path: Path) -> bytes | None:
    """The first 4096 bytes of the file ``path``; None where it is no file or cannot be read."""
    if not path.is_file():
        return None
    try:
        with open(path, "rb") as f:
            return f.read(4096)
    except OSError:
        return None


def _file_kind(head: bytes) -> str:
    """What a file's first bytes say it is: a coplan JSON or YAML file by its format ('a
    coplan.verification file', 'a coplan.feed file'), coplan's plan.csv replay or an export CSV
    by its header, else 'a file of another kind'."""
    m = re.search(rb'"format"\s*:\s*"(coplan\.[a-z_]+)/', head) or re.search(rb'(?m)^format:\s*["\']?(coplan\.[a-z_]+)/', head)
    if m:  # (JSON, or a YAML file's top-level format: a feed)
        return f"a {m.group(1).decode()} file"
    if re.search(rb'"joint_names"\s*:', head) or re.search(rb'(?m)^joint_names:', head):
        return "an export JointTrajectory"  # (coplan export --format json|yaml: one per arm)
    if re.match(rb'\s*(\{\s*"events"\s*:|events:)', head):
        return "an export's events"  # (its picks and places: events.json / events.yaml)
    line = head.split(b"\n", 1)[0].decode("utf-8", "replace").strip()
    if line == "arm,fruit,kind,t_start,t_end":
        return "an export's events"  # (beside an export CSV: <name>.events.csv)
    if line.startswith("t,") and "_q1" in line:
        return "an export CSV" if "_qd1" in line else "coplan's plan.csv replay"
    return "a file of another kind"


def resolve_problem(problem, note=lambda message: None):
    """The problem file an argument names: the shipped default when none is given; a bare name
    (``dense_overlap``): ``dense_overlap.yaml`` here, else a shipped problem's (``note`` is told
    which file that is; ``dense_overlap.yaml`` too when no such file is here); else the path as given."""
    from ..problem.load import default_problem_path, resolve_name

    if problem is None:
        path, taken_as = default_problem_path(), "shipped"
    else:
        path, taken_as = resolve_name(problem)
        if taken_as is not None:
            note(f"{problem}: {taken_as}")
    edited = _edited_copy(path) if taken_as is not None else None
    if edited is not None:  # (a newcomer edits the clone's copy; an installed coplan reads its own)
        note(f"note: {edited} here differs from the shipped copy this command reads ({path}); "
             f"give its path ({edited}) to use it")
    return path


def _edited_copy(shipped: Path) -> Path | None:
    """``problems/<name>`` in the working folder (a clone's copy of a shipped problem) where it
    is another file than ``shipped`` and its text differs; else None."""
    from ..problem.load import default_problem_path

    try:  # (a shipped row is problems/rows/<name>: the same path under ./problems)
        here = Path("problems") / shipped.resolve().relative_to(default_problem_path().parent.resolve())
    except ValueError:
        here = Path("problems") / shipped.name
    try:
        edited = here.is_file() and here.resolve() != shipped.resolve() and here.read_bytes() != shipped.read_bytes()
    except OSError:
        edited = False
    return here if edited else None


def written_note(exc: BaseException | None = None) -> str:
    """Where a run written whole as a Ctrl-C or SIGTERM came is -- the one the interrupt ``exc``
    carries (``written_run``), else the one whose held signal is being answered now
    (:data:`coplan.output.WRITTEN_BEFORE_SIGNAL`) -- as a clause of the interrupted message; ''
    when there is none."""
    from ..output import WRITTEN_BEFORE_SIGNAL

    f = getattr(exc, "written_run", None) if exc is not None else (WRITTEN_BEFORE_SIGNAL[-1] if WRITTEN_BEFORE_SIGNAL else None)
    if f is None:
        return ""
    return (f"; it came as the run's files were written: they are whole, in {f.out}"
            + (f" (the previous run kept in {f.previous})" if f.previous is not None else ""))


def failure_of(exc: BaseException) -> tuple[ExitCode, str]:
    """The exit code and message of any exception a command raised."""
    if isinstance(exc, Failure):
        return exc.code, exc.message
    if isinstance(exc, InputError):
        return (ExitCode.IO_ERROR if exc.unreadable else ExitCode.BAD_INPUT), str(exc)
    if isinstance(exc, KeyboardInterrupt) or (  # (a Ctrl-C landing in a C extension's initialisation: its ImportError)
            type(exc) is ImportError and "initialization failed" in str(exc) and (INTERRUPTED or TERMINATED)):
        return ((ExitCode.TERMINATED, "terminated (SIGTERM)" + written_note(exc)) if TERMINATED
                else (ExitCode.INTERRUPTED, "interrupted by the user (Ctrl-C)" + written_note(exc)))
    if isinstance(exc, CoplanError):  # an error class may name its own exit code
        return ExitCode(getattr(exc, "exit_code", ExitCode.INTERNAL)), str(exc)
    if isinstance(exc, RunKept):  # (the run is whole, elsewhere: its message says where)
        return ExitCode.IO_ERROR, str(exc.strerror)
    if isinstance(exc, OSError):  # disk full, permissions: the path and the reason, nothing half-written left
        where = f": {exc.filename}" if exc.filename else ""
        return ExitCode.IO_ERROR, f"{exc.strerror or exc}{where} (nothing of this run was left half-written)"
    return ExitCode.INTERNAL, f"internal error ({type(exc).__name__}): {exc}. Set COPLAN_DEBUG=1 for a traceback."


def _said(text: str) -> tuple[str | None, str | None]:
    """``(expected, found)`` split from a message of the form "expected X, found Y" (else Nones)."""
    m = _EXPECTED_FOUND.match(text)
    return (m["expected"], m["found"]) if m else (None, None)


def issue_dict(issue: Issue, source: str | None) -> dict[str, Any]:
    """One issue of a bad input file as JSON: file, key path, line, expected, found, message."""
    expected, found_ = _said(issue.message)
    return {"file": source, "path": issue.path, "line": issue.line, "expected": expected, "found": found_,
            "message": issue.message}


def error_document(command: str, code: ExitCode, message: str, exc: BaseException | None = None) -> dict[str, Any]:
    """The ``--json`` document of a failed command (see the module docstring)."""
    code = ExitCode(code)
    if isinstance(exc, InputError):
        errors = [issue_dict(i, exc.source) for i in exc.issues]
    elif exc is not None and code == ExitCode.USAGE:
        errors = [_usage_entry(exc, message)]
    else:
        filename = getattr(exc, "filename", None) if isinstance(exc, OSError) else None
        errors = [{"file": os.fspath(filename) if filename is not None else None, "path": None, "line": None,
                   "expected": None, "found": None, "message": message}]
    return {"format": "coplan.error/1", "command": command, "exit_code": int(code),
            "error": _KIND.get(code, code.name.lower()), "message": message, "errors": errors}


def _usage_entry(exc: BaseException, message: str) -> dict[str, Any]:
    """The ``errors`` entry of a usage error: the option or argument it is about as ``path``
    (``--resolution``, ``PROBLEM``), and ``expected``/``found`` split from its message where it
    has that form, as a problem file's issues are. ``exc``: the framework's (click's) exception, or
    coplan's own refusal (:func:`usage`: "--option [value]: expected ..., found ...")."""
    if not hasattr(exc, "format_message"):  # coplan's own: what it expected follows ": expected "
        m = _OPTION_SAID.match(message)
        at = message.find(": expected ")
        path, text = (m["option"] if m else None), (message[at + 2:] if m and at >= 0 else "")
    else:
        param = getattr(exc, "param", None)
        names = [n for n in (getattr(param, "opts", None) or []) if isinstance(n, str)]
        if param is None:  # (an unknown option: its name only)
            name = getattr(exc, "option_name", None) or getattr(exc, "param_hint", None)
            path = name if isinstance(name, str) else None
        elif names and names[0].startswith("-"):
            path = max(names, key=len)  # (--planner, not -p)
        else:  # an argument, named as the message and the usage line name it (PROBLEM)
            path = getattr(param, "metavar", None) or getattr(param, "human_readable_name", None) or (names[0] if names else None)
        text = str(getattr(exc, "message", "") or "")
    expected, found_ = _said(text)
    return {"file": None, "path": path, "line": None, "expected": expected, "found": found_, "message": message}


def _finite(x):
    if isinstance(x, float) and not math.isfinite(x):
        return None
    if isinstance(x, dict):
        return {str(k): _finite(v) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [_finite(v) for v in x]
    return x


def dumps(doc: dict[str, Any]) -> str:
    """Strict JSON (no NaN/Infinity tokens), one document."""
    return json.dumps(_finite(doc), indent=1, default=str, allow_nan=False)


def run_with_json_usage_errors(app) -> int:
    """Run the typer ``app`` (argv from ``sys.argv``) so that a usage error found before any
    command ran (an unknown option, a bad value) is printed as usual on stderr and as the JSON
    error document on stdout; returns the exit code. Used when ``--json`` is on the command line."""
    import typer

    STARTED.clear()
    try:
        rv = app(standalone_mode=False)
    except typer.TyperException as e:  # the framework's usage errors (its vendored click's UsageError)
        from typer import rich_utils

        rich_utils.rich_format_error(e)
        ctx = getattr(e, "ctx", None)
        command = ctx.command.name if ctx is not None and ctx.command is not None else None
        typer.echo(dumps(error_document(command or "coplan", ExitCode.USAGE, e.format_message(), e)))
        return int(getattr(e, "exit_code", ExitCode.USAGE))
    except (typer.Abort, KeyboardInterrupt):
        rv = int(ExitCode.INTERRUPTED)
    if rv == int(ExitCode.INTERRUPTED) and not STARTED:
        # (Ctrl-C or SIGTERM as the command line was read, before the command ran -- typer answers it
        # with exit 130 -- left stdout empty: a script had no document to read)
        code = as_exited(ExitCode.INTERRUPTED)
        command = next((a for a in sys.argv[1:] if not a.startswith("-")), "coplan")
        typer.echo(dumps(error_document(command, code, f"{_KIND[code]} ({'SIGTERM' if TERMINATED else 'Ctrl-C'}) as the "
                                                       "command started: nothing was done")))
        return int(code)
    return rv if isinstance(rv, int) else 0
