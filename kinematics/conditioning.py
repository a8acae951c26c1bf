"""Conditioning of batches of Jacobians (shared by every mechanism).

The condition number of seed 000 eq. 35, ``kappa = sigma_max / sigma_min``,
is computed on the dimensionally homogeneous Jacobian ``J @ diag(s)`` where
``s`` divides the angular columns by a characteristic length (seed 001
eq. 37). We return ``1/kappa`` in [0, 1] because it is bounded and 0 at a
singularity, which is what the global indices integrate.

Why not ``numpy.linalg.svd``: batched LAPACK on 2x2 .. 4x4 matrices costs
about 1-2 us per matrix, which made the SVD half of a workspace evaluation.
For 2x2 the singular values have a closed form (:func:`_ratio_2x2`). For 3x3
and 4x4 we compute ``sigma_min^2`` and ``sigma_max^2`` as the extreme
eigenvalues of ``G = J^T J`` from its characteristic polynomial, whose
coefficients are sums of principal minors of G (with ``det G = det(J)^2``
computed from J, which keeps the small eigenvalue's relative accuracy at
about ``eps * kappa``). All roots are real and >= 0, so Laguerre's method
converges monotonically to the smallest root from 0 and to the largest from
the trace. Larger matrices fall back to the SVD. The same algorithm runs
compiled, one matrix at a time, in :func:`kinematics.kernels.inverse_condition_batch`
(the default); the numpy code here is its reference (``PM_DESIGN_KERNELS=numpy``).

Accuracy (tested against the SVD): relative error below 1e-4 wherever
``1/kappa > 1e-3``, and absolute error below 1e-3 everywhere. The
characteristic-polynomial route loses precision only when several singular
values are tiny at once (their elementary symmetric functions cancel); such
poses are far below the dexterity limit (0.01) that the workspace uses.
"""

from __future__ import annotations

import numpy as np

from kinematics import kernels
from kinematics.rows import row_all, row_any

_LAGUERRE_STEPS = kernels.LAGUERRE_STEPS


