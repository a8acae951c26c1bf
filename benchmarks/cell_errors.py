"""Where the grid method's volume error lives, cell by cell (docs/accuracy.md, "Order").

Run: ``python -m benchmarks.cell_errors delta "scan 0"`` (a mechanism and one of the designs of
``python -m benchmarks.accuracy``: ``paper``, ``optimum k``, ``random k``, ``scan k``;
``--points`` random points per cell, default 400). Prints, for the boundary cells of
``evaluate(mech)`` at its default resolution (numpy reference path), the cell fractions the rule
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
"""

from __future__ import annotations

import argparse

import numpy as np
from scipy.ndimage import maximum_filter, minimum_filter

from benchmarks.accuracy import SCAN, SCAN_SEED, designs, random_designs
from kinematics import MECHANISMS, kernels
from kinematics import workspace as ws

#: cells per call of the membership test
BATCH = 500


def _captured_cut_cells(mech) -> dict:
    """Run ``evaluate(mech)`` on the numpy path and keep what its cut cells were made of: the
    grid (``values``, ``axes``, ``box``, ``sampled``, ``inside``), the crossings per axis
    (:func:`kinematics.workspace._edge_crossings`) and the cut cells' node-side fractions
    (:func:`kinematics.workspace._faded_cube_fraction`), the cell widths, and V in cells (the
    corrected sums), by wrapping those functions."""
    seen: dict = {}
    wrapped = {
        name: getattr(ws, name) for name in ("_boundary_corrected_sums", "_edge_crossings", "_faded_cube_fraction")
    }

    def sums(values, axes, box, resolution, sampled, inside, *rest):
        # each sampled axis's cell width, as the grid's: the box over its nodes
        widths = [(float(box[1][j]) - float(box[0][j])) / len(axes[j]) for j in sampled]
        seen.update(values=values, axes=axes, box=box, sampled=sampled, inside=inside, widths=widths)
        seen["sums"] = wrapped["_boundary_corrected_sums"](values, axes, box, resolution, sampled, inside, *rest)
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
            seen["evaluation"] = ws.evaluate(mech, error_estimate=False)
    finally:
        for name, function in wrapped.items():
            setattr(ws, name, function)
    return seen


def _monte_carlo_fractions(seen: dict, nodes: np.ndarray, points: int, rng: np.random.Generator) -> np.ndarray:
    """Fraction (M,) of the cells of ``nodes`` (flat indices) inside the workspace, from
    ``points`` uniform random points each."""
    axes, sampled, inside, widths = seen["axes"], seen["sampled"], seen["inside"], seen["widths"]
    index = np.unravel_index(nodes, inside.shape)
    centres = np.column_stack([axes[j][index[j]] for j in range(inside.ndim)])
    out = np.empty(nodes.size)
    for start in range(0, nodes.size, BATCH):
        poses = np.repeat(centres[start : start + BATCH], points, axis=0)
        for j, width in zip(sampled, widths):
            poses[:, j] += (rng.random(poses.shape[0]) - 0.5) * width
        out[start : start + BATCH] = seen["values"](poses)[0].reshape(-1, points).mean(axis=1)
    return out


def breakdown(mech, points: int = 400, seed: int = 1) -> list[tuple[str, int, float]]:
    """Rows ``(kind of cell, cells, sum of (rule - Monte Carlo) in % of V)``, the last row
    the total with the Monte Carlo's standard error in its label."""
    seen = _captured_cut_cells(mech)
    if "inside" not in seen:
        raise SystemExit(f"{mech.name}: integrated by exact sections, no grid cells; not supported")
    inside, sampled = seen["inside"], seen["sampled"]
    if seen["values"].exact is not None:
        raise SystemExit(f"{mech.name}: an exact axis (cell fractions are lengths there); not supported")
    pairs = list(zip(seen["crossings"], seen["widths"]))
    near = np.stack([np.minimum(minus, plus) / w for (minus, plus, _, _), w in pairs])
    far = np.stack([np.maximum(minus, plus) / w for (minus, plus, _, _), w in pairs])
    # the cut cells, in the order _boundary_corrected_sums takes them
    cut = np.nonzero(np.isfinite(near.reshape(len(sampled), -1)).any(axis=0))[0]
    is_in = inside.ravel()[cut]
    counted = np.where(is_in, seen["own"], 1.0 - seen["own"])
    rng = np.random.default_rng(seed)
    sampled_fraction = _monte_carlo_fractions(seen, cut, points, rng)
    diff = counted - sampled_fraction
    slab = (far.reshape(len(sampled), -1)[:, cut] < 0.5).any(axis=0)
    axes_cut = (seen["slopes"] > 0.0).sum(axis=1)
    membership = inside.astype(np.uint8)
    mixed = maximum_filter(membership, size=3, mode="nearest") != minimum_filter(membership, size=3, mode="nearest")
    uncut = np.setdiff1d(np.nonzero(mixed.ravel())[0], cut)
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
    args = parser.parse_args()
    if args.mechanism not in MECHANISMS:
        parser.error(f"mechanism={args.mechanism!r} is invalid: allowed {', '.join(sorted(MECHANISMS))}")
    if args.points < 1:
        parser.error(f"--points={args.points} is invalid: allowed an integer >= 1")
    pool = dict(designs(args.mechanism)) | dict(random_designs(args.mechanism, SCAN_SEED, SCAN, "scan"))
    if args.design not in pool:
        parser.error(f"design={args.design!r} is invalid: allowed {', '.join(pool)}")
    rows = breakdown(pool[args.design], args.points)
    print(f"{args.mechanism}, {args.design}: rule minus Monte Carlo ({args.points} points a cell), % of V")
    for label, count, percent in rows:
        print(f"  {label:56s} {count:6d} cells  {percent:+.4f} %")


if __name__ == "__main__":
    main()
