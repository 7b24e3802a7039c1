"""The ``coplan`` command (``coplan = coplan.cli:main``): a thin typer front end over the library.

- :mod:`.commands`: the commands and ``main`` (the console entry point)
- :mod:`.failures`: exit codes and the ``--json`` error document of every failure
- :mod:`.console`: the console runner (SIGTERM, closed pipes) and ``--help`` formatting
- :mod:`.summary`: the solve summary and verification report
- :mod:`.files`, :mod:`.live`, :mod:`.sweep`: the export/schema, feed/run and sweep commands

Light to import: NumPy, SciPy and the planners load inside the commands that use them.
"""

from .commands import app, main

__all__ = ["app", "main"]
