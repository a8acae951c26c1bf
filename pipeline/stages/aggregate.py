"""Stage 4, aggregate: complete runs into one Parquet dataset with one schema per table.

Layout: ``<dataset>/<table>/<run_id>.parquet`` for the tables ``best``,
``history``, ``designs``, ``front`` (Pareto runs) and ``runs`` (one row per
run: ids, status, timings, overrides, source). Every file of a table has
the table's *unified* schema (the union of all runs' columns, absent values
null, field metadata with units), so ``pd.read_parquet("<dataset>/best")``
returns every column of every run whatever mechanisms and objectives are
mixed.

Guarantees (tested in ``tests/test_dataset.py``):

* keyed on the run id (``<config_hash>-<launch_id>-<job>-<token>``), never on folder
  names: aggregating a run again, by any path, changes nothing; different
  runs never overwrite each other;
* only runs whose ``manifest.json`` says ``complete`` are taken; the others
  are skipped with one line each;
* a run whose files cannot be read is skipped with one line, the others added;
* every dataset file's checksum is recorded (``checksums.json``) and verified
  at each aggregation: a run counts as present only when all its files are
  there and intact in every table; a damaged one is rebuilt from its source
  run (or removed when that is gone), with one line; stale staging copies of
  a killed aggregation are cleaned under the lock;
* all-or-nothing: the new dataset is built beside the old one (a copy plus
  the new runs) and swapped in by renaming; on any error the previous
  dataset is left as it was. An exclusive lock serialises aggregations.

Run on its own: ``python -m pipeline.stages.aggregate <dir> [<dir> ...] [--dataset DIR]``;
a multirun aggregates its sweep at its end (:mod:`pipeline.sweeps.sweeper`). The staged
build and swap is :mod:`pipeline.stages.dataset_build`.
"""

from __future__ import annotations

import argparse
import json
import logging
import sys
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.errors import ConfigError, RunError
from pipeline.stages.dataset_build import build_and_swap, locked, with_run_ids
from pipeline.stages.dataset_checks import (
    clean_stale,
    readable_run,
    verify_dataset,
)
from pipeline.store.checksums import read_registry
from pipeline.store.runs import MANIFEST, read_manifest

log = logging.getLogger(__name__)


@dataclass
class AggregateReport:
    """What one aggregation did: run ids added, already present, and runs skipped (with reasons)."""

    added: list[str] = field(default_factory=list)
    present: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    #: run ids whose dataset files were missing or failed their checksum: rebuilt from the source
    #: run, or removed from the dataset when the source is gone (one line each in the log)
    repaired: list[str] = field(default_factory=list)
    best_tables: list[pa.Table] = field(default_factory=list)

    @property
    def best(self) -> pd.DataFrame | None:
        """The ``best`` rows of every complete run found (added or already present), or None."""
        if not self.best_tables:
            return None
        return pd.concat([t.to_pandas() for t in self.best_tables], ignore_index=True)


def find_runs(source: Path) -> list[Path]:
    """Run directories (holding a manifest) at or below ``source``, sorted; datasets are not searched."""
    source = Path(source)
    found = [p.parent for p in source.rglob(MANIFEST)]
    if (source / MANIFEST).exists():
        found.append(source)
    return sorted({p.resolve() for p in found})


def _collect(sources: list[Path]) -> tuple[list[tuple[Path, dict]], list[str]]:
    complete: dict[str, tuple[Path, dict]] = {}
    skipped = []
    for source in sources:
        for run in find_runs(source):
            manifest = read_manifest(run)
            if manifest is None:
                skipped.append(f"{run}: unreadable manifest")
                continue
            status = manifest.get("status")
            if status != "complete":
                reason = manifest.get("reason") or "not finished"
                skipped.append(f"{run}: {status} ({reason})")
                continue
            missing = [f for f in manifest.get("files", []) if f.endswith(".parquet") and not (run / f).exists()]
            if missing:
                skipped.append(f"{run}: incomplete (missing {', '.join(missing)})")
                continue
            problem = readable_run(run, manifest)
            if problem:
                skipped.append(f"{run}: {problem}")
                continue
            complete.setdefault(manifest["run_id"], (run, manifest))
    return list(complete.values()), skipped


def dataset_run_ids(dataset_dir: Path) -> set[str]:
    """Run ids already in the dataset (its ``runs`` table)."""
    runs = Path(dataset_dir) / "runs"
    return {p.stem for p in runs.glob("*.parquet")} if runs.is_dir() else set()


