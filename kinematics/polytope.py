"""The part of a grid cell where several linear margins are non-negative: its volume and centroid.

A cell is the cube ``[-1/2, 1/2]^d`` in cell units ``u`` (d = 1, 2 or 3 sampled axes, each
coordinate the offset from the cell's node divided by the cell width along that axis). Margin k
is modelled as linear over the cell, ``m_k(u) = level_k + gradient_k . u`` (its value at the
node and its change per cell width), and the cell's inside part is the intersection of the
half-spaces ``m_k >= 0``: a convex polytope. This module computes its volume fraction and
centroid exactly (to rounding), and the variance over it of a given linear function
(:func:`clipped_cell_moments`: the dexterity margin's, for the mean of 1/kappa over the part), so
all are continuous in the levels and gradients: a margin whose zero moves across the cell moves
the fraction smoothly, with no step where it crosses the node.

This is the "linear margins" rule of docs/accuracy.md ("Order", :mod:`kinematics.margin_cells`:
the Tricept's and the Gough-Stewart's cell rule), measured by
``python -m benchmarks.cell_errors MECH DESIGN --candidate``. Unlike one plane per cell, an
edge where two constraint surfaces meet, a corner and a slab keep their shape.

Method: the cube as a list of convex faces, clipped by each margin's plane in turn
(Sutherland-Hodgman on every face; the points where the plane cuts the faces, sorted by angle
about their mean, close the polytope with a new face); then the volume, the centroid and the
function's first and second moments as the sums over the tetrahedra from an inside point to
each face's fan of triangles. Planes that miss the
cell are skipped; one that leaves nothing of it ends the cell at fraction 0. Cells of 1 or 2
axes are the prism of unit height over them (volume = length or area).

Compiled only (numba), like :func:`kinematics.annuli.annuli_x_sections`: a clipper has no
vectorised numpy twin; ``tests/test_polytope.py`` checks it against inclusion-exclusion for one
plane, Monte Carlo for several, and symmetry. Cost (measured on the Tricept's band at its
default, this 2-core machine, noisy): 20-50 ns a cell that one margin empties or none cuts,
0.15 us one that one margin cuts (the closed form), 0.6-0.75 us one that two or more cut (the
clipping's branches), so a rule built on it wants the band only.
"""

from __future__ import annotations

import numpy as np

from kinematics import kernels


@kernels.inline_jit
def _steepest_axis(c, active, n_active):
    """The active axis of largest slope ``c`` (the first of equals), and the sum of the other
    active slopes and of their squares: the prism form holds where ``c[top] >= 2 + others``
    (the plane crosses every edge along that axis)."""
    top_axis = active[0]
    for a in range(1, n_active):
        if c[active[a]] > c[top_axis]:
            top_axis = active[a]
    others = 0.0
    squares = 0.0
    for a in range(n_active):
        j = active[a]
        if j != top_axis:
            others += c[j]
            squares += c[j] * c[j]
    return top_axis, others, squares


@kernels.inline_jit
def prism_plane_cut(c, fraction_centroid, active, n_active):
    """:func:`kinematics.workspace._prism_cut` of one cell (the same operations) into
    ``fraction_centroid`` (d + 1,), the axes of non-zero slope ``active[:n_active]``; False
    (nothing written) where the plane does not cross every edge along its steepest axis."""
    top_axis, others, squares = _steepest_axis(c, active, n_active)
    top = c[top_axis]
    if not top >= 2.0 + others:
        return False
    volume = 0.5 + 1.0 / top
    fraction_centroid[0] = min(max(volume, 0.0), 1.0)
    for a in range(n_active):
        j = active[a]
        if j != top_axis:
            fraction_centroid[j + 1] = min(max(-c[j] / (12.0 * top * volume), -0.5), 0.5)
    part = (volume * volume + squares / (12.0 * top * top)) / (2.0 * volume) - 0.5
    fraction_centroid[top_axis + 1] = min(max(part, -0.5), 0.5)
    return True


