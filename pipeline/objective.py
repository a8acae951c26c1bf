"""Design objectives, defined once, and the parallel batch evaluation of designs.

:data:`OBJECTIVES` is the registry of scalar objectives (all maximised) over
one workspace evaluation: ``volume`` (seed 000 Table 1, seed 001 Table 2),
``gdi`` (seed 000 Table 2), ``suri`` (V/V*) and ``mixed``, the index of seed
000 eq. 36, ``eta = w_d GDI + (1 - w_d) SURI``. Nothing else in the package
writes that formula.

:class:`DesignEvaluator` is a picklable description (mechanism config, grid
options) whose :meth:`DesignEvaluator.evaluate` evaluates a population
``(P, n_design)`` in ``n_jobs`` chunks on the backend that
``joblib.parallel_config`` selects: loky by default (through this module's
own loky executor, :func:`worker_pool`), dask inside ``parallel_config("dask")``.
Rows come back in input order, so results are the same whatever the number of workers.
"""

from __future__ import annotations

import atexit
import contextlib
import multiprocessing.resource_tracker
import signal
import threading
from collections.abc import Callable, Iterator
from concurrent.futures import Future
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed
from joblib._parallel_backends import LokyBackend
from joblib.externals.loky import ProcessPoolExecutor
from joblib.externals.loky.process_executor import BrokenProcessPool
from joblib.parallel import get_active_backend

from kinematics import MECHANISMS
from kinematics.workspace import evaluate
from pipeline import compile_ahead

#: scalar fields of one evaluation, in column order (units: kinematics.workspace)
EVALUATION_FIELDS = ("volume", "gdi", "inverse_condition_min", "inverse_condition_max", "suri",
                     "reference_volume", "n_samples", "n_inside", "valid")


@dataclass(frozen=True)
class Objective:
    """A scalar objective over evaluation fields; maximised.

    ``values(fields, w_d)`` maps the evaluation columns (dict of arrays (K,))
    to the objective (K,); ``unit`` is ``"volume"`` when it carries the
    mechanism's volume unit, else a literal unit ("1" dimensionless).
    """

    name: str
    label: str
    unit: str
    values: Callable[[dict[str, np.ndarray], float], np.ndarray]
    #: w_d of the objective's config option (only the mixed index uses it)
    default_w_d: float = 0.5


def _mixed(fields: dict[str, np.ndarray], w_d: float) -> np.ndarray:
    """Seed 000 eq. 36: ``eta = w_d GDI + (1 - w_d) SURI`` (dimensionless)."""
    return w_d * fields["gdi"] + (1.0 - w_d) * fields["suri"]


OBJECTIVES: dict[str, Objective] = {
    "volume": Objective("volume", "V", "volume", lambda f, w: f["volume"], 0.0),
    "gdi": Objective("gdi", "GDI", "1", lambda f, w: f["gdi"], 1.0),
    "suri": Objective("suri", "SURI", "1", lambda f, w: f["suri"], 0.0),
    "mixed": Objective("mixed", "η", "1", _mixed),
}


def objective_values(name: str, rows: np.ndarray, w_d: float) -> np.ndarray:
    """Objective ``name`` of evaluation rows (K, len(EVALUATION_FIELDS)) -> (K,); 0 where invalid."""
    fields = {field: rows[:, k] for k, field in enumerate(EVALUATION_FIELDS)}
    values = OBJECTIVES[name].values(fields, float(w_d))
    return np.where(fields["valid"] > 0, np.nan_to_num(values, nan=0.0), 0.0)


@dataclass(frozen=True)
class MechanismSpec:
    """What a worker needs to build and evaluate designs of one mechanism configuration.

    A plain picklable record (registry name, fixed constructor parameters,
    options of :func:`kinematics.workspace.evaluate`), so that a worker
    process imports only :mod:`kinematics` and this module, not the config
    machinery (Hydra, pandas, the optimisers): ~0.6 s less per worker start.
    """

    name: str
    fixed: tuple[tuple[str, object], ...]
    options: tuple[tuple[str, object], ...]

    @classmethod
    def of(cls, mechanism) -> "MechanismSpec":
        """The spec of a ``MechanismConfig`` (``pipeline.config``) or of a spec."""
        if isinstance(mechanism, cls):
            return mechanism
        return cls(mechanism.name, tuple(sorted(mechanism.fixed.items())),
                   tuple(sorted(mechanism.evaluation_options().items())))

    def build(self, design: np.ndarray):
        """The mechanism of one design vector (design units); ValueError if infeasible."""
        return MECHANISMS[self.name].from_design(np.asarray(design, dtype=float), **dict(self.fixed))


