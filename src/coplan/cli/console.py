"""Small things the command line needs around its text (no heavy imports: ``coplan --help`` loads this).

* :class:`FlagsGroup` -- the ``typer`` group class that shows flags (``--json``, ``--animate``,
  ``--help``) as taking no value in ``--help`` (typer 0.29's rich help prints ``<bool>`` after them).
* :func:`run_console` -- the console entry point's body (signals, pipes, ``--json`` usage errors).
* :class:`ProgressDisplay` -- progress lines and, on a terminal, rich progress bars on stderr.
* :class:`PipeSafeStream` -- stdout or stderr that survives a reader closing the pipe
  (``coplan problems | head -1``, ``coplan solve 2>&1 | head -1``): the first ``BrokenPipeError``
  sends the stream's file descriptor to ``/dev/null`` and every later write is dropped, so the
  command finishes its work and exits with its own code, with no traceback and no "Exception
  ignored" message at exit (the handling the Python documentation recommends for SIGPIPE).
"""

from __future__ import annotations

import os
import sys

from typer.core import TyperGroup, TyperOption

__all__ = ["text_console", "FlagsGroup", "PipeSafeStream", "ProgressDisplay", "run_console"]


def _flags_take_no_value(params) -> None:
    for p in params:
        if isinstance(p, TyperOption) and p.is_flag and p.metavar is None:
            p.metavar = ""  # typer shows the metavar instead of the type; an empty one shows nothing


class FlagsGroup(TyperGroup):
    """A typer group whose ``--help`` pages show flags without a value type."""

    def get_params(self, ctx):
        params = super().get_params(ctx)
        _flags_take_no_value(params)
        return params

    def get_command(self, ctx, cmd_name: str):
        cmd = super().get_command(ctx, cmd_name)
        if cmd is not None:
            _flags_take_no_value(cmd.get_params(ctx))
        return cmd


def text_console(stderr: bool = False):
    """A command's stdout (or stderr) console: long lines left whole (a pipe or a file gets them
    unbroken), and emoji codes kept as written (a name ":warning:" was printed as the sign, while
    the JSON kept the name)."""
    from rich.console import Console

    return Console(stderr=stderr, soft_wrap=True, emoji=False)


def _closed_pipe(e: OSError) -> bool:
    """Whether a write failed because the reading end of the pipe is gone: EPIPE, or on Windows
    EINVAL (a write to a closed pipe raises that there: CPython issue 79935)."""
    import errno
    import sys

    return isinstance(e, BrokenPipeError) or (sys.platform == "win32" and e.errno == errno.EINVAL)


class PipeSafeStream:
    """A stand-in for ``sys.stdout`` or ``sys.stderr`` that turns a closed pipe into silence (see
    the module docstring)."""

    def __init__(self, stream):
        self._stream = stream
        self.broken = False

    def _silence(self) -> None:
        self.broken = True
        try:
            devnull = os.open(os.devnull, os.O_WRONLY)
            os.dup2(devnull, self._stream.fileno())
            os.close(devnull)
        except (OSError, ValueError):  # no real file descriptor (e.g. a test's stream): writes are dropped anyway
            pass

    def write(self, text: str) -> int:
        if self.broken:
            return len(text)
        try:
            return self._stream.write(text)
        except OSError as e:
            if not _closed_pipe(e):
                raise
            self._silence()
            return len(text)

    def flush(self) -> None:
        if self.broken:
            return
        try:
            self._stream.flush()
        except OSError as e:
            if not _closed_pipe(e):
                raise
            self._silence()

    def __getattr__(self, name):
        return getattr(self._stream, name)


def _redeliver(hook, main: int):
    """An unraisable-exception hook that answers a Ctrl-C or SIGTERM Python swallowed -- its
    KeyboardInterrupt raised inside a weakref callback, a ``__del__`` or a gc callback is printed
    as "Exception ignored" and dropped, and the command went on to finish and write its files
    (exit 0) -- by sending the signal again 20 ms later from a timer (SIGALRM, where the platform
    has one): it lands at the main thread's instruction then and goes to the handler of that
    moment -- which raises it, or holds it while a run's files are written
    (:func:`coplan.output.signals_deferred`), or ignores it where closing must not be cut short
    -- and should it land in another such callback, comes here again. Anything else goes to ``hook``."""
    import os
    import signal

    from . import failures

    if not hasattr(signal, "setitimer"):
        return hook
    pending: list[int] = []  # the signal to send again

    def on_alarm(signum, frame):
        if pending:
            sig = pending.pop()
            pending.clear()
            signal.raise_signal(sig)  # (its handler runs as this one returns, where the main thread is)

    signal.signal(signal.SIGALRM, on_alarm)

    closing: list[bool] = []  # the command is over: nothing is sent again

    def redeliver(args) -> None:
        if args.exc_type is not None and issubclass(args.exc_type, KeyboardInterrupt) and os.getpid() == main:
            if closing:  # (a Ctrl-C swallowed while the interpreter shuts down -- a sweep's cluster closing at exit:
                return   # a timer armed then fired once Python had reset SIGALRM to its default, exit 142)
            pending.append(signal.SIGTERM if failures.TERMINATED and hasattr(signal, "SIGTERM") else signal.SIGINT)
            signal.setitimer(signal.ITIMER_REAL, 0.02)
            return
        hook(args)

    redeliver.pending = pending  # (the console's exit: an interruption not yet sent again is still one)
    redeliver.closing = closing
    return redeliver


