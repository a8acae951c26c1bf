"""Worker processes for the batch evaluation of designs, and the signal handling around them.

A :class:`WorkerGroup` of ``n`` loky worker processes evaluates ``n`` chunks
of a batch while the calling process evaluates one more itself: ``n_jobs``
workers in all, ``n_jobs - 1`` of them extra processes. Each worker is
connected to the caller by its own Unix socket, over which it answers the
``(function, arguments)`` requests it receives, one after the other.

Why not one executor future per chunk (what :mod:`pipeline.evaluation` did
before): a future's arguments and result travel through the executor's
manager and feeder threads, which need the calling process's GIL. While the
caller evaluates its own chunk they wait for it, and while it waits for its
futures every hand-over between threads costs a switch. Measured on the
paper GA's 151 H4 batches (~24 designs, ~23 ms on one core each), on
2 cores (``python -m benchmarks.ga --dispatch``, 9 runs): one future per
worker 1.64-1.77x one core; the caller's chunk plus one future 1.68-1.83x;
the caller's chunk plus one request over a socket 1.84-1.93x, faster than
both in every run.

Loky still starts and ends the processes, with its environment for workers
(one thread per numerical library). The serving runs in a daemon thread of
each worker, started by loky's initializer (:func:`_start_server`), so loky
never has a task running: its own exit hook (which waits for running tasks)
ends the workers as usual. A worker whose connection closes ends itself, so
the workers of a run killed by SIGKILL (the OOM killer) exit at once.
Ctrl-C: the workers start with SIGINT blocked (:func:`submit_masked`); the
main process alone handles it and kills them (:func:`shutdown_workers`).
"""

from __future__ import annotations

import atexit
import contextlib
import importlib
import multiprocessing.resource_tracker
import os
import pickle
import shutil
import signal
import socket
import tempfile
import threading
import time
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from multiprocessing.connection import Client, Connection
from typing import TypeVar

from joblib.externals.loky import ProcessPoolExecutor
from joblib.externals.loky.backend.reduction import dumps as loky_dumps
from joblib.externals.loky.process_executor import BrokenProcessPool

T = TypeVar("T")

#: one thread per worker in numerical libraries (as joblib sets for its loky workers):
#: the workers already use every core
_WORKER_ENV = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                                      "NUMBA_NUM_THREADS")}

#: whether this platform has Unix sockets (not Windows): without them callers use joblib's dispatch
AVAILABLE = hasattr(socket, "AF_UNIX")

#: seconds between two checks, while waiting for the workers to connect, that none has died
_ACCEPT_POLL = 0.05
#: seconds a worker may take to start and connect (~1.5 s here) before the group gives up
CONNECT_TIMEOUT = 120.0


def submit_masked(pool: ProcessPoolExecutor, func: Callable, argument_tuples: list[tuple]) -> list[Future]:
    """``pool.submit(func, *args)`` for each tuple, with SIGINT blocked in this thread.

    Why: Ctrl-C sends SIGINT to the whole process group. A loky worker that
    receives it while it is still importing prints a ``KeyboardInterrupt``
    traceback of its own; one that receives it while computing raises inside
    the task. Workers (and loky's manager thread, which may respawn them) are
    started inside ``submit`` and inherit this thread's signal mask, so they
    never see SIGINT: the main process alone handles Ctrl-C and kills them
    (:func:`shutdown_workers`).
    """
    if not hasattr(signal, "pthread_sigmask"):  # Windows: no process-group SIGINT
        return [pool.submit(func, *args) for args in argument_tuples]
    # Python 3.11's multiprocessing resource tracker, which loky starts with the
    # first worker, *unblocks* SIGINT after starting (it does not restore the
    # mask): start it before the mask is set
    multiprocessing.resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        return [pool.submit(func, *args) for args in argument_tuples]
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextlib.contextmanager
def sigint_deferred() -> Iterator[None]:
    """Within the block, a Ctrl-C (SIGINT) is only noted; it is delivered again, to the
    usual handler, when the block ends.

    Why: numba compiling a kernel must not be interrupted. A ``KeyboardInterrupt``
    raised inside llvmlite's compile callback is swallowed (the run then goes on
    as if Ctrl-C had not been pressed), and one raised elsewhere in the compiler
    can leave a half-built library behind (``RuntimeError: no compiled object
    yet``). Python runs signal handlers in the main thread only, so elsewhere
    this does nothing.
    """
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    received: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: received.append(signum))
    try:
        yield
    finally:
        # None: a handler not installed from Python; the default is the closest
        signal.signal(signal.SIGINT, signal.SIG_DFL if previous is None else previous)
        if received:
            signal.raise_signal(signal.SIGINT)