@kernels.inline_jit
def plane_cut(c, fraction_centroid, active, moment):
    """:func:`kinematics.workspace._cube_fraction` of one cell (the part on the centre's side of the
    plane through the crossings ``u_j = +-1 / c_j``, inclusion-exclusion over the corners; the
    grid method's cut): slopes ``c`` (d,) >= 0 in, ``fraction_centroid`` (d + 1,) out (the
    fraction, then the centroid per axis, positive towards the crossing; 0 along axes of zero
    slope); ``active`` (d, int) and ``moment`` (d,) are scratch (no allocation per cell)."""
    d = c.shape[0]
    n_active = 0
    for j in range(d):
        fraction_centroid[j + 1] = 0.0
        if c[j] > 0.0:
            active[n_active] = j
            n_active += 1
    fraction_centroid[0] = 1.0
    if n_active == 0:
        return
    if prism_plane_cut(c, fraction_centroid, active, n_active):
        return
    bound = 1.0
    scale = 1.0
    for a in range(n_active):
        bound += 0.5 * c[active[a]]
        scale *= c[active[a]] * (a + 1)  # d! prod c
    volume = 0.0
    integral = 0.0
    moment[:n_active] = 0.0
    for corner in range(1 << n_active):
        level = bound
        parity = 0
        for a in range(n_active):
            if (corner >> a) & 1:
                level -= c[active[a]]
                parity += 1
        if level <= 0.0:
            continue
        sign = -1.0 if parity % 2 else 1.0
        power = level
        for _ in range(n_active - 1):  # level**n_active without a call to pow
            power *= level
        volume += sign * power
        integral += sign * power * level
        for a in range(n_active):
            if (corner >> a) & 1:
                moment[a] += sign * power
    volume /= scale
    integral /= scale * (n_active + 1)
    fraction_centroid[0] = min(max(volume, 0.0), 1.0)
    if volume > 0.0:
        for a in range(n_active):
            part = (moment[a] / scale + integral / c[active[a]]) / volume - 0.5
            fraction_centroid[active[a] + 1] = min(max(part, -0.5), 0.5)


@kernels.inline_jit
def _pseudo_angle(x, y):
    """A number in [-2, 2] that increases with ``atan2(y, x)`` (in (-pi, pi]) and starts where it
    starts: ``y / (|x| + |y|)`` on the right half-plane, continued by ``+-2 - that`` on the left
    (0 at the origin). Why: the new face's points only need atan2's order, and atan2 was a fifth
    of a clipped cell's cost."""
    scale = abs(x) + abs(y)
    if scale == 0.0:
        return 0.0
    p = y / scale
    if x >= 0.0:
        return p
    return 2.0 - p if y >= 0.0 else -2.0 - p


#: a vertex whose value under a clipping plane is within this fraction of the plane's scale over
#: the cell (``|level| + sum |normal|``) lies on the plane (:func:`_clip`)
CLIP_TOLERANCE = 1e-12


