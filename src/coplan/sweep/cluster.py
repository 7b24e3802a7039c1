"""A sweep's Dask side: the cluster or scheduler it runs on (:func:`connect`, :func:`close_cluster`),
how Ctrl-C reaches it (:class:`Interrupt`, :func:`sigint_ignored`), and the wait for results
(:func:`completed`, :class:`WorkerWatch`). :func:`coplan.sweep.run.run_sweep` uses them."""

from __future__ import annotations

import contextlib
import logging
import signal
import threading
import time
import warnings
from typing import Callable

__all__ = ["SCHEDULER_TIMEOUT", "WORKER_CHECK_SECONDS", "connect", "close_cluster", "sigint_ignored", "Interrupt",
           "completed", "refused", "WorkerWatch", "default_workers"]

SCHEDULER_TIMEOUT = "20s"  # how long a sweep waits for a --scheduler that does not answer
WORKER_CHECK_SECONDS = 5.0  # how often a sweep waiting on a --scheduler asks whether it has workers


def completed(ac, stop: Interrupt, poll: float = 0.2, idle: Callable[[], None] | None = None):
    """The futures of ``ac`` (a ``distributed.as_completed``) as they finish, asking ``stop``
    between short waits: a Ctrl-C swallowed where it landed still stops the sweep within
    ``poll`` seconds, not after the next solve. ``idle()`` is called at each wait."""
    while not ac.is_empty():
        stop.check()
        batch = ac.next_batch(block=False)
        if not batch:
            if idle is not None:
                idle()
            time.sleep(poll)
            continue
        for fut in batch:
            yield fut
            stop.check()


class WorkerWatch:
    """At most every ``every`` s of waiting, asks the scheduler how many workers it has and
    says so (``note``) when it has none -- a sweep on a ``--scheduler`` no worker has joined,
    or whose workers all left, waits for one, as Dask does; it said nothing -- and again when
    some connect."""

    def __init__(self, client, scheduler: str, note: Callable[[str], None], every: float | None = None):
        self.client, self.scheduler, self.note = client, scheduler, note
        self.every = WORKER_CHECK_SECONDS if every is None else every
        self.last = time.monotonic()
        self.none = False

    def __call__(self) -> None:
        now = time.monotonic()
        if now - self.last < self.every:
            return
        self.last = now
        try:
            n = len((self.client.scheduler_info() or {}).get("workers") or {})
        except Exception:  # noqa: BLE001 -- a scheduler that went away: the futures' own errors say so
            return
        if n == 0 and not self.none:
            self.note(f"the scheduler at {self.scheduler} has no workers: the sweep waits for one to connect "
                      f"(e.g. dask worker {self.scheduler}); Ctrl-C stops it, every finished row kept")
        elif n and self.none:
            self.note(f"{n} worker{'s' * (n != 1)} connected to {self.scheduler}: the sweep goes on")
        self.none = n == 0


