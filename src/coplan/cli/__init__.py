"""The ``coplan`` command (``coplan = coplan.cli:main``): a thin typer front end over the library.

- :mod:`.commands`: the commands and ``main`` (the console entry point)
- :mod:`.failures`: exit codes and the ``--json`` error document of every failure
- :mod:`.console`: the console runner (SIGTERM, closed pipes) and ``--help`` formatting
- :mod:`.summary`: the solve summary and verification report
- :mod:`.figures`, :mod:`.files`, :mod:`.live`, :mod:`.sweep`: the plot/animate/view, export/schema,
  feed/run and sweep commands

Light to import: NumPy, SciPy and the planners load inside the commands that use them.
"""

__all__ = ["app", "main"]


def main() -> None:
    """The console entry point: the commands load here, where a Ctrl-C or SIGTERM while they do
    exits 130 or 143 quietly (it printed Python's traceback of the import, and the process died
    by the signal), then :func:`coplan.cli.commands.main` runs."""
    import os
    import signal
    import sys

    # a stream closed before coplan started (``coplan ... >&-``: Python makes it None) writes to the
    # null device, as one whose reader has gone does (console.PipeSafeStream): the command does its
    # work, writes its files and exits with its own code (it died in a traceback, exit 120)
    if sys.stdout is None:
        sys.stdout = open(os.devnull, "w", encoding="utf-8")
    if sys.stderr is None:
        sys.stderr = open(os.devnull, "w", encoding="utf-8")

    def stopped(code: int, what: str):
        """Exit ``code`` while the commands load; with ``--json``, the error document first (stdout was
        left empty: a script had no document to read)."""
        if "--json" in sys.argv[1:]:
            import json

            message = f"{what} as coplan started: nothing was done"
            command = next((a for a in sys.argv[1:] if not a.startswith("-")), None)
            # (failures.error_document's fields, built here: that module may itself be loading)
            print(json.dumps(indent=1, obj={"format": "coplan.error/1", "command": command, "exit_code": code, "error": what.split(" ")[0],
                              "message": message, "errors": [{"file": None, "path": None, "line": None, "expected": None,
                                                              "found": None, "message": message}]}), flush=True)
        sys.exit(code)

    if hasattr(signal, "SIGTERM"):  # (until the console's own handler)
        signal.signal(signal.SIGTERM, lambda signum, frame: stopped(143, "terminated (SIGTERM)"))
    # a character the stream cannot encode is escaped, not an error: on Windows a redirected stdout
    # is the ANSI code page, strict, and a problem named in Chinese ended a finished solve with
    # "internal error (UnicodeEncodeError)", exit 1, no summary
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.reconfigure(errors="backslashreplace")
        except (AttributeError, ValueError, OSError):  # (not a TextIOWrapper: a test's, or a closed one)
            pass
    try:
        from .commands import main as run
    except KeyboardInterrupt:
        stopped(130, "interrupted (Ctrl-C)")
    run()


def __getattr__(name: str):
    if name == "app":  # (imported on first use: ``import coplan.cli`` stays light for the entry point)
        from .commands import app

        return app
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
