"""Compiled per-pose kernels (numba) and the switch back to the numpy reference.

Why: a workspace evaluation conditions ~10^4 small Jacobians. The numpy path
(:mod:`kinematics.conditioning`, the mechanisms' ``_jacobian``) is vectorised
over poses but spends most of its time allocating (N,)-sized temporaries for
every entry of every intermediate matrix. A fused loop that keeps one pose's
matrix in registers does the same arithmetic ~5-10x faster on one core.

The numpy path stays the reference: ``PM_DESIGN_KERNELS=numpy`` in the
environment (or :func:`reference_kernels` in code) turns every compiled path
off, and the tests compare the two (same V and GDI to 1e-12 relative). The
kernels are serial and free of reductions whose order depends on threads, so
results do not depend on the number of joblib workers.

Compiled code is cached on disk (``cache=True``: next to the sources, or in
numba's user cache when that folder is read-only), so only the first run on a
machine pays the compile time (about 3 s for H4's kernels, measured).
"""

from __future__ import annotations

import contextlib
import math
import os
from collections.abc import Iterator

import numba
import numpy as np

#: environment variable selecting the kernels: ``numba`` (default) or ``numpy``
KERNELS_ENV = "PM_DESIGN_KERNELS"
KERNEL_CHOICES = ("numba", "numpy")
_forced: list[str] = []

#: decorator of every compiled kernel: on-disk cache, no GIL, IEEE semantics
#: (no fastmath: the results must match the numpy reference)
jit = numba.njit(cache=True, nogil=True)
#: the same for small helpers of a kernel, inlined into their caller by numba itself
#: (a plain call into them keeps LLVM from optimising across it: ~1.6x slower loops)
inline_jit = numba.njit(cache=True, nogil=True, inline="always")

#: Laguerre steps of both paths (see :mod:`kinematics.conditioning`)
LAGUERRE_STEPS = 12


def compiled() -> bool:
    """True when the compiled kernels are in use (the default).

    Raises
    ------
    ValueError
        If ``PM_DESIGN_KERNELS`` holds anything but ``numba`` or ``numpy``.
    """
    if _forced:
        return _forced[-1] == "numba"
    choice = os.environ.get(KERNELS_ENV, "numba").strip().lower() or "numba"
    if choice not in KERNEL_CHOICES:
        raise ValueError(f"environment variable {KERNELS_ENV} must be one of "
                         f"{', '.join(KERNEL_CHOICES)}; got {choice!r}")
    return choice == "numba"


@contextlib.contextmanager
def reference_kernels() -> Iterator[None]:
    """Within the block, every evaluation takes the numpy reference path."""
    _forced.append("numpy")
    try:
        yield
    finally:
        _forced.pop()


# ------------------------------------------------------------ conditioning
@inline_jit
def _det3(m, i0, i1, i2, j0, j1, j2):
    """Determinant of rows (i0, i1, i2), columns (j0, j1, j2) of ``m`` (Laplace, row i0)."""
    return (m[i0, j0] * (m[i1, j1] * m[i2, j2] - m[i1, j2] * m[i2, j1])
            - m[i0, j1] * (m[i1, j0] * m[i2, j2] - m[i1, j2] * m[i2, j0])
            + m[i0, j2] * (m[i1, j0] * m[i2, j1] - m[i1, j1] * m[i2, j0]))


@jit
def _laguerre_step(c, degree, x):
    """One Laguerre step on ``c[0] x^n + ... + c[n]`` from ``x`` (0 at a root or a flat point)."""
    p = c[0]
    dp = 0.0
    ddp = 0.0
    for k in range(1, degree + 1):
        ddp = ddp * x + 2.0 * dp
        dp = dp * x + p
        p = p * x + c[k]
    if p == 0.0:
        return 0.0
    inv_p = 1.0 / p
    g = dp * inv_p
    h = g * g - ddp * inv_p
    disc = (degree - 1) * (degree * h - g * g)
    root = math.sqrt(disc) if disc > 0.0 else 0.0
    denom = g + root if g >= 0.0 else g - root
    return degree / denom if denom != 0.0 else 0.0


@jit
def _extreme_roots(c, degree, x_max, x_min):
    """Largest and smallest root of a real-rooted polynomial, by Laguerre from above and below.

    Both iterations run in one loop so that their divisions and square
    roots overlap; each stops at :data:`LAGUERRE_STEPS` or once its step is
    below the last bit of its root.
    """
    done_max = done_min = False
    for _ in range(LAGUERRE_STEPS):
        if not done_max:
            step = _laguerre_step(c, degree, x_max)
            x_max -= step
            done_max = abs(step) <= 1e-9 * abs(x_max)
        if not done_min:
            step = _laguerre_step(c, degree, x_min)
            x_min -= step
            done_min = abs(step) <= 1e-9 * abs(x_min)
        if done_max and done_min:
            break
    return x_max, x_min


