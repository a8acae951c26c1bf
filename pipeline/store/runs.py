"""The run directory's format: its manifest, its result tables, and the launch id that names it.

A run directory holds ``manifest.json`` (written first as ``running`` and
rewritten last as ``complete``, ``failed`` or ``interrupted``) and one Parquet
file per table of :data:`TABLES`. Everything that reads or checks run
directories (the study, aggregation, the report) takes the format from here.
"""

from __future__ import annotations

import json
import os
import secrets
from datetime import datetime
from functools import lru_cache
from pathlib import Path

from pipeline.errors import ConfigError

MANIFEST = "manifest.json"
TABLES = ("best", "history", "designs", "front")


def read_manifest(run_dir: Path) -> dict | None:
    """The manifest of a run directory, or None (absent or unreadable)."""
    try:
        return json.loads((Path(run_dir) / MANIFEST).read_text())
    except (OSError, ValueError):
        return None


def check_run_dir(run_dir: Path) -> None:
    """Refuse a directory that already holds a run (one line); results are never replaced."""
    manifest = read_manifest(run_dir)
    if manifest is not None or any(Path(run_dir).glob("*.parquet")):
        held = manifest.get("run_id", "?") if manifest else "results"
        raise ConfigError(
            f"hydra.run.dir={str(run_dir)!r} is invalid: it already holds run {held}; "
            f"allowed: a new directory (the default makes one per launch)"
        )


#: environment variable carrying a sweep's launch id to jobs run in other processes
#: (joblib, submitit and SLURM launchers), set by the sweeper for the sweep's duration
LAUNCH_ENV = "PM_DESIGN_LAUNCH_ID"


def launch_id() -> str:
    """This launch's id: time, process id and a random token (unique even within one second).

    Inside a sweep it is the sweep's id (``PM_DESIGN_LAUNCH_ID``), whichever
    process runs the job, so every job of the sweep lands in one sweep
    directory; otherwise this process's id, cached so every use within one
    process (run dir, sweep dir, manifests) agrees.
    """
    return os.environ.get(LAUNCH_ENV) or _process_launch_id()


@lru_cache(maxsize=1)
def _process_launch_id() -> str:
    return f"{datetime.now():%Y-%m-%d_%H-%M-%S}_{os.getpid()}_{secrets.token_hex(3)}"
