"""The report's figures: convergence per group of runs, and workspace galleries on one colour scale.

Each returns a PNG as base64 text (embedded in ``report.html``). Groups of runs
are (mechanism, objective, w_d, optimizer, experiment); statistics run over *distinct seeds*
(:func:`pipeline.stages.plot.distinct_seeds`): a study run again with the same
seed is a repeat, not a new sample.
"""

from __future__ import annotations

import base64
import io
import logging

import numpy as np
import pandas as pd

from pipeline.config import DesignSpace, MechanismConfig
from pipeline.stages.optimise import group_gap_label
from pipeline.stages.plot import distinct_seeds, fit_title, panel_grid, set_title, study_labels, with_study
from pipeline.stages.slices import draw_slice, symbol, workspace_slice

log = logging.getLogger(__name__)

#: what makes runs one group (their seeds are samples of one study); "experiment" where recorded;
#: ``study_hash`` keeps apart runs of one experiment name with different overrides (filled by
#: :func:`pipeline.stages.plot.with_study`, "" for datasets that predate it)
GROUP_KEYS = ["mechanism", "objective", "w_d", "optimizer", "experiment", "study_hash"]


def group_keys(frame: pd.DataFrame) -> list[str]:
    """The :data:`GROUP_KEYS` that ``frame`` has (older tables have no "experiment")."""
    return [k for k in GROUP_KEYS if k in frame.columns]


def png(fig) -> str:
    """A figure as base64 PNG text."""
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    return base64.b64encode(buffer.getvalue()).decode()


def caption(row: pd.Series) -> str:
    """What a run is, in words: mechanism, objective (w_d), optimiser, seed."""
    what = f"{row['mechanism']}, {row['objective']}"
    if str(row["objective"]) == "mixed":
        what += f", w_d = {float(row['w_d']):g}"
    return f"{what}, {row['optimizer']}, seed {int(row['seed'])}"


def in_panel(frame: pd.DataFrame, objective: str, mechanism: str) -> pd.Series:
    """The rows of ``frame`` that one (objective, mechanism) panel of :func:`convergence_figure` shows."""
    return (frame["objective"].astype(str) == objective) & (frame["mechanism"].astype(str) == mechanism)


def convergence_figure(best: pd.DataFrame, history: pd.DataFrame) -> str:
    """Best objective so far against the generation, one panel per (objective, mechanism) and one
    line per group: mean and range over distinct seeds, the group's reported optimum where it
    beats the last generation (a star "after polish": the polish step follows the generations),
    with the group's reference optimum (dashed, where one was run) and the runs' recorded gap
    (:func:`pipeline.stages.optimise.group_gap_label`: "within error" below its error bar). Best so far, not best per
    generation: a restarting optimiser (IPOP-CMA-ES) starts each restart from a wide population,
    whose best drops without anything being lost. One panel per mechanism because the objective's
    scale differs between mechanisms (η of a 2-RPR near 0.8, of an H4 near 0.2)."""
    best = with_study(best)
    keys = group_keys(best)
    runs = distinct_seeds(best, keys)
    groups = runs[["run_id", *keys]].merge(history[["run_id", "generation", "best"]], on="run_id")
    # every objective is maximised (pipeline.objectives)
    groups["best"] = groups.sort_values("generation").groupby("run_id")["best"].cummax()
    panels = sorted({(str(o), str(m)) for o, m in zip(groups["objective"], groups["mechanism"])})
    fig, axes = panel_grid(len(panels), 5.0, 3.8)
    for ax, (objective, mechanism) in zip(axes, panels):
        part = groups[in_panel(groups, objective, mechanism)]
        references_drawn = False
        panel_groups = [(dict(zip(keys, key)), frame) for key, frame in part.groupby(keys, sort=True)]
        names = study_labels(
            [
                (
                    " / ".join(str(group[k]) for k in ("optimizer", "experiment") if str(group.get(k, "")))
                    + (f", w_d={group['w_d']:g}" if objective == "mixed" else ""),
                    group["study_hash"],
                )
                for group, _ in panel_groups
            ]
        )
        for (_, frame), name in zip(panel_groups, names):
            stats = frame.groupby("generation")["best"].agg(["mean", "min", "max"])
            n_seeds = frame["run_id"].nunique()
            label = f"{name} ({n_seeds} seed{'s' if n_seeds > 1 else ''})"
            (line,) = ax.plot(stats.index, stats["mean"], label=label)
            ax.fill_between(stats.index, stats["min"], stats["max"], alpha=0.2, color=line.get_color())
            members = runs[runs["run_id"].isin(frame["run_id"].unique())]
            final = float(stats["mean"].iloc[-1])
            reported = float(members["objective_value"].mean()) if "objective_value" in members else np.nan
            if np.isfinite(reported) and reported > final:  # the polish step after the last generation
                polished = "found_by" in members and (members["found_by"].astype(str) == "polish").any()
                last = float(stats.index[-1])
                ax.plot([last, last + 0.5], [final, reported], ":", lw=1, color=line.get_color())
                ax.plot(
                    [last + 0.5],
                    [reported],
                    "*",
                    ms=10,
                    color=line.get_color(),
                    label=f"{'after polish' if polished else 'reported'}: {reported:.4g}"
                    + (" (mean)" if n_seeds > 1 else ""),
                )
            ref = (
                runs.loc[runs["run_id"].isin(frame["run_id"].unique()), "reference_value"]
                if "reference_value" in runs
                else pd.Series(dtype=float)
            )
            ref = ref.dropna()
            if len(ref):
                references_drawn = True
                reference = float(ref.max())
                # the gap as recorded per run (within error where it is below its error bar)
                gap = group_gap_label(members)
                ax.axhline(
                    reference,
                    ls="--",
                    lw=1,
                    color=line.get_color(),
                    # as many digits as the optima table gives a run's value
                    label=f"reference {reference:.6g}" + (f" (gap {gap})" if gap else ""),
                )
        ax.set_xlabel("generation [1]")
        # the panel's own unit: one objective has a unit per mechanism (V of a Tricept in mm·rad²)
        unit = best.loc[in_panel(best, objective, mechanism), "objective_unit"].iloc[0]
        ax.set_ylabel(f"{symbol(objective)} [{unit}]")
        set_title(
            ax,
            f"{mechanism}: convergence of {symbol(objective)}, best so far\n"
            f"(mean and range over distinct seeds{', dashed: reference' if references_drawn else ''})",
            9,
            width=4.3,
        )
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="best")
    return png(fig)


