"""Conditioning of batches of Jacobians (shared by every mechanism).

The condition number of seed 000 eq. 35, ``kappa = sigma_max / sigma_min``,
is computed on the dimensionally homogeneous Jacobian ``J @ diag(s)`` where
``s`` divides the angular columns by a characteristic length (seed 001
eq. 37). We return ``1/kappa`` in [0, 1] because it is bounded and 0 at a
singularity, which is what the global indices integrate.
"""

from __future__ import annotations

import numpy as np


def inverse_condition_number(jac: np.ndarray, column_scale: np.ndarray | None = None) -> np.ndarray:
    """``sigma_min / sigma_max`` of every matrix in a batch.

    Parameters
    ----------
    jac : ndarray, shape (N, m, n)
        Batch of Jacobians. Rows containing NaN mark unreachable poses; +-inf
        entries mark a singular actuator Jacobian (an infinitely large ``J``).
    column_scale : ndarray, shape (n,), optional
        Factor applied to each column before the decomposition (1/length on
        the angular columns homogenises the units).

    Returns
    -------
    ndarray, shape (N,)
        ``1/kappa`` in [0, 1]; 0 for singular matrices (including infinite
        entries), NaN where any entry is NaN.
    """
    jac = np.asarray(jac, dtype=float)
    if jac.ndim != 3:
        raise ValueError(f"jac must have shape (N, m, n); got {jac.shape}")
    if column_scale is not None:
        jac = jac * np.asarray(column_scale, dtype=float)[None, None, :]
    n = jac.shape[0]
    out = np.zeros(n)
    flat = jac.reshape(n, -1)
    is_nan = np.isnan(flat).any(axis=1)
    finite = np.isfinite(flat).all(axis=1)
    out[is_nan] = np.nan
    if finite.any():
        sv = np.linalg.svd(jac[finite], compute_uv=False)
        smax = sv[:, 0]
        smin = sv[:, -1]
        with np.errstate(invalid="ignore", divide="ignore"):
            ratio = np.where(smax > 0, smin / smax, 0.0)
        out[finite] = ratio
    return out