def run_console(app, err_console) -> None:
    """Run the typer ``app`` as the ``coplan`` command. SIGTERM is handled like Ctrl-C (the
    planners save what they have), then exits with 143 instead of 130. stdout and stderr are
    :class:`PipeSafeStream`: a reader closing them (``| head``, ``2>&1 | head``) is no error, the
    command finishes its work, writes its files and exits with its own code. With ``--json`` on
    the command line, a usage error found before the command ran is also printed as the JSON
    error document (:mod:`coplan.cli.failures`)."""
    import signal

    from . import failures
    from ..kinds import ExitCode

    terminated = failures.TERMINATED
    failures.CONSOLE.append(True)
    # worker processes forked from this one inherit the handler (coplan's own reset it to the
    # default at their start, coplan.workers.quiet_child: terminated, they end without a word)
    main = os.getpid()

    def on_term(signum, frame):
        if not terminated:
            terminated.append(signum)
            if os.getpid() != main:
                raise KeyboardInterrupt
            err_console.print("terminated (SIGTERM): stopping" + (
                "" if failures.written_note() else  # (its run is written: the message below says where)
                "; what is finished is kept (a solve its best plan, a sweep its finished rows; a live run writes nothing)"),
                markup=False)
        raise KeyboardInterrupt

    def on_int(signum, frame):
        failures.INTERRUPTED.append(signum)
        raise KeyboardInterrupt

    on_int.raises_keyboard_interrupt = True  # (as Python's own: a sweep may put its own before it)

    if hasattr(signal, "SIGTERM"):
        signal.signal(signal.SIGTERM, on_term)
    signal.signal(signal.SIGINT, on_int)
    sys.unraisablehook = hook = _redeliver(sys.unraisablehook, main)
    sys.stdout = PipeSafeStream(sys.stdout)
    sys.stderr = PipeSafeStream(sys.stderr)  # (progress and messages: ``2>&1 | head`` closes it too)
    try:
        if "--json" in sys.argv[1:]:
            sys.exit(failures.run_with_json_usage_errors(app))
        app()
    except KeyboardInterrupt:
        sys.exit(int(ExitCode.TERMINATED if terminated else ExitCode.INTERRUPTED))
    except SystemExit as e:
        if terminated and e.code in (int(ExitCode.INTERRUPTED), int(ExitCode.OK)):
            sys.exit(int(ExitCode.TERMINATED))
        if getattr(hook, "pending", None) and e.code == int(ExitCode.OK):  # (the command ended before the redelivery)
            sys.exit(int(ExitCode.INTERRUPTED))
        raise
    finally:
        if getattr(hook, "closing", None) is not None:
            hook.closing.append(True)
        if hasattr(signal, "setitimer"):  # (a redelivery still armed: at exit SIGALRM's default killed the process, 142)
            signal.setitimer(signal.ITIMER_REAL, 0)


class ProgressDisplay:
    """The CLI's progress: a :class:`coplan.progress.Reporter`.

    Lines of text go to stderr (dim), as they always did. On a terminal, ticks also draw rich
    progress bars on stderr -- one per level (a comparison's runs, and the stage of the solve
    inside it): the stage, the share of its work budget, elapsed time, and for a planner the
    incumbent and its gap to the lower bound. Not on a terminal (a log, a pipe, CI), no bars
    are drawn; under ``--json`` (``quiet``) nothing at all. ``hint``: a line printed once when a
    run has taken ``hint_after`` seconds (e.g. that ``--time-limit`` exists)."""

    def __init__(self, console, quiet: bool = False, hint: str | None = None, hint_after: float = 10.0):
        import time

        self.console, self.quiet, self.hint, self.hint_after = console, quiet, hint, hint_after
        self.bars = None if quiet or not console.is_terminal else self._bars()
        self.tasks: dict[int, int] = {}
        self.t0 = time.monotonic()
        self._clock = time.monotonic

    def _bars(self):
        from rich.progress import BarColumn, Progress, SpinnerColumn, TaskProgressColumn, TextColumn, TimeElapsedColumn

        return Progress(SpinnerColumn(), TextColumn("{task.description}"), BarColumn(), TaskProgressColumn(),
                        TimeElapsedColumn(), TextColumn("{task.fields[status]}"), console=self.console, transient=True)

    def __enter__(self) -> "ProgressDisplay":
        if self.bars is not None:
            self.bars.start()
        return self

    def __exit__(self, *exc) -> None:
        if self.bars is not None:
            self.bars.stop()

    def __call__(self, message: str) -> None:
        if self.quiet:
            return
        from .summary import safe

        self.console.print(f"[dim]{safe(message)}[/]", highlight=False)

    def tick(self, t) -> None:
        if self.quiet:
            return
        if self.hint and self._clock() - self.t0 > self.hint_after:
            self.console.print(f"[dim]note: {self.hint}[/]", highlight=False)
            self.hint = None
        if self.bars is None:
            return
        from .summary import safe

        status = ""
        if t.incumbent is not None:
            gap = f" ({t.gap:.1%} over the bound)" if t.gap is not None else ""
            status = f"incumbent {t.incumbent:.3f} s{gap}"
        elif t.note:
            status = safe(t.note)
        desc = safe(t.stage) + (f" [dim]{safe(t.unit)}[/]" if t.unit and t.total else "")
        total = None if t.total is None else float(t.total)
        if t.level not in self.tasks:
            self.tasks[t.level] = self.bars.add_task(desc, total=total, status=status)
        for level in [k for k in self.tasks if k > t.level]:  # an outer step ends the inner run's bar
            self.bars.remove_task(self.tasks.pop(level))
        self.bars.update(self.tasks[t.level], description=desc, total=total, completed=float(t.done), status=status)
