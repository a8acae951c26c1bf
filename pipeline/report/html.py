"""A sweep (or a whole dataset) on one self-contained page: ``report.html``.

Written at the end of every multirun into the sweep directory, and on demand:
``python -m pipeline.report <sweep or dataset dir> [--out FILE]``. The page
holds the sweep's config and each run's overrides, a sortable table of the
optima (click a column header), the trade-off (GDI, SURI, η versus w_d,
mean and range over seeds), the convergence of every group of runs (mean
and range over seeds), Pareto fronts where there are any, the workspace
figures of the best designs, and links to the Parquet files. Figures are
embedded as PNG (base64), so the file can be mailed or archived alone.
"""

from __future__ import annotations

import argparse
import base64
import html
import io
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd

from pipeline.errors import ConfigError
from pipeline.stages.plot import _figure, plot_tradeoff, symbol
from pipeline.store.runs import MANIFEST, read_manifest

#: columns of the optima table, in order (those present are shown)
TABLE_COLUMNS = ("job", "mechanism", "objective", "w_d", "optimizer", "seed", "objective_value", "objective_unit",
                 "volume", "volume_unit", "gdi", "suri", "reference_gap", "flat_variables", "at_bounds")
#: workspace figures embedded at most (the best runs first)
MAX_WORKSPACES = 12


def load_sweep(source: Path) -> tuple[pd.DataFrame, pd.DataFrame, dict[str, Path], str]:
    """(best, history, run directories by run id, config text) of a sweep or dataset directory."""
    source = Path(source)
    if (source / "runs").is_dir() and (source / "best").is_dir():  # a dataset
        best = pd.read_parquet(source / "best")
        history = pd.read_parquet(source / "history")
        runs = pd.read_parquet(source / "runs")
        dirs = {r: Path(s) for r, s in zip(runs["run_id"], runs["source"])}
        return best, history, dirs, f"dataset {source} ({len(runs)} runs)"
    frames_best, frames_history, dirs = [], [], {}
    for manifest_path in sorted(source.rglob(MANIFEST)):
        run = manifest_path.parent
        manifest = read_manifest(run)
        if not manifest or manifest.get("status") != "complete":
            continue
        best = pd.read_parquet(run / "best.parquet")
        history = pd.read_parquet(run / "history.parquet")
        for frame in (best, history):
            frame.insert(0, "run_id", manifest["run_id"])
            frame.insert(1, "job", int(manifest["job"]))
        frames_best.append(best)
        frames_history.append(history)
        dirs[manifest["run_id"]] = run
    if not frames_best:
        raise ConfigError(f"source={str(source)!r} is invalid: no complete run below it; "
                          f"allowed: a sweep, run or dataset directory")
    config = (source / "multirun.yaml").read_text() if (source / "multirun.yaml").exists() else ""
    return (pd.concat(frames_best, ignore_index=True), pd.concat(frames_history, ignore_index=True), dirs,
            config)


def _png(fig) -> str:
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png", dpi=110)
    return base64.b64encode(buffer.getvalue()).decode()


def _img(data: str, alt: str) -> str:
    return f'<img alt="{html.escape(alt)}" src="data:image/png;base64,{data}">'


def _file_img(path: Path, alt: str) -> str:
    return _img(base64.b64encode(path.read_bytes()).decode(), alt) if path.exists() else ""


def convergence_figure(best: pd.DataFrame, history: pd.DataFrame) -> str:
    """Best objective per generation, one line per (mechanism, objective, w_d, optimizer): mean and range over runs."""
    keys = ["mechanism", "objective", "w_d", "optimizer"]
    groups = best[["run_id", *keys]].merge(history[["run_id", "generation", "best"]], on="run_id")
    by_objective = sorted(groups["objective"].astype(str).unique())
    fig, axes = _figure(5.5 * len(by_objective), 4, len(by_objective))
    for ax, objective in zip(axes, by_objective):
        part = groups[groups["objective"].astype(str) == objective]
        for key, frame in part.groupby(keys, sort=True):
            stats = frame.groupby("generation")["best"].agg(["mean", "min", "max"])
            label = f"{key[0]}, {key[3]}" + (f", w_d={key[2]:g}" if objective == "mixed" else "")
            ax.plot(stats.index, stats["mean"], label=label)
            ax.fill_between(stats.index, stats["min"], stats["max"], alpha=0.2)
        ax.set_xlabel("generation")
        unit = best.loc[best["objective"].astype(str) == objective, "objective_unit"].iloc[0]
        ax.set_ylabel(f"{symbol(objective)} [{unit}]")
        ax.set_title(f"convergence: {symbol(objective)} (mean and range over seeds)")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7, loc="lower right")
    return _png(fig)


def _cell(value) -> str:
    if isinstance(value, float):
        return "" if np.isnan(value) else f"{value:.6g}"
    return html.escape(str(value))