def _start_server(address: str, preload: tuple[str, ...]) -> None:
    """Each worker's loky initializer (run once, as the process starts): import ``preload``,
    connect to ``address``, say its pid, and serve in a daemon thread (:func:`_serve`).

    An initializer, not a task: each process runs it exactly once, so every
    worker has its own connection, and loky never has a task waiting on one.
    """
    for module in preload:  # the imports (~1.5 s) overlap the caller's work before its first request
        importlib.import_module(module)
    connection = Client(address, family="AF_UNIX")
    connection.send(os.getpid())
    threading.Thread(target=_serve, args=(connection,), name="pm-design-server", daemon=True).start()


def _serve(connection: Connection) -> None:
    """Answer each request (a pickled ``(func, args)``) with ``(True, func(*args))`` or
    ``(False, exception)``; an exception while unpickling the request is answered too.

    When the connection closes (the group was closed, or the calling process
    ended, even by SIGKILL) this process has nothing left to do: it exits.
    """
    try:
        while True:
            request = connection.recv_bytes()
            try:
                func, args = pickle.loads(request)
                reply = (True, func(*args))
            except Exception as exc:  # noqa: BLE001 - handed to the caller, which raises it
                reply = (False, exc)
            try:
                connection.send(reply)
            except Exception as exc:  # noqa: BLE001 - e.g. an exception that cannot be pickled
                connection.send((False, RuntimeError(f"{type(exc).__name__}: {exc}")))
    except (EOFError, OSError):
        pass
    os._exit(0)


