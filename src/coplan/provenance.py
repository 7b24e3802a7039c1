"""What made a file: coplan's version and the software that decides its plans.

``plan.json`` and ``sweep.json`` carry :func:`software_record`, so that a published plan says
which versions made it (``pyproject.toml`` asks only for minimum versions: a later install may
plan differently) and the ``OPENBLAS_CORETYPE`` in effect (coplan pins the kernel IPOPT's
OpenBLAS runs on when it is imported, unless ``COPLAN_OPENBLAS_CORETYPE=native``: see the README).
"""

from __future__ import annotations

import functools
import os
import platform
from importlib import metadata

__all__ = ["software_record", "DECIDING"]

#: The distributions whose versions can change a plan (or its verdict).
DECIDING = ("numpy", "scipy", "casadi", "ortools", "ruckig", "python-fcl")


@functools.lru_cache(maxsize=1)
def _versions() -> tuple[tuple[str, str | None], ...]:
    out = []
    for name in DECIDING:
        try:
            out.append((name, metadata.version(name)))
        except metadata.PackageNotFoundError:
            out.append((name, None))
    return tuple(out)


def software_record() -> dict:
    """``{"coplan": version, "python": ..., "machine": ..., <each of DECIDING>: version,
    "openblas_coretype": OPENBLAS_CORETYPE in effect, "coplan_openblas_coretype": the override}``."""
    from . import __version__

    return {"coplan": __version__, "python": platform.python_version(), "machine": platform.machine(),
            **dict(_versions()), "openblas_coretype": os.environ.get("OPENBLAS_CORETYPE"),
            "coplan_openblas_coretype": os.environ.get("COPLAN_OPENBLAS_CORETYPE")}