def aggregate(sources: Path | list[Path], dataset_dir: Path) -> AggregateReport:
    """Add the complete runs found under ``sources`` to the dataset at ``dataset_dir``.

    Raises
    ------
    ConfigError
        A source that does not exist, or a dataset path that cannot be written (one line).
    RunError
        A failure while building (disk full, ...): the previous dataset is intact.
    """
    sources = [Path(s) for s in ([sources] if isinstance(sources, (str, Path)) else sources)]
    dataset_dir = Path(dataset_dir)
    for source in sources:
        if not source.is_dir():
            raise ConfigError(f"source={str(source)!r} is invalid: allowed an existing run, sweep or parent directory")
    from pipeline.errors import check_writable

    check_writable("--dataset", dataset_dir)
    if dataset_dir.exists() and any(dataset_dir.iterdir()) and not (dataset_dir / "runs").is_dir():
        raise ConfigError(
            f"--dataset={str(dataset_dir)!r} is invalid: the directory holds something else "
            f"than a dataset; allowed: an empty, new or dataset directory"
        )
    report = AggregateReport()
    records, report.skipped = _collect(sources)
    for line in report.skipped:
        log.warning("aggregate: skipped %s", line)
    dataset_dir.parent.mkdir(parents=True, exist_ok=True)
    best_tables = {m["run_id"]: pq.read_table(run / "best.parquet") for run, m in records}  # read once
    with locked(dataset_dir):
        for line in clean_stale(dataset_dir):
            log.warning("aggregate: %s", line)
        present, damaged, sources = verify_dataset(dataset_dir)
        rebuild = _sources_of_damaged(damaged, sources, records, best_tables)
        new = [(run, m) for run, m in records + rebuild if m["run_id"] not in present]
        report.present = sorted(m["run_id"] for _, m in records if m["run_id"] in present)
        report.repaired = sorted(damaged)
        sources.update({m["run_id"]: str(run) for run, m in new})
        if new or damaged or (present and read_registry(dataset_dir) is None):
            build_and_swap(dataset_dir, new, best_tables, set(damaged), sources)
        report.added = [m["run_id"] for _, m in new if m["run_id"] not in damaged]
    manifests = {m["run_id"]: m for _, m in records + rebuild}
    # with their ids (purpose, study_hash), as the dataset has them: the sweep's figures group by them
    report.best_tables = [with_run_ids(t, manifests[run_id]) for run_id, t in best_tables.items()]
    log.info(
        "aggregate: %d runs added, %d already present, %d skipped -> %s",
        len(report.added),
        len(report.present),
        len(report.skipped),
        dataset_dir,
    )
    return report


def _sources_of_damaged(
    damaged: dict[str, str], sources: dict[str, str], records: list[tuple[Path, dict]], best_tables: dict[str, pa.Table]
) -> list[tuple[Path, dict]]:
    """The source runs of damaged dataset runs that are not among ``records`` (read from the
    recorded source directory); one line per damaged run, rebuilt or removed."""
    given = {m["run_id"] for _, m in records}
    out = []
    for run_id, problem in sorted(damaged.items()):
        source = Path(sources[run_id]) if sources.get(run_id) else None
        manifest = read_manifest(source) if source is not None else None
        if run_id in given:
            log.warning("aggregate: dataset run %s: %s; rebuilt from its source run", run_id, problem)
        elif (
            manifest is not None
            and manifest.get("run_id") == run_id
            and manifest.get("status") == "complete"
            and not readable_run(source, manifest)
        ):
            log.warning("aggregate: dataset run %s: %s; rebuilt from %s", run_id, problem, source)
            best_tables[run_id] = pq.read_table(source / "best.parquet")
            out.append((source, manifest))
        else:
            log.warning(
                "aggregate: dataset run %s: %s; removed from the dataset (its source run %s is gone or unreadable)",
                run_id,
                problem,
                source or "is unknown",
            )
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m pipeline.stages.aggregate", description=__doc__.split("\n")[0])
    parser.add_argument("sources", type=Path, nargs="+", help="run, sweep or parent directories")
    parser.add_argument(
        "--dataset", type=Path, default=Path("outputs/dataset"), help="dataset directory (default: outputs/dataset)"
    )
    args = parser.parse_args(argv)
    logging.basicConfig(level=logging.INFO, format="%(message)s")
    try:
        report = aggregate(args.sources, args.dataset)
    except (ConfigError, RunError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        return 2 if isinstance(exc, ConfigError) else 1
    except KeyboardInterrupt:
        print("error: interrupted; the dataset is unchanged", file=sys.stderr)
        return 130
    print(
        json.dumps(
            {
                "dataset": str(args.dataset),
                "added": len(report.added),
                "present": len(report.present),
                "skipped": len(report.skipped),
                "repaired": len(report.repaired),
            }
        )
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
