"""How many processes a run may use: ``auto`` (the cores this process may use, at most 8) or a
whole number from 1 to :data:`MAX_WORKERS` -- one rule for ``--workers``, options files and
options built in Python (``OptimalOptions``, ``RowOptions``, ``MovingOptions``)."""

from __future__ import annotations

import numbers
import os

from .errors import Issue, OptionsError, found

__all__ = ["MAX_WORKERS", "cores", "default_workers", "workers_issue", "settle_workers", "mp_context", "process_pool", "quiet_child"]

#: The most processes one run may ask for: a typo such as 2000 is refused, not started.
MAX_WORKERS = 256


def cores() -> int:
    """The cores this process may use."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def default_workers() -> int:
    """The cores this process may use, at most 8: what ``--workers auto`` asks for."""
    return min(8, cores())


def workers_issue(v) -> str | None:
    """The message for a bad number of processes ``v`` (``auto`` is good), or None."""
    if isinstance(v, str) and v.strip().lower() == "auto":
        return None
    ok = isinstance(v, numbers.Real) and not isinstance(v, bool) and float(v).is_integer() and 1 <= v <= MAX_WORKERS
    return None if ok else f"expected a whole number of processes from 1 to {MAX_WORKERS}, or auto; found {found(v)}"


def settle_workers(obj, name: str = "workers", collect: bool = False) -> list[Issue]:
    """For a frozen options dataclass built in Python: its ``name`` field checked
    (:func:`workers_issue`, :class:`OptionsError` naming the class) and settled to an ``int``
    (``auto``: :func:`default_workers`; ``2.0``: 2). ``collect``: the issue is returned, not
    raised (the caller reports it with its other fields': every bad field at once)."""
    v = getattr(obj, name)
    msg = workers_issue(v)
    if msg is not None:
        if collect:
            return [Issue(name, msg)]
        raise OptionsError([Issue(name, msg)], type(obj).__name__)
    object.__setattr__(obj, name, default_workers() if isinstance(v, str) else int(v))
    return []


def mp_context():
    """The multiprocessing context coplan's workers start in: fork on Linux (nothing to
    re-import; what the parent computed is inherited), spawn elsewhere."""
    import multiprocessing
    import sys

    return multiprocessing.get_context("fork" if sys.platform.startswith("linux") else "spawn")


def quiet_child() -> None:
    """In a worker process: SIGTERM ends it as the default does. A forked worker inherits the
    command line's handler, which raises KeyboardInterrupt -- inside multiprocessing's own exit
    when the parent terminates a worker that has finished, which printed its traceback."""
    import signal

    if hasattr(signal, "SIGTERM"):
        signal.signal(signal.SIGTERM, signal.SIG_DFL)


_BUSY = [False]  # in a pool's worker: whether it is running a task now (:func:`_pool_child`)


def _task(fn, *args, **kwargs):
    """A pool task, marked busy while it runs (:func:`_pool_child`)."""
    _BUSY[0] = True
    try:
        return fn(*args, **kwargs)
    finally:
        _BUSY[0] = False


def _pool_child() -> None:
    """A pool's worker: :func:`quiet_child`, and a Ctrl-C that finds it between tasks ends it
    (SystemExit) without a word (it raised KeyboardInterrupt inside multiprocessing's wait for the next task,
    which printed a traceback under the command's own message); inside a task it raises
    KeyboardInterrupt there as before (the optimal cell planner turns it into its best plan)."""
    import signal

    quiet_child()

    def on_int(signum, frame):
        if _BUSY[0]:
            raise KeyboardInterrupt
        # (SystemExit: multiprocessing ends the process without a traceback, and the locks the wait
        # holds are released on the way out -- os._exit there left the other workers waiting on them)
        raise SystemExit(130)

    signal.signal(signal.SIGINT, on_int)


def process_pool(workers: int):
    """A ``ProcessPoolExecutor`` of ``workers`` processes in :func:`mp_context` (each
    :func:`_pool_child`, its tasks marked busy), or None for one (the work then runs in this process)."""
    if workers <= 1:
        return None
    import sys
    from concurrent.futures import ProcessPoolExecutor

    class Pool(ProcessPoolExecutor):
        def submit(self, fn, /, *args, **kwargs):
            return super().submit(_task, fn, *args, **kwargs)

    if sys.platform == "win32":  # (ProcessPoolExecutor refuses more than 61 there: --workers 100 was an internal error)
        workers = min(workers, 61)
    return Pool(max_workers=workers, mp_context=mp_context(), initializer=_pool_child)
