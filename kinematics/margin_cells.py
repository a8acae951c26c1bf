"""The "linear margins" cell rule: the grid method's rule for a mechanism whose ``cell_rule`` is
``"margins"`` (the Tricept, the Gough-Stewart), and ``evaluate(method="margins")`` for any
mechanism with margins (docs/accuracy.md, "Order").

Every grid node whose 26 neighbours share its membership counts its cell whole (inside) or not
at all. Every other node, the **band** along the boundary (the cut cells and the uncut cells
whose corner the boundary may reach), counts the part of its cell where each of the mechanism's
reachability margins and the dexterity margin ``1/kappa^2 - limit^2`` holds, each taken as
linear over the cell:

- its value at the node; undefined there (an angle where the inverse kinematics has no
  solution), extrapolated from the first neighbour along a sampled axis that defines it (the
  dexterity margin, where none does, from the nearest of the 26 neighbours that knows it);
- its change per cell width along each sampled axis, the central difference of the nodes'
  values (one-sided where a neighbour is undefined);
- along an axis whose grid edge from the node crosses the boundary
  (:func:`kinematics.workspace._margin_secants`: each margin that vanishes along the edge, its
  zero placed on the parabola through its values at the two nodes and at one look between
  them), that margin takes the secant through its zero there (the nearer zero where it vanishes
  on both sides of the node). Why the secants: the margins curve (an arccos
  near the reach limit), and from the nodes' values alone V erred by up to 0.34 % (Delta,
  defaults) against 0.05 % with them.

The part is the intersection of the half-spaces, a convex polytope, whose volume and centroid
:func:`kinematics.polytope.clipped_cell` computes exactly: an edge where two constraint
surfaces meet, a corner and a slab keep their shape, which one plane per cell cannot.

The GDI's integrand ``1/kappa``: over a band cell's part, its mean over the part under the
linear dexterity margin, from the margin's mean (at the part's centroid) and variance there
(:func:`part_inverse_condition`); over a whole cell, its mean as the node's value plus 1/24 of
its second differences along the sampled axes whose two neighbours are inside (1/kappa falls like
a root towards a singular boundary, where the node's value alone, the midpoint rule, erred by
+0.085 % of the Delta's GDI on a scan design with every boundary part exact).

Mechanisms with margins (``Mechanism.constraint_margins``) and no exact axis only: the H4,
whose grid integrates z exactly per column, keeps one plane per cell. Units: margins in their
own units, positions in the pose's (mm, cm or rad), cell offsets in cell widths.
"""

from __future__ import annotations

import functools
import itertools
import math

import numpy as np

from kinematics import kernels
from kinematics.polytope import clipped_cell_moments


def boundary_band(inside: np.ndarray) -> np.ndarray:
    """Flat indices of the nodes some of whose 26 neighbours (8 in 2-D) differ in membership
    (``inside``, the grid's shape, bool). The 3 x 3 x 3 neighbourhood's any and all, one axis at a
    time (the same as scipy's maximum and minimum filters at ``mode="nearest"``, at a tenth of
    their cost on the grids of the defaults)."""
    some, every = inside.copy(), inside.copy()
    for j in range(inside.ndim):
        ahead, behind = [slice(None)] * inside.ndim, [slice(None)] * inside.ndim
        ahead[j], behind[j] = slice(1, None), slice(None, -1)
        ahead, behind = tuple(ahead), tuple(behind)
        some_j, every_j = some.copy(), every.copy()
        some_j[ahead] |= some[behind]
        some_j[behind] |= some[ahead]
        every_j[ahead] &= every[behind]
        every_j[behind] &= every[ahead]
        some, every = some_j, every_j
    return np.nonzero((some & ~every).ravel())[0]


def flat_strides(shape: tuple[int, ...]) -> np.ndarray:
    """The flat-index strides (int64, one per axis) of a C-ordered grid of ``shape``."""
    return np.array([math.prod(shape[j + 1 :]) for j in range(len(shape))], dtype=np.int64)


