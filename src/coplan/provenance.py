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

__all__ = ["software_record", "source_commit", "openblas_kernels", "DECIDING"]

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


@functools.lru_cache(maxsize=1)
def source_commit() -> str | None:
    """Where coplan runs from a git checkout (an editable install, or ``src`` on the path): its
    commit, ``git describe --always --dirty`` (``-dirty``: uncommitted changes); None for an
    installed copy or without git. The version alone (0.1.0 over a thousand commits) could not
    say which code made a plan."""
    import subprocess
    from pathlib import Path

    root = Path(__file__).resolve().parents[2]
    if not (root / ".git").exists() or not (root / "src" / "coplan").is_dir():
        return None
    try:
        out = subprocess.run(["git", "describe", "--always", "--dirty"], cwd=root, capture_output=True, text=True,
                             timeout=10, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None
    return out or None


def openblas_kernels() -> str | None:
    """The kernel each OpenBLAS loaded in this process runs, by library (threadpoolctl), e.g.
    ``"libscipy_openblas: SkylakeX; libscipy_openblas64_: SkylakeX"``: ``OPENBLAS_CORETYPE`` is
    read as each library loads, so one loaded before coplan pinned it (SciPy imported first in
    a notebook) runs the CPU's own kernel whatever the environment says now. None when none is
    loaded or threadpoolctl cannot tell."""
    try:
        from threadpoolctl import threadpool_info

        found = {(os.path.basename(i.get("filepath") or "?").split("-")[0].split(".so")[0], str(i.get("architecture")))
                 for i in threadpool_info() if i.get("internal_api") == "openblas"}
    except Exception:  # noqa: BLE001 -- a record, never a failed solve: threadpoolctl has raised AttributeError on some builds
        return None
    return "; ".join(f"{lib}: {arch}" for lib, arch in sorted(found)) or None


def software_record() -> dict:
    """``{"coplan": version, "source": its git commit where it runs from a checkout (else None),
    "python": ..., "machine": ..., <each of DECIDING>: version, "openblas_coretype":
    OPENBLAS_CORETYPE in effect, "coplan_openblas_coretype": the override, "openblas_kernels":
    the kernel each loaded OpenBLAS runs (:func:`openblas_kernels`)}``."""
    from . import __version__

    return {"coplan": __version__, "source": source_commit(), "python": platform.python_version(),
            "machine": platform.machine(), **dict(_versions()), "openblas_coretype": os.environ.get("OPENBLAS_CORETYPE"),
            "coplan_openblas_coretype": os.environ.get("COPLAN_OPENBLAS_CORETYPE"), "openblas_kernels": openblas_kernels()}
