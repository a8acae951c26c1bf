"""Parquet I/O: atomic writes with the resolved config, version and git commit in the schema metadata."""

from __future__ import annotations

import json
import os
import subprocess
from functools import lru_cache
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.cache import __version__

META_CONFIG = b"pm_design.config"
META_VERSION = b"pm_design.version"
META_COMMIT = b"pm_design.git_commit"


@lru_cache(maxsize=1)
def git_commit() -> str:
    """Commit of the source checkout ("unknown" outside git), "-dirty" if it has changes."""
    root = Path(__file__).resolve().parent.parent
    try:
        sha = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True,
                             text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=root,
                               capture_output=True, text=True, check=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return "unknown"
    return sha + ("-dirty" if dirty else "")


def write_parquet(df: pd.DataFrame, path: Path, config: dict) -> Path:
    """Write ``df`` to ``path`` atomically (temporary file, then rename).

    The schema metadata carries the resolved config as JSON (keys sorted),
    the package version and the git commit.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    table = pa.Table.from_pandas(df, preserve_index=False)
    meta = dict(table.schema.metadata or {})
    meta[META_CONFIG] = json.dumps(config, sort_keys=True).encode()
    meta[META_VERSION] = __version__.encode()
    meta[META_COMMIT] = git_commit().encode()
    table = table.replace_schema_metadata(meta)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        pq.write_table(table, tmp)
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()
    return path


def read_metadata(path: Path) -> dict:
    """``{"config": dict, "version": str, "git_commit": str}`` of a file written here."""
    meta = pq.read_schema(path).metadata or {}
    return {"config": json.loads(meta[META_CONFIG]), "version": meta[META_VERSION].decode(),
            "git_commit": meta[META_COMMIT].decode()}