class WorkerGroup:
    """``n_workers`` loky worker processes, each answering requests over its own connection.

    Parameters
    ----------
    n_workers : int
        Worker processes (>= 1).
    preload : tuple of str
        Modules each worker imports as soon as it starts.

    Start-up (a new interpreter and the imports, ~1.5 s) begins here and
    overlaps whatever the caller does until its first :meth:`map`.
    """

    def __init__(self, n_workers: int, preload: tuple[str, ...] = ()) -> None:
        # a private directory (mode 0700): no other user can connect to the socket
        # (short names: a socket's path is limited to ~100 bytes); removed once all are connected
        self._directory = tempfile.mkdtemp(prefix="pmw-")
        self._address = os.path.join(self._directory, "s")
        self._listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        self._listener.bind(self._address)
        self._listener.listen(n_workers)
        self._listener.settimeout(_ACCEPT_POLL)
        self._connections: list[Connection] = []
        #: process ids of the connected workers
        self.pids: list[int] = []
        self.closed = False
        self._lock = threading.Lock()  # one batch at a time: replies come back in request order
        self._n_workers = n_workers
        self._pool: ProcessPoolExecutor | None = None
        try:
            # no idle timeout: a serving worker has no loky task, and would otherwise be ended while busy
            self._pool = ProcessPoolExecutor(max_workers=n_workers, env=_WORKER_ENV, timeout=None,
                                             initializer=_start_server, initargs=(self._address, preload))
            # loky starts every worker at the first submit; a worker whose initializer fails
            # ends, and these futures then hold BrokenProcessPool
            self._started = submit_masked(self._pool, int, [()] * n_workers)
        except BaseException:  # e.g. Ctrl-C, delivered as the signal mask is restored: end what was started
            self.close(kill=True)
            raise

    @property
    def n_workers(self) -> int:
        return self._n_workers

    def _connect(self) -> None:
        """Wait until every worker has connected; BrokenProcessPool if one ended first
        or if they have not all connected within :data:`CONNECT_TIMEOUT`."""
        deadline = time.monotonic() + CONNECT_TIMEOUT
        while len(self._connections) < self.n_workers:
            try:
                sock, _ = self._listener.accept()
            except TimeoutError:
                for started in self._started:
                    if started.done() and started.exception() is not None:
                        raise started.exception()
                if time.monotonic() > deadline:
                    raise BrokenProcessPool(f"{self.n_workers - len(self._connections)} of {self.n_workers} "
                                            f"worker processes did not connect within {CONNECT_TIMEOUT:g} s")
                continue
            sock.setblocking(True)
            connection = Connection(sock.detach())
            self.pids.append(connection.recv())
            self._connections.append(connection)
        if self._directory is not None:
            self._listener.close()
            shutil.rmtree(self._directory, ignore_errors=True)
            self._directory = None

    def map(self, func: Callable[..., T], argument_tuples: list[tuple], local: Callable[[], T]) -> list[T]:
        """``[local(), func(*args_1), func(*args_2), ...]``: each tuple on its own worker, ``local`` here meanwhile.

        Raises what a call raised (the first, in order), and BrokenProcessPool
        if a worker died. After a worker's death or an interruption of the
        caller (Ctrl-C) the group is closed and its workers killed.
        """
        if len(argument_tuples) > self.n_workers:
            raise ValueError(f"{len(argument_tuples)} requests for {self.n_workers} workers")
        # pickled first (by loky's pickler, cloudpickle: a lambda works too), so that a
        # request that cannot be pickled raises here, before anything is sent
        requests = [bytes(loky_dumps((func, args))) for args in argument_tuples]
        local_error: Exception | None = None
        with self._lock:
            if self.closed:
                raise BrokenProcessPool("the worker group is closed")
            try:
                self._connect()
                busy = self._connections[:len(argument_tuples)]
                for connection, request in zip(busy, requests):
                    connection.send_bytes(request)
                try:
                    mine = local()
                except Exception as exc:  # noqa: BLE001 - raised below, once the replies owed are read
                    local_error = exc
                replies = [connection.recv() for connection in busy]
            except (EOFError, OSError) as exc:
                self.close(kill=True)
                raise BrokenProcessPool(f"a worker process ended unexpectedly ({exc!r})") from exc
            except BaseException:  # Ctrl-C, or a worker that died while connecting: replies may be owed
                self.close(kill=True)
                raise
        if local_error is not None:
            raise local_error
        results = [mine]
        for ok, value in replies:
            if not ok:
                raise value
            results.append(value)
        return results

    def close(self, kill: bool = False) -> None:
        """End the workers: killed (``kill``), or through loky's shutdown (call it between batches)."""
        if self.closed:
            return
        self.closed = True
        self._listener.close()  # a worker not yet connected fails to connect: loky ends it
        # loky ends the processes (their serving threads are daemons) ...
        if self._pool is not None:
            self._pool.shutdown(wait=not kill, kill_workers=kill)
        for connection in self._connections:  # ... and a worker it has not yet ended exits on the closed connection
            connection.close()
        if self._directory is not None:
            shutil.rmtree(self._directory, ignore_errors=True)


#: this package's worker groups by size (kept apart from joblib's own reusable executor,
#: which joblib's Parallel configures its own way: sharing it breaks joblib's loky backend)
_GROUPS: dict[tuple[int, tuple[str, ...]], WorkerGroup] = {}


def worker_group(n_workers: int, preload: tuple[str, ...] = ()) -> WorkerGroup:
    """A :class:`WorkerGroup` of ``n_workers`` processes, kept for reuse (a new one if it was closed)."""
    key = (n_workers, preload)
    if key not in _GROUPS or _GROUPS[key].closed:
        _GROUPS[key] = WorkerGroup(n_workers, preload)
    return _GROUPS[key]


def shutdown_workers(kill: bool = False) -> None:
    """End every worker group of this package (at exit, and at once after Ctrl-C)."""
    while _GROUPS:
        _, group = _GROUPS.popitem()
        group.close(kill=kill)


atexit.register(shutdown_workers)
