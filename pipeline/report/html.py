"""A sweep (or a whole dataset) on one page: ``report.html``.

Written at the end of every multirun into the sweep directory, and on demand:
``python -m pipeline.report <sweep or dataset dir> [--out FILE]``. The page
holds a sortable table of the optima (design variables with units, the gap
to the reference optimum in percent, links to each run's Parquet files), the
runs per group with distinct seeds and repeats told apart, the trade-off
(GDI, SURI, η versus w_d), the convergence of every group (mean and range
over distinct seeds, with the reference optimum), Pareto fronts, the
workspace and 1/κ slices of the best designs (one colour scale per
mechanism), the sweep's config and each run's overrides.

Figures are embedded (base64 PNG), the script and style are inline (no
network), and links to files are *relative* to the page: the folder can be
zipped, moved or mailed and the links still work. The layout is usable from
800 px wide (the table scrolls sideways inside its box).
"""

from __future__ import annotations

import argparse
import base64
import html
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path
from urllib.parse import quote

import numpy as np
import pandas as pd
import pyarrow.parquet as pq
from omegaconf import OmegaConf

from kinematics import MECHANISMS
from pipeline.config import study_hash
from pipeline.errors import ConfigError, RunError
from pipeline.report.figures import GROUP_KEYS, caption, convergence_figure, group_keys, workspace_gallery
from pipeline.stages.dataset_build import with_run_ids
from pipeline.stages.plot import beaten_optima, debug_rows, distinct_seeds, plot_tradeoff, symbol, with_study
from pipeline.store.dataset import DEFAULT_PURPOSES, read_dataset
from pipeline.store.runs import MANIFEST, read_manifest

#: workspace figures embedded at most per mechanism (the best runs first)
MAX_WORKSPACES = 6
STATIC = Path(__file__).resolve().parent / "static"


def is_dataset(source: Path) -> bool:
    """Whether ``source`` is a dataset directory (``runs/`` and ``best/`` tables), not a sweep or run."""
    return (Path(source) / "runs").is_dir() and (Path(source) / "best").is_dir()


def load_sweep(source: Path) -> tuple[pd.DataFrame, pd.DataFrame, dict[str, Path], str]:
    """(best, history, run directories by run id, config text) of a sweep, run or dataset directory.

    The config text is the sweep's own config (:func:`sweep_config`), "" for a folder of runs
    without one, or a line saying what a dataset holds.

    A dataset is read with :func:`pipeline.store.dataset.read_dataset` (debug runs left out).
    """
    source = Path(source)
    if is_dataset(source):
        best, dirs, purposes = read_studies(source)
        history = read_dataset(source, "history", purposes)
        left_out = "; debug runs only" if purposes is None else ", debug runs left out"
        return best, history, dirs, f"dataset {source} ({len(dirs)} runs{left_out})"
    frames_best, frames_history, dirs = [], [], {}
    for manifest_path in sorted(source.rglob(MANIFEST)):
        run = manifest_path.parent
        manifest = read_manifest(run)
        if not manifest or manifest.get("status") != "complete":
            continue
        # the run's ids (purpose, study_hash too) as the dataset would hold them
        frames_best.append(with_run_ids(pq.read_table(run / "best.parquet"), manifest).to_pandas())
        frames_history.append(with_run_ids(pq.read_table(run / "history.parquet"), manifest).to_pandas())
        dirs[manifest["run_id"]] = run
    if not frames_best:
        raise ConfigError(
            f"source={str(source)!r} is invalid: no complete run below it; allowed: a sweep, run or dataset directory"
        )
    config = sweep_config((source / "multirun.yaml").read_text()) if (source / "multirun.yaml").exists() else ""
    return (pd.concat(frames_best, ignore_index=True), pd.concat(frames_history, ignore_index=True), dirs, config)


def read_studies(source: Path) -> tuple[pd.DataFrame, dict[str, Path], tuple[str, ...] | None]:
    """(best, run directories by run id, the purposes kept) of a dataset: its debug runs left out
    (:func:`pipeline.store.dataset.read_dataset`), unless it holds nothing else: then those, and
    purposes None (a smoke test shows its runs rather than nothing, and says so). Each run's
    ``study_hash`` filled where the dataset predates the column (:func:`fill_study_hashes`)."""
    purposes: tuple[str, ...] | None = DEFAULT_PURPOSES
    with warnings.catch_warnings():  # an empty frame's warning: the callers say so themselves
        warnings.simplefilter("ignore", UserWarning)
        best = read_dataset(source, "best", purposes)
    if best.empty:
        purposes = None
        best = read_dataset(source, "best", purposes)
    runs = read_dataset(source, "runs", purposes)
    dirs = {r: Path(s) for r, s in zip(runs["run_id"], runs["source"])}
    return fill_study_hashes(best, dirs), dirs, purposes