@dataclass(frozen=True)
class DesignEvaluator:
    """Evaluates designs of one mechanism configuration.

    Parameters
    ----------
    mechanism : MechanismConfig or MechanismSpec
        Registry name, fixed parameters, evaluation limits (``pipeline.config``);
        workers receive its :class:`MechanismSpec`.
    resolution : int or None
        Grid points per sampled axis (None: the mechanism's default per design).
    n_jobs : int
        Parallel chunks per batch (1 = in-process).
    """

    mechanism: object
    resolution: int | None = None
    n_jobs: int = 1

    def evaluate(self, designs: np.ndarray) -> np.ndarray:
        """Designs (P, n_design) -> evaluation rows (P, len(EVALUATION_FIELDS)), in input order."""
        designs = np.atleast_2d(np.asarray(designs, dtype=float))
        if designs.shape[0] == 0:
            return np.empty((0, len(EVALUATION_FIELDS)))
        spec = MechanismSpec.of(self.mechanism)
        n_chunks = min(self.n_jobs, designs.shape[0])
        backend, _ = get_active_backend()
        pool = worker_pool(self.n_jobs) if n_chunks > 1 and isinstance(backend, LokyBackend) else None
        if pool is not None and spec.name not in _COMPILED:
            # start the workers now: their start-up (a new interpreter and the package's
            # imports, ~1.5 s) then overlaps the compilation below instead of following it
            _submit(pool, _start_worker, [()] * self.n_jobs)
        _compile_kernels(spec, designs)
        if n_chunks == 1:
            return _evaluate_chunk(spec, self.resolution, designs)
        # contiguous equal chunks: no straggler beyond one design
        chunks = np.array_split(designs, n_chunks)
        if pool is not None:
            # loky (the default) straight through a loky executor: joblib's
            # Parallel polls for results every 10 ms, which cost 5-10 ms of every
            # generation (a 30-design H4 batch computes in ~45 ms on 2 workers)
            try:
                futures = _submit(pool, _evaluate_chunk, [(spec, self.resolution, c) for c in chunks])
                parts = [f.result() for f in futures]
            except BrokenProcessPool:
                _POOLS.pop(self.n_jobs, None)  # a worker died (e.g. killed): the next batch starts afresh
                raise
        else:  # dask, threading, multiprocessing: joblib's dispatch
            parts = Parallel(n_jobs=n_chunks)(delayed(_evaluate_chunk)(spec, self.resolution, c) for c in chunks)
        return np.vstack(parts)


#: one thread per worker in numerical libraries (as joblib sets for its loky workers):
#: the workers already use every core
_WORKER_ENV = {name: "1" for name in ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS",
                                      "NUMBA_NUM_THREADS")}

#: this package's worker pools by size (kept apart from joblib's own reusable executor,
#: which joblib's Parallel configures its own way: sharing it breaks joblib's loky backend)
_POOLS: dict[int, ProcessPoolExecutor] = {}


#: seconds after which an idle worker exits (joblib's own default for its loky workers);
#: without it the workers of a run killed by SIGKILL (the OOM killer) would never exit
WORKER_IDLE_TIMEOUT = 300


def worker_pool(n_jobs: int) -> ProcessPoolExecutor:
    """A loky executor of ``n_jobs`` worker processes (one per core, see ``_WORKER_ENV``), kept for reuse."""
    if n_jobs not in _POOLS:
        _POOLS[n_jobs] = ProcessPoolExecutor(max_workers=n_jobs, env=_WORKER_ENV, timeout=WORKER_IDLE_TIMEOUT)
    return _POOLS[n_jobs]


def _submit(pool: ProcessPoolExecutor, func: Callable, argument_tuples: list[tuple]) -> list[Future]:
    """``pool.submit(func, *args)`` for each tuple, with SIGINT blocked in this thread.

    Why: Ctrl-C sends SIGINT to the whole process group. A loky worker that
    receives it while it is still importing prints a ``KeyboardInterrupt``
    traceback of its own; one that receives it while computing raises inside
    the task. Workers (and loky's manager thread, which may respawn them) are
    started inside ``submit`` and inherit this thread's signal mask, so they
    never see SIGINT: the main process alone handles Ctrl-C and kills them
    (:func:`shutdown_pools`).
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
def _sigint_deferred() -> Iterator[None]:
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


def shutdown_pools(kill: bool = False) -> None:
    """End every worker pool of this package (at exit, and at once after Ctrl-C)."""
    while _POOLS:
        _, pool = _POOLS.popitem()
        pool.shutdown(wait=not kill, kill_workers=kill)


atexit.register(shutdown_pools)


#: mechanisms whose compiled kernels this process has already built or loaded
_COMPILED: set[str] = set()


def _compile_kernels(spec: MechanismSpec, designs: np.ndarray) -> None:
    """Build (or load) the mechanism's compiled kernels in this process, once, before evaluating.

    Why: numba compiles on first call and caches on disk; without this, every
    worker of the first batch on a new machine compiles the same kernels at
    the same time (~3 s each). After it, workers load them from the disk cache.
    A tiny grid (2 nodes per axis) of the first design that builds is enough.
    A Ctrl-C during the compilation takes effect once it is done (:func:`_sigint_deferred`).
    """
    if spec.name in _COMPILED:
        return
    for design in designs:
        try:
            mech = spec.build(design)
        except ValueError:
            continue
        compile_ahead.wait_for(spec.name)  # compiled by the entry point's helper, if it runs
        with _sigint_deferred():
            evaluate(mech, **dict(spec.options, resolution=2, error_estimate=False))
        _COMPILED.add(spec.name)
        return


def _start_worker() -> None:
    """Nothing: unpickling it imports this module, and so the kinematics, in a new worker."""


def _evaluate_chunk(spec: MechanismSpec, resolution: int | None, designs: np.ndarray) -> np.ndarray:
    """Evaluate each design of a chunk (runs in a worker). A design the mechanism
    rejects (e.g. q_min >= q_max) gets an all-zero row with ``valid = 0``."""
    options = dict(spec.options, error_estimate=False)
    if resolution is not None:
        options["resolution"] = int(resolution)
    out = np.zeros((designs.shape[0], len(EVALUATION_FIELDS)))
    for k, design in enumerate(designs):
        try:
            mech = spec.build(design)
        except ValueError:
            continue
        scalars = evaluate(mech, **options).scalars()
        out[k] = [float(scalars[name]) if name != "valid" else 1.0 for name in EVALUATION_FIELDS]
    return out
