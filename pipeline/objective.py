"""Design objectives, defined once, and the parallel batch evaluation of designs.

:data:`OBJECTIVES` is the registry of scalar objectives (all maximised) over
one workspace evaluation: ``volume`` (seed 000 Table 1, seed 001 Table 2),
``gdi`` (seed 000 Table 2), ``suri`` (V/V*) and ``mixed``, the index of seed
000 eq. 36, ``eta = w_d GDI + (1 - w_d) SURI``. Nothing else in the package
writes that formula.

:class:`DesignEvaluator` is a picklable description (mechanism config, grid
options) whose :meth:`DesignEvaluator.evaluate` evaluates a population
``(P, n_design)`` in ``n_jobs`` joblib chunks (the backend is whatever
``joblib.parallel_config`` selects: loky by default, dask inside
``parallel_config("dask")``). Rows come back in input order, so results are
the same whatever the number of workers.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from joblib import Parallel, delayed

from kinematics.workspace import evaluate

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
class DesignEvaluator:
    """Evaluates designs of one mechanism configuration.

    Parameters
    ----------
    mechanism : MechanismConfig
        Registry name, fixed parameters, evaluation limits (``pipeline.config``).
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
        n_chunks = min(self.n_jobs, designs.shape[0])
        if n_chunks == 1:
            return _evaluate_chunk(self, designs)
        _compile_kernels(self, designs)
        # contiguous equal chunks: no straggler beyond one design
        chunks = np.array_split(designs, n_chunks)
        parts = Parallel(n_jobs=n_chunks)(delayed(_evaluate_chunk)(self, c) for c in chunks)
        return np.vstack(parts)


#: mechanisms whose compiled kernels this process has already built or loaded
_COMPILED: set[str] = set()


def _compile_kernels(evaluator: DesignEvaluator, designs: np.ndarray) -> None:
    """Build the mechanism's compiled kernels here, once, before the workers start.

    Why: numba compiles on first call and caches on disk; without this, every
    worker of the first batch on a new machine compiles the same kernels at
    the same time (~3 s each). After it, workers load them from the disk cache.
    A tiny grid (2 nodes per axis) of the first design that builds is enough.
    """
    name = evaluator.mechanism.name
    if name in _COMPILED:
        return
    for design in designs:
        try:
            mech = evaluator.mechanism.build(design)
        except ValueError:
            continue
        evaluate(mech, **dict(evaluator.mechanism.evaluation_options(), resolution=2, error_estimate=False))
        _COMPILED.add(name)
        return


def _evaluate_chunk(evaluator: DesignEvaluator, designs: np.ndarray) -> np.ndarray:
    """Evaluate each design of a chunk (runs in a worker). A design the mechanism
    rejects (e.g. q_min >= q_max) gets an all-zero row with ``valid = 0``."""
    mechanism = evaluator.mechanism
    options = dict(mechanism.evaluation_options(), error_estimate=False)
    if evaluator.resolution is not None:
        options["resolution"] = int(evaluator.resolution)
    out = np.zeros((designs.shape[0], len(EVALUATION_FIELDS)))
    for k, design in enumerate(designs):
        try:
            mech = mechanism.build(design)
        except ValueError:
            continue
        scalars = evaluate(mech, **options).scalars()
        out[k] = [float(scalars[name]) if name != "valid" else 1.0 for name in EVALUATION_FIELDS]
    return out
