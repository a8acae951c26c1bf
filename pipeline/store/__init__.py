"""Store layer: Parquet files with their metadata, the run directory's format, the stage cache."""