@kernels.jit
def _clip(faces, counts, n_faces, normal, level, points, scratch, angle):
    """Clip the polytope ``faces[:n_faces]`` (each ``counts[f]`` vertices (.., 3), in order)
    by ``level + normal . u >= 0`` in place; returns the new number of faces. ``points``
    (.., 3), ``scratch`` (.., 3) and ``angle`` (..,) are work space."""
    n_points = 0
    kept = 0
    side = angle  # the plane's value at each vertex of a face (angle is free until the new face)
    # a vertex within rounding of the plane lies on it (inside): a plane through vertices an
    # earlier clip put on it (the same margin twice, or two margins sharing a surface) then cuts
    # nothing, where their values of either sign had made up crossings along the face's edges
    # (up to 6 % of a cell lost)
    on_plane = CLIP_TOLERANCE * (abs(level) + abs(normal[0]) + abs(normal[1]) + abs(normal[2]))
    for f in range(n_faces):
        m = counts[f]
        for i in range(m):
            value = level + normal[0] * faces[f, i, 0] + normal[1] * faces[f, i, 1] + normal[2] * faces[f, i, 2]
            side[i] = 0.0 if abs(value) <= on_plane else value
        out = 0
        for i in range(m):
            j = i + 1 if i + 1 < m else 0
            sa, sb = side[i], side[j]
            a0, a1, a2 = faces[f, i, 0], faces[f, i, 1], faces[f, i, 2]
            if sa >= 0.0:
                scratch[out, 0], scratch[out, 1], scratch[out, 2] = a0, a1, a2
                out += 1
            if (sa >= 0.0) != (sb >= 0.0):
                t = sa / (sa - sb)
                x0 = a0 + t * (faces[f, j, 0] - a0)
                x1 = a1 + t * (faces[f, j, 1] - a1)
                x2 = a2 + t * (faces[f, j, 2] - a2)
                scratch[out, 0], scratch[out, 1], scratch[out, 2] = x0, x1, x2
                out += 1
                points[n_points, 0], points[n_points, 1], points[n_points, 2] = x0, x1, x2
                n_points += 1
        if out >= 3:
            for i in range(out):
                faces[kept, i, 0], faces[kept, i, 1], faces[kept, i, 2] = scratch[i, 0], scratch[i, 1], scratch[i, 2]
            counts[kept] = out
            kept += 1
    if n_points >= 3 and kept > 0:
        # the new face on the plane: its points in the order of their angle about their mean
        c0 = c1 = c2 = 0.0
        for i in range(n_points):
            c0 += points[i, 0]
            c1 += points[i, 1]
            c2 += points[i, 2]
        c0, c1, c2 = c0 / n_points, c1 / n_points, c2 / n_points
        # two directions in the plane: p = normal x the axis of normal's smallest component, q = normal x p
        small = 0
        for k in range(1, 3):
            if abs(normal[k]) < abs(normal[small]):
                small = k
        if small == 0:
            p0, p1, p2 = 0.0, normal[2], -normal[1]
        elif small == 1:
            p0, p1, p2 = -normal[2], 0.0, normal[0]
        else:
            p0, p1, p2 = normal[1], -normal[0], 0.0
        q0 = normal[1] * p2 - normal[2] * p1
        q1 = normal[2] * p0 - normal[0] * p2
        q2 = normal[0] * p1 - normal[1] * p0
        for i in range(n_points):  # insertion sort by angle (a few points), into the new face
            d0, d1, d2 = points[i, 0] - c0, points[i, 1] - c1, points[i, 2] - c2
            key = _pseudo_angle(d0 * p0 + d1 * p1 + d2 * p2, d0 * q0 + d1 * q1 + d2 * q2)
            j = i
            while j > 0 and angle[j - 1] > key:
                angle[j] = angle[j - 1]
                faces[kept, j, 0], faces[kept, j, 1], faces[kept, j, 2] = (
                    faces[kept, j - 1, 0],
                    faces[kept, j - 1, 1],
                    faces[kept, j - 1, 2],
                )
                j -= 1
            angle[j] = key
            faces[kept, j, 0], faces[kept, j, 1], faces[kept, j, 2] = points[i, 0], points[i, 1], points[i, 2]
        counts[kept] = n_points
        kept += 1
    return kept


#: the closed form of :func:`_one_plane` is taken where the cutting margin's smallest non-zero
#: slope is at least this fraction of its largest: its inclusion-exclusion loses to cancellation
#: about ``6e-16 / ratio`` of a cell in the fraction and ``4e-16 / ratio^2`` in the centroid times
#: the fraction (measured against the clipper: 6e-13 and 4e-10 at 1e-3); the clipper takes the
#: others
ONE_PLANE_RATIO = 1e-3
#: ... and where the node is at least this fraction of the largest slope from the plane (cell
#: widths; nearer, the slopes ``|g| / |a|`` overflow: a fraction of NaN at ``|a| = 1e-200``), and,
#: the node outside, the part is at least this much of the cell (``1 - f`` of a smaller corner
#: loses its digits, its centroid lands cells away): the clipper takes those, exact too
ONE_PLANE_NEAR = 1e-9
ONE_PLANE_CORNER = 1e-6


