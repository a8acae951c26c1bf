"""Stage 1, sample: a design of experiments over the design space (scrambled Sobol, seeded)."""

from __future__ import annotations

import logging
import math
import warnings

import numpy as np
import pandas as pd
from scipy.stats import qmc

log = logging.getLogger(__name__)


def sample_designs(mechanism: dict, sample: dict, code_version: str) -> pd.DataFrame:
    """Scrambled Sobol designs inside the design box.

    Parameters
    ----------
    mechanism : dict
        ``mechanism`` node of the resolved config (its ``design`` names and bounds).
    sample : dict
        ``{"n": number of designs, "seed": Sobol scrambling seed}``.
    code_version : str
        Part of the cache key (:data:`pipeline.cache.CODE_VERSION`).

    Returns
    -------
    pandas.DataFrame
        ``design_id`` (int64) and one float64 column per design variable, in
        the design's units (see ``conf/mechanism/*.yaml``).
    """
    design = mechanism["design"]
    n, dim = int(sample["n"]), len(design["names"])
    log.info("sample: computing %d Sobol designs of %s", n, mechanism["name"])
    sobol = qmc.Sobol(d=dim, scramble=True, seed=int(sample["seed"]))
    if n & (n - 1) == 0:
        unit = sobol.random_base2(int(math.log2(n)))
    else:
        with warnings.catch_warnings():  # balance is only guaranteed for powers of 2
            warnings.simplefilter("ignore", UserWarning)
            unit = sobol.random(n)
    points = qmc.scale(unit, design["lower"], design["upper"])
    frame = pd.DataFrame(points, columns=list(design["names"]))
    frame.insert(0, "design_id", np.arange(n, dtype=np.int64))
    return frame
