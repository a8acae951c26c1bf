"""Stage 1, sample: a design of experiments over the design box (scrambled Sobol, seeded)."""

from __future__ import annotations

import logging
import math
import warnings

import numpy as np
import pandas as pd
from scipy.stats import qmc

from pipeline.config import DesignSpace, SampleConfig

log = logging.getLogger(__name__)


def sample_designs(design: DesignSpace, sample: SampleConfig) -> pd.DataFrame:
    """Scrambled Sobol designs inside the design box.

    Returns
    -------
    pandas.DataFrame
        ``design_id`` (int64) and one float64 column per design variable, in
        the design's units (``Mechanism.design_variables``).
    """
    n, dim = int(sample.n), len(design.names)
    log.debug("sample: %d Sobol designs", n)
    sobol = qmc.Sobol(d=dim, scramble=True, seed=int(sample.seed))
    if n & (n - 1) == 0:
        unit = sobol.random_base2(int(math.log2(n)))
    else:
        with warnings.catch_warnings():  # balance is only guaranteed for powers of 2
            warnings.simplefilter("ignore", UserWarning)
            unit = sobol.random(n)
    frame = pd.DataFrame(qmc.scale(unit, design.lower, design.upper), columns=list(design.names))
    frame.insert(0, "design_id", np.arange(n, dtype=np.int64))
    return frame
