"""Stage 4, aggregate: the runs of a sweep into one hive-partitioned Parquet dataset.

Layout: ``<dataset>/<table>/mechanism=<name>/objective=<name>/wd=<w_d>/<sweep>__<run>.parquet``
for the tables ``best``, ``history`` and ``designs``. The partition columns
are not stored in the files (pyarrow refuses a column that is both), except
``w_d``, which stays a float64 column; ``wd`` is its partition label. So
``pd.read_parquet(<dataset>/best)`` gives ``w_d`` float64 and ``mechanism``,
``objective`` categorical. Re-aggregating a sweep overwrites its own files.

Run on its own: ``python -m pipeline.aggregate <sweep dir> [--dataset DIR]``;
a Hydra multirun triggers it at its end (:class:`AggregateOnMultirunEnd`).
"""

from __future__ import annotations

import argparse
import logging
import sys
from pathlib import Path

import pandas as pd
from hydra.experimental.callback import Callback
from omegaconf import DictConfig

from pipeline.io import read_metadata, write_parquet
from pipeline.plot import plot_tradeoff

log = logging.getLogger(__name__)

TABLES = ("best", "history", "designs")
PARTITIONS = ("mechanism", "objective")


def find_runs(sweep_dir: Path) -> list[Path]:
    """Run directories (those holding a ``best.parquet``) below ``sweep_dir``, sorted."""
    return sorted(p.parent for p in Path(sweep_dir).rglob("best.parquet")
                  if "dataset" not in p.relative_to(sweep_dir).parts)


def aggregate(sweep_dir: Path, dataset_dir: Path) -> Path:
    """Write the sweep's runs into ``dataset_dir``; returns it. Also plots ``tradeoff.png`` in the sweep."""
    sweep_dir, dataset_dir = Path(sweep_dir), Path(dataset_dir)
    runs = find_runs(sweep_dir)
    if not runs:
        raise ValueError(f"no runs (best.parquet) under {sweep_dir}")
    sweep_name = sweep_dir.name
    best_frames = []
    for run in runs:
        run_key = f"{sweep_name}__{'_'.join(run.relative_to(sweep_dir).parts) or 'run'}"
        for table in TABLES:
            path = run / f"{table}.parquet"
            frame = pd.read_parquet(path)
            if table == "best":
                best_frames.append(frame.copy())
            frame.insert(0, "run", run_key)
            frame["run"] = frame["run"].astype("string")
            first = frame.iloc[0]
            target = (dataset_dir / table / f"mechanism={first['mechanism']}"
                      / f"objective={first['objective']}" / f"wd={float(first['w_d']):.4f}"
                      / f"{run_key}.parquet")
            write_parquet(frame.drop(columns=list(PARTITIONS)), target, read_metadata(path)["config"])
    plot_tradeoff(pd.concat(best_frames, ignore_index=True), sweep_dir / "tradeoff.png")
    log.info("aggregate: %d runs of %s into %s", len(runs), sweep_dir, dataset_dir)
    return dataset_dir


class AggregateOnMultirunEnd(Callback):
    """Hydra callback: aggregate the sweep into ``paths.dataset_dir`` when a multirun ends."""

    def on_multirun_end(self, config: DictConfig, **kwargs) -> None:
        sweep_dir = Path(config.hydra.sweep.dir)
        if find_runs(sweep_dir):
            aggregate(sweep_dir, Path(config.paths.dataset_dir))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pipeline.aggregate", description=__doc__.split("\n")[0])
    parser.add_argument("sweep_dir", type=Path, help="directory of a sweep (or a single run)")
    parser.add_argument("--dataset", type=Path, default=Path("outputs/dataset"),
                        help="dataset directory (default: outputs/dataset)")
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        aggregate(args.sweep_dir, args.dataset)
    except ValueError as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2
    print(args.dataset)
    return 0


if __name__ == "__main__":
    sys.exit(main())
