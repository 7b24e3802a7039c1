"""``python -m coplan.cli``: the ``coplan`` command."""

from .commands import main

main()
