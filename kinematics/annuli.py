"""Exact areas of intersections of discs and annuli (planar constant-orientation workspaces).

A planar RPR leg of length ``rho_min..rho_max`` confines its platform joint to
an annulus; at constant orientation the 2-RPR and 3-RPR workspaces are
intersections of annuli (seed 003 eq. 12-14, seed 004). These functions give
their areas exactly, as references for the grid integration, and their exact
sections along x (:func:`annuli_x_sections`), on which ``workspace.evaluate``
integrates the planar mechanisms.
"""

from __future__ import annotations

import itertools
import math

import numpy as np

from kinematics import kernels


def lens_area(r1: float, r2: float, distance: float) -> float:
    """Area of the intersection of two discs of radii r1, r2 whose centres are ``distance`` apart.

    Closed form from circle-circle intersection geometry: two circular
    segments, ``r^2 acos(.) `` each, minus the kite between the centres and
    the two intersection points (Heron's formula).
    """
    d = float(distance)
    if d >= r1 + r2:
        return 0.0
    if d <= abs(r1 - r2):
        return math.pi * min(r1, r2) ** 2
    a1 = math.acos(np.clip((d * d + r1 * r1 - r2 * r2) / (2 * d * r1), -1.0, 1.0))
    a2 = math.acos(np.clip((d * d + r2 * r2 - r1 * r1) / (2 * d * r2), -1.0, 1.0))
    kite = 0.5 * math.sqrt(max((-d + r1 + r2) * (d + r1 - r2) * (d - r1 + r2) * (d + r1 + r2), 0.0))
    return r1 * r1 * a1 + r2 * r2 * a2 - kite


def two_annuli_area(distance: float, r_in: float, r_out: float) -> float:
    """Area of the intersection of two equal annuli ``r_in <= |p - c_i| <= r_out``.

    Inclusion-exclusion on discs (inner discs lie inside outer ones):
    ``|O1 O2| - |O1 I2| - |I1 O2| + |I1 I2|``.
    """
    return lens_area(r_out, r_out, distance) - 2 * lens_area(r_out, r_in, distance) + lens_area(r_in, r_in, distance)


def discs_intersection_area(centres: np.ndarray, radii: np.ndarray) -> float:
    """Exact area of the intersection of discs (Green's theorem over the boundary arcs).

    The intersection is convex and bounded by arcs of the circles. For each
    circle, the arcs between its intersection points with the others are
    kept when their midpoint lies in every other disc; each kept arc from
    angle a to b contributes ``(r^2 (b - a) + r cx (sin b - sin a) - r cy (cos b - cos a)) / 2``.
    """
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    radii = np.asarray(radii, dtype=float).ravel()
    n = len(radii)
    if n == 0:
        return 0.0
    if np.any(radii <= 0):
        return 0.0
    area = 0.0
    for i in range(n):
        c, r = centres[i], radii[i]
        cuts = [0.0, 2 * math.pi]
        for j in range(n):
            if j == i:
                continue
            d = float(np.hypot(*(centres[j] - c)))
            if d == 0 or d >= r + radii[j] or d <= abs(r - radii[j]):
                continue
            base = math.atan2(centres[j, 1] - c[1], centres[j, 0] - c[0])
            half = math.acos((d * d + r * r - radii[j] ** 2) / (2 * d * r))
            cuts.extend([(base - half) % (2 * math.pi), (base + half) % (2 * math.pi)])
        cuts = sorted(cuts)
        for a, b in zip(cuts[:-1], cuts[1:]):
            if b - a <= 0:
                continue
            mid = 0.5 * (a + b)
            point = c + r * np.array([math.cos(mid), math.sin(mid)])
            others = [k for k in range(n) if k != i]
            inside = all(np.hypot(*(point - centres[k])) <= radii[k] * (1 + 1e-12) for k in others)
            # identical circles: let only the first one draw the shared arc
            duplicate = any(k < i and np.allclose(centres[k], c) and radii[k] == r for k in others)
            if inside and not duplicate:
                area += 0.5 * (
                    r * r * (b - a) + r * c[0] * (math.sin(b) - math.sin(a)) - r * c[1] * (math.cos(b) - math.cos(a))
                )
    return max(area, 0.0)