@kernels.inline_jit
def _one_plane(a, gradient, slopes, cut, active, moment):
    """A cell cut by exactly one margin ``a + gradient . u >= 0`` (``gradient`` (d,); the others
    miss it on their positive side) in closed form where it is well conditioned
    (:data:`ONE_PLANE_RATIO`): the fraction and centroid into ``cut`` (d + 1,) and True; False
    (nothing decided: the clipper takes it) otherwise. ``slopes`` (d,), ``active``, ``moment``
    scratch.

    The margin is the plane through the points ``u_j = -a / g_j``: on the node's side (``a > 0``)
    :func:`plane_cut` with slopes ``|g_j| / a`` is the part, its centroid positive towards the
    plane (``-sign(g_j)``); with ``a < 0`` the part is the complement of the node's side (slopes
    ``|g_j| / -a``, towards ``+sign(g_j)``), its centroid ``-f c / (1 - f)`` from the node side's
    fraction ``f`` and centroid ``c``. Why: a cell cut by one margin (about half of the Tricept's
    cut cells) costs the clipper 5-10x as much, and both are exact, so taking either is
    continuous."""
    d = gradient.shape[0]
    top = 0.0
    for j in range(d):
        top = max(top, abs(gradient[j]))
    for j in range(d):
        g = abs(gradient[j])
        if g > 0.0 and g < ONE_PLANE_RATIO * top:
            return False
    if abs(a) < ONE_PLANE_NEAR * top:
        return False  # a plane through (next to) the node: slopes |g| / |a| would overflow
    for j in range(d):
        slopes[j] = abs(gradient[j]) / abs(a)
    plane_cut(slopes, cut, active, moment)
    if a > 0.0:
        for j in range(d):
            cut[j + 1] = -cut[j + 1] if gradient[j] > 0.0 else cut[j + 1]
        return True
    node_side = cut[0]
    rest = 1.0 - node_side
    if rest < ONE_PLANE_CORNER:
        return False  # a corner of the cell: 1 - f and the centroid lose their digits
    cut[0] = rest
    for j in range(d):
        part = min(max(-node_side * cut[j + 1] / rest, -0.5), 0.5)
        cut[j + 1] = part if gradient[j] > 0.0 else -part
    return True


@kernels.inline_jit
def _node_side_square(c, h, active, n_active):
    """``integral of (h . w)^2`` over the node's side of :func:`plane_cut`'s plane, in its frame:
    ``w`` in ``[0, 1]^n`` over the active axes (``u_j + 1/2``, ``u`` positive towards the plane),
    the part ``c . w <= B``, ``B = 1 + sum c / 2``; ``h`` (d,) the function's slopes in that frame
    (inactive axes are not integrated here). Cell volumes; exact, the same two forms as
    :func:`plane_cut`: the prism (the plane crosses every edge along its steepest axis: the part
    is the region under a linear height ``tau`` over the others, and the integral the moments of
    linear functions over a box) or inclusion-exclusion, ``(1/2) d^2/dt^2`` of
    ``int (B - (c + t h) . w)_+^2 dw = 2 sum_v (-1)^|v| (B - c . v)_+^(n+2) / ((n+2)! prod c)``."""
    top_axis, others, _ = _steepest_axis(c, active, n_active)
    top = c[top_axis]
    if top >= 2.0 + others:
        # x = w - 1/2 over the base, uniform: E[x] = 0, E[x^2] = 1/12, odd moments 0
        tau = 1.0 / top + 0.5
        q = 0.0
        bb = ab = aa = 0.0
        for a in range(n_active):
            j = active[a]
            if j != top_axis:
                beta = -c[j] / top
                q += 0.5 * h[j]
                bb += beta * beta / 12.0
                ab += h[j] * beta / 12.0
                aa += h[j] * h[j] / 12.0
        ht = h[top_axis]
        cube = tau**3 + 3.0 * tau * bb
        q_tau2 = q * tau * tau + q * bb + 2.0 * tau * ab
        q2_tau = q * q * tau + tau * aa + 2.0 * q * ab
        return q2_tau + ht * q_tau2 + ht * ht * cube / 3.0
    bound = 1.0
    scale = 1.0
    r1 = 0.0
    r2 = 0.0
    for a in range(n_active):
        j = active[a]
        bound += 0.5 * c[j]
        scale *= c[j] * (a + 1)  # n! prod c
        r1 += h[j] / c[j]
        r2 += (h[j] / c[j]) ** 2
    power_n = n_active + 2
    s0 = s1 = s2 = 0.0
    for corner in range(1 << n_active):
        level = bound
        hv = 0.0
        parity = 0
        for a in range(n_active):
            if (corner >> a) & 1:
                level -= c[active[a]]
                hv += h[active[a]]
                parity += 1
        if level <= 0.0:
            continue
        sign = -1.0 if parity % 2 else 1.0
        power = 1.0
        for _ in range(n_active):
            power *= level  # level**n
        s0 += sign * power * level * level
        s1 += sign * hv * power * level
        s2 += sign * hv * hv * power
    # S = s0, S' = -N s1, S'' = N (N - 1) s2 with N = n + 2; / (prod c (n + 2)!) = / (scale (n+1)(n+2))
    total = power_n * (power_n - 1) * s2 + 2.0 * r1 * power_n * s1 + (r1 * r1 + r2) * s0
    return total / (scale * (n_active + 1) * (n_active + 2))


