"""Reading the aggregated dataset back: :func:`read_dataset` (``from pipeline.store import read_dataset``).

``pd.read_parquet`` works on every table folder, but drops the Arrow field
metadata (each column's unit and meaning). :func:`read_dataset` keeps it:
``df.attrs["units"]`` maps column -> unit ("" for keys and text),
``df.attrs["descriptions"]`` column -> meaning, ``df.attrs["metadata"]`` the
schema metadata of the table's first file (package version, git commit). It
also leaves debug runs (``purpose == "debug"``, the ``+debug`` presets) out
unless asked, so quick looks never mix into a study's numbers.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq

from pipeline.errors import ConfigError

#: tables of a dataset (``<dataset>/<table>/<run_id>.parquet``)
DATASET_TABLES = ("best", "history", "designs", "front", "runs")
#: purposes shown by default (:data:`pipeline.config.schema.PURPOSES` minus debug)
DEFAULT_PURPOSES = ("study", "benchmark")


def read_dataset(
    path: str | Path = "outputs/dataset", table: str = "best", purposes: tuple[str, ...] | None = DEFAULT_PURPOSES
) -> pd.DataFrame:
    """One table of a dataset as a DataFrame, with units in ``df.attrs``.

    Parameters
    ----------
    path : str or Path
        The dataset directory (``paths.dataset_dir``; default ``outputs/dataset``).
    table : str
        ``best`` (one row per run), ``history``, ``designs``, ``front`` or ``runs``.
    purposes : tuple of str or None
        Runs kept by their ``purpose`` column (default: studies and benchmarks, no
        debug runs); None keeps every run. A :class:`UserWarning` says so where this
        leaves no row of a table that has rows (a dataset of ``+debug`` runs only).

    Raises
    ------
    ConfigError
        One line when ``table`` is not a table name or the folder holds no such table.
    """
    if table not in DATASET_TABLES:
        raise ConfigError(f"table={table!r} is invalid: allowed {', '.join(DATASET_TABLES)}")
    folder = Path(path) / table
    files = sorted(folder.glob("*.parquet")) if folder.is_dir() else []
    if not files:
        raise ConfigError(
            f"dataset={str(path)!r} is invalid: no {table} table in it (no runs aggregated yet?); "
            f"allowed: a dataset directory (paths.dataset_dir)"
        )
    arrow = pq.read_table(folder)
    df = arrow.to_pandas()
    if purposes is not None and "purpose" in df.columns:
        purpose = df["purpose"].astype(str)
        df = df[purpose.isin(purposes)].reset_index(drop=True)
        if len(purpose) and df.empty:  # an empty frame alone reads as "nothing ran"
            left_out = ", ".join(sorted(set(purpose) - set(purposes)))
            warnings.warn(
                f"read_dataset: all {len(purpose)} rows of {table} are {left_out} runs, left out by "
                f"purposes={tuple(purposes)}; purposes=None keeps them",
                UserWarning,
                stacklevel=2,
            )
    schema = pq.read_schema(files[0])
    df.attrs["units"] = {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema}
    df.attrs["descriptions"] = {f.name: (f.metadata or {}).get(b"description", b"").decode() for f in schema}
    df.attrs["metadata"] = {
        k.decode(): v.decode() for k, v in (schema.metadata or {}).items() if k != b"pm_design.config"
    }
    return df