def debug_note(best: pd.DataFrame) -> str:
    """A visible line above everything where any run is a debug run (``purpose``), else ""."""
    count = int(debug_rows(best).sum())
    if not count:
        return ""
    return (
        f'<p class="note"><strong>{count} of {len(best)} runs are debug runs</strong> (+debug presets, '
        "tiny sizes): a smoke test, not results.</p>\n"
    )


def beaten_note(best: pd.DataFrame) -> str:
    """A warning above the report where a mixed-index optimum scores below another run's design
    of the same study at its own w_d (:func:`~pipeline.stages.plot.beaten_optima`): the
    optimiser stopped in another basin, and the trade-off dips there."""
    beaten = beaten_optima(best)
    if not len(beaten):
        return ""
    items = "".join(
        f"<li>{html.escape(str(row.mechanism))}, w_d = {row.w_d:g} (seed {row.seed}): η "
        f"{row.objective_value:.6g} ± {row.objective_error:.2g}, while the design found at w_d = "
        f"{row.other_w_d:g} (seed {row.other_seed}) scores {row.other_value:.6g} there "
        f"(+{100 * row.gap:.2f} %)</li>"
        for row in beaten.itertuples()
    )
    return (
        f'<p class="note"><strong>{len(beaten)} optimum{"s" * (len(beaten) > 1)} beaten by another run\'s design '
        "of the same study</strong> (η = w_d·GDI + (1 − w_d)·SURI of that design, from its stored GDI and "
        "SURI, beyond both runs' error): the optimiser stopped in another basin. Rerun those w_d with "
        "more restarts or another optimiser; the trade-off marks them with a red ring.</p>"
        f"<ul>{items}</ul>"
    )


def fill_study_hashes(best: pd.DataFrame, dirs: dict[str, Path]) -> pd.DataFrame:
    """``best`` with each run's ``study_hash``, from its manifest where the dataset has none (runs
    aggregated before the column existed; "" where the run's folder is gone)."""
    best = with_study(best)
    for k in np.nonzero((best["study_hash"] == "").to_numpy())[0]:
        manifest = read_manifest(dirs[best["run_id"].iloc[k]]) if best["run_id"].iloc[k] in dirs else None
        if manifest and manifest.get("config"):
            best.loc[best.index[k], "study_hash"] = study_hash(manifest["config"])
    return best


def sweep_config(text: str) -> str:
    """A sweep's ``multirun.yaml`` without its ``hydra`` node (Hydra's help text, logging and
    launcher settings: hundreds of lines before the study's own config; each job's overrides
    are listed beside it), as YAML text (interpolations left as written)."""
    config = OmegaConf.create(text)
    if "hydra" in config:
        del config["hydra"]
    return OmegaConf.to_yaml(config)


def runs_configs(best: pd.DataFrame, dirs: dict[str, Path]) -> str:
    """The configs of the runs of a folder without a sweep config: each distinct config once
    (collapsed, headed by the runs that used it), or a line saying none was recorded."""
    by_config: dict[str, list[str]] = {}
    for _, row in best.iterrows():
        config = (read_manifest(dirs[row["run_id"]]) or {}).get("config") if row["run_id"] in dirs else None
        if config:
            text = OmegaConf.to_yaml(OmegaConf.create(config))
            by_config.setdefault(text, []).append(caption(row))
    if not by_config:
        return "<p>No config recorded for these runs (no multirun.yaml, no run manifest with one).</p>"
    return "".join(
        f"<details><summary>config of {html.escape('; '.join(names))}</summary><pre>{html.escape(text)}</pre></details>"
        for text, names in by_config.items()
    )


def _img(data: str, alt: str) -> str:
    return f'<div class="zoom"><img alt="{html.escape(alt)}" src="data:image/png;base64,{data}"></div>'


def _file_img(path: Path, alt: str) -> str:
    return _img(base64.b64encode(path.read_bytes()).decode(), alt) if path.exists() else ""


def _cell(value, sort_value=None) -> str:
    attr = "" if sort_value is None else f' data-value="{html.escape(str(sort_value))}"'
    if value is None or (isinstance(value, float) and np.isnan(value)):
        return f"<td{attr}></td>"
    if isinstance(value, (float, np.floating)):
        return f"<td{attr}>{float(value):.6g}</td>"
    return f"<td{attr}>{html.escape(str(value))}</td>"


def design_columns(best: pd.DataFrame) -> list[tuple[str, str]]:
    """(column, unit) of the design variables of the mechanisms in ``best``, in class order."""
    out = []
    for name in sorted(best["mechanism"].astype(str).unique()):
        for v in MECHANISMS[name].design_variables if name in MECHANISMS else ():
            if v.name in best.columns and v.name not in [c for c, _ in out]:
                out.append((v.name, v.unit))
    return out


