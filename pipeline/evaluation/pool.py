"""The fitness worker processes, on joblib's public loky API, and the signal handling around them.

A :class:`FitnessPool` is a loky ``ProcessPoolExecutor`` (``joblib.externals.loky``)
of ``n`` worker processes, kept for reuse between batches (:func:`fitness_pool`).
:meth:`FitnessPool.map` sends ``n`` chunks of a batch to the workers as futures
while the calling process evaluates one more chunk itself: ``n + 1`` chunks
on ``n + 1`` cores.

* A worker's exception is raised in the caller with the worker's traceback
  attached (loky chains it as the exception's ``__cause__``).
* No wait without a time limit: a batch whose futures are not done within
  its timeout kills the pool and raises ``TimeoutError``.
* A worker that dies (e.g. the OOM killer) breaks that batch
  (``BrokenProcessPool``); the pool is then dropped and the next batch starts
  a new one. The workers of a process killed by SIGKILL end within
  :data:`PARENT_POLL` seconds (:func:`start_worker`).
* Ctrl-C: workers are started with SIGINT blocked (as is loky's manager
  thread, which starts any later worker); the main process alone handles it
  and kills them (:func:`shutdown_pools`).
"""

from __future__ import annotations

import atexit
import concurrent.futures
import contextlib
import importlib
import logging
import multiprocessing.resource_tracker
import os
import signal
import threading
import time
from collections.abc import Callable, Iterator
from typing import TypeVar

from joblib import cpu_count
from joblib.externals.loky import ProcessPoolExecutor
from joblib.externals.loky.process_executor import BrokenProcessPool

T = TypeVar("T")
log = logging.getLogger(__name__)

#: one thread per worker in numerical libraries (as joblib sets for its loky workers):
#: the workers already use every core
WORKER_ENV = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS", "NUMBA_NUM_THREADS")}


#: seconds between two checks, in each worker, that the process that started it is alive
PARENT_POLL = 0.5

_CAPS_LOGGED: set[tuple[int, int]] = set()


def usable_cores() -> int:
    """The cores this process may use (``joblib.cpu_count()``: CPU affinity and cgroup quotas)."""
    return max(1, int(cpu_count()))


def worker_count(n_jobs: int) -> int:
    """The processes a run evaluates with: ``n_jobs`` capped at the cores this process may use.

    ``joblib.cpu_count()`` honours the CPU affinity (``taskset``, a SLURM task's
    ``cpus_per_task``) and cgroup quotas (containers). Whatever the launcher,
    a run never starts more fitness workers than it has cores; a cap is logged.
    """
    cores = usable_cores()
    if n_jobs > cores and (n_jobs, cores) not in _CAPS_LOGGED:
        _CAPS_LOGGED.add((n_jobs, cores))
        log.info("parallel.n_jobs=%d capped at %d: the cores this process may use", n_jobs, cores)
    return max(1, min(n_jobs, cores))


@contextlib.contextmanager
def sigint_blocked() -> Iterator[None]:
    """SIGINT blocked in this thread: processes and threads started within inherit the mask.

    Why: Ctrl-C sends SIGINT to the whole process group. A loky worker that
    receives it while importing prints a ``KeyboardInterrupt`` traceback of its
    own; one that receives it while computing raises inside the task.
    """
    if not hasattr(signal, "pthread_sigmask"):  # Windows: no process-group SIGINT
        yield
        return
    # Python 3.11's multiprocessing resource tracker, which loky starts with the
    # first worker, *unblocks* SIGINT after starting (it does not restore the
    # mask): start it before the mask is set
    multiprocessing.resource_tracker.ensure_running()
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT})
    try:
        yield
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


#: the warning loky's resource tracker prints at exit when it removes a semaphore that a pool
#: interrupted while starting left behind (it cleans up; the message is the only trace)
_TRACKER_WARNING = "ignore:resource_tracker:UserWarning"


def _quiet_resource_tracker() -> None:
    """Filter :data:`_TRACKER_WARNING` in the processes this one starts (loky's resource tracker
    is one: it inherits the environment when the first pool starts it).

    Why: a Ctrl-C while the workers start ends the run with its one ``error:`` line; the
    tracker's leaked-semaphore warning, printed after it from the tracker's own process, would
    add lines of noise about a semaphore it has just removed."""
    filters = [f for f in os.environ.get("PYTHONWARNINGS", "").split(",") if f]
    if _TRACKER_WARNING not in filters:
        os.environ["PYTHONWARNINGS"] = ",".join([*filters, _TRACKER_WARNING])


