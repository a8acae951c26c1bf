"""Stage 5, plot: figures of a run and of a sweep (PNG, optionally PDF or SVG).

* ``convergence.png``: best and mean objective per generation (seed 000 Fig. 7);
* ``workspace.png``: the mechanism's plot slice (``Mechanism.plot_slice``),
  coloured by the height of the exactly integrated axis where there is one
  (H4: z extent, seed 000 Fig. 5);
* ``inverse_condition.png``: 1/κ on the same slice (seed 000 Fig. 6);
* ``pareto.png``: the non-dominated designs of a Pareto optimiser;
* ``tradeoff.png`` (sweeps): GDI, SURI and η of the optima versus w_d, mean
  and range over seeds (seed 000 Fig. 8).

Figures are built on :class:`matplotlib.figure.Figure` with an Agg canvas,
never through pyplot's global state, so importing this module does not
change the backend of a notebook.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.colors import ListedColormap
from matplotlib.figure import Figure

from kinematics.base import Mechanism
from kinematics.workspace import evaluate

#: slice resolution of the workspace figures (grid points per plotted axis)
SLICE_RESOLUTION = 120
_SYMBOLS = {"theta": "θ", "psi": "ψ", "phi": "φ", "mixed": "η", "gdi": "GDI", "suri": "SURI", "volume": "V"}


def _figure(width: float, height: float, ncols: int = 1) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(1, ncols, squeeze=False)[0])
    return fig, axes


def _save(fig: Figure, path: Path, plot=None) -> Path:
    """Write ``path`` (PNG) atomically, plus ``plot.format`` (pdf/svg) beside it."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    dpi = getattr(plot, "dpi", 150)
    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=dpi)
    tmp.replace(path)
    extra = getattr(plot, "format", None)
    if extra:
        fig.savefig(path.with_suffix(f".{extra}"))
    return path


def symbol(name: str) -> str:
    """Greek symbol of a pose variable or objective (θ, ψ, φ, η), else the name."""
    return _SYMBOLS.get(name, name)


def run_figures(mechanism, objective, optimizer, plot, optimum: dict) -> dict[str, bytes]:
    """The figures of one run, as file name -> content: convergence, workspace and 1/κ slices of
    the optimum, and the Pareto front of a multi-objective optimiser.

    Drawn in a temporary folder and returned as bytes so that the pipeline can
    cache this stage like the others (a second identical run draws nothing).
    ``mechanism``, ``objective``, ``optimizer`` and ``plot`` are the run's
    config sections (``pipeline.config``); ``optimum`` the optimise stage's result.
    """
    design = [optimum["best"][n] for n in mechanism.design.names]
    mech = mechanism.build(design)
    orientation = mechanism.orientation_rad() or mech.default_orientation
    what = f"{mech.name}, {objective.name}" + (f", w_d = {objective.w_d:g}" if objective.name == "mixed" else "")
    unit = optimum["best"]["objective_unit"]
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        plot_convergence(optimum["history"], directory / "convergence.png",
                         f"{optimizer.name} convergence ({what})", f"{symbol(objective.name)} [{unit}]", plot)
        plot_workspace(mech, orientation, mechanism.min_inverse_condition, mechanism.length, directory, what, plot)
        if optimum["front"] is not None:
            plot_front(optimum["front"], list(optimizer.objectives), directory / "pareto.png", what, plot)
        return {p.name: p.read_bytes() for p in sorted(directory.iterdir()) if not p.name.startswith(".")}


def plot_convergence(history: pd.DataFrame, path: Path, title: str, ylabel: str, plot=None) -> Path:
    """Best and mean objective per generation (seed 000 Fig. 7)."""
    fig, (ax,) = _figure(6, 4)
    ax.plot(history["generation"], history["best"], label="best")
    ax.plot(history["generation"], history["mean"], label="population mean", alpha=0.7)
    ax.set_xlabel("generation")
    ax.set_ylabel(ylabel)
    ax.set_title(title)
    ax.legend(loc="lower right")
    ax.grid(alpha=0.3)
    return _save(fig, path, plot)


