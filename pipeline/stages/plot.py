"""Stage 5, plot: figures of a run and of a sweep (PNG, optionally PDF or SVG).

* ``convergence.png``: best and mean objective per generation (seed 000 Fig. 7);
* ``workspace.png``: the mechanism's plot slice (``Mechanism.plot_slice``),
  coloured by the height of the exactly integrated axis where there is one
  (H4: z extent, seed 000 Fig. 5);
* ``inverse_condition.png``: 1/κ on the same slice (seed 000 Fig. 6);
* ``pareto.png``: the non-dominated designs of a Pareto optimiser;
* ``tradeoff.png`` (sweeps): GDI, SURI and η of the optima versus w_d, one
  line per (optimiser, experiment), mean and range over its seeds (seed 000 Fig. 8).

The workspace slices (sampling and drawing) are :mod:`pipeline.stages.slices`.
Figures are built on :class:`matplotlib.figure.Figure` with an Agg canvas,
never through pyplot's global state, so importing this module does not
change the backend of a notebook.
"""

from __future__ import annotations

import tempfile
import textwrap
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D

from kinematics.base import Mechanism
from pipeline.stages.slices import draw_slice, symbol, workspace_slice


def _figure(width: float, height: float, ncols: int = 1) -> tuple[Figure, np.ndarray]:
    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(1, ncols, squeeze=False)[0])
    return fig, axes


def fit_title(text: str, width: float, fontsize: float) -> str:
    """``text`` wrapped to fit ``width`` inches at ``fontsize`` points: a too long title is cut
    off at the figure's edges or runs under its colour bar (a Gough-Stewart slice names six
    pose variables). Breaks at "; " first, then between words; kept lines stay whole."""
    chars = max(int(width * 72 / (0.6 * fontsize)), 16)  # a character is about 0.6 em wide
    lines = []
    for line in text.split("\n"):
        parts = line.split("; ") if len(line) > chars else [line]
        for k, part in enumerate(parts):
            part = part + (";" if k < len(parts) - 1 else "")
            lines.extend(_balanced_wrap(part, chars))
    return "\n".join(lines)


