"""Design objectives, defined once: the scalar functions of one workspace evaluation.

:data:`OBJECTIVES` is the registry of scalar objectives (all maximised) over
one workspace evaluation: ``volume`` (seed 000 Table 1, seed 001 Table 2),
``gdi`` (seed 000 Table 2), ``suri`` (V/V*) and ``mixed``, the index of seed
000 eq. 36, ``eta = w_d GDI + (1 - w_d) SURI``. Nothing else in the package
writes that formula.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: scalar fields of one evaluation, in column order (units: kinematics.workspace)
EVALUATION_FIELDS = (
    "volume",
    "gdi",
    "inverse_condition_min",
    "inverse_condition_max",
    "suri",
    "reference_volume",
    "n_samples",
    "n_inside",
    "valid",
)


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