def inverse_condition_number(jac: np.ndarray, column_scale: np.ndarray | None = None) -> np.ndarray:
    """``sigma_min / sigma_max`` of every matrix in a batch.

    Parameters
    ----------
    jac : ndarray, shape (N, n, n)
        Batch of square Jacobians. Rows containing NaN mark unreachable
        poses; +-inf entries mark a singular actuator Jacobian (an infinitely
        large ``J``).
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
    if jac.ndim != 3 or jac.shape[1] != jac.shape[2]:
        raise ValueError(f"jac must have shape (N, n, n); got {jac.shape}")
    if 2 <= jac.shape[1] <= 4 and kernels.compiled():
        scale = np.ones(jac.shape[1]) if column_scale is None else np.asarray(column_scale, dtype=float)
        return kernels.inverse_condition_batch(np.ascontiguousarray(jac), scale)
    if column_scale is not None:
        jac = jac * np.asarray(column_scale, dtype=float)[None, None, :]
    n = jac.shape[0]
    out = np.zeros(n)
    if n == 0:
        return out
    flat = jac.reshape(n, -1)
    is_nan = row_any(np.isnan(flat))
    finite = row_all(np.isfinite(flat))
    out[is_nan] = np.nan
    if finite.all():
        return _ratio(jac)
    if finite.any():
        out[finite] = _ratio(jac[finite])
    return out


def inverse_condition_svd(jac: np.ndarray) -> np.ndarray:
    """Reference ``sigma_min / sigma_max`` by SVD, shape (N,), for finite (N, n, n)."""
    sv = np.linalg.svd(jac, compute_uv=False)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(sv[:, 0] > 0, sv[:, -1] / sv[:, 0], 0.0)


def _ratio(jac: np.ndarray) -> np.ndarray:
    size = jac.shape[1]
    if size == 1:
        return (jac[:, 0, 0] != 0).astype(float)
    if size == 2:
        return _ratio_2x2(jac)
    if size > 4:
        return inverse_condition_svd(jac)
    cols = np.ascontiguousarray(np.moveaxis(jac, 0, -1))  # (n, n, N): one array per entry
    gram = [[None] * size for _ in range(size)]
    for i in range(size):
        for j in range(i, size):
            gram[i][j] = gram[j][i] = np.einsum("kn,kn->n", cols[:, i], cols[:, j])
    coeffs = _characteristic(gram, cols, size)
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        # start each iteration on its side of the root, as close as cheap bounds
        # allow: sum(lambda^2) = e1^2 - 2 e2 >= lambda_max^2 (and the trace >= lambda_max),
        # e_n / e_(n-1) <= lambda_min (e_(n-1) >= the product of the n - 1 largest)
        trace = -coeffs[1]
        squares = trace * trace - 2.0 * coeffs[2]
        upper = np.minimum(np.where(squares > 0, np.sqrt(np.abs(squares)), trace), trace)
        e_last, e_before = np.abs(coeffs[size]), np.abs(coeffs[size - 1])
        lower = np.minimum(np.where(e_before > 0, e_last / np.where(e_before > 0, e_before, 1.0), 0.0), upper)
        lam_max = _laguerre(coeffs, upper)
        lam_min = _laguerre(coeffs, lower)
        ratio = np.sqrt(np.clip(lam_min, 0.0, None) / lam_max)
    ratio = np.where(lam_max > 0, ratio, 0.0)
    return np.clip(np.nan_to_num(ratio, nan=0.0), 0.0, 1.0)


def _ratio_2x2(jac: np.ndarray) -> np.ndarray:
    """Closed form for 2 x 2 (N, 2, 2): ``lambda_max = (t + sqrt(t^2 - 4 det^2)) / 2`` of
    ``G = J^T J`` (t its trace), and ``sigma_min / sigma_max = |det J| / lambda_max``
    (``lambda_min lambda_max = det(J)^2``: no cancellation for small ``sigma_min``)."""
    m00, m01, m10, m11 = jac[:, 0, 0], jac[:, 0, 1], jac[:, 1, 0], jac[:, 1, 1]
    det = m00 * m11 - m01 * m10
    trace = m00 * m00 + m10 * m10 + m01 * m01 + m11 * m11
    disc = trace * trace - 4.0 * det * det
    lam_max = 0.5 * (trace + np.sqrt(np.where(disc > 0.0, disc, 0.0)))
    with np.errstate(invalid="ignore", divide="ignore", over="ignore"):
        ratio = np.abs(det) / np.where(lam_max > 0.0, lam_max, 1.0)
    ratio = np.where(lam_max > 0.0, ratio, 0.0)
    return np.clip(np.nan_to_num(ratio, nan=0.0), 0.0, 1.0)


def _det(m: list[list[np.ndarray]], rows: tuple[int, ...], cols: tuple[int, ...]) -> np.ndarray:
    """Determinant of the sub-matrix ``m[rows][cols]`` (Laplace along the first row)."""
    if len(rows) == 1:
        return m[rows[0]][cols[0]]
    total = 0.0
    for k, c in enumerate(cols):
        minor = _det(m, rows[1:], cols[:k] + cols[k + 1 :])
        total = total + (-1) ** k * m[rows[0]][c] * minor
    return total


def _characteristic(gram, cols, size: int) -> list[np.ndarray]:
    """Coefficients ``[1, -e1, e2, -e3, ...]`` of ``det(x I - G)``, highest degree first.

    ``e_k`` is the sum of the principal k x k minors of G; ``e_n = det(J)^2``.
    """
    from itertools import combinations

    idx = tuple(range(size))
    coeffs = [np.ones_like(gram[0][0])]
    for k in range(1, size):
        e_k = sum(_det(gram, sub, sub) for sub in combinations(idx, k))
        coeffs.append((-1) ** k * e_k)
    jm = [[cols[i][j] for j in idx] for i in idx]
    det_j = _det(jm, idx, idx)
    coeffs.append((-1) ** size * det_j * det_j)
    return coeffs


def _laguerre(coeffs: list[np.ndarray], x: np.ndarray) -> np.ndarray:
    """Laguerre iterations for a real-rooted polynomial, vectorised over the batch."""
    degree = len(coeffs) - 1
    for _ in range(_LAGUERRE_STEPS):
        p = coeffs[0]
        dp = np.zeros_like(x)
        ddp = np.zeros_like(x)
        for c in coeffs[1:]:
            ddp = ddp * x + 2 * dp
            dp = dp * x + p
            p = p * x + c
        at_root = p == 0
        inv_p = 1.0 / np.where(at_root, 1.0, p)
        g = dp * inv_p
        h = g * g - ddp * inv_p
        root = np.sqrt(np.clip((degree - 1) * (degree * h - g * g), 0.0, None))
        denom = np.where(g >= 0, g + root, g - root)
        step = np.where(at_root | (denom == 0), 0.0, degree / np.where(denom == 0, 1.0, denom))
        x = x - step
        # converged everywhere (cubic convergence: the next step is below the last bit)
        if not np.any(np.abs(step) > 1e-9 * np.abs(x)):
            break
    return x
