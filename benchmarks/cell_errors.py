"""Where the grid method's volume error lives, cell by cell (docs/accuracy.md, "Order").

Run: ``python -m benchmarks.cell_errors delta "scan 0"`` (a mechanism and one of the designs of
``python -m benchmarks.accuracy``: ``paper``, ``optimum k``, ``random k``, ``scan k``;
``--points`` random points per cell, default 400). Prints, for the boundary cells of
``evaluate(mech, method="planes")`` (one plane per cell, whatever the mechanism's cell rule) at
its default resolution (numpy reference path), the cell fractions the rule
counts minus their Monte-Carlo fractions (the membership test at uniform random points of
each cell), summed per kind of cell and given in % of V:

- cut cells with a node in a slab thinner than its cell (a crossing on either side of one axis,
  the farther within the cell), the other cut cells by the number of axes with a crossing
  (1: the plane is normal to that axis), each split into inside and outside nodes;
- cells of nodes with no cut edge but a node of the other membership among their 26
  neighbours (an outside node whose cell's corner lies inside, and its mirror).

Their sum is the method's error against its own Monte Carlo (with the MC's standard error), to
compare with the error against a 4x finer grid (``benchmarks.accuracy``). A diagnosis, not a
target: it says which cells the next cell rule must treat. Mechanisms with an exact axis (H4)
are not supported (a cell's fraction there is a length, not a membership), nor those integrated
by exact sections (the 2-RPR, the 3-RPR). Seeded (seed 1).

``--candidate`` also measures the cell rule of ``evaluate(method="margins")`` (the Tricept's and
the Gough-Stewart's cell rule, ``cell_rule``) on the same random points as the Monte Carlo (so that the two rules' difference carries
no sampling noise): **linear margins** (:func:`linear_margin_inside`). Each of the mechanism's margins and the
dexterity margin ``1/kappa^2 - limit^2`` is taken as linear over a cut node's cell: its value at
the node, its central difference between the neighbouring nodes (one-sided where one is
undefined), and, along an axis whose edge crossing that margin places, the secant through
that crossing. The cell's inside part is the intersection of their half-spaces: an edge where
two constraint surfaces meet, and a slab between two of them, keep their shape, which one plane
per node cannot (docs/accuracy.md, "Order"). A last row gives the exact part of each cut cell
under that rule (:func:`kinematics.polytope.clipped_cell`) against the same points.

``--repairs`` measures two repairs of the planes rule on the captured grid, each exact on its
model (:func:`rule_repairs`), against the 4x reference: **slab cells by two planes** (the plane
through the nearest crossings and the axis plane through the farther crossing of each axis whose
farther crossing lies inside the cell) and **corner cells by linear margins** (the uncut cells
with a node of the other membership among their neighbours, each counted by the linear margins at
its own node, :func:`linear_margins`, instead of 0 or 1). A diagnosis of the Delta's scan miss
(docs/accuracy.md): neither repair is in ``evaluate``.

``--volume [RESOLUTION ...]`` measures the rule over the whole grid instead, at the default and at
the given resolutions, against the 4x reference of ``benchmarks.accuracy`` (no Monte Carlo):
the code's V and GDI errors, the linear margins' (:func:`volume_errors`), and their V without
the crossings' secants.
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.ndimage import maximum_filter, minimum_filter

from benchmarks.accuracy import (
    SCAN,
    SCAN_SEED,
    designs,
    random_designs,
    reference_evaluation,
)
from kinematics import MECHANISMS, kernels, margin_cells
from kinematics import workspace as ws
from kinematics.polytope import clipped_cell

#: cells per call of the membership test
BATCH = 500


def _captured_cut_cells(mech, resolution: int | None = None) -> dict:
    """Run ``evaluate(mech)`` on the numpy path and keep what its cut cells were made of: the
    grid (``values``, ``axes``, ``box``, ``sampled``, ``inside``), the crossings per axis
    (:func:`kinematics.workspace._edge_crossings`) and the cut cells' node-side fractions
    (:func:`kinematics.workspace._faded_cube_fraction`), the cell widths, the nodes' 1/kappa
    (``ic``) and V in cells (the corrected sums), by wrapping those functions."""
    seen: dict = {}
    wrapped = {
        name: getattr(ws, name) for name in ("_boundary_corrected_sums", "_edge_crossings", "_faded_cube_fraction")
    }

    def sums(values, axes, box, sampled, inside, f0, f1, steps, ic):
        # each sampled axis's cell width, as the grid's: the box over its nodes
        widths = [(float(box[1][j]) - float(box[0][j])) / len(axes[j]) for j in sampled]
        seen.update(values=values, axes=axes, box=box, sampled=sampled, inside=inside, widths=widths, ic=ic)
        seen["sums"] = wrapped["_boundary_corrected_sums"](values, axes, box, sampled, inside, f0, f1, steps, ic)
        return seen["sums"]

    def crossings(*args, **kwargs):
        seen["crossings"] = wrapped["_edge_crossings"](*args, **kwargs)
        return seen["crossings"]

    def fraction(slopes):
        own, centroid = wrapped["_faded_cube_fraction"](slopes)
        seen.update(slopes=slopes, own=own)
        return own, centroid

    try:
        ws._boundary_corrected_sums, ws._edge_crossings, ws._faded_cube_fraction = sums, crossings, fraction
        with kernels.reference_kernels():
            seen["evaluation"] = ws.evaluate(mech, resolution=resolution, method="planes", error_estimate=False)
    finally:
        for name, function in wrapped.items():
            setattr(ws, name, function)
    return seen


def _captured_grid(mech, resolution: int | None = None) -> dict:
    """:func:`_captured_cut_cells` of a mechanism this diagnosis supports (a grid of memberships);
    SystemExit with one line for the others."""
    seen = _captured_cut_cells(mech, resolution)
    if "inside" not in seen:
        raise SystemExit(f"{mech.name}: integrated by exact sections, no grid cells; not supported")
    if seen["values"].exact is not None:
        raise SystemExit(f"{mech.name}: an exact axis (cell fractions are lengths there); not supported")
    return seen


def _cut_nodes(seen: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The distances (d, nodes; cell widths) from every node to its nearest and its farther edge
    crossing along each sampled axis (inf: none), and the cut nodes (flat indices, in the order
    ``_boundary_corrected_sums`` takes them)."""
    pairs = list(zip(seen["crossings"], seen["widths"]))
    d = len(seen["sampled"])
    near = np.stack([np.minimum(minus, plus) / w for (minus, plus, _, _), w in pairs]).reshape(d, -1)
    far = np.stack([np.maximum(minus, plus) / w for (minus, plus, _, _), w in pairs]).reshape(d, -1)
    return near, far, np.nonzero(np.isfinite(near).any(axis=0))[0]


