"""The "linear margins" cell rule of ``evaluate(method="margins")`` (docs/accuracy.md, "Order").

Every grid node whose 26 neighbours share its membership counts its cell whole (inside) or not
at all. Every other node, the **band** along the boundary (the cut cells and the uncut cells
whose corner the boundary may reach), counts the part of its cell where each of the mechanism's
reachability margins and the dexterity margin ``1/kappa^2 - limit^2`` holds, each taken as
linear over the cell:

- its value at the node; undefined there (an angle where the inverse kinematics has no
  solution), extrapolated from the first neighbour along a sampled axis that defines it;
- its change per cell width along each sampled axis, the central difference of the nodes'
  values (one-sided where a neighbour is undefined);
- along an axis with an edge crossing (:func:`kinematics.workspace._sparse_crossings`, the
  grid method's crossings), the margin nearest 0 at the crossing takes the secant through it
  (the reachability margins evaluated there, the dexterity margin from the crossing's 1/kappa).
  Why the secants: the margins curve (an arccos near the reach limit), and from the nodes'
  values alone V erred by up to 0.34 % (Delta, defaults) against 0.05 % with them.

The part is the intersection of the half-spaces, a convex polytope, whose volume and centroid
:func:`kinematics.polytope.clipped_cell` computes exactly: an edge where two constraint
surfaces meet, a corner and a slab keep their shape, which one plane per cell cannot.

The GDI's integrand ``1/kappa``: over a band cell's part, its value at the part's centroid from
the linear dexterity margin there; over a whole cell, its mean as the node's value plus 1/24 of
its second differences along the sampled axes whose two neighbours are inside (1/kappa falls like
a root towards a singular boundary, where the node's value alone, the midpoint rule, erred by
+0.085 % of the Delta's GDI on a scan design with every boundary part exact).

Mechanisms with margins (``Mechanism.constraint_margins``) and no exact axis only: the H4,
whose grid integrates z exactly per column, keeps ``method="grid"``. Units: margins in their
own units, positions in the pose's (mm, cm or rad), cell offsets in cell widths.
"""

from __future__ import annotations

import numpy as np
from scipy.ndimage import binary_dilation, maximum_filter, minimum_filter

from kinematics import kernels
from kinematics.polytope import clipped_cell


def boundary_band(inside: np.ndarray) -> np.ndarray:
    """Flat indices of the nodes some of whose 26 neighbours (8 in 2-D) differ in membership
    (``inside``, the grid's shape, bool)."""
    membership = inside.astype(np.uint8)
    mixed = maximum_filter(membership, size=3, mode="nearest") != minimum_filter(membership, size=3, mode="nearest")
    return np.nonzero(mixed.ravel())[0]


class NodeMargins:
    """The margins (K + 1 columns) of the grid nodes near the band: the mechanism's reachability
    margins (``values.margins``) and the dexterity margin ``ic^2 - min_ic^2`` (``ic`` the nodes'
    1/kappa, NaN where unreachable), NaN where undefined, computed once for every node within
    one node (26 neighbours) of ``nodes`` and two along each axis: the differences of a band node
    need its neighbours' values, and an undefined value at it a neighbour's differences."""

    def __init__(self, values, axes: list[np.ndarray], inside: np.ndarray, ic: np.ndarray, nodes: np.ndarray):
        self.shape = inside.shape
        self.size = inside.size
        near = np.zeros(inside.size, dtype=bool)
        near[nodes] = True
        cross = np.zeros((3,) * inside.ndim, dtype=bool)
        for j in range(inside.ndim):
            line = [1] * inside.ndim
            line[j] = slice(None)
            cross[tuple(line)] = True
        near = binary_dilation(near.reshape(inside.shape), np.ones((3,) * inside.ndim, dtype=bool))
        near = binary_dilation(near, cross).ravel()
        where = np.nonzero(near)[0]
        index = np.unravel_index(where, inside.shape)
        poses = np.column_stack([axes[j][index[j]] for j in range(inside.ndim)])
        reach = values.margins(poses)
        dexterity = ic.ravel()[where] ** 2 - values.min_ic**2
        # one row of NaN at the end: the value of a node off the grid or not computed
        self.table = np.vstack([np.column_stack([reach, dexterity]), np.full((1, reach.shape[1] + 1), np.nan)])
        self.slot = np.full(inside.size, where.size, dtype=np.int64)
        self.slot[where] = np.arange(where.size)
        self.strides = [int(np.prod(inside.shape[j + 1 :])) for j in range(inside.ndim)]