def _link(path: Path, base: Path) -> str:
    """``path`` relative to the page's folder, as a URL (works after the folder is moved)."""
    return quote(Path(os.path.relpath(Path(path).resolve(), base.resolve())).as_posix(), safe="/=,+")


def optima_table(best: pd.DataFrame, dirs: dict[str, Path], base: Path) -> str:
    """The sortable table of the optima, one row per run."""
    designs = design_columns(best)
    head = [
        "job",
        "mechanism",
        "objective",
        "w_d",
        "optimizer",
        "seed",
        *[f"{n} [{u}]" for n, u in designs],
        "objective",
        "V",
        "GDI",
        "SURI",
        "gap to reference",
        "flat variables",
        "at bounds",
        "files",
    ]
    rows = []
    for _, row in best.iterrows():
        cells = [
            _cell(row.get("job")),
            _cell(row["mechanism"]),
            _cell(row["objective"]),
            # w_d weighs the mixed index only: another objective's stored 0 would read as a weight
            _cell(row["w_d"] if str(row["objective"]) == "mixed" else None),
            _cell(row["optimizer"]),
            _cell(row["seed"]),
        ]
        cells += [_cell(row.get(n)) for n, _ in designs]
        unit = row.get("objective_unit", "")
        unit = "" if unit in (None, "1") else unit  # a dimensionless index reads "η = 0.2", not "η = 0.2 1"
        value = row["objective_value"]
        # the optimum's estimated discretisation error (issue 23: error bars are data)
        error = row.get("objective_error")
        error = "" if error is None or pd.isna(error) else f" ± {float(error):.2g}"
        cells.append(_cell(f"{symbol(str(row['objective']))} = {value:.6g}{error} {unit}".rstrip(), value))
        cells.append(_cell(f"{row['volume']:.6g} {row.get('volume_unit', '')}", row["volume"]))
        cells += [_cell(row.get("gdi")), _cell(row.get("suri"))]
        gap = row.get("reference_gap")
        gap = None if gap is None or pd.isna(gap) else 100 * float(gap)
        # "within error" or "g % ± e %" (issue 23: a gap below its error is never quoted as a percentage)
        label = row.get("reference_gap_label")
        label = label if isinstance(label, str) and label else (None if gap is None else f"{gap:.3g} %")
        cells.append(_cell(label, gap))
        cells += [_cell(row.get("flat_variables", "")), _cell(row.get("at_bounds", ""))]
        run_dir = dirs.get(row["run_id"])
        links = " ".join(
            f'<a href="{_link(run_dir / f"{t}.parquet", base)}">{t}</a>'
            for t in ("best", "history", "designs", "front")
            if run_dir is not None and (run_dir / f"{t}.parquet").exists()
        )
        cells.append(f"<td>{links}</td>")
        rows.append(f'<tr title="{html.escape(str(row["run_id"]))}">' + "".join(cells) + "</tr>")
    header = "".join(f"<th>{html.escape(h)}</th>" for h in head)
    return (
        f'<div class="scroll"><table id="optima" class="sortable"><thead><tr>{header}</tr></thead>'
        f"<tbody>{''.join(rows)}</tbody></table></div>"
    )


def seeds_table(best: pd.DataFrame) -> str:
    """Runs per group: distinct seeds (statistics run over these) and repeats of one seed."""
    best = with_study(best)
    rows, keys = [], group_keys(best)
    for key, frame in best.groupby(keys, sort=True):
        # a repeat: the same run config (study and seed) again
        n_runs, n_seeds = len(frame), len(distinct_seeds(frame, keys))
        seeds = ", ".join(str(s) for s in sorted(frame["seed"].unique()))
        rows.append("<tr>" + "".join(_cell(v) for v in (*key, n_runs, n_seeds, seeds, n_runs - n_seeds)) + "</tr>")
    header = "".join(f"<th>{h}</th>" for h in (*keys, "runs", "distinct seeds", "seeds", "repeats of a seed"))
    return (
        f'<div class="scroll"><table class="sortable"><thead><tr>{header}</tr></thead>'
        f"<tbody>{''.join(rows)}</tbody></table></div>"
        '<p class="note">Means and ranges are over distinct seeds; a repeat (same study, same seed) '
        "gives the same result and is counted once.</p>"
    )