def _toward(seen: dict) -> np.ndarray:
    """The direction (d, nodes; +1 up, -1 down) of each node's nearest crossing along each
    sampled axis, as :func:`_cut_nodes` orders its distances (a tie: up)."""
    toward = np.stack([np.where(plus <= minus, 1.0, -1.0) for minus, plus, _, _ in seen["crossings"]])
    return toward.reshape(len(seen["sampled"]), -1)


def _monte_carlo_fractions(seen: dict, nodes: np.ndarray, points: int, rng: np.random.Generator) -> np.ndarray:
    """Fraction (M,) of the cells of ``nodes`` (flat indices) inside the workspace, from
    ``points`` uniform random points each (:func:`_cell_points`)."""
    return _cell_points(seen, nodes, points, rng)[1].mean(axis=1)


def _cell_points(seen: dict, nodes: np.ndarray, points: int, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """``points`` uniform random points in each cell of ``nodes`` (flat indices): their offsets
    from the node in cell widths (M, points, d) along the sampled axes, and their membership
    (M, points)."""
    axes, sampled, inside, widths = seen["axes"], seen["sampled"], seen["inside"], seen["widths"]
    index = np.unravel_index(nodes, inside.shape)
    centres = np.column_stack([axes[j][index[j]] for j in range(inside.ndim)])
    offsets = rng.random((nodes.size, points, len(sampled))) - 0.5
    member = np.empty((nodes.size, points), dtype=bool)
    for start in range(0, nodes.size, BATCH):
        poses = np.repeat(centres[start : start + BATCH], points, axis=0)
        for k, (j, width) in enumerate(zip(sampled, widths)):
            poses[:, j] += offsets[start : start + BATCH, :, k].ravel() * width
        member[start : start + BATCH] = seen["values"](poses)[0].reshape(-1, points)
    return offsets, member


def linear_margins(seen: dict, nodes: np.ndarray, secant: bool = True) -> tuple[np.ndarray, np.ndarray]:
    """The rule "linear margins" of ``evaluate(method="margins")``
    (:func:`kinematics.margin_cells.linear_margins`) in the cells of ``nodes`` (flat indices) of
    the captured grid: each margin's value at the node (M, K + 1) and its change per cell width
    along the sampled axes (M, K + 1, d), NaN where unknown; the secants through the crossings
    of :func:`kinematics.workspace._margin_secants` (``secant=False``: the differences alone)."""
    values, axes, inside, sampled, ic = (seen[k] for k in ("values", "axes", "inside", "sampled", "ic"))
    poses = ws._node_poses(axes, list(np.unravel_index(np.arange(inside.size), inside.shape)))
    margins = margin_cells.NodeMargins(values.margins(poses), ic, values.min_ic)
    secants = ws._margin_secants(values, axes, sampled, margins, inside) if secant else None
    return margin_cells.linear_margins(margins, sampled, secants, nodes)


def linear_margin_inside(seen: dict, nodes: np.ndarray, offsets: np.ndarray) -> np.ndarray:
    """Membership (M, points) of the points ``offsets`` (M, points, d; cell widths from the node)
    of the cells of ``nodes`` (flat indices) under :func:`linear_margins`: every margin
    ``m_c(node) + g_c . offset >= 0`` (an unknown one holds)."""
    at, slope = linear_margins(seen, nodes)
    linear = at[:, None, :] + np.einsum("mpd,mkd->mpk", offsets, slope)
    return np.where(np.isfinite(linear), linear >= 0.0, True).all(axis=2)


def candidate(mech, points: int = 200, seed: int = 1) -> list[tuple[str, float, float, float, float]]:
    """Rows ``(rule, net error, at inside nodes, at outside nodes, mean |error| per cell)`` over the
    cut cells, in % of V (the last a fraction of a cell), against the membership of random points:
    the code's rule (its exact cut fractions: the row carries the Monte Carlo's noise, in its mean
    error per cell too), the same planes tested on those points, and the candidate "linear
    margins" on those points (these two rows differ without sampling noise)."""
    seen = _captured_grid(mech)
    near, _, cut = _cut_nodes(seen)
    toward = _toward(seen)
    is_in = seen["inside"].ravel()[cut]
    offsets, member = _cell_points(seen, cut, points, np.random.default_rng(seed))
    truth = member.mean(axis=1)
    cells = float(seen["sums"][0])
    # the code's plane tested on the same points (its fading left out): the node's side where
    # sum_k u_k * direction_k / distance_k < 1 over the axes with a crossing
    plane = np.where(np.isfinite(near[:, cut]), toward[:, cut] / np.maximum(near[:, cut], 1e-12), 0.0).T
    node_side = np.einsum("mpd,md->mp", offsets, plane) < 1.0
    rules = {
        "plane through the nearest crossings (the code)": np.where(is_in, seen["own"], 1.0 - seen["own"]),
        "the same planes on the points (no fading)": np.where(is_in[:, None], node_side, ~node_side).mean(axis=1),
        "linear margins (method margins) on the points": linear_margin_inside(seen, cut, offsets).mean(axis=1),
        # the same rule's exact part of each cell: its row carries the Monte Carlo's noise
        "linear margins, exact part (kinematics.polytope)": clipped_cell(*linear_margins(seen, cut))[0],
    }
    rows = []
    for rule, counted in rules.items():
        diff = counted - truth
        rows.append(
            (
                rule,
                100 * float(diff.sum()) / cells,
                100 * float(diff[is_in].sum()) / cells,
                100 * float(diff[~is_in].sum()) / cells,
                float(np.abs(diff).mean()),
            )
        )
    return rows


def _mixed_uncut_nodes(seen: dict, cut: np.ndarray) -> np.ndarray:
    """The nodes (flat indices) with no cut edge but a node of the other membership among their
    3^d - 1 neighbours: the cells whose corner the boundary may cross unseen by the crossings."""
    membership = seen["inside"].astype(np.uint8)
    mixed = maximum_filter(membership, size=3, mode="nearest") != minimum_filter(membership, size=3, mode="nearest")
    return np.setdiff1d(np.nonzero(mixed.ravel())[0], cut)


def slab_parts(seen: dict) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The slab cells of the captured grid (inside nodes whose farther crossing along some axis
    lies within the cell, flat indices (S,)) and two exact parts of each (fractions of a cell,
    (S,)): under the plane through the nearest crossings alone (the planes rule without its
    fading), and under that plane and, per such axis, the axis plane through the farther
    crossing (the workspace's other side of the slab)."""
    near, far, cut = _cut_nodes(seen)
    d = near.shape[0]
    toward = _toward(seen)
    slab = cut[seen["inside"].ravel()[cut] & (far[:, cut] < 0.5).any(axis=0)]
    # the node's side of the plane: 1 - sum_k toward_k u_k / near_k >= 0 (u in cell units)
    gradient = np.where(np.isfinite(near[:, slab]), -toward[:, slab] / np.maximum(near[:, slab], 1e-12), 0.0).T
    level = np.ones((slab.size, 1))
    one_plane, _ = clipped_cell(level, gradient[:, None, :])
    # the farther crossing lies on the side opposite the nearer: toward_k u_k <= far_k there
    within = far[:, slab].T < 0.5
    far_level = np.where(within, far[:, slab].T, np.nan)
    far_gradient = np.where(within[:, :, None], np.eye(d)[None] * toward[:, slab].T[:, :, None], np.nan)
    two_planes, _ = clipped_cell(
        np.concatenate([level, far_level], axis=1), np.concatenate([gradient[:, None, :], far_gradient], axis=1)
    )
    return slab, one_plane, two_planes


def rule_repairs(mech, reference: bool = True) -> dict[str, float]:
    """The two repairs of ``--repairs`` on ``mech`` at its default resolution, in % of V:
    ``slab`` (two planes minus one, over the slab cells; <= 0), ``corner_outside`` and
    ``corner_inside`` (linear margins minus the node's own count, 0 or 1, over the corner cells
    of each kind), and with ``reference`` the code's V error against the 4x reference
    (``code``, as ``benchmarks.accuracy``'s scan) and with the repairs (``repaired``)."""
    seen = _captured_grid(mech)
    _, _, cut = _cut_nodes(seen)
    cells = float(seen["sums"][0])
    _, one_plane, two_planes = slab_parts(seen)
    corner = _mixed_uncut_nodes(seen, cut)
    is_in = seen["inside"].ravel()[corner]
    fraction, _ = clipped_cell(*linear_margins(seen, corner))
    change = fraction - is_in
    out = {
        "slab": 100 * float((two_planes - one_plane).sum()) / cells,
        "corner_outside": 100 * float(change[~is_in].sum()) / cells,
        "corner_inside": 100 * float(change[is_in].sum()) / cells,
    }
    if reference:
        ratio = seen["evaluation"].volume / reference_evaluation(mech).volume
        out["code"] = 100 * (ratio - 1)
        out["repaired"] = out["code"] + ratio * (out["slab"] + out["corner_outside"] + out["corner_inside"])
    return out


def volume_errors(mech, resolutions: list[int | None]) -> list[tuple]:
    """Rows ``(resolution, nodes, code's V, GDI errors, linear margins' V, GDI errors, V error
    without the crossings' secants)`` in % of the reference (the code at
    :data:`benchmarks.accuracy.REFERENCE_FACTOR` x the finer default, as the scan of
    ``benchmarks.accuracy``). The linear margins' are ``evaluate(method="margins")``'s (the
    whole grid: :mod:`kinematics.margin_cells`); without the secants, its V from the nodes'
    margins alone. No Monte Carlo: the errors are the rules' own."""
    reference = reference_evaluation(mech)  # as benchmarks.accuracy's scan
    rows = []
    for resolution in resolutions:
        seen = _captured_grid(mech, resolution)
        inside = seen["inside"]
        code = seen["evaluation"]
        rule = ws.evaluate(mech, resolution=resolution, method="margins", error_estimate=False)
        band = margin_cells.boundary_band(inside)
        fraction, _ = clipped_cell(*linear_margins(seen, band, secant=False))
        cells = float(inside.sum()) - float(inside.ravel()[band].sum()) + float(fraction.sum())
        per_cell = code.volume / float(seen["sums"][0])  # V of one cell of this grid
        rows.append(
            (
                "default" if resolution is None else str(resolution),
                int(inside.size),
                100 * (code.volume / reference.volume - 1),
                100 * (code.gdi / reference.gdi - 1),
                100 * (rule.volume / reference.volume - 1),
                100 * (rule.gdi / reference.gdi - 1),
                100 * (cells * per_cell / reference.volume - 1),
            )
        )
    return rows


def breakdown(mech, points: int = 400, seed: int = 1) -> list[tuple[str, int, float]]:
    """Rows ``(kind of cell, cells, sum of (rule - Monte Carlo) in % of V)``, the last row
    the total with the Monte Carlo's standard error in its label."""
    seen = _captured_grid(mech)
    inside, sampled = seen["inside"], seen["sampled"]
    _, far, cut = _cut_nodes(seen)
    is_in = inside.ravel()[cut]
    counted = np.where(is_in, seen["own"], 1.0 - seen["own"])
    rng = np.random.default_rng(seed)
    sampled_fraction = _monte_carlo_fractions(seen, cut, points, rng)
    diff = counted - sampled_fraction
    slab = (far[:, cut] < 0.5).any(axis=0)
    axes_cut = (seen["slopes"] > 0.0).sum(axis=1)
    uncut = _mixed_uncut_nodes(seen, cut)
    uncut_in = inside.ravel()[uncut]
    uncut_fraction = _monte_carlo_fractions(seen, uncut, points, rng)
    uncut_diff = uncut_in - uncut_fraction
    cells = float(seen["sums"][0])  # V in cells: the corrected sum of the weights (1 a node here)
    rows = []
    kinds = [("slab thinner than the cell", slab)] + [
        (f"cut along {k} " + ("axis" if k == 1 else "axes"), ~slab & (axes_cut == k))
        for k in range(1, len(sampled) + 1)
    ]
    for label, kind in kinds:
        for side, where in (("inside", is_in), ("outside", ~is_in)):
            part = kind & where
            rows.append((f"{label}, {side} node", int(part.sum()), 100 * float(diff[part].sum()) / cells))
    for side, where in (("inside", uncut_in), ("outside", ~uncut_in)):
        rows.append(
            (
                f"no cut edge, a neighbour differs, {side} node",
                int(where.sum()),
                100 * float(uncut_diff[where].sum()) / cells,
            )
        )
    every = np.concatenate([sampled_fraction, uncut_fraction])
    noise = 100 * float(np.sqrt(np.sum(every * (1.0 - every)) / points)) / cells
    rows.append(
        (f"total (Monte Carlo standard error {noise:.3f} %)", int(cut.size + uncut.size), sum(r[2] for r in rows))
    )
    return rows


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("mechanism")
    parser.add_argument("design", help='"paper", "optimum k", "random k" or "scan k" (benchmarks.accuracy)')
    parser.add_argument("--points", type=int, default=400)
    parser.add_argument("--candidate", action="store_true", help="also measure the candidate rule (linear margins)")
    parser.add_argument(
        "--repairs",
        action="store_true",
        help="the slab cells by two planes and the corner cells by linear margins, against the 4x reference",
    )
    parser.add_argument(
        "--volume",
        type=int,
        nargs="*",
        metavar="RESOLUTION",
        help="the whole V of the code and of the linear margins against the 4x reference, at the default "
        "and at these resolutions (nodes per axis)",
    )
    args = parser.parse_args()
    if args.mechanism not in MECHANISMS:
        parser.error(f"mechanism={args.mechanism!r} is invalid: allowed {', '.join(sorted(MECHANISMS))}")
    if args.points < 1:
        parser.error(f"--points={args.points} is invalid: allowed an integer >= 1")
    pool = dict(designs(args.mechanism)) | dict(random_designs(args.mechanism, SCAN_SEED, SCAN, "scan"))
    if args.design not in pool:
        parser.error(f"design={args.design!r} is invalid: allowed {', '.join(pool)}")
    if args.repairs:
        r = rule_repairs(pool[args.design])
        print(
            f"{args.mechanism}, {args.design}: V against the 4x reference {r['code']:+.3f} %; slab cells by two "
            f"planes {r['slab']:+.3f} %, corner cells by linear margins {r['corner_outside']:+.3f} % (outside "
            f"nodes) {r['corner_inside']:+.3f} % (inside); with both {r['repaired']:+.3f} %"
        )
        return
    if args.volume is not None:
        if any(r < 4 for r in args.volume):
            parser.error(f"--volume={args.volume} is invalid: allowed resolutions >= 4")
        print(f"{args.mechanism}, {args.design}: V, GDI errors against the 4x reference, %")
        for label, nodes, *errors in volume_errors(pool[args.design], [None, *args.volume]):
            print(
                f"  resolution {label:8s} {nodes:8d} nodes  code {errors[0]:+.4f} {errors[1]:+.4f}  "
                f"linear margins {errors[2]:+.4f} {errors[3]:+.4f}  without secants V {errors[4]:+.4f}"
            )
        return
    rows = breakdown(pool[args.design], args.points)
    print(f"{args.mechanism}, {args.design}: rule minus Monte Carlo ({args.points} points a cell), % of V")
    for label, count, percent in rows:
        print(f"  {label:56s} {count:6d} cells  {percent:+.4f} %")
    if args.candidate:
        print(f"cut cells, rule minus the membership of the same {args.points} points a cell, % of V:")
        for rule, net, at_in, at_out, per_cell in candidate(pool[args.design], args.points):
            print(
                f"  {rule:48s} {net:+.4f} % (inside nodes {at_in:+.4f} %, outside {at_out:+.4f} %), "
                f"mean |error| {per_cell:.4f} of a cell"
            )


if __name__ == "__main__":
    main()