@kernels.inline_jit
def _value(table, slot, shape, strides, node, j, step, c):
    """Margin ``c`` of the node ``step`` nodes along grid axis ``j`` from ``node``; NaN off the grid."""
    coordinate = (node // strides[j]) % shape[j] + step
    if coordinate < 0 or coordinate >= shape[j]:
        return np.nan
    return table[slot[node + step * strides[j]], c]


@kernels.inline_jit
def _difference(table, slot, shape, strides, node, j, c):
    """The change per node of margin ``c`` along grid axis ``j`` at ``node``: the central
    difference, one-sided where a neighbour is off the grid or undefined, 0 where both are."""
    here = table[slot[node], c]
    ahead = _value(table, slot, shape, strides, node, j, 1, c) - here
    behind = here - _value(table, slot, shape, strides, node, j, -1, c)
    if np.isfinite(ahead) and np.isfinite(behind):
        return 0.5 * (ahead + behind)
    if np.isfinite(ahead):
        return ahead
    if np.isfinite(behind):
        return behind
    return 0.0


@kernels.jit
def _node_linear_margins(table, slot, shape, strides, nodes, sampled):
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
        here = slot[node]
        for k in range(d):
            j = sampled[k]
            coordinate = (node // strides[j]) % shape[j]
            above[k] = slot[node + strides[j]] if coordinate + 1 < shape[j] else missing
            below[k] = slot[node - strides[j]] if coordinate > 0 else missing
        for c in range(count):
            value = table[here, c]
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
                    at[i, c] = neighbour - step * _difference(table, slot, shape, strides, there, sampled[k], c)
                    for kk in range(d):
                        slope[i, c, kk] = _difference(table, slot, shape, strides, there, sampled[kk], c)
                    found = True
                    break
                if found:
                    break
    return at, slope


def linear_margins(
    values,
    axes: list[np.ndarray],
    sampled: list[int],
    widths: list[float],
    margins: NodeMargins,
    crossings: list[tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]],
    nodes: np.ndarray,
) -> tuple[np.ndarray, np.ndarray]:
    """Each margin's value (M, K + 1) at the nodes ``nodes`` (flat indices) and its change per
    cell width along the sampled axes (M, K + 1, d), NaN where unknown (module docstring).

    Parameters
    ----------
    values : kinematics.workspace._PointValues
        The mechanism's margins at poses, and its dexterity limit ``min_ic``.
    axes : list of ndarray
        The grid's node positions per pose axis (unit of the axis).
    sampled, widths : list
        The sampled pose axes and their cell widths (unit of the axis).
    margins : NodeMargins
        The nodes' margins.
    crossings : list of (node, axis, distance, dexterity)
        Per side (the crossing above the node, then below), arrays over the crossings: the node
        (flat index), the sampled axis (index into ``sampled``), the distance from the node
        (cell widths, > 0) and the dexterity margin there (NaN unknown).
    nodes : ndarray of int, shape (M,)
    """
    at, slope = _node_linear_margins(
        margins.table,
        margins.slot,
        np.asarray(margins.shape, dtype=np.int64),
        np.asarray(margins.strides, dtype=np.int64),
        np.ascontiguousarray(nodes, dtype=np.int64),
        np.asarray(sampled, dtype=np.int64),
    )
    row_of = np.full(margins.size, -1, dtype=np.int64)
    row_of[nodes] = np.arange(nodes.size)
    for sign, (node, axis, distance, dexterity) in zip((1.0, -1.0), crossings):
        rows = row_of[node]
        keep = (rows >= 0) & (distance > 1e-9)
        rows, axis, distance, dexterity = rows[keep], axis[keep], distance[keep], dexterity[keep]
        if not rows.size:
            continue
        index = np.unravel_index(node[keep], margins.shape)
        poses = np.column_stack([axes[jj][index[jj]] for jj in range(len(margins.shape))])
        columns = np.asarray(sampled)[axis]
        poses[np.arange(rows.size), columns] += sign * distance * np.asarray(widths)[axis]
        there = np.column_stack([values.margins(poses), dexterity])
        along = slope[rows, :, axis]
        nearness = np.where(np.isfinite(there), np.abs(there) / (np.abs(along) + 1e-300), np.inf)
        margin = np.argmin(nearness, axis=1)
        defined = np.isfinite(at[rows, margin])
        rows, margin, axis, distance = rows[defined], margin[defined], axis[defined], distance[defined]
        slope[rows, margin, axis] = -at[rows, margin] / (sign * distance)
    return at, slope


def cell_means(integrand: np.ndarray, inside: np.ndarray, sampled: list[int]) -> np.ndarray:
    """Each inside node's cell mean of an integrand given at the nodes (grid shape): the node's
    value plus 1/24 of its second difference along each sampled axis whose two neighbours are
    inside (the mean of a parabola over a cell of width 1 is its centre value plus ``f''/24``);
    0 outside."""
    known = np.where(inside, integrand, np.nan)
    mean = known.copy()
    for j in sampled:
        second = np.full(known.shape, np.nan)
        middle, ahead, behind = ([slice(None)] * known.ndim for _ in range(3))
        middle[j], ahead[j], behind[j] = slice(1, -1), slice(2, None), slice(0, -2)
        second[tuple(middle)] = known[tuple(ahead)] + known[tuple(behind)] - 2.0 * known[tuple(middle)]
        mean += np.where(np.isfinite(second), second, 0.0) / 24.0
    return np.where(inside, mean, 0.0)


def margin_cell_sums(
    values,
    axes: list[np.ndarray],
    sampled: list[int],
    inside: np.ndarray,
    ic: np.ndarray,
    cut: dict[str, np.ndarray] | None,
) -> tuple[float, float]:
    """``(sum of the cells' inside fractions, sum of their fractions times mean 1/kappa)`` over
    the grid, in cells (module docstring): V is the first times the cell volume, the GDI the
    second over the first.

    Parameters
    ----------
    inside : ndarray of bool, grid shape
        The nodes' membership (reachable and dexterous).
    ic : ndarray, grid shape
        The nodes' 1/kappa (NaN where unreachable).
    cut : dict or None
        :func:`kinematics.workspace._sparse_crossings` (None: no edge is cut).
    """
    node_ic = np.where(inside, ic, 0.0)
    if cut is None:
        return float(inside.sum()), float(cell_means(node_ic, inside, sampled).sum())
    band = boundary_band(inside)
    margins = NodeMargins(values, axes, inside, ic, band)
    widths = [float(w) for w in cut["steps_of"]]
    # each crossing as seen from its two end nodes: above the left one, below the right one
    axis, left, right, crossing = cut["axis"], cut["left"], cut["right"], cut["crossing"]
    weight, weighted = cut["value"]
    with np.errstate(divide="ignore", invalid="ignore"):
        dexterity = np.where(weight > 0, (weighted / weight) ** 2 - values.min_ic**2, np.nan)
    position = cut["positions"]
    sides = []
    for end, sign in ((left, 1.0), (right, -1.0)):
        has = end >= 0
        coordinate = (end[has] // cut["strides"][axis[has]]) % cut["sizes"][axis[has]]
        distance = sign * (crossing[has] - position[axis[has], coordinate + 1]) / cut["steps_of"][axis[has]]
        sides.append((end[has], axis[has], distance, dexterity[has]))
    at, slope = linear_margins(values, axes, sampled, widths, margins, sides, band)
    fraction, centroid = clipped_cell(at, slope)
    dex = at[:, -1] + np.einsum("md,md->m", slope[:, -1, :], centroid)
    part_ic = np.where(np.isfinite(dex), np.sqrt(np.maximum(dex + values.min_ic**2, 0.0)), node_ic.ravel()[band])
    whole = inside.ravel().copy()
    whole[band] = False
    means = cell_means(node_ic, inside, sampled).ravel()
    cells = float(whole.sum()) + float(fraction.sum())
    return cells, float(means[whole].sum()) + float(fraction @ part_ic)
