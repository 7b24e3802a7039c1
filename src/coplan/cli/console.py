"""Small things the command line needs around its text (no heavy imports: ``coplan --help`` loads this).

* :class:`FlagsGroup` -- the ``typer`` group class that shows flags (``--json``, ``--animate``,
  ``--help``) as taking no value in ``--help`` (typer 0.29's rich help prints ``<bool>`` after them).
* :func:`run_console` -- the console entry point's body (signals, pipes, ``--json`` usage errors).
* :class:`PipeSafeStdout` -- stdout that survives a reader closing the pipe (``coplan problems |
  head -1``): the first ``BrokenPipeError`` sends fd 1 to ``/dev/null`` and every later write is
  dropped, so the command finishes its work and exits with its own code, with no traceback and no
  "Exception ignored" message at exit (the handling the Python documentation recommends for SIGPIPE).
"""

from __future__ import annotations

import os
import sys

from typer.core import TyperGroup, TyperOption

__all__ = ["FlagsGroup", "PipeSafeStdout", "run_console"]


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


class PipeSafeStdout:
    """A stand-in for ``sys.stdout`` that turns a closed pipe into silence (see the module docstring)."""

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
        except BrokenPipeError:
            self._silence()
            return len(text)

    def flush(self) -> None:
        if self.broken:
            return
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._silence()

    def __getattr__(self, name):
        return getattr(self._stream, name)


def run_console(app, err_console) -> None:
    """Run the typer ``app`` as the ``coplan`` command. SIGTERM is handled like Ctrl-C (the
    planners save what they have), then exits with 143 instead of 130. stdout is a
    :class:`PipeSafeStdout`: a reader closing it (``| head``) is no error, the command finishes
    and exits with its own code. With ``--json`` on the command line, a usage error found before
    the command ran is also printed as the JSON error document (:mod:`coplan.cli.failures`)."""
    import signal

    from . import failures
    from ..kinds import ExitCode

    terminated = failures.TERMINATED

    def on_term(signum, frame):
        if not terminated:
            terminated.append(signum)
            err_console.print("terminated (SIGTERM): saving what there is", markup=False)
        raise KeyboardInterrupt

    if hasattr(signal, "SIGTERM"):
        signal.signal(signal.SIGTERM, on_term)
    sys.stdout = PipeSafeStdout(sys.stdout)
    try:
        if "--json" in sys.argv[1:]:
            sys.exit(failures.run_with_json_usage_errors(app))
        app()
    except KeyboardInterrupt:
        sys.exit(int(ExitCode.TERMINATED if terminated else ExitCode.INTERRUPTED))
    except SystemExit as e:
        if terminated and e.code in (int(ExitCode.INTERRUPTED), int(ExitCode.OK)):
            sys.exit(int(ExitCode.TERMINATED))
        raise
