"""Compiled per-pose kernels (numba) and the switch back to the numpy reference.

Why: a workspace evaluation conditions ~10^4 small Jacobians. The numpy path
(:mod:`kinematics.conditioning`, the mechanisms' ``_jacobian``) is vectorised
over poses but spends most of its time allocating (N,)-sized temporaries for
every entry of every intermediate matrix. A fused loop that keeps one pose's
matrix in registers does the same arithmetic ~5-10x faster on one core.

The numpy path stays the reference: ``PM_DESIGN_KERNELS=numpy`` in the
environment (or :func:`reference_kernels` in code) turns every compiled path
off, and the tests compare the two (same V and GDI to 1e-12 relative). The
planar mechanisms' exact sections (:func:`kinematics.annuli.annuli_x_sections`)
are compiled only: they have no numpy twin, and the conformance harness checks
them against the cell grid instead. The
kernels are serial and free of reductions whose order depends on threads, so
results do not depend on the number of joblib workers.

Compiled code is cached on disk (``cache=True``: next to the sources, or in
numba's user cache when that folder is read-only), so only the first run on a
machine pays the compile time (about 3.5 s for H4's kernels, measured).
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
#: the same with numpy's error model: a float division by zero gives inf or NaN instead of raising,
#: so a loop over poses whose divisions are all guarded by selects has no branch left and LLVM
#: vectorises it (4 poses per AVX2 instruction). The results are the same IEEE operations.
vector_jit = numba.njit(cache=True, nogil=True, error_model="numpy")
#: the same for small helpers of a kernel, inlined into their caller by numba itself
#: (a plain call into them keeps LLVM from optimising across it: ~1.6x slower loops). numba
#: checks a cached kernel against its own file only: a kernel that inlines helpers of another
#: module is not recompiled when that module changes, so every kernel calls compiled helpers of
#: its own module only
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
        raise ValueError(
            f"environment variable {KERNELS_ENV} must be one of {', '.join(KERNEL_CHOICES)}; got {choice!r}"
        )
    return choice == "numba"


@contextlib.contextmanager
def reference_kernels() -> Iterator[None]:
    """Within the block, every evaluation takes the numpy reference path."""
    _forced.append("numpy")
    try:
        yield
    finally:
        _forced.pop()


# ------------------------------------------------------------ trigonometry
@jit
def periodic_cos_sin(angles):
    """``cos`` and ``sin`` of each angle (N,) (rad), for an angle column of a grid: a grid
    repeats its values with a period (the angle is a fast axis), so the values of the pose one
    period back are reused when its angle is the same number (the same results as computing
    every one, at a fraction of the cost). Any other order of angles is computed in full."""
    count = angles.shape[0]
    cos_a, sin_a = np.empty(count), np.empty(count)
    period = 1
    while period < min(count, 4096) and angles[period] != angles[0]:
        period += 1
    if period == 1 or period >= count:  # runs of one angle (a slow axis), or no repetition
        for p in range(count):
            angle = angles[p]
            if p >= period and angles[p - period] == angle:
                cos_a[p], sin_a[p] = cos_a[p - period], sin_a[p - period]
            else:
                cos_a[p], sin_a[p] = math.cos(angle), math.sin(angle)
        return cos_a, sin_a
    # a fast axis: the same choice per pose, as runs of poses that repeat the period before,
    # each copied in a loop of its own (the loop above, with its test per pose, stalls on the
    # value stored one period back: ~5x slower for a grid's angle column)
    for p in range(period):
        cos_a[p], sin_a[p] = math.cos(angles[p]), math.sin(angles[p])
    p = period
    while p < count:
        q = p
        while q < count and angles[q - period] == angles[q]:
            q += 1
        for r in range(p, q):
            cos_a[r] = cos_a[r - period]
            sin_a[r] = sin_a[r - period]
        if q < count:
            cos_a[q], sin_a[q] = math.cos(angles[q]), math.sin(angles[q])
        p = q + 1
    return cos_a, sin_a


# ------------------------------------------------------------ conditioning
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
def _ratio_of_extremes(lam_max, lam_min):
    """``sqrt(lambda_min / lambda_max)`` clipped to [0, 1]; 0 for a zero or undefined ratio."""
    if not lam_max > 0.0:
        return 0.0
    ratio = math.sqrt(max(lam_min, 0.0) / lam_max)
    if ratio != ratio:
        return 0.0
    return min(max(ratio, 0.0), 1.0)


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
        out[p] = (
            _inverse_condition_2x2(m[0, 0], m[0, 1], m[1, 0], m[1, 1]) if kind == 0 else (np.nan if kind == 1 else 0.0)
        )
    return out


#: poses per block of the 3 x 3 and 4 x 4 batches: the Laguerre passes over a block run until
#: its slowest pose has converged
BLOCK = 256


@inline_jit
def _coefficients_3x3(jac, p, column_scale):
    """Matrix ``p`` of ``jac`` times ``diag(column_scale)``: the coefficients
    ``x^3 + c1 x^2 + c2 x + c3`` of the characteristic polynomial of ``G = m^T m`` (sums of
    principal minors; ``c3 = -det(m)^2``). ``-c1``, the trace of G, is the sum of the squared
    entries: finite exactly when every entry is finite, unless the sum overflows. Written out on
    scalars so that the matrix stays in registers."""
    s0, s1, s2 = column_scale[0], column_scale[1], column_scale[2]
    m00, m01, m02 = jac[p, 0, 0] * s0, jac[p, 0, 1] * s1, jac[p, 0, 2] * s2
    m10, m11, m12 = jac[p, 1, 0] * s0, jac[p, 1, 1] * s1, jac[p, 1, 2] * s2
    m20, m21, m22 = jac[p, 2, 0] * s0, jac[p, 2, 1] * s1, jac[p, 2, 2] * s2
    g00 = 0.0 + m00 * m00 + m10 * m10 + m20 * m20
    g01 = 0.0 + m00 * m01 + m10 * m11 + m20 * m21
    g02 = 0.0 + m00 * m02 + m10 * m12 + m20 * m22
    g11 = 0.0 + m01 * m01 + m11 * m11 + m21 * m21
    g12 = 0.0 + m01 * m02 + m11 * m12 + m21 * m22
    g22 = 0.0 + m02 * m02 + m12 * m12 + m22 * m22
    trace = 0.0 + g00 + g11 + g22
    e2 = 0.0 + (g00 * g11 - g01 * g01) + (g00 * g22 - g02 * g02) + (g11 * g22 - g12 * g12)
    det = m00 * (m11 * m22 - m12 * m21) - m01 * (m10 * m22 - m12 * m20) + m02 * (m10 * m21 - m11 * m20)
    return -trace, e2, -det * det, 0.0


@inline_jit
def _coefficients_4x4(jac, p, column_scale):
    """The same for a 4 x 4 matrix: ``x^4 + c1 x^3 + c2 x^2 + c3 x + c4`` (``c4 = det(m)^2``)."""
    s0, s1, s2, s3 = column_scale[0], column_scale[1], column_scale[2], column_scale[3]
    m00, m01, m02, m03 = jac[p, 0, 0] * s0, jac[p, 0, 1] * s1, jac[p, 0, 2] * s2, jac[p, 0, 3] * s3
    m10, m11, m12, m13 = jac[p, 1, 0] * s0, jac[p, 1, 1] * s1, jac[p, 1, 2] * s2, jac[p, 1, 3] * s3
    m20, m21, m22, m23 = jac[p, 2, 0] * s0, jac[p, 2, 1] * s1, jac[p, 2, 2] * s2, jac[p, 2, 3] * s3
    m30, m31, m32, m33 = jac[p, 3, 0] * s0, jac[p, 3, 1] * s1, jac[p, 3, 2] * s2, jac[p, 3, 3] * s3
    g00 = m00 * m00 + m10 * m10 + m20 * m20 + m30 * m30
    g01 = m00 * m01 + m10 * m11 + m20 * m21 + m30 * m31
    g02 = m00 * m02 + m10 * m12 + m20 * m22 + m30 * m32
    g03 = m00 * m03 + m10 * m13 + m20 * m23 + m30 * m33
    g11 = m01 * m01 + m11 * m11 + m21 * m21 + m31 * m31
    g12 = m01 * m02 + m11 * m12 + m21 * m22 + m31 * m32
    g13 = m01 * m03 + m11 * m13 + m21 * m23 + m31 * m33
    g22 = m02 * m02 + m12 * m12 + m22 * m22 + m32 * m32
    g23 = m02 * m03 + m12 * m13 + m22 * m23 + m32 * m33
    g33 = m03 * m03 + m13 * m13 + m23 * m23 + m33 * m33
    trace = g00 + g11 + g22 + g33
    e2 = (
        (g00 * g11 - g01 * g01)
        + (g00 * g22 - g02 * g02)
        + (g00 * g33 - g03 * g03)
        + (g11 * g22 - g12 * g12)
        + (g11 * g33 - g13 * g13)
        + (g22 * g33 - g23 * g23)
    )
    # 2 x 2 minors shared by the four principal 3 x 3 minors (Laplace on their first row)
    q12 = g11 * g22 - g12 * g12
    q13 = g11 * g33 - g13 * g13
    q23 = g22 * g33 - g23 * g23
    e3 = (
        g00 * q12
        - g01 * (g01 * g22 - g12 * g02)
        + g02 * (g01 * g12 - g11 * g02)
        + g00 * q13
        - g01 * (g01 * g33 - g13 * g03)
        + g03 * (g01 * g13 - g11 * g03)
        + g00 * q23
        - g02 * (g02 * g33 - g23 * g03)
        + g03 * (g02 * g23 - g22 * g03)
        + g11 * q23
        - g12 * (g12 * g33 - g23 * g13)
        + g13 * (g12 * g23 - g22 * g13)
    )
    # det(m) by Laplace on row 0 (the 3 x 3 minors of rows 1-3 by Laplace on their first row)
    det = (
        m00 * (m11 * (m22 * m33 - m23 * m32) - m12 * (m21 * m33 - m23 * m31) + m13 * (m21 * m32 - m22 * m31))
        - m01 * (m10 * (m22 * m33 - m23 * m32) - m12 * (m20 * m33 - m23 * m30) + m13 * (m20 * m32 - m22 * m30))
        + m02 * (m10 * (m21 * m33 - m23 * m31) - m11 * (m20 * m33 - m23 * m30) + m13 * (m20 * m31 - m21 * m30))
        - m03 * (m10 * (m21 * m32 - m22 * m31) - m11 * (m20 * m32 - m22 * m30) + m12 * (m20 * m31 - m21 * m30))
    )
    return -trace, e2, -e3, det * det


@inline_jit
def _laguerre_starts(trace, e2, e_before, e_last):
    """Starting points above ``lambda_max`` and below ``lambda_min`` of ``G = m^T m`` from its
    trace, ``e2`` and the last two elementary symmetric functions (absolute values), so that
    each iteration converges monotonically to its root: ``sum(lambda^2) = e1^2 - 2 e2 >=
    lambda_max^2`` and ``e_n / e_(n-1) <= lambda_min`` (``e_(n-1)`` >= the product of the
    n - 1 largest eigenvalues)."""
    squares = trace * trace - 2.0 * e2
    root = math.sqrt(max(squares, 0.0))  # then selected: a select vectorises, a branch does not
    upper = root if squares > 0.0 else trace
    quotient = e_last / e_before
    lower = quotient if e_before > 0.0 else 0.0
    return min(upper, trace), min(lower, upper)


@vector_jit
def _laguerre_pass(c1, c2, c3, c4, degree, x, done):
    """One Laguerre step on ``x^n + c1 x^(n-1) + ... + c_n`` (n = ``degree``, 3 or 4; ``c4``
    unused for 3) for every pose of a block, branch-free so that LLVM vectorises the loop;
    a pose marked ``done`` keeps its root, a pose whose step falls below the last bit of its
    root is marked. Returns how many poses are still iterating."""
    quartic = degree == 4
    n = float(degree)
    active = 0
    for p in range(x.shape[0]):
        xv = x[p]
        # Horner with the first two derivatives, from the leading coefficient 1
        ddp = 0.0 * xv + 2.0 * 0.0
        dp = 0.0 * xv + 1.0
        pv = 1.0 * xv + c1[p]
        ddp = ddp * xv + 2.0 * dp
        dp = dp * xv + pv
        pv = pv * xv + c2[p]
        ddp = ddp * xv + 2.0 * dp
        dp = dp * xv + pv
        pv = pv * xv + c3[p]
        ddp4 = ddp * xv + 2.0 * dp
        dp4 = dp * xv + pv
        pv4 = pv * xv + c4[p]
        ddp = ddp4 if quartic else ddp
        dp = dp4 if quartic else dp
        pv = pv4 if quartic else pv
        inv_p = 1.0 / pv
        g = dp * inv_p
        h = g * g - ddp * inv_p
        disc = (n - 1.0) * (n * h - g * g)
        root = math.sqrt(disc)  # NaN where disc < 0, then not selected
        root = root if disc > 0.0 else 0.0
        denom = g + root if g >= 0.0 else g - root
        step = n / denom
        step = 0.0 if (denom == 0.0 or pv == 0.0) else step  # at a root or a flat point
        moved = xv - step
        finished = done[p]
        x[p] = xv if finished else moved
        finished = finished | (abs(step) <= 1e-9 * abs(moved))
        done[p] = finished
        active += 1 - finished
    return active


@vector_jit
def _coefficient_pass(jac, column_scale, degree, work):
    """Coefficients ``work[0:4]`` (:func:`_coefficients_3x3` or :func:`_coefficients_4x4` by
    ``degree``) and starting points ``work[4:6]`` (:func:`_laguerre_starts`) of every matrix of
    ``jac`` (a block). Written so that LLVM vectorises each loop: one loop per size and one for
    the starting points (together, its cost model keeps the 4 x 4 loop scalar), indices known to
    be >= 0 (no wrap-around test), one array written (few run-time alias checks), no branch."""
    if degree == 4:
        for k in range(jac.shape[0]):
            work[0, k], work[1, k], work[2, k], work[3, k] = _coefficients_4x4(jac, k, column_scale)
        for k in range(jac.shape[0]):
            work[4, k], work[5, k] = _laguerre_starts(-work[0, k], work[1, k], abs(work[2, k]), abs(work[3, k]))
    else:
        for k in range(jac.shape[0]):
            work[0, k], work[1, k], work[2, k], work[3, k] = _coefficients_3x3(jac, k, column_scale)
        for k in range(jac.shape[0]):
            work[4, k], work[5, k] = _laguerre_starts(-work[0, k], work[1, k], abs(work[1, k]), abs(work[2, k]))


@jit
def _batch_laguerre(jac, column_scale, degree):
    """The 3 x 3 (``degree`` 3) or 4 x 4 batch of :func:`inverse_condition_batch`, in blocks of
    :data:`BLOCK` matrices: their coefficients and starting points (:func:`_coefficient_pass`,
    vectorised); the matrices with an entry that is not finite get their value at once and leave
    the block; then Laguerre passes over the block (:func:`_laguerre_pass`, vectorised) from
    above ``lambda_max`` and below ``lambda_min``, each matrix stopping on its own once its step
    is below the last bit of its root or after :data:`LAGUERRE_STEPS`: the operations of a loop
    over one matrix at a time, hence the same values."""
    count = jac.shape[0]
    out = np.empty(count)
    work = np.empty((6, BLOCK))  # c1, c2, c3, c4, x_max, x_min of each matrix of the block
    c1, c2, c3, c4, x_max, x_min = work[0], work[1], work[2], work[3], work[4], work[5]
    done_max, done_min = np.empty(BLOCK, dtype=np.uint8), np.empty(BLOCK, dtype=np.uint8)
    rows = np.empty(BLOCK, dtype=np.int64)
    m = np.empty((degree, degree))
    for start in range(0, count, BLOCK):
        size = min(BLOCK, count - start)
        _coefficient_pass(jac[start : start + size], column_scale, degree, work)
        kept = 0
        for k in range(size):
            # classified as _scaled_copy does; a finite trace of G means finite entries
            kind = 0 if math.isfinite(c1[k]) else _scaled_copy(jac, start + k, column_scale, m)
            if kind != 0:
                out[start + k] = np.nan if kind == 1 else 0.0
                continue
            rows[kept] = start + k
            c1[kept], c2[kept], c3[kept], c4[kept] = c1[k], c2[k], c3[k], c4[k]
            x_max[kept], x_min[kept] = x_max[k], x_min[k]
            done_max[kept] = done_min[kept] = 0
            kept += 1
        for _ in range(LAGUERRE_STEPS):
            active = _laguerre_pass(
                c1[:kept], c2[:kept], c3[:kept], c4[:kept], degree, x_max[:kept], done_max[:kept]
            ) + _laguerre_pass(c1[:kept], c2[:kept], c3[:kept], c4[:kept], degree, x_min[:kept], done_min[:kept])
            if active == 0:
                break
        for k in range(kept):
            out[rows[k]] = _ratio_of_extremes(x_max[k], x_min[k])
    return out


def _batch_3x3(jac: np.ndarray, column_scale: np.ndarray) -> np.ndarray:
    """3 x 3 batch (see :func:`inverse_condition_batch`)."""
    return _batch_laguerre(jac, column_scale, 3)


def _batch_4x4(jac: np.ndarray, column_scale: np.ndarray) -> np.ndarray:
    """4 x 4 batch (see :func:`inverse_condition_batch`)."""
    return _batch_laguerre(jac, column_scale, 4)


#: the batch of each matrix size
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
