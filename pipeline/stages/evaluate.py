"""Stage 2, evaluate: V, GDI, SURI and 1/kappa range of every sampled design.

Independent of the objective and of w_d, so a w_d sweep reuses it from the cache.
"""

from __future__ import annotations

import logging

import pandas as pd

from pipeline.config import MechanismConfig
from pipeline.evaluation import DesignEvaluator
from pipeline.objectives import EVALUATION_FIELDS

log = logging.getLogger(__name__)

#: evaluation fields kept as int64 / bool columns
INTEGER_FIELDS = ("n_samples", "n_inside")


def evaluation_frame(rows) -> pd.DataFrame:
    """Evaluation rows (K, len(EVALUATION_FIELDS)) as typed columns."""
    frame = pd.DataFrame(rows, columns=list(EVALUATION_FIELDS))
    for name in INTEGER_FIELDS:
        frame[name] = frame[name].astype("int64")
    frame["valid"] = frame["valid"].astype(bool)
    return frame


def evaluate_designs(
    mechanism: MechanismConfig, resolution: int | None, method: str, designs: pd.DataFrame, n_jobs: int = 1
) -> pd.DataFrame:
    """The sampled designs with one column per evaluation field.

    ``resolution`` and ``method`` are the config's ``evaluate.resolution`` and
    ``evaluate.method`` (both part of the stage's cache key).

    Returns
    -------
    pandas.DataFrame
        ``design_id``, the design variables, then :data:`~pipeline.objectives.EVALUATION_FIELDS`
        (volume in the mechanism's volume unit, gdi, suri, ...; ``valid`` bool).
    """
    log.debug("evaluate: %d designs of %s (%s) with %d workers", len(designs), mechanism.name, method, n_jobs)
    evaluator = DesignEvaluator(mechanism, resolution, n_jobs, method)
    rows = evaluator.evaluate(designs[mechanism.design.names].to_numpy())
    return pd.concat([designs.reset_index(drop=True), evaluation_frame(rows)], axis=1)
