"""How the dataset is written: each run's tables keyed by its ids, one unified schema per table,
built in a staging copy and swapped in by renaming, under an exclusive lock.

:func:`build_and_swap` is the all-or-nothing step of :func:`pipeline.stages.aggregate.aggregate`
(which decides what to add, keep, repair or remove); on any error the previous dataset is left as
it was.
"""

from __future__ import annotations

import fcntl
import os
import secrets
import shutil
from contextlib import contextmanager
from pathlib import Path

import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pipeline.config import study_hash
from pipeline.errors import RunError
from pipeline.stages.dataset_checks import dataset_files, registry_entries
from pipeline.store.checksums import write_registry
from pipeline.store.parquet import column_unit, to_table, write_table
from pipeline.store.runs import TABLES

DATASET_TABLES = (*TABLES, "runs")


def unify(schemas: list[pa.Schema]) -> pa.Schema:
    """Union of the schemas' fields (first occurrence's metadata; numeric types promoted)."""
    plain = [pa.schema(list(s), metadata=None) for s in schemas]
    return pa.unify_schemas(plain, promote_options="permissive")


def conform(table: pa.Table, schema: pa.Schema) -> pa.Table:
    """``table`` with exactly ``schema``'s fields, in its order: absent columns null, types cast."""
    present = set(table.column_names)
    arrays = [
        table.column(f.name).cast(f.type) if f.name in present else pa.nulls(table.num_rows, f.type) for f in schema
    ]
    return pa.Table.from_arrays(arrays, schema=pa.schema(list(schema), metadata=table.schema.metadata))


@contextmanager
def locked(dataset_dir: Path):
    lock_path = dataset_dir.parent / f".{dataset_dir.name}.lock"
    with open(lock_path, "w") as handle:
        fcntl.flock(handle, fcntl.LOCK_EX)
        try:
            yield
        finally:
            fcntl.flock(handle, fcntl.LOCK_UN)


def with_run_ids(table: pa.Table, manifest: dict) -> pa.Table:
    """``table`` (one of a run's) with the run's ids from its ``manifest`` as leading columns, as the
    dataset stores them: run, launch and job, ``purpose`` and ``study_hash``."""
    ids = {
        "run_id": manifest["run_id"],
        "launch_id": manifest["launch_id"],
        "job": int(manifest["job"]),
        # runs recorded before the field existed were made as studies
        "purpose": str((manifest.get("config") or {}).get("purpose", "study")),
        # which runs are one study's seeds and w_d points (the report's and the figures' groups)
        "study_hash": study_hash(manifest["config"]) if manifest.get("config") else "",
    }
    for k, (name, value) in enumerate(ids.items()):
        typ = pa.int64() if name == "job" else pa.string()
        unit, meaning = column_unit(name)
        field = pa.field(name, typ, metadata={b"unit": unit.encode(), b"description": meaning.encode()})
        table = table.add_column(k, field, pa.array([value] * table.num_rows, typ))
    return table


def _run_tables(run: Path, manifest: dict, best: pa.Table) -> dict[str, pa.Table]:
    """The run's tables with its ids as leading columns, and its ``runs`` row (``best``: already read)."""
    out = {}
    for table in TABLES:
        path = run / f"{table}.parquet"
        if table != "best" and not path.exists():
            continue
        out[table] = with_run_ids(best if table == "best" else pq.read_table(path), manifest)
    best = out["best"].slice(0, 1).to_pandas()
    runs = pd.DataFrame(
        [
            {
                **{k: best[k].iloc[0] for k in ("run_id", "launch_id", "job", "purpose", "study_hash")},
                "config_hash": manifest["config_hash"],
                **{k: best[k].iloc[0] for k in ("experiment", "mechanism", "objective", "w_d", "optimizer", "seed")},
                "status": manifest["status"],
                "wall_time": float(manifest["timings"].get("total", 0.0)),
                "overrides": " ".join(manifest.get("overrides", [])),
                "code_version": manifest.get("code_version", ""),
                "git_commit": manifest.get("git_commit", ""),
                "source": str(run),
            }
        ]
    )
    out["runs"] = to_table(runs)
    return out


def build_and_swap(
    dataset_dir: Path,
    new: list[tuple[Path, dict]],
    best_tables: dict[str, pa.Table],
    remove: set[str] = frozenset(),
    sources: dict[str, str] | None = None,
) -> None:
    """Build the new dataset in a staging copy (``remove``: run ids whose files are dropped
    first; ``new``: runs added), record every file's checksum, swap it in."""
    token = secrets.token_hex(4)
    staging = dataset_dir.parent / f".{dataset_dir.name}.staging-{token}"
    try:
        if dataset_dir.exists():
            shutil.copytree(dataset_dir, staging)
        else:
            staging.mkdir(parents=True)
        for run_id in remove:
            for path in dataset_files(staging).get(run_id, {}).values():
                path.unlink()
        tables = [(m, _run_tables(run, m, best_tables[m["run_id"]])) for run, m in new]
        for name in DATASET_TABLES:
            fresh = [(m, t[name]) for m, t in tables if name in t]
            if not fresh:
                continue
            folder = staging / name
            folder.mkdir(exist_ok=True)
            old_files = sorted(folder.glob("*.parquet"))
            schemas = ([pq.read_schema(old_files[0])] if old_files else []) + [t.schema for _, t in fresh]
            schema = _with_field_metadata(unify(schemas), schemas)
            if old_files and not pq.read_schema(old_files[0]).equals(schema, check_metadata=False):
                for path in old_files:  # a new column: every file takes the unified schema
                    write_table(conform(pq.read_table(path), schema), path)
            for manifest, table in fresh:
                write_table(conform(table, schema), folder / f"{manifest['run_id']}.parquet", manifest["config"])
        write_registry(staging, registry_entries(staging, sources or {}))
        if dataset_dir.exists():
            old = dataset_dir.parent / f".{dataset_dir.name}.old-{token}"
            os.rename(dataset_dir, old)
            try:
                os.rename(staging, dataset_dir)
            except OSError:
                os.rename(old, dataset_dir)
                raise
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.rename(staging, dataset_dir)
    except OSError as exc:
        raise RunError(f"aggregate into {dataset_dir} failed, dataset unchanged: {exc.strerror or exc}") from None
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _with_field_metadata(schema: pa.Schema, sources: list[pa.Schema]) -> pa.Schema:
    """Give each unified field the unit metadata it has in the first schema that holds it."""
    meta = {}
    for s in sources:
        for f in s:
            meta.setdefault(f.name, f.metadata)
    return pa.schema([f.with_metadata(meta.get(f.name)) for f in schema])