def build_report(source: Path) -> str:
    """The report page of a sweep or dataset directory, as HTML text."""
    best, history, dirs, config = load_sweep(source)
    best = best.sort_values(["mechanism", "objective", "w_d", "seed"], kind="stable").reset_index(drop=True)
    columns = [c for c in TABLE_COLUMNS if c in best.columns]
    header = "".join(f"<th>{html.escape(c)}</th>" for c in [*columns, "files"])
    rows = []
    for _, row in best.iterrows():
        run_dir = dirs.get(row["run_id"])
        links = " ".join(f'<a href="{html.escape((run_dir / f"{t}.parquet").as_uri())}">{t}</a>'
                         for t in ("best", "history", "designs", "front")
                         if run_dir is not None and (run_dir / f"{t}.parquet").exists())
        rows.append("<tr>" + "".join(f"<td>{_cell(row[c])}</td>" for c in columns) + f"<td>{links}</td></tr>")
    tradeoff = ""
    if (best["objective"].astype(str) == "mixed").any():
        with tempfile.TemporaryDirectory() as tmp:
            tradeoff = _file_img(plot_tradeoff(best, Path(tmp) / "tradeoff.png"), "trade-off")
    fronts = "".join(_file_img(d / "pareto.png", f"Pareto front {rid}") for rid, d in dirs.items())
    order = best.sort_values("objective_value", ascending=False)["run_id"]
    workspaces = "".join(f"<figure>{_file_img(dirs[rid] / 'workspace.png', 'workspace')}"
                         f"<figcaption>{html.escape(rid)}</figcaption></figure>"
                         for rid in list(order)[:MAX_WORKSPACES]
                         if rid in dirs and (dirs[rid] / "workspace.png").exists())
    overrides = "".join(
        f"<li><code>{html.escape(rid)}</code>: {html.escape(' '.join((read_manifest(d) or {}).get('overrides', [])))}</li>"
        for rid, d in dirs.items())
    generated = time.strftime("%Y-%m-%d %H:%M:%S")
    return f"""<!DOCTYPE html>
<html lang="en"><head><meta charset="utf-8"><title>pm-design report: {html.escape(Path(source).name)}</title>
<style>
body {{ font-family: system-ui, sans-serif; margin: 2em; color: #222; }}
table {{ border-collapse: collapse; font-size: 13px; }} th, td {{ border: 1px solid #ccc; padding: 3px 6px; }}
th {{ background: #eef; cursor: pointer; position: sticky; top: 0; }} tr:nth-child(even) {{ background: #f8f8f8; }}
img {{ max-width: 100%; }} figure {{ display: inline-block; width: 31%; margin: 0.5%; }}
pre {{ background: #f4f4f4; padding: 1em; max-height: 20em; overflow: auto; }}
</style></head><body>
<h1>pm-design report: {html.escape(str(source))}</h1>
<p>{len(best)} complete runs; generated {generated}. Click a column header to sort.</p>
<h2>Optima</h2>
<table id="optima"><thead><tr>{header}</tr></thead><tbody>{''.join(rows)}</tbody></table>
<h2>Trade-off</h2>{tradeoff or '<p>No mixed-index runs.</p>'}
<h2>Convergence</h2>{_img(convergence_figure(best, history), 'convergence')}
{'<h2>Pareto fronts</h2>' + fronts if fronts else ''}
<h2>Workspaces of the best designs</h2>{workspaces or '<p>No figures (plot.enabled=false).</p>'}
<h2>Configuration</h2><pre>{html.escape(config)}</pre><ul>{overrides}</ul>
<script>
document.querySelectorAll("#optima th").forEach(function (th, col) {{
  th.addEventListener("click", function () {{
    var body = document.querySelector("#optima tbody");
    var rows = Array.prototype.slice.call(body.rows);
    var up = th.dataset.up !== "1"; th.dataset.up = up ? "1" : "0";
    rows.sort(function (a, b) {{
      var x = a.cells[col].textContent, y = b.cells[col].textContent;
      var nx = parseFloat(x), ny = parseFloat(y);
      var c = (!isNaN(nx) && !isNaN(ny)) ? nx - ny : x.localeCompare(y);
      return up ? c : -c;
    }});
    rows.forEach(function (r) {{ body.appendChild(r); }});
  }});
}});
console.log("pm-design report ready: " + document.querySelectorAll("#optima tbody tr").length + " runs");
</script>
</body></html>
"""


def write_report(source: Path, out: Path | None = None) -> Path:
    """Write ``report.html`` (default: inside ``source``) atomically; returns its path."""
    from pipeline.store.parquet import write_text

    out = Path(out) if out is not None else Path(source) / "report.html"
    return write_text(out, build_report(source))


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
    print(json.dumps({"report": str(path)}))
    return 0