@kernels.inline_jit
def _one_plane_variance(a, gradient, direction, cut, slopes, active, frame):
    """The variance of ``direction . u`` (cell units of ``u``) over the part :func:`_one_plane`
    just put in ``cut`` (its fraction and centroid in ``u``; ``slopes`` the plane's,
    ``|gradient| / |a|``): ``cube & {a + gradient . u >= 0}``. Exact (to rounding), from the node
    side's second moment in :func:`plane_cut`'s frame (:func:`_node_side_square`); for ``a < 0``
    the part is the complement of the node side, its moments the cube's less the node side's.
    ``active``, ``frame`` (d,) scratch."""
    d = gradient.shape[0]
    n_active = 0
    free = 0.0  # inactive axes: uniform over the cell, independent of the rest
    for j in range(d):
        # plane_cut's u' (positive towards the plane) is sigma u: sigma = -sign(g) for a > 0
        # (the node side is the part), +sign(g) for a < 0 (the part is the far side)
        sigma = -1.0 if (gradient[j] > 0.0) == (a > 0.0) else 1.0
        frame[j] = sigma * direction[j]  # h'_j, h . u = h' . u'
        if slopes[j] > 0.0:
            active[n_active] = j
            n_active += 1
        else:
            free += direction[j] * direction[j] / 12.0
    if n_active == 0:
        return free
    half = 0.0  # h' . (1/2, ...): w = u' + 1/2
    cube = 0.0  # integral over the cube of (h' . u')^2
    for k in range(n_active):
        half += 0.5 * frame[active[k]]
        cube += frame[active[k]] ** 2 / 12.0
    square_w = _node_side_square(slopes, frame, active, n_active)  # integral over the node side
    if a > 0.0:
        volume = cut[0]
        if volume <= 0.0:
            return free
        mean_u = 0.0  # E[h' . u'] = E[h . u] over the part
        for k in range(n_active):
            j = active[k]
            mean_u += direction[j] * cut[j + 1]
        mean_w = mean_u + half
        return max(square_w / volume - mean_w * mean_w, 0.0) + free
    rest = cut[0]
    node = 1.0 - rest
    # the part's centroid c (in u) is -node m / rest, m the node side's centroid: E_node[h . u]
    mean_part = 0.0
    for k in range(n_active):
        j = active[k]
        mean_part += direction[j] * cut[j + 1]
    node_mean_u = -rest * mean_part / node  # E_node[h' . u']
    node_square_u = square_w - 2.0 * half * (node_mean_u + half) * node + half * half * node
    part_square = (cube - node_square_u) / rest
    return max(part_square - mean_part * mean_part, 0.0) + free


