"""The Hydra task of one run or one job of a multirun: :func:`run_from_hydra`.

What ``python -m pipeline`` runs for a single run and for every job of a sweep
(through whatever launcher), and what the reproduction document launches its
sweeps with (:mod:`pipeline.reproduction.launch`): one :func:`pipeline.study.run_study`
into Hydra's output directory, its failure turned into one line (single run) or
into the job's returned status (multirun), an interrupt into :class:`Interrupted`.
"""

from __future__ import annotations

import logging
import os
import sys
from pathlib import Path

from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig

from pipeline.errors import ConfigError, RunError
from pipeline.stages.aggregate import aggregate
from pipeline.study.run import run_study

log = logging.getLogger(__name__)


def remove_if_empty(path: Path, levels: int = 3) -> None:
    """Hydra creates the run directory (and its parents) before the task starts; remove the
    empty ones it made (the run directory and up to ``levels - 1`` empty parents)."""
    for _ in range(levels):
        try:
            path.rmdir()
        except OSError:
            return
        path = path.parent


def run_from_hydra(cfg: DictConfig) -> dict:
    """The task of ``python -m pipeline``: one run, its failure reported as one line.

    Single run: bad input exits 2, a run-time failure 1, Ctrl-C 130, SIGTERM
    143, each with one ``error:`` line and no traceback. In a multirun a
    run-time failure is returned as the job's status so the other jobs go on
    (:class:`pipeline.sweeps.sweeper.CheckedSweeper` sums them up); an
    interrupt ends the sweep.
    """
    guard_log_files()
    hc = HydraConfig.get()
    run_dir = Path(hc.runtime.output_dir)
    multirun = hc.mode == RunMode.MULTIRUN
    job = int(hc.job.num) if multirun else 0
    try:
        run_study(cfg, run_dir, job, list(hc.overrides.task))
        if not multirun:  # a sweep aggregates its jobs at its end (pipeline.sweeps)
            dataset = Path(cfg.paths.dataset_dir)
            aggregate(run_dir, dataset)
            shown = os.path.relpath(run_dir) if run_dir.is_absolute() else str(run_dir)
            print(
                f"run: {shown}\ndataset: {dataset} "
                f"(from pipeline.store import read_dataset; read_dataset({str(dataset)!r}))"
            )
        return {"status": "complete", "reason": ""}
    except (ConfigError, RunError) as exc:
        if isinstance(exc, ConfigError):
            remove_if_empty(run_dir)
        if multirun:
            log.error("job %d failed: %s", job, exc)
            return {"status": "failed", "reason": str(exc)}
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2 if isinstance(exc, ConfigError) else 1)
    except KeyboardInterrupt as exc:
        raise Interrupted(run_dir, exc) from None


def guard_log_files() -> None:
    """Make the log files Hydra set up drop a record they cannot write instead of raising.

    Why: ``logging.FileHandler`` opens its file (``delay: true``) outside its
    own error handling, so on a full disk the first log call of the run
    raised ``OSError`` from wherever it was made, even while the failure was
    being recorded. With ``logging.raiseExceptions = False`` the record is dropped silently.
    """
    for logger in (logging.getLogger(), logging.getLogger("pipeline")):
        for handler in logger.handlers:
            if isinstance(handler, logging.FileHandler) and not getattr(handler, "_pm_guarded", False):
                handler.emit = _guarded_emit(handler, handler.emit)
                handler._pm_guarded = True


def _guarded_emit(handler: logging.Handler, emit):
    def emit_or_drop(record: logging.LogRecord) -> None:
        try:
            emit(record)
        except OSError:
            handler.handleError(record)

    return emit_or_drop


class Interrupted(KeyboardInterrupt):
    """An interrupt of the run in ``run_dir`` (its manifest says ``interrupted``)."""

    def __init__(self, run_dir: Path, cause: KeyboardInterrupt) -> None:
        super().__init__(str(run_dir))
        self.run_dir, self.cause = run_dir, cause
