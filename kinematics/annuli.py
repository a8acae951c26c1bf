"""Exact areas of intersections of discs and annuli (planar constant-orientation workspaces).

A planar RPR leg of length ``rho_min..rho_max`` confines its platform joint to
an annulus; at constant orientation the 2-RPR and 3-RPR workspaces are
intersections of annuli (seed 003 eq. 12-14, seed 004). These functions give
their areas exactly, as references for the grid integration.
"""

from __future__ import annotations

import itertools
import math

import numpy as np


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
