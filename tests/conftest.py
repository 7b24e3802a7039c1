"""Shared fixtures for coplan's tests (helpers live in each test module, so the suite does
not depend on how pytest imports this file)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

os.environ.setdefault("MPLBACKEND", "Agg")

from coplan.problem import Problem, default_problem_path, load_problem  # noqa: E402


def _trace_sigint_ignored():
    """Keep where SIGINT was last set to be ignored on this worker's main thread (its stack), for
    the warning below: something between two tests leaves it so, not yet traced."""
    import signal
    import threading
    import traceback

    real = signal.signal
    where: list[str] = []

    def traced(signum, handler):
        if signum == signal.SIGINT and handler is signal.SIG_IGN and threading.current_thread() is threading.main_thread():
            where[:] = ["".join(traceback.format_stack(limit=14)[:-1])]
        return real(signum, handler)

    signal.signal = traced
    return where


_SIGINT_IGNORED_AT = _trace_sigint_ignored()


_PREVIOUS_TEST: list[str] = []  # the last test this worker ran (a warning below names it)


@pytest.fixture(autouse=True)
def sigint_as_found(request):
    """Every test begins with Python's own Ctrl-C handler, as a fresh process has, and one that
    leaves another (ignored, or a C library's) is named in the warnings summary and the handler
    put back; a test that begins with another names what left it (a fixture's set-up, or a test
    before it on this worker). A CI run found SIGINT ignored as some tests began, and those that
    send themselves a Ctrl-C saw it dropped: a row's solve ended 0, not 130. Found since: it is
    each worker's *first* test (no test before it on that worker), so the worker process began
    with SIGINT ignored -- as every process does that a non-interactive shell starts in the
    background (``cmd &``, ``nohup``: POSIX has such a job ignore SIGINT), and Python then keeps
    it ignored; no test or fixture sets it."""
    import signal
    import threading
    import time
    import warnings

    if threading.current_thread() is not threading.main_thread():
        yield
        return
    found = signal.getsignal(signal.SIGINT)
    if found is not signal.default_int_handler:
        signal.signal(signal.SIGINT, signal.default_int_handler)
        warnings.warn(f"SIGINT's handler was {found!r} as this test began (left so by a fixture's set-up or a test "
                      "before it on this worker"
                      + (f", which was {_PREVIOUS_TEST[-1]}, its handler Python's own as it ended" if _PREVIOUS_TEST else "")
                      + "): set to Python's own"
                      + (f"; it was last ignored at:\n{_SIGINT_IGNORED_AT[0]}" if _SIGINT_IGNORED_AT else ""), RuntimeWarning)
    yield
    _PREVIOUS_TEST[:] = [request.node.nodeid]
    for _ in range(20):  # (a watcher that restores it may take a moment)
        if signal.getsignal(signal.SIGINT) is signal.default_int_handler:
            return
        time.sleep(0.1)
    now = signal.getsignal(signal.SIGINT)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    warnings.warn(f"this test left SIGINT's handler {now!r}: set back to Python's own", RuntimeWarning)


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
