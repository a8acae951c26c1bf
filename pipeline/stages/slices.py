"""The workspace slice of one design: sampled on a grid (:func:`workspace_slice`) and drawn
(:func:`draw_slice`), for ``workspace.png`` / ``inverse_condition.png`` of a run
(:func:`pipeline.stages.plot.plot_workspace`) and the report's and document's families of slices.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from kinematics.base import Mechanism
from kinematics.workspace import evaluate

#: slice resolution of the workspace figures (grid points per plotted axis)
SLICE_RESOLUTION = 120
#: the slices' sampling: the cell-centre grid over the whole pose box (a figure draws the nodes
#: and integrates nothing; ``method="grid"`` would crop its grid to the workspace's extent)
SLICE_METHOD = "midpoint"
_SYMBOLS = {"theta": "θ", "psi": "ψ", "phi": "φ", "mixed": "η", "gdi": "GDI", "suri": "SURI", "volume": "V"}


def symbol(name: str) -> str:
    """Greek symbol of a pose variable or objective (θ, ψ, φ, η), else the name."""
    return _SYMBOLS.get(name, name)


@dataclass
class Slice:
    """A 2-D slice of one design's workspace, as drawn by :func:`plot_workspace`.

    ``x``, ``y``: sample coordinates on the plotted axes (the mechanism's units,
    rad for angles); ``extent``: height of the exactly integrated axis (H4: z
    extent, length unit) or None; ``inverse_condition``: 1/κ; both NaN outside.
    """

    x: np.ndarray
    y: np.ndarray
    extent: np.ndarray | None
    inverse_condition: np.ndarray
    inside: np.ndarray
    xlabel: str
    ylabel: str
    extent_label: str
    fixed_label: str
    equal_aspect: bool


def workspace_slice(mech: Mechanism, orientation: tuple[float, float], min_ic: float, length: float | None) -> Slice:
    """The mechanism's plot slice (``Mechanism.plot_slice``) of one design, sampled on a
    :data:`SLICE_RESOLUTION` grid (orientation in rad, ``length`` in the length unit)."""
    fixed, (i, j), _ = mech.plot_slice(orientation)
    label = ", ".join(
        f"{symbol(n)} = {np.degrees(v):.1f}°"
        if mech.angular[mech.pose_names.index(n)]
        else f"{symbol(n)} = {v:.4g} {mech.length_unit}"
        for n, v in fixed.items()
    )
    ev = evaluate(
        mech,
        orientation=orientation,
        min_inverse_condition=min_ic,
        length=length,
        fixed=fixed,
        resolution=SLICE_RESOLUTION,
        method=SLICE_METHOD,
        return_samples=True,
        error_estimate=False,
    )
    pts, inside = ev.samples, ev.inside
    names = mech.pose_names
    axis_label = [f"{symbol(n)} [{'rad' if mech.angular[k] else mech.length_unit}]" for k, n in enumerate(names)]
    extent = None if ev.extent is None else np.where(inside, ev.extent[:, 1] - ev.extent[:, 0], np.nan)
    return Slice(
        x=pts[:, i],
        y=pts[:, j],
        extent=extent,
        inverse_condition=np.where(inside, ev.inverse_conditions, np.nan),
        inside=inside,
        xlabel=axis_label[i],
        ylabel=axis_label[j],
        extent_label=(
            f"{symbol(names[2])} extent [{mech.length_unit}]" if len(names) > 2 else f"extent [{mech.length_unit}]"
        ),
        fixed_label=label,
        equal_aspect=mech.angular[i] == mech.angular[j],
    )


def draw_slice(
    fig: Figure, ax, data: Slice, kind: str, vmin: float | None = None, vmax: float | None = None, colorbar: bool = True
):
    """Draw ``kind`` ("workspace" or "inverse_condition") of ``data`` on ``ax``; returns the mesh.

    ``vmin``/``vmax`` fix the colour scale (one scale for a family of figures).
    """
    if kind == "workspace" and data.extent is not None:
        values, bar, cmap = data.extent, data.extent_label, "viridis"
    elif kind == "workspace":
        values, bar, cmap = np.where(data.inside, 1.0, np.nan), None, ListedColormap(["tab:blue"])
    else:
        values, bar, cmap = data.inverse_condition, "1/κ [1]", "magma"
        vmin = 0.0 if vmin is None else vmin
    # one rectangle per grid cell: visible at any resolution and any axis scale
    mesh = _cells(ax, data.x, data.y, values, cmap, vmin=vmin, vmax=vmax)
    if bar and colorbar:
        fig.colorbar(mesh, ax=ax, label=bar)
    ax.set_xlabel(data.xlabel)
    ax.set_ylabel(data.ylabel)
    if data.equal_aspect:
        ax.set_aspect("equal")
    return mesh


def _cells(ax, x: np.ndarray, y: np.ndarray, values: np.ndarray, cmap, vmin=None, vmax=None):
    """Regular grid samples as a pcolormesh (NaN transparent)."""
    xs, ys = np.unique(np.round(x, 12)), np.unique(np.round(y, 12))
    grid = np.full((ys.size, xs.size), np.nan)
    grid[np.searchsorted(ys, np.round(y, 12)), np.searchsorted(xs, np.round(x, 12))] = values
    return ax.pcolormesh(xs, ys, np.ma.masked_invalid(grid), cmap=cmap, vmin=vmin, vmax=vmax, shading="nearest")