def annuli_intersection_area(centres: np.ndarray, r_in: np.ndarray, r_out: np.ndarray) -> float:
    """Exact area of ``{p : r_in_i <= |p - c_i| <= r_out_i for all i}``.

    ``(∩ O_i) minus (∪ I_i)``, with the union removed by inclusion-exclusion:
    ``|∩O| - sum_{S != {}} (-1)^{|S|+1} |∩O ∩ (∩_{i in S} I_i)|``.
    """
    centres = np.asarray(centres, dtype=float).reshape(-1, 2)
    r_in = np.broadcast_to(np.asarray(r_in, dtype=float), (len(centres),))
    r_out = np.broadcast_to(np.asarray(r_out, dtype=float), (len(centres),))
    area = discs_intersection_area(centres, r_out)
    n = len(centres)
    for size in range(1, n + 1):
        for subset in itertools.combinations(range(n), size):
            sub = list(subset)
            inter = discs_intersection_area(np.vstack([centres, centres[sub]]), np.concatenate([r_out, r_in[sub]]))
            area -= (-1) ** (size + 1) * inter
    return max(area, 0.0)


# ----------------------------------------------------- exact x-sections
@kernels.inline_jit
def _above(s0, s1, level):
    """Part of a segment where the linear interpolant of s (from s0 to s1) exceeds ``level``:
    ``(fraction, integral of s over it per unit length)``."""
    if s0 > level and s1 > level:
        return 1.0, 0.5 * (s0 + s1)
    if s0 <= level and s1 <= level:
        return 0.0, 0.0
    t = (s0 - level) / (s0 - s1)
    if s0 > level:
        return t, t * 0.5 * (s0 + level)
    return 1.0 - t, (1.0 - t) * 0.5 * (level + s1)


@kernels.inline_jit
def _segment(s0, s1, d0, d1, limit, width):
    """Dexterous measure and integral of ``|s|`` on a segment of ``width`` (length unit) with the signed
    ``1/kappa`` s0, s1 and its x-derivatives d0, d1 at the ends: ``|s|`` linear between the
    ends, cut where it meets ``limit`` (0: no limit), plus the Hermite (corrected trapezoid)
    term ``width^2 / 12 (d|s|_0 - d|s|_1)`` times the dexterous fraction (continuous)."""
    f_pos, i_pos = _above(s0, s1, limit)
    f_neg, i_neg = _above(-s0, -s1, limit)
    fraction = 1.0 if limit <= 0.0 else f_pos + f_neg
    integral = (i_pos + i_neg) * width
    if s0 * s1 > 0.0:
        sign = 1.0 if s0 > 0.0 else -1.0
        integral += fraction * width * width / 12.0 * sign * (d0 - d1)
    return fraction * width, integral


