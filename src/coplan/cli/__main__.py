"""``python -m coplan.cli``: the ``coplan`` command."""

from . import main

main()
