"""Polynomial elimination and root polishing shared by the forward kinematics.

Why this module exists: the forward kinematics of H4 (seed 000 eq. 22-24),
of the 3-RPR (a degree-6 polynomial in tan(phi/2)) and of the Tricept (seed
001 eq. 25-27) all reduce to trigonometric polynomials in one or two angles.
Expanding them symbolically is long and error-prone (the OCR text carries
typos in exactly those expansions), so we build them *numerically*:

1. evaluate the trigonometric polynomial on an equally spaced grid of angles
   and read its Fourier coefficients with an FFT (exact for a trigonometric
   polynomial of known degree, up to rounding);
2. map ``exp(i k theta)`` to ``(1 + iT)^(n+k) (1 - iT)^(n-k) / (1 + T^2)^n``
   with ``T = tan(theta/2)`` (seed 000 eq. 23) to get an ordinary polynomial
   in ``T``;
3. take its roots (companion matrix), or, for two angles, eliminate one of
   them with a Sylvester matrix and solve the resulting polynomial
   eigenvalue problem by a companion linearisation (numerically stable,
   unlike expanding the determinant);
4. polish every real candidate with Newton's method on the original
   constraint equations and keep the ones that converge.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import lru_cache

import numpy as np
import scipy.linalg
from numpy.polynomial import polynomial as P


# --------------------------------------------------------- trig polynomials
def sample_angles(degree: int) -> np.ndarray:
    """Equally spaced angles (rad) that resolve a trig polynomial of ``degree``.

    Returns ``4 * degree + 4`` samples (at least ``2 * degree + 1`` are needed;
    the surplus lets callers verify that higher harmonics vanish).
    """
    m = 4 * degree + 4
    return 2.0 * np.pi * np.arange(m) / m


def trig_coefficients(values: np.ndarray, degree: int, axis: int = -1) -> np.ndarray:
    """Complex Fourier coefficients ``c_k, k = -degree..degree`` along ``axis``.

    ``values`` holds samples at :func:`sample_angles` ``(degree)`` along ``axis``.
    The function is ``f(theta) = sum_k c_k exp(i k theta)``.
    """
    values = np.moveaxis(np.asarray(values), axis, -1)
    m = values.shape[-1]
    spec = np.fft.fft(values, axis=-1) / m
    idx = np.arange(-degree, degree + 1) % m
    return np.moveaxis(spec[..., idx], -1, axis)


@lru_cache(maxsize=16)
def _tan_half_basis(degree: int) -> np.ndarray:
    """Matrix B (2n+1, 2n+1): row k+n holds (1+iT)^(n+k) (1-iT)^(n-k), ascending in T."""
    n = degree
    rows = []
    for k in range(-n, n + 1):
        row = P.polymul(P.polypow([1.0, 1.0j], n + k), P.polypow([1.0, -1.0j], n - k))
        rows.append(np.pad(row, (0, 2 * n + 1 - len(row))))
    return np.array(rows)


def trig_to_tan_half(coefs: np.ndarray, axis: int = -1) -> np.ndarray:
    """Map trig coefficients (length 2n+1 along ``axis``) to polynomial coefficients in T.

    The result, ascending in ``T = tan(theta/2)`` along ``axis``, is
    ``(1 + T^2)^n f(theta)``; it is real when ``f`` is real.
    """
    coefs = np.moveaxis(np.asarray(coefs), axis, -1)
    n = (coefs.shape[-1] - 1) // 2
    poly = coefs @ _tan_half_basis(n)
    return np.moveaxis(poly, -1, axis)


def trig_polynomial_in_tan_half(func: Callable[[np.ndarray], np.ndarray], degree: int) -> np.ndarray:
    """Coefficients (highest degree first, length 2*degree+1) of ``(1+T^2)^n f(theta)``.

    ``func`` maps an array of angles (rad) to the values of a real trig
    polynomial of the given degree.
    """
    theta = sample_angles(degree)
    coefs = trig_coefficients(func(theta), degree)
    return np.real(trig_to_tan_half(coefs))[::-1]


def tan_half_to_angle(t: np.ndarray) -> np.ndarray:
    """``theta = 2 atan(T)`` in (-pi, pi) (rad)."""
    return 2.0 * np.arctan(t)


def near_real(roots: np.ndarray, rel_tol: float = 1e-4) -> np.ndarray:
    """Real parts of roots whose imaginary part is small relative to ``1 + |root|``.

    The tolerance is loose on purpose: close real roots come out of the
    eigen-solver as complex pairs; Newton polishing decides what is real.
    """
    roots = np.asarray(roots)
    roots = roots[np.isfinite(roots)]
    keep = np.abs(roots.imag) <= rel_tol * (1.0 + np.abs(roots))
    return np.real(roots[keep])


def real_tan_half_angles(coefs_high_first: np.ndarray) -> np.ndarray:
    """Angles (rad) of the near-real roots of a polynomial in ``T = tan(angle/2)``.

    A vanishing leading coefficient means the degree dropped: ``T`` infinite,
    i.e. ``angle = pi``, is then a root too.
    """
    coefs = np.asarray(coefs_high_first, dtype=float)
    angles = tan_half_to_angle(near_real(polynomial_roots(coefs)))
    if abs(coefs[0]) < 1e-10 * np.max(np.abs(coefs)):
        angles = np.append(angles, np.pi)
    return angles


def polynomial_roots(coefs_high_first: np.ndarray) -> np.ndarray:
    """All complex roots of a polynomial, dropping leading coefficients that are ~0."""
    c = np.asarray(coefs_high_first, dtype=float)
    scale = np.max(np.abs(c)) if c.size else 0.0
    if scale == 0:
        return np.empty(0, dtype=complex)
    nz = np.nonzero(np.abs(c) > 1e-13 * scale)[0]
    c = c[nz[0] :]
    if c.size <= 1:
        return np.empty(0, dtype=complex)
    return np.roots(c / scale)


# ------------------------------------------------ bivariate elimination
def sylvester_matrix_polynomial(f: np.ndarray, g: np.ndarray) -> np.ndarray:
    """Sylvester matrix of ``f`` and ``g`` in y, as a matrix polynomial in x.

    Parameters
    ----------
    f, g : ndarray, shape (dx + 1, dy + 1)
        Coefficients ``f[i, j]`` of ``x^i y^j`` (ascending in both).

    Returns
    -------
    ndarray, shape (deg_x + 1, m + n, m + n)
        ``S[l]`` is the coefficient of ``x^l``; ``det(sum_l S[l] x^l)`` is the
        resultant of f and g with respect to y (m, n the y-degrees).
    """
    m = f.shape[1] - 1
    n = g.shape[1] - 1
    dx = max(f.shape[0], g.shape[0])
    size = m + n
    S = np.zeros((dx, size, size))
    for row in range(n):  # n shifted copies of f (descending powers of y)
        S[: f.shape[0], row, row : row + m + 1] = f[:, ::-1]
    for row in range(m):
        S[: g.shape[0], n + row, row : row + n + 1] = g[:, ::-1]
    return S


def matrix_polynomial_eigenvalues(S: np.ndarray) -> np.ndarray:
    """Finite eigenvalues ``x`` of ``det(sum_l S[l] x^l) = 0`` (companion linearisation).

    Uses the first companion pencil ``A z = x B z`` solved with QZ, which stays
    accurate where expanding the determinant would not.
    """
    # drop trailing all-zero coefficients
    scale = np.max(np.abs(S))
    while S.shape[0] > 1 and np.max(np.abs(S[-1])) <= 1e-14 * scale:
        S = S[:-1]
    d = S.shape[0] - 1
    k = S.shape[1]
    if d == 0:
        return np.empty(0, dtype=complex)
    S = S / scale
    A = np.zeros((d * k, d * k))
    B = np.eye(d * k)
    A[: (d - 1) * k, k:] = np.eye((d - 1) * k)
    for j in range(d):
        A[(d - 1) * k :, j * k : (j + 1) * k] = -S[j]
    B[(d - 1) * k :, (d - 1) * k :] = S[d]
    vals = scipy.linalg.eigvals(A, B)
    return vals[np.isfinite(vals)]


# ------------------------------------------------------------- polishing
def newton_polish(
    residual: Callable[[np.ndarray], np.ndarray],
    jacobian: Callable[[np.ndarray], np.ndarray],
    x0: np.ndarray,
    iterations: int = 40,
) -> tuple[np.ndarray, np.ndarray]:
    """Newton's method on a batch of square systems.

    Parameters
    ----------
    residual : callable, (K, n) -> (K, n)
    jacobian : callable, (K, n) -> (K, n, n)
    x0 : ndarray, shape (K, n)
        Starting points.

    Returns
    -------
    x : ndarray, shape (K, n)
        Polished points.
    res : ndarray, shape (K, n)
        Residuals at ``x``.
    """
    x = np.array(x0, dtype=float, copy=True)
    if x.shape[0] == 0:
        return x, x.copy()
    active = np.ones(x.shape[0], dtype=bool)
    for _ in range(iterations):
        idx = np.nonzero(active)[0]
        r = residual(x[idx])
        jac = jacobian(x[idx])
        ok = np.isfinite(r).all(axis=1) & np.isfinite(jac).all(axis=(1, 2))
        # pinv instead of solve: a singular Jacobian on one candidate must not
        # abort the batch
        step = np.einsum("kij,kj->ki", np.linalg.pinv(jac[ok]), r[ok])
        x[idx[ok]] -= step
        done = np.max(np.abs(step) / (1.0 + np.abs(x[idx[ok]])), axis=1) < 1e-14
        active[idx[~ok]] = False  # diverged: leave it, the caller's residual check rejects it
        active[idx[ok][done]] = False
        if not active.any():
            break
    return x, residual(x)


def unique_rows(x: np.ndarray, rel_tol: float = 1e-7) -> np.ndarray:
    """Rows of ``x`` (K, n) with near-duplicates (relative ``rel_tol``) removed, first kept."""
    kept: list[np.ndarray] = []
    for row in x:
        if not any(np.all(np.abs(row - k) <= rel_tol * (1.0 + np.abs(k))) for k in kept):
            kept.append(row)
    return np.array(kept).reshape(-1, x.shape[1])


def wrap_angle(a: np.ndarray) -> np.ndarray:
    """Angle(s) wrapped to (-pi, pi] (rad); values within 1e-9 of -pi map to +pi.

    The snap keeps one representative for a solution found on either side of
    the cut, so duplicates are recognised.
    """
    w = np.mod(np.asarray(a, dtype=float) + np.pi, 2 * np.pi) - np.pi
    return np.where(w <= -np.pi + 1e-9, w + 2 * np.pi, w)
