"""Stage 5, plot: matplotlib (Agg) PNG figures of a run and of a w_d sweep.

* ``convergence.png``: best and mean fitness per generation (seed 000 Fig. 7);
* ``workspace.png``: a 2-D map of the workspace (seed 000 Fig. 5: H4 at
  theta = 0, coloured by the height of the workspace column; the planar
  mechanisms at constant orientation as in seed 003 Fig. 8-11 and seed 004;
  the Tricept's (psi, theta) slice at one c as in seed 001 Fig. 3);
* ``inverse_condition.png``: 1/kappa on the same slice (seed 000 Fig. 6; for
  H4 1/kappa does not depend on z, so the map holds for every z);
* ``tradeoff.png`` (sweeps): GDI, SURI and eta versus w_d (seed 000 Fig. 8).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pandas as pd  # noqa: E402

from kinematics.base import Mechanism  # noqa: E402
from kinematics.workspace import Evaluation, evaluate  # noqa: E402

_UNITS = {"h4": "cm", "tricept": "mm", "rpr3": "mm", "rpr2": "mm"}


def _save(fig, path: Path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp.png")
    fig.savefig(tmp, dpi=110, bbox_inches="tight")
    plt.close(fig)
    tmp.replace(path)
    return path


def plot_convergence(history: pd.DataFrame, path: Path, title: str = "") -> Path:
    """Best and mean fitness per generation (seed 000 Fig. 7)."""
    fig, ax = plt.subplots(figsize=(6, 4))
    ax.plot(history["generation"], history["best"], label="best")
    ax.plot(history["generation"], history["mean"], label="mean", alpha=0.7)
    ax.set_xlabel("generation")
    ax.set_ylabel("fitness")
    ax.set_title(title or "GA convergence")
    ax.legend()
    ax.grid(alpha=0.3)
    return _save(fig, path)


def workspace_slice(mech: Mechanism, orientation: tuple[float, float], min_ic: float,
                    resolution: int = 120) -> tuple[Evaluation, tuple[int, int], str]:
    """A 2-D slice of the workspace and the indices of its two plotted pose variables.

    H4: theta fixed at the middle of the range (0 for a symmetric range);
    3-RPR: phi at the middle of its range; 2-RPR: the plane; Tricept: the
    (psi, theta) plane at the c with the most workspace.
    """
    mid = 0.5 * (orientation[0] + orientation[1])
    name = mech.name
    if name == "tricept":
        coarse = evaluate(mech, orientation=orientation, min_inverse_condition=min_ic,
                          resolution=16, return_samples=True, error_estimate=False)
        c_levels = coarse.samples[coarse.inside, 0]
        lo, hi = mech.pose_bounds(orientation)
        c_best = float(np.median(c_levels)) if c_levels.size else 0.5 * float(lo[0] + hi[0])
        ev = evaluate(mech, orientation=orientation, min_inverse_condition=min_ic, fixed={"c": c_best},
                      resolution=resolution, return_samples=True, error_estimate=False)
        return ev, (1, 2), f"c = {c_best:.0f} mm"
    if name == "rpr2":
        ev = evaluate(mech, min_inverse_condition=min_ic, resolution=resolution * 2,
                      return_samples=True, error_estimate=False)
        return ev, (0, 1), ""
    ev = evaluate(mech, orientation=(mid, mid), min_inverse_condition=min_ic,
                  resolution=resolution, return_samples=True, error_estimate=False)
    angle = mech.pose_names[-1]
    return ev, (0, 1), f"{angle} = {np.degrees(mid):.1f} deg"


def plot_workspace(mech: Mechanism, orientation: tuple[float, float], min_ic: float,
                   directory: Path, title: str = "") -> list[Path]:
    """``workspace.png`` and ``inverse_condition.png`` of one design."""
    ev, (i, j), label = workspace_slice(mech, orientation, min_ic)
    pts = ev.samples
    names = mech.pose_names
    unit = _UNITS.get(mech.name, "")
    axis_label = [f"{n} [{'rad' if mech.angular[k] else unit}]" for k, n in enumerate(names)]
    out = []
    fig, ax = plt.subplots(figsize=(6, 5))
    inside = ev.inside
    if ev.extent is not None:  # H4: colour by the height of the workspace column
        height = np.where(inside, ev.extent[:, 1] - ev.extent[:, 0], np.nan)
        sc = ax.scatter(pts[:, i], pts[:, j], c=height, s=6, marker="s", cmap="viridis")
        fig.colorbar(sc, ax=ax, label=f"z extent [{unit}]")
    else:
        ax.scatter(pts[~inside, i], pts[~inside, j], s=2, c="0.9", marker="s")
        ax.scatter(pts[inside, i], pts[inside, j], s=4, c="tab:blue", marker="s")
    ax.set_xlabel(axis_label[i])
    ax.set_ylabel(axis_label[j])
    ax.set_title(f"{title} workspace {label}\narea {ev.volume:.4g} {ev.volume_unit}".strip())
    ax.set_aspect("equal" if mech.angular[i] == mech.angular[j] else "auto")
    out.append(_save(fig, Path(directory) / "workspace.png"))

    fig, ax = plt.subplots(figsize=(6, 5))
    ic = np.where(inside, ev.inverse_conditions, np.nan)
    sc = ax.scatter(pts[:, i], pts[:, j], c=ic, s=6, marker="s", cmap="magma", vmin=0)
    fig.colorbar(sc, ax=ax, label="1/kappa")
    ax.set_xlabel(axis_label[i])
    ax.set_ylabel(axis_label[j])
    ax.set_title(f"{title} 1/kappa {label}".strip())
    ax.set_aspect("equal" if mech.angular[i] == mech.angular[j] else "auto")
    out.append(_save(fig, Path(directory) / "inverse_condition.png"))
    return out


def plot_tradeoff(best: pd.DataFrame, path: Path) -> Path:
    """GDI, SURI and eta of the optima versus w_d, one panel per mechanism (seed 000 Fig. 8)."""
    mixed = best[best["objective"].astype(str) == "mixed"].copy()
    mechanisms = sorted(mixed["mechanism"].astype(str).unique()) or ["(none)"]
    fig, axes = plt.subplots(1, len(mechanisms), figsize=(5 * len(mechanisms), 4), squeeze=False)
    for ax, name in zip(axes[0], mechanisms):
        part = mixed[mixed["mechanism"].astype(str) == name].sort_values("w_d")
        for column, style in (("gdi", "o-"), ("suri", "s-"), ("eta", "^-")):
            if len(part):
                ax.plot(part["w_d"], part[column], style, label=column.upper() if column != "eta" else "eta")
        ax.set_xlabel("w_d")
        ax.set_title(name)
        ax.grid(alpha=0.3)
        ax.legend()
    return _save(fig, path)