def connect(workers: int, scheduler: str | None, retries: int):
    """``(client, cluster)``: a client of the ``scheduler`` given (no cluster of ours), else of a
    new ``LocalCluster`` of ``workers`` one-thread processes, a task retried ``retries`` times."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler is not None:
        refused(scheduler)
        return Client(scheduler, timeout=SCHEDULER_TIMEOUT), None
    with dask.config.set({"distributed.scheduler.allowed-failures": retries}), warnings.catch_warnings():
        # the scheduler's HTTP routes move to a free port when another cluster holds 8787: not news
        warnings.filterwarnings("ignore", message=r"Port \d+ is already in use", category=UserWarning)
        # the worker processes start with Ctrl-C ignored (a disposition a new process inherits):
        # Ctrl-C reaches the whole foreground group, and each worker printed its KeyboardInterrupt
        # traceback; this process stops the sweep and closes the cluster, which ends them
        with sigint_ignored() as held:
            cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                                   silence_logs=logging.CRITICAL)
        if held:  # Ctrl-C while the cluster started: stop now (it was dropped, and the sweep ran to its end)
            cluster.close()
            raise KeyboardInterrupt
        return Client(cluster), cluster


def refused(scheduler: str, tries: int = 3, pause: float = 0.5) -> None:
    """Raise :class:`ConnectionRefusedError` where nothing listens at a ``tcp://`` scheduler's
    port (``tries`` times, ``pause`` s apart: a scheduler that is starting has a moment): Dask's
    client retries a refused connection until its timeout, and a mistyped port cost a sweep
    :data:`SCHEDULER_TIMEOUT` before it said so. A host that does not answer at all (no refusal)
    is left to that timeout, and other protocols to Dask."""
    import socket

    from distributed.comm.addressing import parse_address, parse_host_port

    try:
        proto, loc = parse_address(scheduler)
        host, port = parse_host_port(loc) if proto == "tcp" else (None, None)
    except ValueError:  # (malformed: Dask's own error says so)
        return
    if host is None:
        return
    for k in range(tries):
        try:
            with socket.create_connection((host, port), timeout=2.0):
                return
        except ConnectionRefusedError:
            if k + 1 == tries:
                raise ConnectionRefusedError(f"connection refused at {host}:{port}: no scheduler listens there") from None
            time.sleep(pause)
        except OSError:  # (unresolved, unroutable, slow: Dask's own connect says so, within its timeout)
            return


@contextlib.contextmanager
def sigint_ignored():
    """SIGINT ignored in this process while the block runs, so that the processes it starts
    inherit that -- and a Ctrl-C meanwhile noticed, not dropped: the list yielded holds True
    afterwards if one came (main thread only: elsewhere Python cannot change a handler, and
    nothing is changed).

    An ignored signal is gone, and blocking it cannot hold it (the threads the cluster starts
    take it unblocked), so a watcher process in this process group, which a terminal's Ctrl-C
    reaches too, catches it and says so."""
    held: list[bool] = []
    if threading.current_thread() is not threading.main_thread():
        yield held
        return
    import subprocess
    import sys

    watcher = subprocess.Popen(  # (started before SIGINT is ignored here: it would inherit that)
        [sys.executable, "-c", "import signal, sys\nsignal.signal(signal.SIGINT, lambda *a: sys.exit(3))\n"
                               "print(flush=True)\nsys.stdin.read()"],
        stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
    try:
        watcher.stdout.readline()  # its handler is set
        old = signal.signal(signal.SIGINT, signal.SIG_IGN)
        try:
            yield held
        finally:
            try:
                watcher.stdin.close()
                if watcher.wait(timeout=10) != 0:
                    held.append(True)
            finally:  # (a watcher slow to end -- TimeoutExpired on a loaded machine -- left SIGINT ignored for good)
                signal.signal(signal.SIGINT, old)
    finally:
        if watcher.poll() is None:
            watcher.kill()
            watcher.wait()


class Interrupt:
    """While a sweep runs: Ctrl-C remembered as well as raised. Raised alone, it could land in a
    callback that swallows it (Dask's garbage-collection diagnosis: "Exception ignored in ...
    KeyboardInterrupt"), and the sweep ran on to its end and exited 0; the main loop asks
    :meth:`check` between its waits (main thread only; elsewhere nothing is changed)."""

    def __init__(self):
        self.seen = False
        self.old = None

    def _handler(self, signum, frame):
        self.seen = True
        if callable(self.old):  # (the console's records the Ctrl-C, then raises)
            self.old(signum, frame)
        raise KeyboardInterrupt

    def __enter__(self):
        h = signal.getsignal(signal.SIGINT)
        # (Python's own handler, or the ``coplan`` console's, which raises as it does: the sweep's
        # was never installed under the console, whose handler is not Python's)
        if threading.current_thread() is threading.main_thread() and (
                h is signal.default_int_handler or getattr(h, "raises_keyboard_interrupt", False)):
            self.old = signal.signal(signal.SIGINT, self._handler)
        return self

    def check(self) -> None:
        if self.seen:
            raise KeyboardInterrupt

    def __exit__(self, *exc):
        if self.old is not None:
            signal.signal(signal.SIGINT, self.old)
        return False


def default_workers() -> int:
    """A sweep's workers by default: every core this process may use."""
    from ..workers import cores

    return cores()


def close_cluster(client, cluster, interrupted: bool, client_log, client_level: int, lock) -> None:
    """Close the client and the cluster, restore the loggers' levels, release the folder."""
    # closing is not interrupted: a second Ctrl-C there left the cluster to Dask's exit hook,
    # which printed its KeyboardInterrupt traceback
    main = threading.current_thread() is threading.main_thread()
    old = signal.signal(signal.SIGINT, signal.SIG_IGN) if main else None
    # (after a SIGTERM, the comms closing under the client once printed distributed.batched's
    # CommClosedError traceback: the cluster is going away, which is not news)
    dask_log = logging.getLogger("distributed")
    dask_level = dask_log.level
    if interrupted:
        dask_log.setLevel(logging.CRITICAL)
    try:
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    finally:
        client_log.setLevel(client_level)
        dask_log.setLevel(dask_level)
        lock.release()
        if main:
            signal.signal(signal.SIGINT, old)
