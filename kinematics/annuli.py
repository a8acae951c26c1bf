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
def _signed_inverse_condition_3x3(r00, r01, r02, r10, r11, r12, r20, r21, r22):
    """``sign(det J) sigma_min / sigma_max`` of a 3 x 3 matrix J given by rows.

    The eigenvalues of ``G = J^T J`` in closed form (the trigonometric solution of the
    symmetric 3 x 3 eigenproblem); the smallest as ``det(J)^2 / (lambda_1 lambda_2)``, which
    keeps its relative accuracy near a singularity. The sign makes the value smooth through
    a singularity (``det J`` changes sign there): linear interpolation then places the
    dexterity limit on either side of it.
    """
    det = r00 * (r11 * r22 - r12 * r21) - r01 * (r10 * r22 - r12 * r20) + r02 * (r10 * r21 - r11 * r20)
    g00 = r00 * r00 + r10 * r10 + r20 * r20
    g11 = r01 * r01 + r11 * r11 + r21 * r21
    g22 = r02 * r02 + r12 * r12 + r22 * r22
    g01 = r00 * r01 + r10 * r11 + r20 * r21
    g02 = r00 * r02 + r10 * r12 + r20 * r22
    g12 = r01 * r02 + r11 * r12 + r21 * r22
    q = (g00 + g11 + g22) / 3.0
    d0, d1, d2 = g00 - q, g11 - q, g22 - q
    p2 = d0 * d0 + d1 * d1 + d2 * d2 + 2.0 * (g01 * g01 + g02 * g02 + g12 * g12)
    if p2 <= 0.0:
        return 1.0 if det >= 0.0 else -1.0
    p = math.sqrt(p2 / 6.0)
    b00, b11, b22, b01, b02, b12 = d0 / p, d1 / p, d2 / p, g01 / p, g02 / p, g12 / p
    half_det = 0.5 * (b00 * (b11 * b22 - b12 * b12) - b01 * (b01 * b22 - b12 * b02) + b02 * (b01 * b12 - b11 * b02))
    angle = math.acos(min(max(half_det, -1.0), 1.0)) / 3.0
    lam1 = q + 2.0 * p * math.cos(angle)
    lam3 = q + 2.0 * p * math.cos(angle + 2.0 * math.pi / 3.0)
    lam2 = 3.0 * q - lam1 - lam3
    if not lam1 > 0.0:
        return 0.0
    lam_min = det * det / (lam1 * lam2) if lam2 > 0.0 else max(lam3, 0.0)
    ratio = math.sqrt(min(lam_min / lam1, 1.0))
    return ratio if det >= 0.0 else -ratio


@kernels.inline_jit
def planar_legs_signed_inverse_condition(x, y, centres_x, centres_y, arms_x, arms_y, angular_scale):
    """Signed inverse condition number ``sign(det J) sigma_min / sigma_max`` of the Jacobian of
    planar RPR legs at the point (x, y) (mm) whose legs run from the annulus centres
    ``(centres_x[i], centres_y[i])``: ``L_i = (x, y) - c_i``, one row per leg.

    * 3 legs (3-RPR, pose (x, y, phi); seed 003 eq. 12-14 and the Jacobian of
      :meth:`kinematics.rpr3.RPR3._jacobian`): rows ``(L_i / |L_i|, (a_i x L_i) / |L_i| s)``,
      ``a_i`` the arm ``Rot(phi) B'_i`` (``arms_x``, ``arms_y``) and ``s`` the angular scale
      (mm, the characteristic length homogenising phi); 3 x 3 by
      :func:`_signed_inverse_condition_3x3`.
    * 2 legs (2-RPR, pose (x, y); seed 004 eq. 1-2): unit rows ``L_i / |L_i|``, so
      ``sigma_1^2 + sigma_2^2 = 2`` and ``sigma_1 sigma_2 = |D|``, ``D = det J``:
      ``1/kappa = |D| / (1 + sqrt(1 - D^2))`` (arms and scale unused).

    The sign makes the value smooth through a singularity (``det J`` changes sign there).
    """
    if centres_x.shape[0] == 2:
        rx0, ry0 = x - centres_x[0], y - centres_y[0]
        rx1, ry1 = x - centres_x[1], y - centres_y[1]
        q0 = math.sqrt(rx0 * rx0 + ry0 * ry0)
        q1 = math.sqrt(rx1 * rx1 + ry1 * ry1)
        det = (rx0 * ry1 - ry0 * rx1) / (q0 * q1)
        return det / (1.0 + math.sqrt(max(1.0 - det * det, 0.0)))
    r = np.empty(9)
    for i in range(3):
        leg_x, leg_y = x - centres_x[i], y - centres_y[i]
        rho = math.sqrt(leg_x * leg_x + leg_y * leg_y)
        r[3 * i] = leg_x / rho
        r[3 * i + 1] = leg_y / rho
        r[3 * i + 2] = (arms_x[i] * leg_y - arms_y[i] * leg_x) / rho * angular_scale
    return _signed_inverse_condition_3x3(r[0], r[1], r[2], r[3], r[4], r[5], r[6], r[7], r[8])


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


