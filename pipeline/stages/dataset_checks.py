"""What aggregation checks before it trusts a dataset or a run (:mod:`pipeline.stages.aggregate`).

* :func:`clean_stale`: staging and old copies left by an aggregation that was
  killed (a full dataset copy each) are removed, or the old copy restored
  when the swap was cut between its two renames; called under the lock;
* :func:`verify_dataset`: a run is *present* only when every file recorded
  for it (``checksums.json``, :mod:`pipeline.store.checksums`) exists with
  its checksum, in every table; the others are *damaged* and are rebuilt
  from their source run;
* :func:`readable_run`: a run's manifest has the fields aggregation uses and
  each of its tables can be read; an unreadable run is skipped with one line
  and the others are added.
"""

from __future__ import annotations

import logging
import os
import shutil
from pathlib import Path

import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.store.checksums import read_registry, sha256_file
from pipeline.store.runs import TABLES

log = logging.getLogger(__name__)

#: manifest fields aggregation reads
MANIFEST_FIELDS = ("run_id", "launch_id", "job", "config_hash", "status", "timings", "config")
#: tables every complete run has (``front``: Pareto runs only)
REQUIRED_TABLES = ("best", "history", "designs")


def clean_stale(dataset_dir: Path) -> list[str]:
    """Remove what a killed aggregation left beside ``dataset_dir``; returns one line per item.

    Must be called holding the dataset's lock: no aggregation is then running,
    so every staging directory is stale.
    """
    lines = []
    parent, name = dataset_dir.parent, dataset_dir.name
    for old in sorted(parent.glob(f".{name}.old-*")):
        if not dataset_dir.exists():  # killed between the two renames of the swap
            os.rename(old, dataset_dir)
            lines.append(f"restored {dataset_dir} from {old.name} (an aggregation was killed during its swap)")
        else:
            shutil.rmtree(old, ignore_errors=True)
            lines.append(f"removed stale {old.name}")
    for staging in sorted(parent.glob(f".{name}.staging-*")):
        shutil.rmtree(staging, ignore_errors=True)
        lines.append(f"removed stale {staging.name} (an aggregation was killed)")
    return lines


def dataset_files(dataset_dir: Path) -> dict[str, dict[str, Path]]:
    """``{run_id: {"<table>/<run_id>.parquet": path}}`` of every file of the dataset's tables."""
    out: dict[str, dict[str, Path]] = {}
    for table in (*TABLES, "runs"):
        folder = dataset_dir / table
        if folder.is_dir():
            for path in folder.glob("*.parquet"):
                out.setdefault(path.stem, {})[f"{table}/{path.name}"] = path
    return out


def verify_dataset(dataset_dir: Path) -> tuple[set[str], dict[str, str], dict[str, str]]:
    """The run ids present (every recorded file there with its checksum), the damaged ones
    (``{run_id: reason}``) and every run's recorded source directory.

    A dataset made before checksums were recorded (no ``checksums.json``) is
    trusted when each run's files are readable Parquet in every required table.
    """
    files = dataset_files(dataset_dir)
    registry = read_registry(dataset_dir)
    if registry is None and files:
        log.warning("aggregate: %s has no readable checksums.json; its files are checked by reading them", dataset_dir)
    registry = registry or {}
    present, damaged = set(), {}
    sources = {run_id: str(entry.get("source", "")) for run_id, entry in registry.items()}
    for run_id in sorted(set(files) | set(registry)):
        entry = registry.get(run_id)
        have = files.get(run_id, {})
        if entry is not None:
            recorded = entry.get("files", {})
            missing = sorted(set(recorded) - set(have))
            altered = sorted(rel for rel in set(recorded) & set(have) if sha256_file(have[rel]) != recorded[rel])
            extra = sorted(set(have) - set(recorded))
            problem = (
                f"missing {', '.join(missing)}"
                if missing
                else f"checksum mismatch in {', '.join(altered)}"
                if altered
                else f"unrecorded {', '.join(extra)}"
                if extra
                else ""
            )
        else:
            needed = [f"{t}/{run_id}.parquet" for t in (*REQUIRED_TABLES, "runs")]
            missing = [rel for rel in needed if rel not in have]
            unreadable = [rel for rel in sorted(have) if not _readable(have[rel])]
            problem = (
                f"missing {', '.join(missing)}"
                if missing
                else f"unreadable {', '.join(unreadable)}"
                if unreadable
                else ""
            )
            if not problem:
                sources[run_id] = ""
        if problem:
            damaged[run_id] = problem
        else:
            present.add(run_id)
    return present, damaged, sources


def _readable(path: Path) -> bool:
    try:
        pq.read_metadata(path)
        return True
    except (OSError, pa.ArrowException):
        return False


def readable_run(run: Path, manifest: dict) -> str:
    """Why aggregation cannot take this complete run (``""``: it can): a manifest field missing,
    a table missing or not readable as Parquet."""
    missing = [k for k in MANIFEST_FIELDS if k not in manifest]
    if missing:
        return f"manifest lacks {', '.join(missing)}"
    for table in TABLES:
        path = run / f"{table}.parquet"
        if not path.exists():
            if table in REQUIRED_TABLES or f"{table}.parquet" in manifest.get("files", []):
                return f"missing {path.name}"
            continue
        try:
            pq.read_table(path)
        except (OSError, pa.ArrowException) as exc:
            return f"unreadable {path.name} ({str(exc).splitlines()[0] if str(exc) else type(exc).__name__})"
    return ""


def registry_entries(dataset_dir: Path, sources: dict[str, str]) -> dict[str, dict]:
    """Checksums of every file now in ``dataset_dir``, by run id, with each run's source."""
    return {
        run_id: {
            "source": sources.get(run_id, ""),
            "files": {rel: sha256_file(path) for rel, path in sorted(paths.items())},
        }
        for run_id, paths in dataset_files(dataset_dir).items()
    }