def _balanced_wrap(text: str, chars: int) -> list[str]:
    """``text`` in as few lines of at most ``chars`` characters as it needs, of even lengths
    (no line of one word left over)."""
    lines = textwrap.wrap(text, chars, break_on_hyphens=False, break_long_words=False) or [""]
    for width in range(-(-len(text) // len(lines)), chars):
        even = textwrap.wrap(text, width, break_on_hyphens=False, break_long_words=False)
        if len(even) == len(lines):
            return even
    return lines


def set_title(ax, text: str, fontsize: float = 10, width: float | None = None) -> None:
    """The axes' title, wrapped (:func:`fit_title`) to ``width`` inches (default 0.7 of the
    figure's width: the rest holds labels, ticks and a colour bar)."""
    width = 0.7 * ax.figure.get_figwidth() if width is None else width
    ax.set_title(fit_title(text, width, fontsize), fontsize=fontsize)


def panel_grid(n_panels: int, width: float, height: float, max_columns: int = 3) -> tuple[Figure, np.ndarray]:
    """A figure of ``n_panels`` panels (each ``width`` x ``height`` inches) in rows of at most
    ``max_columns``: a row of seven panels shrunk to a page's width cannot be read. Returns the
    figure and the used axes (flat, row by row); the grid's unused cells are hidden."""
    n_panels = max(int(n_panels), 1)
    ncols = min(n_panels, max_columns)
    nrows = -(-n_panels // ncols)
    fig = Figure(figsize=(width * ncols, height * nrows), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, squeeze=False).ravel()
    for ax in axes[n_panels:]:
        ax.set_axis_off()
    return fig, axes[:n_panels]


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


#: how the figures of debug runs (``+debug`` presets: tiny sizes) say what they are: a run's
#: titles start with the first, a trade-off of such runs with the second
DEBUG_MARK = "DEBUG run, not a result"
DEBUG_RUNS_MARK = "DEBUG runs (+debug), not results"


def run_figures(mechanism, objective, optimizer, plot, optimum: dict, purpose: str = "study") -> dict[str, bytes]:
    """The figures of one run, as file name -> content: convergence, workspace and 1/κ slices of
    the optimum, and the Pareto front of a multi-objective optimiser. A debug run's titles start
    with :data:`DEBUG_MARK` (``purpose``: the config's).

    Drawn in a temporary folder and returned as bytes so that the pipeline can
    cache this stage like the others (a second identical run draws nothing).
    ``mechanism``, ``objective``, ``optimizer`` and ``plot`` are the run's
    config sections (``pipeline.config``); ``optimum`` the optimise stage's result.
    """
    best = optimum["best"]
    design = [best[n] for n in mechanism.design.names]
    mech = mechanism.build(design)
    orientation = mechanism.orientation_rad() or mech.default_orientation
    what = f"{mech.name}, {objective.name}" + (f", w_d = {objective.w_d:g}" if objective.name == "mixed" else "")
    what += f", seed {optimizer.seed}"
    if purpose == "debug":
        what = f"{DEBUG_MARK}: {what}"
    unit = best["objective_unit"]
    design_volume = f"design's V = {best['volume']:.6g} {best['volume_unit']}"
    with tempfile.TemporaryDirectory() as tmp:
        directory = Path(tmp)
        plot_convergence(
            optimum["history"],
            directory / "convergence.png",
            f"{optimizer.name} convergence ({what})",
            f"{symbol(objective.name)} [{unit}]",
            plot,
            reference=best.get("reference_value"),
            optimum=best.get("objective_value"),
            found_by=str(best.get("found_by", "")),
            gap=str(best.get("reference_gap_label", "")),
        )
        plot_workspace(
            mech,
            orientation,
            mechanism.min_inverse_condition,
            mechanism.length,
            directory,
            what,
            plot,
            design_volume=design_volume,
        )
        if optimum["front"] is not None:
            units = {"volume": best["volume_unit"]}
            plot_front(optimum["front"], list(optimizer.objectives), directory / "pareto.png", what, plot, units)
        return {p.name: p.read_bytes() for p in sorted(directory.iterdir()) if not p.name.startswith(".")}


def plot_convergence(
    history: pd.DataFrame,
    path: Path,
    title: str,
    ylabel: str,
    plot=None,
    reference: float | None = None,
    optimum: float | None = None,
    found_by: str = "",
    gap: str = "",
) -> Path:
    """Best so far, best and mean objective per generation (seed 000 Fig. 7), with the reference optimum.

    ``optimum`` (the objective's unit): the run's reported optimum; where it is better than
    the history's best (the polish step after the last generation) it is drawn as a marker
    after the last generation, labelled by ``found_by``. ``reference``: the reference optimum
    (the best of several searches, :mod:`pipeline.stages.optimise`), drawn as a horizontal
    line labelled with ``gap``, the run's gap as recorded (``reference_gap_label``: "within
    error" where the gap is below its error, never a percentage finer than the objective);
    None or NaN: not run.
    """
    fig, (ax,) = _figure(6, 4)
    # best so far (objectives are maximised): a restart of IPOP-CMA-ES lowers the generation's
    # best without losing the run's
    so_far = history["best"].cummax()
    ax.plot(history["generation"], so_far, label="best so far")
    ax.plot(history["generation"], history["best"], label="best of the generation", lw=0.8, alpha=0.6)
    ax.plot(history["generation"], history["mean"], label="population mean", alpha=0.7)
    final = float(so_far.iloc[-1])
    if optimum is not None and np.isfinite(optimum) and optimum > final:
        last = float(history["generation"].iloc[-1])
        step = "after polish" if found_by == "polish" else f"reported ({found_by})" if found_by else "reported"
        ax.plot([last, last + 0.5], [final, optimum], ":", color="C0", lw=1)
        ax.plot([last + 0.5], [optimum], "*", color="C3", ms=11, label=f"{step}: {optimum:.6g}")
    if reference is not None and np.isfinite(reference):
        label = f"reference optimum {reference:.6g}" + (f" (gap {gap})" if gap else "")
        ax.axhline(reference, color="k", ls="--", lw=1, label=label)
    ax.set_xlabel("generation [1]")
    ax.set_ylabel(ylabel)
    set_title(ax, title, 11, width=0.85 * fig.get_figwidth())
    ax.legend(loc="lower right", fontsize=8)
    ax.grid(alpha=0.3)
    return _save(fig, path, plot)


def plot_workspace(
    mech: Mechanism,
    orientation: tuple[float, float],
    min_ic: float,
    length: float | None,
    directory: Path,
    what: str,
    plot=None,
    design_volume: str = "",
) -> list[Path]:
    """``workspace.png`` and ``inverse_condition.png`` of one design on its plot slice.

    The title names the slice (the fixed pose variables) and, when given,
    ``design_volume``: the design's workspace volume over the whole pose space
    (e.g. "design's V = 1.457e+05 cm³·rad"); the slice's own area is not the design's V.
    """
    data = workspace_slice(mech, orientation, min_ic, length)
    out = []
    for name in ("workspace", "inverse_condition"):
        fig, (ax,) = _figure(6, 5)
        draw_slice(fig, ax, data, name)
        kind = "workspace" if name == "workspace" else "1/κ"
        where = f"slice {data.fixed_label}" if data.fixed_label else "whole workspace"
        set_title(ax, f"{kind}, {what}\n{where}" + (f"; {design_volume}" if design_volume else ""), 10)
        out.append(_save(fig, Path(directory) / f"{name}.png", plot))
    return out


def plot_front(
    front: pd.DataFrame, objectives: list[str], path: Path, what: str, plot=None, units: dict[str, str] | None = None
) -> Path:
    """The non-dominated designs of a Pareto optimiser in the plane of its two objectives
    (``units``: unit of an objective other than "1", e.g. ``{"volume": "cm³·rad"}``)."""
    units = units or {}
    fig, (ax,) = _figure(6, 4.5)
    a, b = objectives
    order = np.argsort(front[a].to_numpy())
    ax.plot(front[a].to_numpy()[order], front[b].to_numpy()[order], "o-", ms=4)
    ax.set_xlabel(f"{symbol(a)} [{units.get(a, '1')}]")
    ax.set_ylabel(f"{symbol(b)} [{units.get(b, '1')}]")
    set_title(ax, f"Pareto front of {symbol(a)} and {symbol(b)}, {what}", 11, width=0.85 * fig.get_figwidth())
    ax.grid(alpha=0.3)
    return _save(fig, path, plot)


def debug_rows(frame: pd.DataFrame) -> pd.Series:
    """Which rows are debug runs (``purpose``; none where the table has no such column)."""
    if "purpose" not in frame:
        return pd.Series(False, index=frame.index)
    return frame["purpose"].astype(str) == "debug"


def with_study(best: pd.DataFrame) -> pd.DataFrame:
    """``best`` with a ``study_hash`` column ("" where the dataset predates it or a row has none):
    the key that keeps apart studies run under one experiment name with different overrides."""
    study = best["study_hash"] if "study_hash" in best.columns else pd.Series("", index=best.index)
    return best.assign(study_hash=study.fillna("").astype(str))


def distinct_seeds(best: pd.DataFrame, keys: list[str]) -> pd.DataFrame:
    """One row per run config: repeats (the same study and seed run again, equal ``config_hash``,
    which give the same result) are counted once, so statistics are over distinct seeds only.
    Rows of a table without ``config_hash``: one per (``keys``, seed)."""
    if "config_hash" in best.columns:
        return best.drop_duplicates("config_hash", keep="first")
    if "seed" not in best.columns:
        return best
    return best.drop_duplicates([*keys, "seed"], keep="first")


def study_labels(keys: list[tuple]) -> list[str]:
    """Legend labels of groups keyed ``(..., study_hash)``: the other keys joined by " / ", and the
    study's first 6 hex digits where two groups would otherwise read the same."""
    plain = [" / ".join(str(k) for k in key[:-1] if str(k)) or "runs" for key in keys]
    return [
        f"{label} [{key[-1][:6]}]" if plain.count(label) > 1 and key[-1] else label for label, key in zip(plain, keys)
    ]


def tradeoff_lines(best: pd.DataFrame) -> tuple[pd.DataFrame, list[str]]:
    """The mixed-index rows of ``best`` (with ``study_hash``, :func:`with_study`) and the keys of
    the trade-off's lines within a mechanism: optimiser and experiment where the table has them,
    then ``study_hash`` (a dataset from before study_hash existed still keeps optimisers and
    experiments apart)."""
    mixed = with_study(best[best["objective"].astype(str) == "mixed"])
    return mixed, [k for k in ("optimizer", "experiment") if k in mixed.columns] + ["study_hash"]


def beaten_optima(best: pd.DataFrame) -> pd.DataFrame:
    """Mixed-index optima that another run's design of the same study beats at their own w_d.

    eta = w_d GDI + (1 - w_d) SURI is linear in w_d for a fixed design, so every optimum of a
    sweep (mechanism, optimiser, experiment and ``study_hash``, the trade-off's lines: the same
    evaluation settings, other w_d and seeds) can be
    scored at every other run's w_d from its stored GDI and SURI, with no evaluation. An optimum
    below the best of those by more than the larger of the two runs' ``objective_error`` (their
    discretisation errors; 0 where absent) stopped short of a design the sweep itself found: a
    local optimum (another basin), which a trade-off curve would show as a dip.

    Returns
    -------
    DataFrame
        One row per beaten optimum: ``mechanism``, ``study_hash``, ``w_d``, ``seed``, ``run_id``,
        ``objective_value``, ``objective_error``, the beating design's ``other_w_d`` and
        ``other_seed``, its eta at this run's w_d ``other_value``, and ``gap`` (other_value /
        objective_value - 1). Empty where nothing is beaten.
    """
    columns = [
        "mechanism",
        "study_hash",
        "w_d",
        "seed",
        "run_id",
        "objective_value",
        "objective_error",
        "other_w_d",
        "other_seed",
        "other_value",
        "gap",
    ]
    needed = {"objective", "mechanism", "w_d", "gdi", "suri", "objective_value"}
    if not needed <= set(best.columns):
        return pd.DataFrame(columns=columns)
    mixed, line_keys = tradeoff_lines(best)
    keys = ["mechanism", *line_keys]
    rows = []
    for key, group in mixed.groupby(keys, sort=True):
        mechanism, study = key[0], key[-1]
        if group["w_d"].nunique() < 2:
            continue
        w = group["w_d"].to_numpy(dtype=float)
        gdi, suri = group["gdi"].to_numpy(dtype=float), group["suri"].to_numpy(dtype=float)
        value = group["objective_value"].to_numpy(dtype=float)
        error = (
            group["objective_error"].fillna(0.0).to_numpy(dtype=float)
            if "objective_error" in group
            else np.zeros(len(group))
        )
        scored = w[:, None] * gdi[None, :] + (1.0 - w[:, None]) * suri[None, :]  # run i's w_d, run j's design
        other = np.argmax(scored, axis=1)
        for i, j in enumerate(other):
            margin = scored[i, j] - value[i]
            if margin > max(error[i], error[j]) and margin > 1e-12 * abs(value[i]):
                row = group.iloc[i]
                rows.append(
                    [
                        mechanism,
                        study,
                        float(w[i]),
                        row.get("seed"),
                        row.get("run_id"),
                        float(value[i]),
                        float(error[i]),
                        float(w[j]),
                        group.iloc[j].get("seed"),
                        float(scored[i, j]),
                        float(scored[i, j] / value[i] - 1.0),
                    ]
                )
    return pd.DataFrame(rows, columns=columns)


#: what the trade-off draws per line group: column, label, marker and line style
TRADEOFF_QUANTITIES = (("gdi", "GDI", "o", "-"), ("suri", "SURI", "s", "--"), ("objective_value", "η", "^", ":"))


def plot_tradeoff(best: pd.DataFrame, path: Path, plot=None) -> Path:
    """GDI, SURI and η of the mixed-index optima versus w_d, one panel per mechanism (seed 000 Fig. 8).

    One colour per group of comparable runs, (optimiser, experiment, study): a GA at w_d = 0.5 and
    a CMA-ES at w_d = 0.8 are different studies, never one line, and never each other's
    seeds; nor is an experiment run with an override (another orientation, another resolution):
    ``study_hash`` differs, and its line's label carries the hash's first digits
    (:func:`study_labels`). Within a group, runs with the same w_d and different seeds are drawn as the mean
    with a band from their minimum to maximum; repeats of one seed count once
    (:func:`distinct_seeds`); η carries error bars, its estimated discretisation error
    (``objective_error``, the largest over the seeds). Panels in rows of at most three (:func:`panel_grid`).
    """
    mixed, group_keys = tradeoff_lines(best)
    keys = [k for k in ("mechanism", *group_keys, "w_d") if k in mixed.columns]
    mixed = distinct_seeds(mixed, keys)
    mechanisms = sorted(mixed["mechanism"].astype(str).unique()) or ["none"]
    fig, axes = panel_grid(len(mechanisms), 4.8, 3.9)  # titles wrapped to 4 of a panel's 4.8 in
    for ax, name in zip(axes, mechanisms):
        part = mixed[mixed["mechanism"].astype(str) == name]
        groups = [
            (key if isinstance(key, tuple) else (key,), frame) for key, frame in part.groupby(group_keys, sort=True)
        ]
        labels = study_labels([key for key, _ in groups])
        handles, most_seeds = [], 0
        beaten = beaten_optima(part)
        if len(beaten):  # a run that stopped short of a design its own sweep found (another basin)
            ax.plot(beaten["w_d"], beaten["objective_value"], "o", ms=11, mfc="none", mec="red", mew=1.5, zorder=5)
            handles.append(
                Line2D([], [], marker="o", ms=9, mfc="none", mec="red", ls="", label="η beaten by another w_d's design")
            )
        for number, ((_, frame), label) in enumerate(zip(groups, labels)):
            colour = f"C{number % 10}"
            stats = frame.groupby("w_d")[["gdi", "suri", "objective_value"]].agg(["mean", "min", "max"])
            w = stats.index.to_numpy()
            for column, _, marker, style in TRADEOFF_QUANTITIES:
                ax.plot(w, stats[(column, "mean")], marker=marker, ls=style, color=colour, ms=4)
                ax.fill_between(w, stats[(column, "min")], stats[(column, "max")], color=colour, alpha=0.15)
            if "objective_error" in frame:  # η's estimated discretisation error, the largest of the seeds
                error = frame.groupby("w_d")["objective_error"].max().reindex(stats.index)
                ax.errorbar(
                    w,
                    stats[("objective_value", "mean")],
                    yerr=error.to_numpy(),
                    fmt="none",
                    ecolor=colour,
                    capsize=3,
                    lw=1,
                )
            seeds = int(frame.groupby("w_d").size().max())
            most_seeds = max(most_seeds, seeds)
            handles.append(
                Line2D([], [], color=colour, lw=6, alpha=0.6, label=f"{label} ({seeds} seed{'s' * (seeds > 1)})")
            )
        ax.set_xlabel("$w_d$ [1]")
        ax.set_ylabel("GDI, SURI, η [1]")
        ax.grid(alpha=0.3)
        if len(part):
            spread = "mean and range over the seeds of each line" if most_seeds > 1 else "one seed per point"
            spread += "; bars: η's error"
            title = f"{name}: GDI, SURI, η of the optima vs $w_d$\n({spread})"
            set_title(ax, f"{DEBUG_RUNS_MARK}\n{title}" if debug_rows(part).any() else title, 10, width=4.0)
            styles = [
                Line2D([], [], color="0.3", marker=marker, ls=style, ms=4, label=label)
                for _, label, marker, style in TRADEOFF_QUANTITIES
            ]
            ax.legend(handles=styles + handles, loc="best", fontsize=7)
        else:  # a sweep of V or GDI alone: say so rather than draw an empty legend
            ax.set_title("the mixed index η versus $w_d$")
            ax.text(0.5, 0.5, "no mixed-index runs in this sweep", ha="center", va="center", transform=ax.transAxes)
    return _save(fig, path, plot)