@kernels.jit
def annuli_x_sections(ys, centres_x, centres_y, arms_x, arms_y, rho_min, rho_max, angular_scale, origin, step, limit):
    """Exact sections along x of intersections of annuli (planar RPR legs), and ``1/kappa``
    integrated along them.

    Row p (at ``y = ys[p]``) is the set of x with ``rho_min <= |(x, y) - c_pi| <= rho_max`` for
    every centre ``c_pi = (centres_x[p, i], centres_y[p, i])`` (a planar RPR leg per annulus:
    seed 003 eq. 12-14, seed 004 eq. 1-2): the intersection of the outer discs' chords, an
    interval, minus the inner discs' chords, in closed form (at most ``m + 1`` intervals for m
    annuli). Along each interval the signed inverse condition number s of the legs' Jacobian
    (:func:`planar_legs_signed_inverse_condition`, with the row's arms and ``angular_scale``;
    ``sign(det J) / kappa``, smooth through a singularity) is sampled at the interval's ends and
    at the nodes ``origin + k step`` inside it, with its x-derivative (a difference over
    ``1e-6 step``); the dexterous part ``|s| > limit`` is cut where the linear interpolant of s
    meets the limit (each such crossing is sampled too), and ``|s|`` is integrated by the
    corrected trapezoid rule (cubic Hermite, :func:`_segment`). Every quantity moves
    continuously with the centres and ``y``.

    Parameters
    ----------
    ys : ndarray, shape (N,)
        The rows' y (mm).
    centres_x, centres_y : ndarray, shape (N, m)
        Annulus centres per row (mm); m = 3 (3-RPR) or 2 (2-RPR).
    arms_x, arms_y : ndarray, shape (N, m)
        The legs' platform arms per row (mm; 3-RPR: ``Rot(phi) B'_i``; unused for m = 2).
    rho_min, rho_max : float
        Inner and outer radius of every annulus (the leg range, mm).
    angular_scale : float
        Homogenising length of the angular column (mm; unused for m = 2).
    origin, step : float
        Sample nodes along x (mm), ``step > 0``.
    limit : float
        Dexterity limit on ``|s|`` (0: none).

    Returns
    -------
    measure, reach, integral, ic_min, ic_max : ndarray, shape (N,)
        Length of each dexterous section, of the reachable section (the intervals, whatever
        ``1/kappa``), the integral of ``1/kappa`` over the dexterous one, the extremes of
        ``1/kappa`` over its samples (inf / -inf for an empty section).
    evaluated : int
        Evaluations of ``1/kappa`` (the cost).
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
        c_x, c_y, a_x, a_y = centres_x[p], centres_y[p], arms_x[p], arms_y[p]
        left, right = -np.inf, np.inf
        for i in range(legs):
            b = y - c_y[i]
            w2 = outer2 - b * b
            if w2 < 0.0:
                left, right = 1.0, 0.0
                break
            w = math.sqrt(w2)
            left, right = max(left, c_x[i] - w), min(right, c_x[i] + w)
        if not right > left:
            continue
        n = 1
        lo[0], hi[0] = left, right
        for i in range(legs):  # remove the inner discs (|L_i| < rho_min)
            b = y - c_y[i]
            w2 = inner2 - b * b
            if w2 <= 0.0:
                continue
            w = math.sqrt(w2)
            hole_lo, hole_hi = c_x[i] - w, c_x[i] + w
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
            sa = planar_legs_signed_inverse_condition(xa, y, c_x, c_y, a_x, a_y, angular_scale)
            da = (planar_legs_signed_inverse_condition(xa + delta, y, c_x, c_y, a_x, a_y, angular_scale) - sa) / delta
            evaluated += 2
            k = math.floor((xa - origin) / step) + 1
            while True:
                xb = min(origin + k * step, end)
                sb = planar_legs_signed_inverse_condition(xb, y, c_x, c_y, a_x, a_y, angular_scale)
                db = (
                    sb - planar_legs_signed_inverse_condition(xb - delta, y, c_x, c_y, a_x, a_y, angular_scale)
                ) / delta
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
                            st = planar_legs_signed_inverse_condition(xt, y, c_x, c_y, a_x, a_y, angular_scale)
                            dt = (
                                planar_legs_signed_inverse_condition(xt + delta, y, c_x, c_y, a_x, a_y, angular_scale)
                                - st
                            ) / delta
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


@kernels.inline_jit
def _in_every_annulus(x, y, centres_x, centres_y, layer, rho_min, rho_max, slack):
    """Whether ``(x, y)`` (mm) lies in every annulus of row ``layer``, within ``slack`` (mm)."""
    for i in range(centres_x.shape[1]):
        distance = math.hypot(x - centres_x[layer, i], y - centres_y[layer, i])
        if distance < rho_min - slack or distance > rho_max + slack:
            return False
    return True


@kernels.jit
def annuli_y_extent(centres_x, centres_y, rho_min, rho_max):
    """Exact extent along y of intersections of annuli, one intersection per row.

    Row p is the set of points within ``rho_min..rho_max`` of every centre
    ``(centres_x[p, i], centres_y[p, i])`` (a planar RPR leg per annulus: seed 003 eq. 12-14,
    seed 004 eq. 1-2). Its lowest point, where it is not empty, lies on its boundary, which is
    made of arcs of the annuli's circles: it is the bottom of an outer circle, the top of an
    inner one (the set lies outside it), or a point where two circles of different annuli
    meet. So are the highest point's candidates, mirrored (all four extremes of both circles
    of each annulus are tried: a superset). Every such candidate that lies in
    every annulus (within ``1e-9 rho_max``, the rounding of a point computed on two circles)
    counts, and the extremes of their y are the extent. Continuous in the centres, except where
    a part of the set shrinks to a point and vanishes (its area goes to 0 there).

    Parameters
    ----------
    centres_x, centres_y : ndarray, shape (N, m)
        Annulus centres per row (mm).
    rho_min, rho_max : float
        Inner and outer radius of every annulus (mm), ``0 <= rho_min < rho_max``.

    Returns
    -------
    lower, upper : ndarray, shape (N,)
        The least and greatest y of each row's intersection (mm); NaN where it is empty.
    """
    count, legs = centres_x.shape
    lower = np.full(count, np.nan)
    upper = np.full(count, np.nan)
    slack = 1e-9 * rho_max
    for p in range(count):
        low = np.inf
        high = -np.inf
        for i in range(legs):
            x, y = centres_x[p, i], centres_y[p, i]
            # the bottom and top of the outer circle, the top and bottom of the inner one
            for candidate in (y - rho_max, y + rho_max, y + rho_min, y - rho_min):
                if _in_every_annulus(x, candidate, centres_x, centres_y, p, rho_min, rho_max, slack):
                    low = min(low, candidate)
                    high = max(high, candidate)
        for i in range(legs):
            for j in range(i + 1, legs):
                dx = centres_x[p, j] - centres_x[p, i]
                dy = centres_y[p, j] - centres_y[p, i]
                distance = math.hypot(dx, dy)
                if distance == 0.0:  # concentric annuli: their circles do not cross
                    continue
                for r_i in (rho_min, rho_max):
                    for r_j in (rho_min, rho_max):
                        along = (distance * distance + r_i * r_i - r_j * r_j) / (2.0 * distance)
                        across_squared = r_i * r_i - along * along
                        if across_squared < 0.0:
                            continue
                        across = math.sqrt(across_squared)
                        mid_x = centres_x[p, i] + along * dx / distance
                        mid_y = centres_y[p, i] + along * dy / distance
                        for sign in (1.0, -1.0):
                            x = mid_x - sign * across * dy / distance
                            y = mid_y + sign * across * dx / distance
                            if _in_every_annulus(x, y, centres_x, centres_y, p, rho_min, rho_max, slack):
                                low = min(low, y)
                                high = max(high, y)
        if low <= high:
            lower[p] = low
            upper[p] = high
    return lower, upper
