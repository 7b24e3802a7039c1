"""The line every benchmark script prints first: what was measured, where and when, so that a
published figure names its run (its commit was typed by hand before, and came out wrong).

``commit`` is ``git describe --always --dirty`` of the checkout (``-dirty``: uncommitted changes),
and the tree of ``src/`` (a commit that changes only documentation plans the same); the machine's
cores and its load average at the start (the times depend on both, the plans on neither)."""

from __future__ import annotations

import os
import platform
import subprocess
import time
from pathlib import Path

__all__ = ["run_header", "src_commit"]

ROOT = Path(__file__).resolve().parents[1]


def _git(*args: str) -> str:
    try:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=30, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return "unknown"


def src_commit() -> str:
    """The code a figure was measured on: the git tree of ``src/`` (so a commit that changes only
    documentation keeps it), ``+dirty`` if ``src/`` has uncommitted changes; ``unknown`` outside git."""
    tree = _git("rev-parse", "--short", "HEAD:src")
    if tree == "unknown":
        return tree
    status = _git("status", "--porcelain", "--untracked-files=no", "--", "src")
    return tree + ("+dirty" if status and status != "unknown" else "")


def run_header() -> str:
    """``commit 3f06369-dirty (src tree f366d46), coplan 0.1.0, python 3.11.7, 2 cores, load 0.4
    0.6 0.5, 2026-12-02 15:40 UTC``."""
    import coplan

    load = " ".join(f"{x:.1f}" for x in os.getloadavg()) if hasattr(os, "getloadavg") else "unknown"
    return (f"commit {_git('describe', '--always', '--dirty')} (src tree {src_commit()}), "
            f"coplan {coplan.__version__}, python {platform.python_version()}, {os.cpu_count()} cores, load {load}, "
            f"{time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}")