@kernels.inline_jit
def annuli_x_sections(ys, centres_x, centres_y, rho_min, rho_max, signed_ic, row_args, origin, step, limit):
    """Exact sections along x of intersections of annuli, and ``1/kappa`` integrated along them.

    Row p (at ``y = ys[p]``) is the set of x with ``rho_min <= |(x, y) - c_pi| <= rho_max`` for
    every centre ``c_pi = (centres_x[p, i], centres_y[p, i])`` (a planar RPR leg per annulus:
    seed 003 eq. 12-14, seed 004 eq. 1-2): the intersection of the outer discs' chords, an
    interval, minus the inner discs' chords, in closed form (at most ``m + 1`` intervals for m
    annuli). Along each interval the signed inverse condition number
    ``s = signed_ic(x, y, row_args[p])`` (``sign(det J) / kappa``, smooth through a singularity)
    is sampled at the interval's ends and at the nodes ``origin + k step`` inside it, with its
    x-derivative (a difference over ``1e-6 step``); the dexterous part ``|s| > limit`` is cut
    where the linear interpolant of s meets the limit (each such crossing is sampled too), and
    ``|s|`` is integrated by the corrected trapezoid rule (cubic Hermite, :func:`_segment`).
    Every quantity moves continuously with the centres and ``y``. Inlined into a kernel per
    mechanism that names its ``signed_ic`` (:data:`kinematics.kernels.inline_jit`: so that the
    mechanism's kernel is cached on disk).

    Parameters
    ----------
    ys : ndarray, shape (N,)
        The rows' y (length unit of the mechanism, e.g. mm).
    centres_x, centres_y : ndarray, shape (N, m)
        Annulus centres per row (same unit).
    rho_min, rho_max : float
        Inner and outer radius of every annulus (the leg range).
    signed_ic : compiled function ``(x, y, args) -> float``
        Signed ``1/kappa`` at (x, y) of the row whose arguments are ``args`` (1-D float array).
    row_args : ndarray, shape (N, k)
        Per-row arguments of ``signed_ic``.
    origin, step : float
        Sample nodes along x, ``step > 0``.
    limit : float
        Dexterity limit on ``|s|`` (0: none).

    Returns
    -------
    measure, reach, integral, ic_min, ic_max : ndarray, shape (N,)
        Length of each dexterous section, of the reachable section (the intervals, whatever
        ``1/kappa``), the integral of ``1/kappa`` over the dexterous one, the extremes of
        ``1/kappa`` over its samples (inf / -inf for an empty section).
    evaluated : int
        Evaluations of ``signed_ic`` (the cost).
    """
    count, legs = centres_x.shape
    measure = np.zeros(count)
    reach = np.zeros(count)
    integral = np.zeros(count)
    ic_min = np.full(count, np.inf)
    ic_max = np.full(count, -np.inf)
    evaluated = 0
    size = 2 * legs + 2
    lo, hi, lo2, hi2 = np.empty(size), np.empty(size), np.empty(size), np.empty(size)
    outer2, inner2 = rho_max * rho_max, rho_min * rho_min
    delta = 1e-6 * step  # forward difference of the x-derivative
    for p in range(count):
        y = ys[p]
        args = row_args[p]
        left, right = -np.inf, np.inf
        for i in range(legs):
            b = y - centres_y[p, i]
            w2 = outer2 - b * b
            if w2 < 0.0:
                left, right = 1.0, 0.0
                break
            w = math.sqrt(w2)
            left, right = max(left, centres_x[p, i] - w), min(right, centres_x[p, i] + w)
        if not right > left:
            continue
        n = 1
        lo[0], hi[0] = left, right
        for i in range(legs):  # remove the inner discs (|L_i| < rho_min)
            b = y - centres_y[p, i]
            w2 = inner2 - b * b
            if w2 <= 0.0:
                continue
            w = math.sqrt(w2)
            hole_lo, hole_hi = centres_x[p, i] - w, centres_x[p, i] + w
            k = 0
            for j in range(n):
                if hole_hi <= lo[j] or hole_lo >= hi[j]:
                    lo2[k], hi2[k] = lo[j], hi[j]
                    k += 1
                    continue
                if hole_lo > lo[j]:
                    lo2[k], hi2[k] = lo[j], hole_lo
                    k += 1
                if hole_hi < hi[j]:
                    lo2[k], hi2[k] = hole_hi, hi[j]
                    k += 1
            n = k
            for j in range(n):
                lo[j], hi[j] = lo2[j], hi2[j]
        total, weighted = 0.0, 0.0
        for j in range(n):
            reach[p] += hi[j] - lo[j]
            end = hi[j]
            xa = lo[j]
            sa = signed_ic(xa, y, args)
            da = (signed_ic(xa + delta, y, args) - sa) / delta
            evaluated += 2
            k = math.floor((xa - origin) / step) + 1
            while True:
                xb = min(origin + k * step, end)
                sb = signed_ic(xb, y, args)
                db = (sb - signed_ic(xb - delta, y, args)) / delta
                evaluated += 2
                if abs(sb) > limit:
                    ic_min[p], ic_max[p] = min(ic_min[p], abs(sb)), max(ic_max[p], abs(sb))
                xc, sc, dc = xa, sa, da
                if limit > 0.0:
                    # the limit's crossings by linear interpolation become samples too
                    t1, t2 = 2.0, 2.0
                    for level in (limit, -limit):
                        if (sa - level) * (sb - level) < 0.0:
                            t = (sa - level) / (sa - sb)
                            if t1 > 1.0:
                                t1 = t
                            else:
                                t2 = t
                    if t2 < t1:
                        t1, t2 = t2, t1
                    for t in (t1, t2):
                        if t < 1.0:
                            xt = xa + t * (xb - xa)
                            st = signed_ic(xt, y, args)
                            dt = (signed_ic(xt + delta, y, args) - st) / delta
                            evaluated += 2
                            dm, di = _segment(sc, st, dc, dt, limit, xt - xc)
                            total += dm
                            weighted += di
                            xc, sc, dc = xt, st, dt
                dm, di = _segment(sc, sb, dc, db, limit, xb - xc)
                total += dm
                weighted += di
                if xb >= end:
                    break
                xa, sa, da = xb, sb, db
                k += 1
        measure[p], integral[p] = total, weighted
    return measure, reach, integral, ic_min, ic_max, evaluated
