"""Design objectives, defined once, and the parallel batch evaluation of designs.

:data:`OBJECTIVES` is the registry of scalar objectives (all maximised) over
one workspace evaluation: ``volume`` (seed 000 Table 1, seed 001 Table 2),
``gdi`` (seed 000 Table 2), ``suri`` (V/V*) and ``mixed``, the index of seed
000 eq. 36, ``eta = w_d GDI + (1 - w_d) SURI``. Nothing else in the package
writes that formula.

:class:`DesignEvaluator` is a picklable description (mechanism config, grid
options) whose :meth:`DesignEvaluator.evaluate` evaluates a population
``(P, n_design)`` in ``n_jobs`` chunks on the backend that
``joblib.parallel_config`` selects: loky by default (this process and
``n_jobs - 1`` loky workers, :mod:`pipeline.workers`), dask inside
``parallel_config("dask")``.
Rows come back in input order, so results are the same whatever the number of workers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed
from joblib._parallel_backends import LokyBackend
from joblib.parallel import get_active_backend

from kinematics import MECHANISMS
from kinematics.workspace import evaluate
from pipeline import compile_ahead, workers

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
        Parallel chunks per batch (1 = in-process; loky: this process evaluates
        one chunk, ``n_jobs - 1`` worker processes the others).
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
        # loky (the default): this process evaluates the first chunk, a worker group
        # (pipeline.workers) the others; joblib's Parallel polls for results every
        # 10 ms, which cost 5-10 ms of every GA generation. Made before the
        # compilation below, so that the workers' start-up (~1.5 s) overlaps it.
        group = (workers.worker_group(self.n_jobs - 1, preload=(__name__,))
                 if n_chunks > 1 and isinstance(backend, LokyBackend) and workers.AVAILABLE else None)
        _compile_kernels(spec, designs)
        if n_chunks == 1:
            return _evaluate_chunk(spec, self.resolution, designs)
        # contiguous equal chunks: no straggler beyond one design
        chunks = np.array_split(designs, n_chunks)
        if group is not None:
            parts = group.map(_evaluate_chunk, [(spec, self.resolution, c) for c in chunks[1:]],
                              local=lambda: _evaluate_chunk(spec, self.resolution, chunks[0]))
        else:  # dask, threading, multiprocessing: joblib's dispatch
            parts = Parallel(n_jobs=n_chunks)(delayed(_evaluate_chunk)(spec, self.resolution, c) for c in chunks)
        return np.vstack(parts)


#: mechanisms whose compiled kernels this process has already built or loaded
_COMPILED: set[str] = set()


def _compile_kernels(spec: MechanismSpec, designs: np.ndarray) -> None:
    """Build (or load) the mechanism's compiled kernels in this process, once, before evaluating.

    Why: numba compiles on first call and caches on disk; without this, every
    worker of the first batch on a new machine compiles the same kernels at
    the same time (~3 s each). After it, workers load them from the disk cache.
    A tiny grid (2 nodes per axis) of the first design that builds is enough.
    A Ctrl-C during the compilation takes effect once it is done (:func:`pipeline.workers.sigint_deferred`).
    """
    if spec.name in _COMPILED:
        return
    for design in designs:
        try:
            mech = spec.build(design)
        except ValueError:
            continue
        compile_ahead.wait_for(spec.name)  # compiled by the entry point's helper, if it runs
        with workers.sigint_deferred():
            evaluate(mech, **dict(spec.options, resolution=2, error_estimate=False))
        _COMPILED.add(spec.name)
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
