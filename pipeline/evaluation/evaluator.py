"""The parallel batch evaluation of designs.

:class:`DesignEvaluator` is a picklable description (mechanism config, grid
options: resolution and integration method) whose
:meth:`DesignEvaluator.evaluate` evaluates a population
``(P, n_design)`` in ``n_jobs`` chunks on the backend that
``joblib.parallel_config`` selects: loky by default (this process and
``n_jobs - 1`` loky workers, :mod:`pipeline.evaluation.pool`), dask inside
``parallel_config("dask")``. ``n_jobs`` is capped at the cores the process may
use (:func:`pipeline.evaluation.pool.worker_count`).
Rows come back in input order, so results are the same whatever the number of workers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed
from joblib.parallel import BACKENDS, get_active_backend

from kinematics import resolve_mechanism
from kinematics.workspace import evaluate
from pipeline.evaluation.pool import fitness_pool, sigint_deferred
from pipeline.evaluation.scale import retry_lost_workers, workers_for
from pipeline.objectives import EVALUATION_FIELDS


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
    def of(cls, mechanism, method: str | None = None) -> MechanismSpec:
        """The spec of a ``MechanismConfig`` (``pipeline.config``) or of a spec; ``method``
        (``evaluate.method``) joins its evaluation options (None: leave them as they are)."""
        spec = (
            mechanism
            if isinstance(mechanism, cls)
            else cls(
                mechanism.name,
                tuple(sorted(mechanism.fixed.items())),
                tuple(sorted(mechanism.evaluation_options().items())),
            )
        )
        if method is None:
            return spec
        return cls(spec.name, spec.fixed, tuple(sorted({**dict(spec.options), "method": str(method)}.items())))

    def build(self, design: np.ndarray):
        """The mechanism of one design vector (design units); ValueError if infeasible."""
        return resolve_mechanism(self.name).from_design(np.asarray(design, dtype=float), **dict(self.fixed))


@dataclass(frozen=True)
class DesignEvaluator:
    """Evaluates designs of one mechanism configuration.

    Parameters
    ----------
    mechanism : MechanismConfig or MechanismSpec
        Registry name, fixed parameters, evaluation limits (``pipeline.config``);
        workers receive its :class:`MechanismSpec`.
    resolution : int or None
        Grid points per sampled axis (None: the mechanism's default per design and method).
    n_jobs : int
        Parallel chunks per batch (1 = in-process; loky: this process evaluates
        one chunk, ``n_jobs - 1`` worker processes the others), capped by the
        usable cores and the batch size (:func:`pipeline.evaluation.scale.workers_for`);
        on dask a batch is sent again after a lost worker while workers remain.
    method : str or None
        Workspace integration method of :func:`kinematics.workspace.evaluate`
        (``evaluate.method``: "grid" or "midpoint"); None: that function's default.
        The pipeline's stages always pass the config's.
    """

    mechanism: object
    resolution: int | None = None
    n_jobs: int = 1
    method: str | None = None

    def evaluate(self, designs: np.ndarray) -> np.ndarray:
        """Designs (P, n_design) -> evaluation rows (P, len(EVALUATION_FIELDS)), in input order."""
        designs = np.atleast_2d(np.asarray(designs, dtype=float))
        if designs.shape[0] == 0:
            return np.empty((0, len(EVALUATION_FIELDS)))
        spec = MechanismSpec.of(self.mechanism, self.method)
        backend, _ = get_active_backend()
        loky = isinstance(backend, BACKENDS["loky"])
        n_chunks = workers_for(self.n_jobs, designs.shape[0])  # capped by the usable cores (logged) and the batch
        # loky (the default): this process evaluates the first chunk, a kept pool of loky
        # workers (pipeline.evaluation.pool) the others; joblib's Parallel polls for results
        # every 10 ms, which cost 5-10 ms of every GA generation. Made before the
        # compilation below, so that the workers' start-up (~1.5 s) overlaps it.
        pool = fitness_pool(n_chunks - 1, preload=(__name__,)) if n_chunks > 1 and loky else None
        _compile_kernels(spec, designs)
        if n_chunks == 1:
            return _evaluate_chunk(spec, self.resolution, designs)
        # contiguous equal chunks: no straggler beyond one design
        chunks = np.array_split(designs, n_chunks)
        if pool is not None:
            parts = pool.map(
                _evaluate_chunk,
                [(spec, self.resolution, c) for c in chunks[1:]],
                local=lambda: _evaluate_chunk(spec, self.resolution, chunks[0]),
                timeout=CHUNK_TIMEOUT + SECONDS_PER_DESIGN * len(chunks[1]),
            )
        else:  # dask, threading, multiprocessing: joblib's dispatch
            parts = retry_lost_workers(
                lambda: Parallel(n_jobs=n_chunks)(delayed(_evaluate_chunk)(spec, self.resolution, c) for c in chunks)
            )
        return np.vstack(parts)


#: seconds the workers may take for their chunks once this process has evaluated its own,
#: plus :data:`SECONDS_PER_DESIGN` per design of a chunk (a design takes ~1-100 ms): a
#: hung worker fails the run instead of holding it for ever
CHUNK_TIMEOUT = 300.0
SECONDS_PER_DESIGN = 10.0

#: (mechanism, integration method) whose compiled kernels this process has already built or loaded
_COMPILED: set[tuple[str, object]] = set()


def _compile_kernels(spec: MechanismSpec, designs: np.ndarray) -> None:
    """Build (or load) the mechanism's compiled kernels in this process, once, before evaluating.

    Why: numba compiles on first call and caches on disk; without this, every
    worker of the first batch on a new machine compiles the same kernels at
    the same time (~3 s each). After it, workers load them from the disk cache.
    A tiny grid (2 nodes per axis, with the run's integration method) of the
    first design that builds is enough.
    A Ctrl-C during the compilation takes effect once it is done (:func:`pipeline.evaluation.pool.sigint_deferred`).
    """
    key = (spec.name, dict(spec.options).get("method"))
    if key in _COMPILED:
        return
    for design in designs:
        try:
            mech = spec.build(design)
        except ValueError:
            continue
        with sigint_deferred():
            evaluate(mech, **dict(spec.options, resolution=2, error_estimate=False))
        _COMPILED.add(key)
        return


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