def galleries(best: pd.DataFrame, dirs: dict[str, Path]) -> str:
    """Workspace and 1/κ slices of the best designs of each mechanism, one colour scale per figure."""
    parts = []
    for name in sorted(best["mechanism"].astype(str).unique()):
        rows = best[best["mechanism"].astype(str) == name].sort_values("objective_value", ascending=False)
        rows = rows[[rid in dirs and (dirs[rid] / "workspace.png").exists() for rid in rows["run_id"]]]
        rows = distinct_seeds(with_study(rows), GROUP_KEYS).head(MAX_WORKSPACES)  # a repeat draws the same panel
        configs = {rid: (read_manifest(dirs[rid]) or {}).get("config") for rid in rows["run_id"]}
        configs = {k: v for k, v in configs.items() if v}
        for kind, alt in (("workspace", "workspace"), ("inverse_condition", "1/κ")):
            data = workspace_gallery(rows, configs, kind)
            if data:
                parts.append(
                    f"<figure>{_img(data, f'{alt} of the best {name} designs')}"
                    f"<figcaption>{alt} of the best {name} designs: "
                    f"{html.escape('; '.join(caption(r) for _, r in rows.iterrows()))}"
                    f"</figcaption></figure>"
                )
    return "".join(parts)


def build_report(source: Path, out: Path | None = None) -> str:
    """The report page of a sweep or dataset directory, as HTML text (links relative to ``out``)."""
    source = Path(source)
    base = (Path(out) if out is not None else source / "report.html").parent
    best, history, dirs, config = load_sweep(source)
    best = best.sort_values(["mechanism", "objective", "w_d", "seed"], kind="stable").reset_index(drop=True)
    tradeoff = ""
    if (best["objective"].astype(str) == "mixed").any():
        with tempfile.TemporaryDirectory() as tmp:
            tradeoff = _file_img(plot_tradeoff(best, Path(tmp) / "tradeoff.png"), "trade-off")
    fronts = "".join(
        f"<figure>{_file_img(d / 'pareto.png', 'Pareto front')}<figcaption>"
        f"{html.escape(caption(best[best['run_id'] == rid].iloc[0]))}</figcaption></figure>"
        for rid, d in dirs.items()
        if (d / "pareto.png").exists() and (best["run_id"] == rid).any()
    )
    overrides = "".join(
        f"<li>{html.escape(caption(row))}: <code>"
        f"{html.escape(' '.join((read_manifest(dirs[row['run_id']]) or {}).get('overrides', [])) or '(none)')}"
        f"</code></li>"
        for _, row in best.iterrows()
        if row["run_id"] in dirs
    )
    if is_dataset(source):  # the line saying what it holds
        configuration = f"<p>{html.escape(config)}</p>"
    elif config:
        configuration = (
            "<p>The sweep's base config; each job's own overrides are listed below it.</p>"
            f"<pre>{html.escape(config)}</pre>"
        )
    else:
        configuration = runs_configs(best, dirs)
    style = (STATIC / "report.css").read_text()
    script = (STATIC / "report.js").read_text()
    title = html.escape(source.resolve().name)
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8">
<meta name="viewport" content="width=device-width, initial-scale=1">
<title>pm-design report: {title}</title>
<style>{style}</style></head><body>
<h1>pm-design report: {title}</h1>
{debug_note(best)}{beaten_note(best)}<p>{len(best)} complete runs; generated {time.strftime("%Y-%m-%d %H:%M:%S")}. Click a column header to sort;
scroll or click a figure to zoom (drag to pan, double-click to reset). Hover a row for its run id.</p>
<h2>Optima</h2>{optima_table(best, dirs, base)}
<h2>Runs and seeds</h2>{seeds_table(best)}
<h2>Trade-off</h2>{tradeoff or "<p>No mixed-index runs.</p>"}
<h2>Convergence</h2>{_img(convergence_figure(best, history), "convergence")}
{"<h2>Pareto fronts</h2>" + fronts if fronts else ""}
<h2>Workspaces of the best designs</h2>{galleries(best, dirs) or "<p>No figures (plot.enabled=false).</p>"}
<h2>Configuration</h2>{configuration}<ul>{overrides}</ul>
<script>{script}</script>
</body></html>
"""


def write_report(source: Path, out: Path | None = None) -> Path:
    """Write ``report.html`` (default: inside ``source``) atomically; returns its path."""
    from pipeline.store.parquet import write_text

    out = Path(out) if out is not None else Path(source) / "report.html"
    text = build_report(source, out)
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RunError(f"cannot write {out}: {exc.strerror or exc}") from None
    return write_text(out, text)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pipeline.report", description=__doc__.split("\n")[0])
    parser.add_argument("source", type=Path, help="a sweep, run or dataset directory")
    parser.add_argument("--out", type=Path, default=None, help="output file (default: <source>/report.html)")
    args = parser.parse_args(argv)
    if not args.source.is_dir():
        print(f"error: source={str(args.source)!r} is invalid: allowed an existing directory", file=sys.stderr)
        return 2
    try:
        path = write_report(args.source, args.out)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    except RunError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 1
    print(json.dumps({"report": str(path)}))
    return 0
