"""Shared fixtures for coplan's tests (helpers live in each test module, so the suite does
not depend on how pytest imports this file)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

from coplan.problem import Problem, default_problem_path, load_problem  # noqa: E402


@pytest.fixture(autouse=True)
def sigint_as_found():
    """A test that leaves Ctrl-C's handler changed (ignored, or a C library's) is named in the
    warnings summary and the handler put back: the next test on that worker found a held Ctrl-C
    dropped, its run ending 0 not 130, once in a loaded CI run (the culprit not traced)."""
    import signal
    import threading
    import time
    import warnings

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    before = signal.getsignal(signal.SIGINT)
    yield
    for _ in range(20):  # (a watcher that restores it may take a moment)
        if signal.getsignal(signal.SIGINT) is before:
            return
        time.sleep(0.1)
    now = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, before if before is not None else signal.default_int_handler)
    warnings.warn(f"this test left SIGINT's handler {now!r} (was {before!r}): put back", RuntimeWarning)


@pytest.fixture(scope="session")
def problems_dir() -> Path:
    """The folder of the problem files shipped inside the package."""
    return default_problem_path().parent


@pytest.fixture(scope="session")
def greenhouse() -> Problem:
    """The lesson's three-arm cell (the default problem)."""
    return load_problem(default_problem_path())


@pytest.fixture(scope="session")
def single_arm() -> Problem:
    """The lesson's single-arm pick-and-place demo."""
    return load_problem(default_problem_path().parent / "single_arm.yaml")


@pytest.fixture
def fifo(tmp_path):
    """A named pipe fed from a thread: ``path = fifo(body)`` (as ``cat file | coplan ... /dev/stdin``)."""
    import threading

    threads = []

    def make(body: bytes, name: str = "fifo") -> Path:
        path = tmp_path / name
        os.mkfifo(path)

        def feed():
            with open(path, "wb") as f:
                f.write(body)

        t = threading.Thread(target=feed, daemon=True)
        t.start()
        threads.append(t)
        return path

    yield make
    for t in threads:
        t.join(5)