@jit
def _gram4(m, gram):
    """``gram = m^T m`` for 4 x 4 ``m`` (constant trip counts: the compiler unrolls them)."""
    for i in range(4):
        for j in range(i, 4):
            s = m[0, i] * m[0, j] + m[1, i] * m[1, j] + m[2, i] * m[2, j] + m[3, i] * m[3, j]
            gram[i, j] = s
            gram[j, i] = s


@jit
def _charpoly4(g, coeffs):
    """``coeffs[2] = e2``, ``coeffs[3] = -e3`` of a symmetric 4 x 4 ``g`` (principal minors).

    Written out on scalars so that the compiler keeps the matrix in registers.
    """
    g00, g01, g02, g03 = g[0, 0], g[0, 1], g[0, 2], g[0, 3]
    g11, g12, g13 = g[1, 1], g[1, 2], g[1, 3]
    g22, g23 = g[2, 2], g[2, 3]
    g33 = g[3, 3]
    coeffs[2] = ((g00 * g11 - g01 * g01) + (g00 * g22 - g02 * g02) + (g00 * g33 - g03 * g03)
                 + (g11 * g22 - g12 * g12) + (g11 * g33 - g13 * g13) + (g22 * g33 - g23 * g23))
    # 2 x 2 minors shared by the four principal 3 x 3 minors (Laplace on their first row)
    m12 = g11 * g22 - g12 * g12
    m13 = g11 * g33 - g13 * g13
    m23 = g22 * g33 - g23 * g23
    e3 = (g00 * m12 - g01 * (g01 * g22 - g12 * g02) + g02 * (g01 * g12 - g11 * g02)
          + g00 * m13 - g01 * (g01 * g33 - g13 * g03) + g03 * (g01 * g13 - g11 * g03)
          + g00 * m23 - g02 * (g02 * g33 - g23 * g03) + g03 * (g02 * g23 - g22 * g03)
          + g11 * m23 - g12 * (g12 * g33 - g23 * g13) + g13 * (g12 * g23 - g22 * g13))
    coeffs[3] = -e3


@inline_jit
def _inverse_condition_2x2(m00, m01, m10, m11):
    """``sigma_min / sigma_max`` of a finite 2 x 2 matrix in closed form (as
    :func:`kinematics.conditioning._ratio_2x2`): ``lambda_max`` of ``G = m^T m``
    from the quadratic, then ``lambda_min lambda_max = det(m)^2`` gives
    ``sigma_min / sigma_max = |det m| / lambda_max`` without cancellation."""
    det = m00 * m11 - m01 * m10
    trace = m00 * m00 + m10 * m10 + m01 * m01 + m11 * m11
    disc = trace * trace - 4.0 * det * det
    lam_max = 0.5 * (trace + math.sqrt(disc if disc > 0.0 else 0.0))
    if not lam_max > 0.0:
        return 0.0
    ratio = abs(det) / lam_max
    if ratio != ratio:
        return 0.0
    return min(ratio, 1.0)


@inline_jit
def _extreme_ratio(coeffs, n, trace):
    """``sqrt(lambda_min / lambda_max)`` in [0, 1] of the characteristic polynomial ``coeffs``
    (degree n, trace ``-coeffs[1]``) of ``G = m^T m``, by Laguerre from both sides."""
    # start each iteration on its side of the root, as close as cheap bounds allow:
    # sum(lambda^2) = e1^2 - 2 e2 >= lambda_max^2, and e_n / e_(n-1) <= lambda_min
    # (e_(n-1) >= the product of the n - 1 largest eigenvalues)
    squares = trace * trace - 2.0 * coeffs[2]
    upper = math.sqrt(squares) if squares > 0.0 else trace
    e_last, e_before = abs(coeffs[n]), abs(coeffs[n - 1])
    lower = e_last / e_before if e_before > 0.0 else 0.0
    lam_max, lam_min = _extreme_roots(coeffs, n, min(upper, trace), min(lower, upper))
    if not lam_max > 0.0:
        return 0.0
    ratio = math.sqrt(max(lam_min, 0.0) / lam_max)
    if ratio != ratio:
        return 0.0
    return min(max(ratio, 0.0), 1.0)