def start_worker(parent: int, preload: tuple[str, ...]) -> None:
    """Each worker's loky initializer: watch the parent, then import ``preload`` (so that the
    imports, ~1.5 s, overlap the caller's work before its first batch).

    Why the watch: a loky worker holds both ends of its call queue, so it never sees its
    parent die; after a SIGKILL of the run (the OOM killer) it would wait for a task for
    ever (or ~35 s with loky's idle timeout). A daemon thread ends it once it is orphaned.
    """
    threading.Thread(target=_exit_when_orphaned, args=(parent,), name="pm-design-orphan-watch", daemon=True).start()
    for module in preload:
        importlib.import_module(module)


def _exit_when_orphaned(parent: int) -> None:
    while os.getppid() == parent:
        time.sleep(PARENT_POLL)
    os._exit(1)


class FitnessPool:
    """``n_workers`` loky worker processes, started (in the background) by the constructor.

    Parameters
    ----------
    n_workers : int
        Worker processes (>= 1).
    preload : tuple of str
        Modules each worker imports as soon as it starts.
    """

    def __init__(self, n_workers: int, preload: tuple[str, ...] = ()) -> None:
        self.n_workers = n_workers
        self.closed = False
        _quiet_resource_tracker()
        # no idle timeout: the pool is kept for the run (ended at exit, or at once after Ctrl-C)
        self._executor = ProcessPoolExecutor(
            max_workers=n_workers,
            env=WORKER_ENV,
            timeout=None,
            initializer=start_worker,
            initargs=(os.getpid(), preload),
        )
        try:
            with sigint_blocked():  # loky starts the workers and its manager thread at the first submit
                self._executor.submit(os.getpid)
        except BaseException:  # e.g. Ctrl-C, delivered as the mask is restored: end what was started
            self.close(kill=True)
            raise

    def map(
        self, func: Callable[..., T], argument_tuples: list[tuple], local: Callable[[], T], timeout: float
    ) -> list[T]:
        """``[local(), func(*args_1), func(*args_2), ...]``: each tuple on a worker, ``local`` here meanwhile.

        Raises what a call raised (``local``'s first, then the workers' in order, each with
        the worker's traceback as its ``__cause__``); ``TimeoutError`` if the workers' results
        are not all in ``timeout`` seconds after ``local`` returned; ``BrokenProcessPool`` if
        a worker died. After a death, a timeout or an interruption (Ctrl-C) the pool is
        closed and its workers killed.
        """
        if self.closed:
            raise BrokenProcessPool("the fitness pool is closed")
        local_error: Exception | None = None
        try:
            # (no mask needed here: loky's manager thread, which starts any new worker, was
            # started under the mask by the constructor's submit and keeps it)
            futures = [self._executor.submit(func, *args) for args in argument_tuples]
            try:
                mine = local()
            except Exception as exc:  # noqa: BLE001 - raised below, once the workers' results are in
                local_error = exc
            _, pending = concurrent.futures.wait(futures, timeout=timeout)
            if pending:
                raise TimeoutError(
                    f"{len(pending)} of {len(futures)} fitness workers gave no result within {timeout:g} s"
                )
            results = [mine] if local_error is None else []
            errors = [f.exception() for f in futures]
        except BaseException:  # Ctrl-C, a timeout, a broken pool: no worker may outlive it
            self.close(kill=True)
            raise
        if any(isinstance(e, BrokenProcessPool) for e in errors):
            self.close(kill=True)
        if local_error is not None:
            raise local_error
        for error in errors:
            if error is not None:
                raise error
        return results + [f.result() for f in futures]

    def close(self, kill: bool = False) -> None:
        """End the workers: killed (``kill``), or through loky's shutdown (waits for running tasks)."""
        if self.closed:
            return
        self.closed = True
        self._executor.shutdown(wait=not kill, kill_workers=kill)


#: this package's pools by size and preload (kept apart from joblib's own reusable executor,
#: which joblib's Parallel configures its own way)
POOLS: dict[tuple[int, tuple[str, ...]], FitnessPool] = {}


def fitness_pool(n_workers: int, preload: tuple[str, ...] = ()) -> FitnessPool:
    """A :class:`FitnessPool` of ``n_workers`` processes, kept for reuse (a new one if it was closed)."""
    key = (n_workers, preload)
    if key not in POOLS or POOLS[key].closed:
        POOLS[key] = FitnessPool(n_workers, preload)
    return POOLS[key]


def shutdown_pools(kill: bool = False) -> None:
    """End every pool of this package (at exit, and at once after Ctrl-C)."""
    while POOLS:
        _, pool = POOLS.popitem()
        pool.close(kill=kill)


atexit.register(shutdown_pools)
