"""One given design, evaluated: V, GDI, SURI and η of design variables a user types in.

``pm-design evaluate mechanism=h4 d_ratio=0.135 h_ratio=0.139 Qz_ratio=0.352``
(:mod:`pipeline.cli.evaluate`) calls :func:`evaluate_design`; the numbers are the
ones the optimise stage reports for an optimum (same evaluator, same grid
rules), so a design read off a paper or a dataset can be checked alone.
"""

from __future__ import annotations

import numpy as np
import pandas as pd

from kinematics.workspace import default_resolution
from pipeline.config import Config
from pipeline.errors import ConfigError, check, finite
from pipeline.evaluation import DesignEvaluator
from pipeline.objectives import objective_values
from pipeline.stages.evaluate import evaluation_frame
from pipeline.store.parquet import param_column


def evaluate_design(c: Config, design: list[float]) -> pd.DataFrame:
    """One row: the design variables (design units), the mechanism's parameters
    (``param_<name>_<unit>``), V (``volume_unit``), GDI, SURI, 1/κ range, η at the
    config's ``objective.w_d``, and the grid resolution and integration method used
    (``evaluate.resolution``, ``evaluate.method``).

    Raises
    ------
    ConfigError
        A design of the wrong length, outside the design box or not buildable (one line).
    """
    m = c.mechanism
    names = list(m.design.names)
    check("design", design, len(design) == len(names), f"{len(names)} numbers ({', '.join(names)})")
    for name, v, lo, hi in zip(names, design, m.design.lower, m.design.upper):
        check(name, v, finite(v) and lo <= v <= hi, f"[{lo:g}, {hi:g}] (mechanism.design bounds)")
    x = np.asarray(design, dtype=float)
    try:
        mech = m.build(x)
    except ValueError as exc:
        raise ConfigError(f"design={list(design)} is invalid: {exc}") from None
    method = c.evaluate.method
    resolution = c.evaluate.resolution or default_resolution(mech, m.orientation_rad(), None, method)
    rows = DesignEvaluator(m, resolution, 1, method).evaluate(x[None, :])
    frame = evaluation_frame(rows).drop(columns=["valid"])
    row: dict = {"mechanism": m.name, **dict(zip(names, x.tolist()))}
    row.update(
        {
            param_column(k, mech.param_unit(k, v)): v
            for k, v in mech.params().items()
            if isinstance(v, (int, float, str)) and not isinstance(v, bool) and k not in names
        }
    )
    row.update(frame.to_dict("records")[0])  # per column: int64 counts stay integers (as in the dataset)
    row["volume_unit"] = mech.volume_unit(m.orientation_rad())
    row["w_d"] = float(c.objective.w_d)
    row["eta"] = float(objective_values("mixed", rows, c.objective.w_d)[0])
    row["resolution"] = int(resolution)
    row["method"] = method
    return pd.DataFrame([row])