class NodeMargins:
    """The margins (K + 1 columns) of every grid node: the mechanism's reachability margins
    (``reach``, computed with the fine pass) and the dexterity margin ``ic^2 - min_ic^2`` (``ic``
    the nodes' 1/kappa, NaN where unreachable), NaN where undefined. Why every node: the margins
    of 8,000 Tricept nodes cost a third of those of the band's neighbourhood gathered node by node.

    Attributes
    ----------
    table : ndarray, shape (N + 1, K + 1)
        Row ``n`` the margins of flat node ``n``; the last row all NaN (a node off the grid).
    shape : tuple of int
        The grid's shape.
    strides : ndarray of int64
        Flat-index strides of the grid's axes (:func:`flat_strides`).
    """

    def __init__(self, reach: np.ndarray, ic: np.ndarray, min_ic: float):
        self.shape = ic.shape
        self.size = ic.size
        self.table = np.empty((ic.size + 1, reach.shape[1] + 1))
        self.table[:-1, :-1] = reach
        self.table[:-1, -1] = ic.ravel() ** 2 - min_ic**2
        self.table[-1] = np.nan
        self.strides = flat_strides(ic.shape)


@kernels.inline_jit
def _value(table, shape, strides, node, j, step, c):
    """Margin ``c`` of the node ``step`` nodes along grid axis ``j`` from ``node``; NaN off the grid."""
    coordinate = (node // strides[j]) % shape[j] + step
    if coordinate < 0 or coordinate >= shape[j]:
        return np.nan
    return table[node + step * strides[j], c]


@kernels.inline_jit
def _difference(table, shape, strides, node, j, c):
    """The change per node of margin ``c`` along grid axis ``j`` at ``node``: the central
    difference, one-sided where a neighbour is off the grid or undefined, 0 where both are."""
    here = table[node, c]
    ahead = _value(table, shape, strides, node, j, 1, c) - here
    behind = here - _value(table, shape, strides, node, j, -1, c)
    if np.isfinite(ahead) and np.isfinite(behind):
        return 0.5 * (ahead + behind)
    if np.isfinite(ahead):
        return ahead
    if np.isfinite(behind):
        return behind
    return 0.0


@kernels.jit
def _node_linear_margins(table, shape, strides, nodes, sampled):
    """Each margin's value and differences at ``nodes`` (the part of :func:`linear_margins`
    before the secants), compiled: a margin undefined at the node from the first neighbour along
    a sampled axis (in order, the one above first) that defines it. Per node the table rows of
    its neighbours along each sampled axis are found once (the last row of ``table``, all NaN,
    stands for a neighbour off the grid)."""
    m, count, d = nodes.shape[0], table.shape[1], sampled.shape[0]
    missing = table.shape[0] - 1
    at = np.empty((m, count))
    slope = np.empty((m, count, d))
    above = np.empty(d, dtype=np.int64)
    below = np.empty(d, dtype=np.int64)
    for i in range(m):
        node = nodes[i]
        for k in range(d):
            j = sampled[k]
            coordinate = (node // strides[j]) % shape[j]
            above[k] = node + strides[j] if coordinate + 1 < shape[j] else missing
            below[k] = node - strides[j] if coordinate > 0 else missing
        for c in range(count):
            value = table[node, c]
            at[i, c] = value
            for k in range(d):
                ahead = table[above[k], c] - value
                behind = value - table[below[k], c]
                if np.isfinite(ahead) and np.isfinite(behind):
                    slope[i, c, k] = 0.5 * (ahead + behind)
                elif np.isfinite(ahead):
                    slope[i, c, k] = ahead
                elif np.isfinite(behind):
                    slope[i, c, k] = behind
                else:
                    slope[i, c, k] = 0.0
            if np.isfinite(value):
                continue
            found = False
            for k in range(d):
                for step in (1, -1):
                    neighbour = table[above[k], c] if step == 1 else table[below[k], c]
                    if not np.isfinite(neighbour):
                        continue
                    there = node + step * strides[sampled[k]]
                    at[i, c] = neighbour - step * _difference(table, shape, strides, there, sampled[k], c)
                    for kk in range(d):
                        slope[i, c, kk] = _difference(table, shape, strides, there, sampled[kk], c)
                    found = True
                    break
                if found:
                    break
    return at, slope


def linear_margins(
    margins: NodeMargins,
    sampled: list[int],
    secants: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None,
    nodes: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Each margin's value (M, K + 1) at the nodes ``nodes`` (flat indices, (M,)) and its change
    per cell width along the sampled axes (M, K + 1, d), NaN where unknown (module docstring).

    Parameters
    ----------
    margins : NodeMargins
        The nodes' margins.
    sampled : list of int
        The sampled pose axes (grid axes).
    secants : (node, axis, distance, column) or None
        Arrays over the crossings seen from one end node each
        (:func:`kinematics.workspace._margin_secants`): the node (flat index), the sampled axis
        (index into ``sampled``), the signed distance to the crossing along it (cell widths,
        +: towards the node above) and the margin (column of ``margins.table``) that vanishes
        there. That margin's slope along that axis becomes the secant through its zero there.
        None: no secants (the differences alone).

    The dexterity margin of a node where neither it nor its face neighbours know it is borrowed
    from a neighbour's model (:func:`_borrow_dexterity`).
    """
    at, slope = _node_linear_margins(
        margins.table,
        np.asarray(margins.shape, dtype=np.int64),
        margins.strides,
        np.ascontiguousarray(nodes, dtype=np.int64),
        np.asarray(sampled, dtype=np.int64),
    )
    row_of = np.full(margins.size, -1, dtype=np.int64)
    row_of[nodes] = np.arange(nodes.size)
    if secants is not None:
        _secants(at, slope, row_of, secants)
    _borrow_dexterity(at, slope, margins, row_of, nodes, sampled)
    return at, slope


@functools.cache
def _neighbour_offsets(d: int) -> np.ndarray:
    """The 3^d - 1 offsets (rows, in nodes) to a node's neighbours along d sampled axes, the
    nearest first (face, then edge, then corner neighbours), each group in lexicographic order."""
    offsets = [o for o in itertools.product((-1, 0, 1), repeat=d) if any(o)]
    table = np.array(sorted(offsets, key=lambda o: sum(abs(v) for v in o)), dtype=np.int64)
    table.setflags(write=False)  # cached: shared by every call
    return table


def _borrow_dexterity(
    at: np.ndarray,
    slope: np.ndarray,
    margins: NodeMargins,
    row_of: np.ndarray,
    nodes: np.ndarray,
    sampled: list[int],
) -> None:
    """The dexterity margin (last column, in place) of the nodes where it is still unknown (its
    node and face neighbours unreachable: a corner of the workspace reaches into its cell), the
    linear model of the nearest neighbour among ``nodes`` (26 in 3-D, the face ones first) whose
    own value is known (in ``margins.table``: not one extrapolated from its face neighbours, whose slopes may be 0 where they had none), continued to the node; it then
    bounds the cell's part too, as every margin does. Why: the part of such a cell kept
    1/kappa = 0, an under-count of the GDI by the share of V in these parts (0.2 % of the
    Gough-Stewart's at 22 per axis, 0.05 % of the Tricept's), where the rule's cells elsewhere
    over-count it a little."""
    missing = np.nonzero(~np.isfinite(at[:, -1]))[0]
    if missing.size:
        _borrowed_dexterity(
            at,
            slope,
            np.isfinite(margins.table[nodes, -1]),
            row_of,
            np.ascontiguousarray(nodes[missing]),
            missing,
            np.asarray(margins.shape, dtype=np.int64),
            margins.strides,
            np.asarray(sampled, dtype=np.int64),
            _neighbour_offsets(len(sampled)),
        )


@kernels.jit
def _borrowed_dexterity(at, slope, known, row_of, missing_nodes, missing, shape, strides, sampled, offsets):
    """:func:`_borrow_dexterity`'s loop, compiled: per missing row the offsets in order, the
    first neighbour (a row of ``at``) whose own dexterity margin is ``known``."""
    c = at.shape[1] - 1
    d = sampled.shape[0]
    coordinates = np.empty(d, dtype=np.int64)
    for i in range(missing.shape[0]):
        node = missing_nodes[i]
        for k in range(d):  # once per node: an integer division per offset and axis cost 2/3 of the loop
            coordinates[k] = (node // strides[sampled[k]]) % shape[sampled[k]]
        for o in range(offsets.shape[0]):
            there = node
            inside_grid = True
            for k in range(d):
                j = sampled[k]
                coordinate = coordinates[k] + offsets[o, k]
                if coordinate < 0 or coordinate >= shape[j]:
                    inside_grid = False
                    break
                there += offsets[o, k] * strides[j]
            if not inside_grid:
                continue
            source = row_of[there]
            if source < 0 or not known[source]:
                continue
            # the neighbour's model at the node, which lies at -offset from it (cell widths)
            value = at[source, c]
            for k in range(d):
                value -= slope[source, c, k] * offsets[o, k]
            at[missing[i], c] = value
            for k in range(d):
                slope[missing[i], c, k] = slope[source, c, k]
            break


def _secants(
    at: np.ndarray,
    slope: np.ndarray,
    row_of: np.ndarray,
    secants: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray],
) -> None:
    """The secants of :func:`linear_margins` into ``slope`` (in place). Where one margin vanishes
    on both sides of a node along one axis (a margin with a ridge between them), the nearer
    crossing's secant: the better slope over the node's cell, and one answer whatever the order of
    the crossings (of two at the same distance, the first in ``secants``' order)."""
    node, axis, distance, column = secants
    _nearest_secants(
        at,
        slope,
        row_of,
        np.ascontiguousarray(node, dtype=np.int64),
        np.ascontiguousarray(axis, dtype=np.int64),
        np.ascontiguousarray(distance, dtype=float),
        np.ascontiguousarray(column, dtype=np.int64),
    )


@kernels.jit
def _nearest_secants(at, slope, row_of, node, axis, distance, column):
    """:func:`_secants`' loop, compiled: per (row, margin, axis) entry of ``slope`` the secant
    ``-at / distance`` of the nearest crossing seen from a band node (``row_of`` >= 0) where the
    margin is defined and the crossing is not at the node (``|distance| > 1e-9`` cell widths).
    The crossings sorted by entry (stably: of two at the same distance the first given), the
    nearest of each run. Why compiled: the numpy sort that picked the nearest per entry cost the
    Tricept a tenth of its evaluation; why sorted: an array of every entry's nearest distance
    (the size of ``slope``) cost the Gough-Stewart 600 page faults an evaluation."""
    m, count, d = slope.shape
    valid = np.empty(node.shape[0], dtype=np.int64)
    n_valid = 0
    for i in range(node.shape[0]):
        row = row_of[node[i]]
        if row >= 0 and abs(distance[i]) > 1e-9 and np.isfinite(at[row, column[i]]):
            valid[n_valid] = i
            n_valid += 1
    valid = valid[:n_valid]
    entry = np.empty(n_valid, dtype=np.int64)
    for v in range(n_valid):
        i = valid[v]
        entry[v] = (row_of[node[i]] * count + column[i]) * d + axis[i]
    order = np.argsort(entry, kind="mergesort")
    v = 0
    while v < n_valid:
        best = valid[order[v]]
        w = v + 1
        while w < n_valid and entry[order[w]] == entry[order[v]]:
            if abs(distance[valid[order[w]]]) < abs(distance[best]):
                best = valid[order[w]]
            w += 1
        row, c = row_of[node[best]], column[best]
        slope[row, c, axis[best]] = -at[row, c] / distance[best]
        v = w


def cell_means(integrand: np.ndarray, inside: np.ndarray, sampled: list[int]) -> np.ndarray:
    """Each inside node's cell mean of an integrand given at the nodes (grid shape): the node's
    value plus 1/24 of its second difference along each sampled axis whose two neighbours are
    inside (the mean of a parabola over a cell of width 1 is its centre value plus ``f''/24``);
    0 outside."""
    mean = _cell_means(
        np.ascontiguousarray(integrand, dtype=float).ravel(),
        np.ascontiguousarray(inside).ravel(),
        np.asarray(inside.shape, dtype=np.int64),
        flat_strides(inside.shape),
        np.asarray(sampled, dtype=np.int64),
    )
    return mean.reshape(inside.shape)


@kernels.jit
def _cell_means(integrand, inside, shape, strides, sampled):
    """:func:`cell_means` on the flat grid, compiled."""
    mean = np.zeros(integrand.shape[0])
    for node in range(integrand.shape[0]):
        if not inside[node]:
            continue
        here = integrand[node]
        value = here
        for k in range(sampled.shape[0]):
            j = sampled[k]
            coordinate = (node // strides[j]) % shape[j]
            if coordinate == 0 or coordinate == shape[j] - 1:
                continue
            above, below = node + strides[j], node - strides[j]
            if inside[above] and inside[below]:
                value += ((integrand[above] + integrand[below]) - 2.0 * here) / 24.0
        mean[node] = value
    return mean


def part_inverse_condition(
    at: np.ndarray,
    slope: np.ndarray,
    centroid: np.ndarray,
    variance: np.ndarray,
    fallback: np.ndarray,
    min_ic: float,
) -> np.ndarray:
    """1/kappa (dimensionless, (M,)) of each band cell's inside part: the mean over the part of
    ``sqrt(X)``, ``X = m + min_ic^2``, ``m`` the linear dexterity margin ``ic^2 - min_ic^2`` (the
    last margin of ``at`` (M, K + 1) and ``slope`` (M, K + 1, d), per cell width), to second order
    in its spread: ``sqrt(E) max(1 - r / 8, (1 + r)^(-1/2))``, ``E`` the mean of ``X`` over the part
    (the model at its ``centroid``, (M, d), cell units), ``r = Var / E^2`` with ``variance`` the
    variance of ``m`` over the part ((M,), :func:`kinematics.polytope.clipped_cell_moments`);
    ``fallback`` (M,) where the cell has no dexterity model.

    Why: 1/kappa is concave along its margin (a square root: it falls like the root of the
    distance towards a singular boundary), so its value at the centroid, ``sqrt(E)``, is above its
    mean over the part: the Tricept's GDI erred by up to +0.089 % at its default that way, and by
    0.049 % with the mean (``python -m benchmarks.part_means tricept``: the Monte Carlo mean of
    the same model agrees). ``1 - r / 8`` is the delta method's second-order term (on a whole
    Tricept cell 1.4e-5 of its value from the exact mean, where it corrects by 1.5e-3); Hoelder's lower bound
    ``(1 + r)^(-1/2)`` takes over where the spread is not small (a part reaching to ``m`` near 0
    with ``min_ic = 0``), so that it stays positive. Continuous: the variance is exact on every
    path of the clipper, and the maximum of two continuous functions is continuous."""
    dex = at[:, -1] + np.einsum("md,md->m", slope[:, -1, :], centroid)
    mean = np.maximum(dex + min_ic**2, 0.0)
    ratio = np.divide(variance, mean * mean, out=np.zeros_like(mean), where=mean > 0.0)
    factor = np.maximum(1.0 - ratio / 8.0, 1.0 / np.sqrt(1.0 + ratio))
    return np.where(np.isfinite(dex), np.sqrt(mean) * factor, fallback)


def margin_cell_sums(
    margins: NodeMargins,
    sampled: list[int],
    inside: np.ndarray,
    ic: np.ndarray,
    secants: tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray] | None,
    min_ic: float,
) -> tuple[float, float]:
    """``(sum of the cells' inside fractions, sum of their fractions times mean 1/kappa)`` over
    the grid, in cells (module docstring): V is the first times the cell volume, the GDI the
    second over the first.

    Parameters
    ----------
    margins : NodeMargins
        Every node's margins.
    sampled : list of int
        The sampled pose axes (grid axes).
    inside : ndarray of bool, grid shape
        The nodes' membership (reachable and dexterous).
    ic : ndarray, grid shape
        The nodes' 1/kappa (NaN where unreachable).
    secants : tuple or None
        The crossings' secants (:func:`linear_margins`); None: none (no edge is cut).
    min_ic : float
        The dexterity limit on 1/kappa (dimensionless).
    """
    node_ic = np.where(inside, ic, 0.0)
    band = boundary_band(inside)
    if not band.size:  # every node's neighbours share its membership: no cell is cut
        return float(inside.sum()), float(cell_means(node_ic, inside, sampled).sum())
    at, slope = linear_margins(margins, sampled, secants, band)
    fraction, centroid, variance = clipped_cell_moments(at, slope, slope[:, -1, :])
    part_ic = part_inverse_condition(at, slope, centroid, variance, node_ic.ravel()[band], min_ic)
    whole = inside.ravel().copy()
    whole[band] = False
    means = cell_means(node_ic, inside, sampled).ravel()
    cells = float(whole.sum()) + float(fraction.sum())
    return cells, float(means[whole].sum()) + float(fraction @ part_ic)
