"""Store layer: Parquet files with their metadata, the run directory's format, the stage cache,
and :func:`read_dataset` (a dataset table with its units in ``df.attrs``)."""

from pipeline.store.dataset import read_dataset

__all__ = ["read_dataset"]