def plot_workspace(mech: Mechanism, orientation: tuple[float, float], min_ic: float, length: float | None,
                   directory: Path, what: str, plot=None) -> list[Path]:
    """``workspace.png`` and ``inverse_condition.png`` of one design on its plot slice."""
    fixed, (i, j), _ = mech.plot_slice(orientation)
    label = ", ".join(f"{symbol(n)} = {np.degrees(v):.1f}°" if mech.angular[mech.pose_names.index(n)]
                      else f"{symbol(n)} = {v:.4g} {mech.length_unit}" for n, v in fixed.items())
    ev = evaluate(mech, orientation=orientation, min_inverse_condition=min_ic, length=length, fixed=fixed,
                  resolution=SLICE_RESOLUTION, return_samples=True, error_estimate=False)
    pts, inside = ev.samples, ev.inside
    names = mech.pose_names
    axis_label = [f"{symbol(n)} [{'rad' if mech.angular[k] else mech.length_unit}]" for k, n in enumerate(names)]
    cell = [(pts[:, k].max() - pts[:, k].min()) / max(SLICE_RESOLUTION - 1, 1) for k in (i, j)]
    out = []
    panels = [("workspace", None), ("inverse_condition", ev.inverse_conditions)]
    for name, values in panels:
        fig, (ax,) = _figure(6, 5)
        if name == "workspace" and ev.extent is not None:
            values = np.where(inside, ev.extent[:, 1] - ev.extent[:, 0], np.nan)
            bar = f"{symbol(names[2])} extent [{mech.length_unit}]" if len(names) > 2 else "extent"
            cmap = "viridis"
        elif name == "workspace":
            values = np.where(inside, 1.0, np.nan)
            bar, cmap = None, ListedColormap(["tab:blue"])
        else:
            values = np.where(inside, values, np.nan)
            bar, cmap = "1/κ", "magma"
        # one rectangle per grid cell: visible at any resolution and any axis scale
        mesh = _cells(ax, pts[:, i], pts[:, j], values, cell, cmap, vmin=0 if name != "workspace" else None)
        if bar:
            fig.colorbar(mesh, ax=ax, label=bar)
        ax.set_xlabel(axis_label[i])
        ax.set_ylabel(axis_label[j])
        kind = "workspace" if name == "workspace" else "1/κ"
        ax.set_title(f"{kind}, {what}" + (f"\n{label}" if label else "")
                     + (f"; V = {ev.volume:.4g} {ev.volume_unit}" if name == "workspace" else ""))
        if mech.angular[i] == mech.angular[j]:
            ax.set_aspect("equal")
        out.append(_save(fig, Path(directory) / f"{name}.png", plot))
    return out


def _cells(ax, x: np.ndarray, y: np.ndarray, values: np.ndarray, cell: list[float], cmap: str, vmin=None):
    """Regular grid samples as a pcolormesh (NaN transparent)."""
    xs, ys = np.unique(np.round(x, 12)), np.unique(np.round(y, 12))
    grid = np.full((ys.size, xs.size), np.nan)
    grid[np.searchsorted(ys, np.round(y, 12)), np.searchsorted(xs, np.round(x, 12))] = values
    return ax.pcolormesh(xs, ys, np.ma.masked_invalid(grid), cmap=cmap, vmin=vmin, shading="nearest")


def plot_front(front: pd.DataFrame, objectives: list[str], path: Path, what: str, plot=None) -> Path:
    """The non-dominated designs of a Pareto optimiser in the plane of its two objectives."""
    fig, (ax,) = _figure(6, 4.5)
    a, b = objectives
    order = np.argsort(front[a].to_numpy())
    ax.plot(front[a].to_numpy()[order], front[b].to_numpy()[order], "o-", ms=4)
    ax.set_xlabel(f"{symbol(a)} [1]" if a != "volume" else "V")
    ax.set_ylabel(f"{symbol(b)} [1]" if b != "volume" else "V")
    ax.set_title(f"Pareto front, {what}")
    ax.grid(alpha=0.3)
    return _save(fig, path, plot)


def plot_tradeoff(best: pd.DataFrame, path: Path, plot=None) -> Path:
    """GDI, SURI and η of the mixed-index optima versus w_d, one panel per mechanism (seed 000 Fig. 8).

    Runs with the same (mechanism, w_d) (seeds, repeats) are drawn as the mean
    with a band from their minimum to maximum.
    """
    mixed = best[best["objective"].astype(str) == "mixed"]
    mechanisms = sorted(mixed["mechanism"].astype(str).unique()) or ["none"]
    fig, axes = _figure(4.5 * len(mechanisms), 3.8, len(mechanisms))
    for ax, name in zip(axes, mechanisms):
        part = mixed[mixed["mechanism"].astype(str) == name]
        stats = part.groupby("w_d")[["gdi", "suri", "objective_value"]].agg(["mean", "min", "max"])
        for column, label, style in (("gdi", "GDI", "o-"), ("suri", "SURI", "s-"),
                                     ("objective_value", "η", "^-")):
            if len(stats):
                w = stats.index.to_numpy()
                ax.plot(w, stats[(column, "mean")], style, label=label, ms=4)
                ax.fill_between(w, stats[(column, "min")], stats[(column, "max")], alpha=0.2)
        n_runs = part.groupby("w_d").size()
        ax.set_xlabel("$w_d$ [1]")
        ax.set_ylabel("index [1]")
        ax.grid(alpha=0.3)
        if len(stats):
            ax.set_title(f"{name}: optima vs $w_d$ (runs per point: {n_runs.max()})")
            ax.legend(loc="best")
        else:  # a sweep of V or GDI alone: say so rather than draw an empty legend
            ax.set_title("the mixed index η versus $w_d$")
            ax.text(0.5, 0.5, "no mixed-index runs in this sweep", ha="center", va="center",
                    transform=ax.transAxes)
    return _save(fig, path, plot)
