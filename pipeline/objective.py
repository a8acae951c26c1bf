"""Design objectives: a design vector -> one workspace evaluation -> a fitness.

:class:`DesignObjective` is a picklable description (mechanism name, fixed
parameters, evaluation options, objective and ``w_d``). Its
:meth:`DesignObjective.evaluate_batch` evaluates a population ``(P, n_design)``
in a few large joblib tasks (``n_jobs`` chunks, not one task per design);
the backend is whatever ``joblib.parallel_config`` selects ("loky" by
default, "dask" inside ``parallel_config("dask")`` with a
``distributed.Client``). Results come back in input order, so the output is
the same whatever the number of workers.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from joblib import Parallel, delayed

from kinematics import MECHANISMS
from kinematics.workspace import evaluate

OBJECTIVES = ("volume", "gdi", "mixed")

#: scalar fields of one evaluation, in column order (units in kinematics.workspace)
EVALUATION_FIELDS = ("volume", "volume_error", "gdi", "gdi_error", "inverse_condition_min",
                     "inverse_condition_max", "inverse_condition_mean", "suri",
                     "reference_volume", "n_samples", "n_inside", "valid")


@dataclass(frozen=True)
class DesignObjective:
    """Fitness of designs of one mechanism.

    Parameters
    ----------
    mechanism : str
        Registry name (``kinematics.MECHANISMS``).
    objective : {"volume", "gdi", "mixed"}
        Table 1 (max V), Table 2 (max GDI) or eq. 36 (``w_d GDI + (1 - w_d) SURI``).
    w_d : float
        Weight of the GDI in the mixed index, in [0, 1].
    fixed : dict
        Constructor parameters that are not design variables (e.g. ``stroke``).
    options : dict
        Keyword options of :func:`kinematics.workspace.evaluate`.
    n_jobs : int
        Parallel workers for a batch (1 = in-process).
    """

    mechanism: str
    objective: str = "mixed"
    w_d: float = 0.5
    fixed: dict = field(default_factory=dict)
    options: dict = field(default_factory=dict)
    n_jobs: int = 2

    def __post_init__(self) -> None:
        if self.mechanism not in MECHANISMS:
            raise ValueError(f"unknown mechanism {self.mechanism!r}; allowed: {', '.join(MECHANISMS)}")
        if self.objective not in OBJECTIVES:
            raise ValueError(f"objective must be one of {', '.join(OBJECTIVES)}; got {self.objective!r}")
        if not (isinstance(self.w_d, (int, float)) and 0.0 <= float(self.w_d) <= 1.0):
            raise ValueError(f"w_d must be in [0, 1]; got {self.w_d!r}")
        if not (isinstance(self.n_jobs, int) and self.n_jobs >= 1):
            raise ValueError(f"n_jobs must be an integer >= 1; got {self.n_jobs!r}")

    @property
    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """The mechanism's default design bounds (``design_variables``), each (n_design,).

        The pipeline takes its bounds from the config (``mechanism.design``), which may override these.
        """
        variables = MECHANISMS[self.mechanism].design_variables
        return (np.array([v.lower for v in variables]), np.array([v.upper for v in variables]))

    def fitness_of(self, values: np.ndarray) -> np.ndarray:
        """Fitness from evaluation rows (K, len(EVALUATION_FIELDS)); 0 for invalid designs."""
        col = {name: values[:, k] for k, name in enumerate(EVALUATION_FIELDS)}
        if self.objective == "volume":
            fit = col["volume"]
        elif self.objective == "gdi":
            fit = col["gdi"]
        else:
            fit = self.w_d * col["gdi"] + (1.0 - self.w_d) * col["suri"]
        return np.where(col["valid"] > 0, np.nan_to_num(fit, nan=0.0), 0.0)

    def evaluate_batch(self, designs: np.ndarray) -> np.ndarray:
        """Evaluate designs (P, n_design) -> rows (P, len(EVALUATION_FIELDS)), in input order."""
        designs = np.atleast_2d(np.asarray(designs, dtype=float))
        if designs.shape[0] == 0:
            return np.empty((0, len(EVALUATION_FIELDS)))
        n_chunks = min(self.n_jobs, designs.shape[0])
        if n_chunks == 1:
            return _evaluate_chunk(self, designs)
        chunks = np.array_split(designs, n_chunks)
        parts = Parallel(n_jobs=n_chunks)(delayed(_evaluate_chunk)(self, c) for c in chunks)
        return np.vstack(parts)

    def __call__(self, designs: np.ndarray) -> np.ndarray:
        """Fitness of designs (P, n_design) -> (P,) (the GA's batch fitness)."""
        return self.fitness_of(self.evaluate_batch(designs))


def _evaluate_chunk(objective: DesignObjective, designs: np.ndarray) -> np.ndarray:
    """Evaluate each design of a chunk (runs in a worker). A design the mechanism
    rejects (e.g. q_min >= q_max) gets an all-zero row with ``valid = 0``."""
    cls = MECHANISMS[objective.mechanism]
    options = dict(objective.options)
    options.setdefault("error_estimate", False)
    out = np.zeros((designs.shape[0], len(EVALUATION_FIELDS)))
    for k, design in enumerate(designs):
        try:
            mech = cls.from_design(design, **objective.fixed)
        except ValueError:
            continue
        ev = evaluate(mech, **options)
        scalars = ev.scalars()
        out[k] = [float(scalars[name]) if name != "valid" else 1.0 for name in EVALUATION_FIELDS]
    return out