@inline_jit
def _inverse_condition_3x3(m, gram, coeffs):
    """``sigma_min / sigma_max`` of one finite 3 x 3 ``m`` (as :func:`kinematics.conditioning._ratio`):
    the extreme eigenvalues of ``G = m^T m`` from its characteristic polynomial (sums of
    principal minors, ``det G = det(m)^2``) by Laguerre's method. ``gram`` (3, 3) and
    ``coeffs`` (4,) are scratch arrays."""
    for i in range(3):
        for j in range(i, 3):
            s = 0.0
            for k in range(3):
                s += m[k, i] * m[k, j]
            gram[i, j] = s
            gram[j, i] = s
    coeffs[0] = 1.0
    trace = 0.0
    for i in range(3):
        trace += gram[i, i]
    coeffs[1] = -trace
    e2 = 0.0
    for i in range(3):
        for j in range(i + 1, 3):
            e2 += gram[i, i] * gram[j, j] - gram[i, j] * gram[j, i]
    coeffs[2] = e2
    det = _det3(m, 0, 1, 2, 0, 1, 2)
    coeffs[3] = -det * det
    return _extreme_ratio(coeffs, 3, trace)


@inline_jit
def _inverse_condition_4x4(m, gram, coeffs):
    """The same for one finite 4 x 4 ``m``; ``gram`` (4, 4), ``coeffs`` (5,)."""
    _gram4(m, gram)
    coeffs[0] = 1.0
    trace = 0.0
    for i in range(4):
        trace += gram[i, i]
    coeffs[1] = -trace
    _charpoly4(gram, coeffs)
    det = (m[0, 0] * _det3(m, 1, 2, 3, 1, 2, 3) - m[0, 1] * _det3(m, 1, 2, 3, 0, 2, 3)
           + m[0, 2] * _det3(m, 1, 2, 3, 0, 1, 3) - m[0, 3] * _det3(m, 1, 2, 3, 0, 1, 2))
    coeffs[4] = det * det
    return _extreme_ratio(coeffs, 4, trace)


@inline_jit
def _scaled_copy(jac, p, column_scale, m):
    """Copy matrix ``p`` of ``jac`` times ``diag(column_scale)`` into ``m``; 0 when every entry
    is finite (or finite with an overflowing sum), 1 if any is NaN, 2 if any is infinite."""
    n = m.shape[0]
    total = 0.0
    for i in range(n):
        for j in range(n):
            v = jac[p, i, j] * column_scale[j]
            total += v
            m[i, j] = v
    if math.isfinite(total):  # every entry finite: the common case, one test
        return 0
    has_inf = False
    for i in range(n):
        for j in range(n):
            v = m[i, j]
            if v != v:
                return 1
            if math.isinf(v):
                has_inf = True
    return 2 if has_inf else 0


@jit
def _batch_2x2(jac, column_scale):
    """2 x 2 batch (see :func:`inverse_condition_batch`): the closed form."""
    out = np.empty(jac.shape[0])
    m = np.empty((2, 2))
    for p in range(jac.shape[0]):
        kind = _scaled_copy(jac, p, column_scale, m)
        out[p] = (_inverse_condition_2x2(m[0, 0], m[0, 1], m[1, 0], m[1, 1]) if kind == 0
                  else (np.nan if kind == 1 else 0.0))
    return out


@jit
def _batch_3x3(jac, column_scale):
    """3 x 3 batch (see :func:`inverse_condition_batch`)."""
    out = np.empty(jac.shape[0])
    m, gram, coeffs = np.empty((3, 3)), np.empty((3, 3)), np.empty(4)
    for p in range(jac.shape[0]):
        kind = _scaled_copy(jac, p, column_scale, m)
        out[p] = _inverse_condition_3x3(m, gram, coeffs) if kind == 0 else (np.nan if kind == 1 else 0.0)
    return out


@jit
def _batch_4x4(jac, column_scale):
    """4 x 4 batch (see :func:`inverse_condition_batch`)."""
    out = np.empty(jac.shape[0])
    m, gram, coeffs = np.empty((4, 4)), np.empty((4, 4)), np.empty(5)
    for p in range(jac.shape[0]):
        kind = _scaled_copy(jac, p, column_scale, m)
        out[p] = _inverse_condition_4x4(m, gram, coeffs) if kind == 0 else (np.nan if kind == 1 else 0.0)
    return out


#: the compiled batch of each matrix size; one function per size, so that a mechanism
#: compiles only the code of its own size on a new machine (the first run's compile time)
_BATCHES = {2: _batch_2x2, 3: _batch_3x3, 4: _batch_4x4}


def inverse_condition_batch(jac: np.ndarray, column_scale: np.ndarray) -> np.ndarray:
    """``1/kappa`` of each matrix of ``jac`` (N, n, n), n = 2, 3 or 4, times ``diag(column_scale)``.

    Same algorithm as :func:`kinematics.conditioning._ratio`: closed form for
    n = 2; otherwise the extreme eigenvalues of ``G = m^T m`` from its
    characteristic polynomial (sums of principal minors, ``det G = det(m)^2``)
    by Laguerre's method. NaN where any entry is NaN (unreachable pose), 0
    where an entry is infinite (singular actuator Jacobian), as
    :func:`kinematics.conditioning.inverse_condition_number`. Values in [0, 1].
    """
    return _BATCHES[jac.shape[1]](jac, column_scale)