@kernels.jit
def _clipped_cells(level, gradient, direction, fraction, centroid, variance):
    """Fill ``fraction`` (M,), ``centroid`` (M, d) and ``variance`` (M,: of ``direction . u``) of
    the cells (see :func:`clipped_cell_moments`).

    Per cell one pass over the margins sorts them into those that miss it (or are not modelled:
    a non-finite level or slope), those that cut it, and one that leaves nothing of it (the cell
    is empty, whatever the others); no cut: the whole cell; one: :func:`_one_plane`; else the
    cube clipped by each cutting margin in order. Why one pass: an empty cell (a third of the
    Tricept's band) was scanned twice and clipped by the margins before its empty one."""
    m, n_margins, d = gradient.shape
    size = 6 + n_margins  # faces of the polytope, and vertices of one face, at most
    faces = np.empty((size, 2 * size, 3))
    counts = np.empty(size, dtype=np.int64)
    points = np.empty((2 * size, 3))
    scratch = np.empty((2 * size, 3))
    angle = np.empty(2 * size)
    normal = np.zeros(3)
    cube = np.empty((6, 4, 3))  # 6 faces of 4 corners, each in order around its face
    for axis in range(3):
        for s in range(2):
            b, c = (axis + 1) % 3, (axis + 2) % 3
            for i in range(4):
                cube[2 * axis + s, i, axis] = s - 0.5
                cube[2 * axis + s, i, b] = -0.5 if i == 0 or i == 3 else 0.5
                cube[2 * axis + s, i, c] = -0.5 if i < 2 else 0.5
    cutting = np.empty(n_margins, dtype=np.int64)
    one = np.empty(d)  # the single cutting margin's slopes, for plane_cut
    one_cut = np.empty(d + 1)
    one_active = np.empty(d, dtype=np.int64)
    one_moment = np.empty(d)
    one_frame = np.empty(d)
    h = np.empty(d)  # the cell's direction, a non-finite entry as 0 (a margin not modelled there)
    for cell in range(m):
        for j in range(d):
            h[j] = direction[cell, j] if np.isfinite(direction[cell, j]) else 0.0
        empty = False
        n_cut = 0
        for k in range(n_margins):
            a = level[cell, k]
            if not np.isfinite(a):
                continue
            spread = 0.0
            finite = True
            for j in range(d):
                g = gradient[cell, k, j]
                if not np.isfinite(g):
                    finite = False
                    break
                spread += 0.5 * abs(g)
            if not finite or a - spread >= 0.0:
                continue  # not modelled, or the whole cell satisfies it
            if a + spread <= 0.0:
                empty = True  # nothing of the cell does (at most a face)
                break
            cutting[n_cut] = k
            n_cut += 1
        if empty or n_cut == 0:
            fraction[cell] = 0.0 if empty else 1.0
            spread = 0.0
            for j in range(d):
                centroid[cell, j] = 0.0
                spread += h[j] ** 2 / 12.0
            variance[cell] = 0.0 if empty else spread
            continue
        if n_cut == 1 and _one_plane(
            level[cell, cutting[0]], gradient[cell, cutting[0]], one, one_cut, one_active, one_moment
        ):
            fraction[cell] = one_cut[0]
            for j in range(d):
                centroid[cell, j] = one_cut[j + 1]
            variance[cell] = _one_plane_variance(
                level[cell, cutting[0]],
                gradient[cell, cutting[0]],
                h,
                one_cut,
                one,
                one_active,
                one_frame,
            )
            continue
        n_faces = 6
        faces[:6, :4, :] = cube
        counts[:6] = 4
        for i in range(n_cut):
            k = cutting[i]
            for j in range(3):
                normal[j] = gradient[cell, k, j] if j < d else 0.0
            n_faces = _clip(faces, counts, n_faces, normal, level[cell, k], points, scratch, angle)
            if n_faces == 0:
                break
        if n_faces == 0:
            fraction[cell] = 0.0
            variance[cell] = 0.0
            for j in range(d):
                centroid[cell, j] = 0.0
            continue
        # an inside point: the mean of the vertices; tetrahedra to each face's fan
        r0 = r1 = r2 = 0.0
        total = 0
        for f in range(n_faces):
            for i in range(counts[f]):
                r0 += faces[f, i, 0]
                r1 += faces[f, i, 1]
                r2 += faces[f, i, 2]
            total += counts[f]
        r0, r1, r2 = r0 / total, r1 / total, r2 / total
        volume = 0.0
        s0 = s1 = s2 = 0.0
        # the function h . x (x from the inside point; h = direction, 0 beyond d): its first and
        # second moments over each tetrahedron (0, a, b, c): V (ha + hb + hc) / 4 and
        # V (ha^2 + hb^2 + hc^2 + (ha + hb + hc)^2) / 20
        h0 = h[0]
        h1 = h[1] if d > 1 else 0.0
        h2 = h[2] if d > 2 else 0.0
        first = second = 0.0
        for f in range(n_faces):
            a0, a1, a2 = faces[f, 0, 0] - r0, faces[f, 0, 1] - r1, faces[f, 0, 2] - r2
            ha = h0 * a0 + h1 * a1 + h2 * a2
            for i in range(1, counts[f] - 1):
                b0, b1, b2 = faces[f, i, 0] - r0, faces[f, i, 1] - r1, faces[f, i, 2] - r2
                c0, c1, c2 = faces[f, i + 1, 0] - r0, faces[f, i + 1, 1] - r1, faces[f, i + 1, 2] - r2
                v = abs(a0 * (b1 * c2 - b2 * c1) - a1 * (b0 * c2 - b2 * c0) + a2 * (b0 * c1 - b1 * c0)) / 6.0
                volume += v
                s0 += v * (a0 + b0 + c0) / 4.0
                s1 += v * (a1 + b1 + c1) / 4.0
                s2 += v * (a2 + b2 + c2) / 4.0
                hb = h0 * b0 + h1 * b1 + h2 * b2
                hc = h0 * c0 + h1 * c1 + h2 * c2
                first += v * (ha + hb + hc) / 4.0
                second += v * (ha * ha + hb * hb + hc * hc + (ha + hb + hc) ** 2) / 20.0
        fraction[cell] = min(volume, 1.0)
        if volume > 0.0:
            mean = first / volume
            variance[cell] = max(second / volume - mean * mean, 0.0)
        else:
            variance[cell] = 0.0
        if volume > 0.0:
            moment = (s0, s1, s2)
            shift = (r0, r1, r2)
            for j in range(d):
                centroid[cell, j] = moment[j] / volume + shift[j]
        else:
            for j in range(d):
                centroid[cell, j] = 0.0