def _mechanism_config(config: dict) -> MechanismConfig:
    m = dict(config["mechanism"])
    m["design"] = DesignSpace(**m["design"])
    return MechanismConfig(**m)


def workspace_gallery(rows: pd.DataFrame, configs: dict[str, dict], kind: str, columns: int = 3) -> str:
    """The plot slices of ``rows`` (one mechanism; best first) side by side on ONE colour scale.

    ``kind``: "workspace" (H4: z extent) or "inverse_condition" (1/κ from 0);
    ``configs``: each run's resolved config (its manifest), by run id.
    """
    slices, titles = [], []
    for _, row in rows.iterrows():
        config = configs.get(row["run_id"])
        if config is None:
            continue
        mc = _mechanism_config(config)
        mech = mc.build([row[n] for n in mc.design.names])
        slices.append(
            workspace_slice(mech, mc.orientation_rad() or mech.default_orientation, mc.min_inverse_condition, mc.length)
        )
        titles.append(f"{caption(row)}\n{symbol(str(row['objective']))} = {row['objective_value']:.4g}")
    if not slices:
        return ""
    values = [s.inverse_condition if kind == "inverse_condition" else s.extent for s in slices]
    finite = [v[np.isfinite(v)] for v in values if v is not None]
    finite = [v for v in finite if v.size]
    vmin = 0.0 if kind == "inverse_condition" else (min(v.min() for v in finite) if finite else None)
    vmax = max(v.max() for v in finite) if finite else None
    # each design is cut where its own plot slice lies (a Tricept at its own median c): one common
    # slice is named once, in the figure's title, differing slices each in its panel's title
    labels = {s.fixed_label for s in slices}
    if len(labels) > 1:
        titles = [f"{t}\nslice {s.fixed_label}" for t, s in zip(titles, slices)]
    fig, axes = panel_grid(len(slices), 4.2, 3.8, columns)
    fig.set_figwidth(fig.get_figwidth() + 1.0)  # the shared colour bar
    mesh = None
    for ax, data, title in zip(axes, slices, titles):
        mesh = draw_slice(fig, ax, data, kind, vmin=vmin, vmax=vmax, colorbar=False)
        set_title(ax, title, 8, width=3.6)
    label = "1/κ [1]" if kind == "inverse_condition" else slices[0].extent_label
    if mesh is not None and (kind == "inverse_condition" or slices[0].extent is not None):
        fig.colorbar(mesh, ax=list(axes), label=f"{label} (one scale for all panels)")
    if len(labels) > 1:
        where = "each at its own slice"
    else:
        where = f"slice {slices[0].fixed_label}" if slices[0].fixed_label else "whole workspace"
    title = f"{'workspace' if kind == 'workspace' else '1/κ'} of the best designs, {where}"
    fig.suptitle(fit_title(title, 0.9 * fig.get_figwidth(), 10), fontsize=10)
    return png(fig)
