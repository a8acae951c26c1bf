"""Checksums of the files of a dataset: a registry ``checksums.json`` at the dataset's top.

``{"runs": {run_id: {"source": run directory, "files": {"<table>/<run_id>.parquet": sha256}}}}``.
Aggregation verifies every recorded file before it counts a run as present
(:mod:`pipeline.stages.aggregate`), so a truncated, altered or deleted file
is found and rebuilt from its source run instead of being served.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path

from pipeline.store.parquet import write_text

REGISTRY = "checksums.json"


def sha256_file(path: Path) -> str:
    """SHA-256 (hex) of a file's bytes, read in 1 MiB blocks."""
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def read_registry(dataset_dir: Path) -> dict[str, dict] | None:
    """``{run_id: {"source": ..., "files": {relative path: sha256}}}``; None when absent or unreadable."""
    try:
        data = json.loads((Path(dataset_dir) / REGISTRY).read_text())
        runs = data["runs"]
        return runs if isinstance(runs, dict) else None
    except (OSError, ValueError, KeyError, TypeError):
        return None


def write_registry(dataset_dir: Path, runs: dict[str, dict]) -> None:
    """Write the registry atomically (:class:`~pipeline.errors.RunError` on failure)."""
    write_text(Path(dataset_dir) / REGISTRY, json.dumps({"runs": runs}, indent=1, sort_keys=True))