def clipped_cell(level: np.ndarray, gradient: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Volume fraction and centroid of ``{u in [-1/2, 1/2]^d : level_k + gradient_k . u >= 0
    for every margin k}``: the inside part of a grid cell under linear margins
    (:func:`clipped_cell_moments` without a variance).

    Parameters
    ----------
    level : ndarray, shape (M, K)
        Each margin's value at the cell's node (the cube's centre), in the margin's own unit.
        NaN: the margin is not modelled in that cell (it does not cut it).
    gradient : ndarray, shape (M, K, d)
        Each margin's change per cell width along each of the cell's d = 1, 2 or 3 axes, same
        unit. A non-finite entry leaves that margin out of that cell.

    Returns
    -------
    fraction : ndarray, shape (M,)
        The inside part's volume over the cell's, in [0, 1].
    centroid : ndarray, shape (M, d)
        The inside part's centroid in cell units from the node (0 where the part is empty).

    Raises
    ------
    ValueError
        If the shapes do not match or d is not 1, 2 or 3.
    """
    fraction, centroid, _ = clipped_cell_moments(
        level, gradient, np.zeros(np.shape(gradient)[:1] + np.shape(gradient)[2:])
    )
    return fraction, centroid


def clipped_cell_moments(
    level: np.ndarray, gradient: np.ndarray, direction: np.ndarray
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`clipped_cell`, and the variance over each part of the linear function
    ``direction . u``: its second central moment, exact (to rounding) on every path (the whole
    cell ``sum h_j^2 / 12``; one cutting margin in closed form, :func:`_node_side_square`; the
    clipped polytope from its tetrahedra), so that it moves continuously where a cell passes from
    one path to another.

    Parameters
    ----------
    level, gradient : ndarray
        As :func:`clipped_cell`.
    direction : ndarray, shape (M, d)
        The function's change per cell width along each axis, in its own unit (the dexterity
        margin's gradient for :mod:`kinematics.margin_cells`); a non-finite entry counts as 0.

    Returns
    -------
    fraction, centroid : ndarray
        As :func:`clipped_cell` (the same numbers).
    variance : ndarray, shape (M,)
        ``E[(h . u)^2] - E[h . u]^2`` over the part, the function's unit squared (0 where the part
        is empty).

    Raises
    ------
    ValueError
        If the shapes do not match or d is not 1, 2 or 3.
    """
    level = np.ascontiguousarray(level, dtype=float)
    gradient = np.ascontiguousarray(gradient, dtype=float)
    direction = np.ascontiguousarray(direction, dtype=float)
    if level.ndim != 2 or gradient.ndim != 3 or gradient.shape[:2] != level.shape:
        raise ValueError(
            f"clipped_cell: level must be (M, K) and gradient (M, K, d); got {level.shape} and {gradient.shape}"
        )
    d = gradient.shape[2]
    if d not in (1, 2, 3):
        raise ValueError(f"clipped_cell: the cell has d = {d} axes; allowed 1, 2 or 3")
    if direction.shape != (level.shape[0], d):
        raise ValueError(f"clipped_cell: direction must be (M, d) = {(level.shape[0], d)}; got {direction.shape}")
    fraction = np.empty(level.shape[0])
    centroid = np.empty((level.shape[0], d))
    variance = np.empty(level.shape[0])
    _clipped_cells(level, gradient, direction, fraction, centroid, variance)
    return fraction, centroid, variance
