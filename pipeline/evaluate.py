"""Stage 2, evaluate: V, GDI, SURI and 1/kappa statistics of every sampled design.

Independent of the objective and of w_d, so a w_d sweep reuses it from the cache.
"""

from __future__ import annotations

import logging

import pandas as pd

from pipeline.objective import EVALUATION_FIELDS, DesignObjective
from pipeline.sample import sample_designs

log = logging.getLogger(__name__)


def evaluation_options(mechanism: dict, evaluate: dict, factor: int = 1) -> dict:
    """Keyword options of :func:`kinematics.workspace.evaluate` from the config nodes."""
    options = {"min_inverse_condition": float(mechanism["min_inverse_condition"])}
    if mechanism.get("orientation") is not None:
        options["orientation"] = tuple(float(v) for v in mechanism["orientation"])
    if mechanism.get("length") is not None:
        options["length"] = float(mechanism["length"])
    if evaluate.get("resolution") is not None:
        options["resolution"] = int(evaluate["resolution"]) * factor
    return options


def design_objective(mechanism: dict, evaluate: dict, objective: dict | None = None,
                     n_jobs: int = 1, factor: int = 1) -> DesignObjective:
    """The :class:`DesignObjective` of the config nodes (objective defaults to the mixed index)."""
    objective = objective or {"name": "mixed", "w_d": 0.5}
    return DesignObjective(mechanism["name"], objective=objective["name"], w_d=float(objective["w_d"]),
                           fixed=dict(mechanism["fixed"]), n_jobs=int(n_jobs),
                           options=evaluation_options(mechanism, evaluate, factor))


def evaluate_designs(mechanism: dict, sample: dict, evaluate: dict, code_version: str,
                     designs: pd.DataFrame | None = None, n_jobs: int = 2) -> pd.DataFrame:
    """The sampled designs with one column per evaluation field.

    ``designs`` is the output of :func:`~pipeline.sample.sample_designs` for
    ``(mechanism, sample, code_version)``; it is not part of the cache key
    (those arguments are), and is recomputed when not given.

    Returns
    -------
    pandas.DataFrame
        ``design_id``, the design variables, then :data:`~pipeline.objective.EVALUATION_FIELDS`
        (volume in the mechanism's volume unit, gdi, suri, ... ; ``valid`` 1/0).
    """
    if designs is None:
        designs = sample_designs(mechanism, sample, code_version)
    log.info("evaluate: computing %d designs of %s with %d workers", len(designs),
             mechanism["name"], n_jobs)
    objective = design_objective(mechanism, evaluate, n_jobs=n_jobs)
    rows = objective.evaluate_batch(designs[mechanism["design"]["names"]].to_numpy())
    frame = designs.copy()
    for k, name in enumerate(EVALUATION_FIELDS):
        frame[name] = rows[:, k]
    frame["n_samples"] = frame["n_samples"].astype("int64")
    frame["n_inside"] = frame["n_inside"].astype("int64")
    frame["valid"] = frame["valid"].astype(bool)
    return frame
