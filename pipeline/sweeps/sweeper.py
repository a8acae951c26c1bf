"""The sweeper of ``python -m pipeline -m``: Hydra's basic sweeper, made safe for datasets.

* **every job is validated before the first computes**: each job's config is
  composed and checked (:func:`pipeline.config.validate`); a bad one stops
  the sweep with one line naming the job's overrides and the field, exit 2,
  nothing written;
* a sweep directory that already holds anything is refused (no mixing of
  stale runs into a new sweep);
* a job that fails at run time does not stop the sweep (the task records it
  in its manifest and returns); at the end the completed jobs are
  aggregated into ``paths.dataset_dir``, ``tradeoff.png`` and ``report.html``
  (:mod:`pipeline.report`) are written into the sweep directory, and a
  one-line summary is printed; the exit status is 1 if any job failed.

It takes the sweep from the command line and from ``hydra.sweeper.params``
(so an experiment file can declare its own sweep), and launches through
whatever launcher is configured (basic, joblib, submitit): every job gets the
sweep's launch id and literal sweep directory, also in another process, and a
launcher running jobs side by side must leave one core per worker
(jobs x ``parallel.n_jobs`` <= cores; SLURM: ``parallel.n_jobs`` <= ``cpus_per_task``).
"""

from __future__ import annotations

import logging
import os
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from hydra._internal.core_plugins.basic_sweeper import BasicSweeper
from hydra.errors import HydraException
from hydra.plugins.sweeper import Sweeper
from omegaconf import open_dict
from omegaconf.errors import OmegaConfBaseException

from pipeline.errors import ConfigError, RunError

log = logging.getLogger(__name__)


@dataclass
class CheckedSweeperConf:
    _target_: str = "hydra_plugins.pm_design.checked_sweeper.CheckedSweeper"
    max_batch_size: Optional[int] = None
    params: Optional[Dict[str, str]] = None


def _fail(message: str, code: int = 2) -> None:
    print(f"error: {message}", file=sys.stderr)
    sys.exit(code)


def _launcher_kind(launcher) -> str:
    return str(launcher.get("_target_", "")).rsplit(".", 1)[-1]


def jobs_side_by_side(launcher, n_jobs_in_batch: int) -> int:
    """How many jobs of a batch the configured launcher runs at once on this machine.

    Basic launcher: 1. Hydra's joblib launcher: its ``n_jobs`` (joblib's
    convention: -1 = every core). submitit's local launcher: every job of the
    batch. SLURM: 1 per allocation (jobs run on their own CPUs).
    """
    kind = _launcher_kind(launcher)
    cores = os.cpu_count() or 1
    if kind == "JoblibLauncher":
        n = int(launcher.get("n_jobs") or 1)
        n = cores + 1 + n if n < 0 else n
        return max(1, min(n, n_jobs_in_batch))
    if kind == "LocalLauncher":
        return max(1, n_jobs_in_batch)
    return 1


def check_workers(launcher, side_by_side: int, workers: int) -> None:
    """jobs side by side x ``parallel.n_jobs`` <= cores (SLURM: ``parallel.n_jobs`` <= cpus_per_task).

    Raises
    ------
    ConfigError
        One line naming ``parallel.n_jobs`` and the largest allowed value.
    """
    kind = _launcher_kind(launcher)
    if kind == "SlurmLauncher":
        cpus = launcher.get("cpus_per_task")
        if cpus is not None and workers > int(cpus):
            raise ConfigError(f"parallel.n_jobs={workers} is invalid: allowed <= "
                              f"hydra.launcher.cpus_per_task={cpus} (the CPUs of one SLURM task)")
        return
    cores = os.cpu_count() or 1
    allowed = max(1, cores // side_by_side)
    if side_by_side > 1 and workers > allowed:
        raise ConfigError(f"parallel.n_jobs={workers} is invalid: the launcher runs {side_by_side} jobs "
                          f"side by side on {cores} cores; allowed <= {allowed} "
                          f"(jobs x parallel.n_jobs <= cores)")


class CheckedSweeper(BasicSweeper):
    def __init__(self, max_batch_size: Optional[int], params: Optional[Dict[str, str]] = None) -> None:
        # BasicSweeper.__init__ calls super(BasicSweeper, self), which fails once Hydra's plugin
        # scan has re-executed its module (a new BasicSweeper class object); set its fields here
        Sweeper.__init__(self)
        self.overrides = None
        self.batch_index = 0
        self.max_batch_size = max_batch_size
        self.params = params or {}
        self.hydra_context = None
        self.config = None
        self.launcher = None

    def sweep(self, arguments: List[str]) -> Any:
        from pipeline.store.runs import LAUNCH_ENV, launch_id

        # one launch id and one literal sweep dir for every job, also for launchers
        # that run jobs in other processes (they would resolve ${run_id:} afresh)
        previous = os.environ.get(LAUNCH_ENV)
        os.environ[LAUNCH_ENV] = launch_id()
        try:
            with open_dict(self.config):
                self.config.hydra.sweep.dir = str(self.config.hydra.sweep.dir)
            return self._sweep(arguments)
        finally:
            if previous is None:
                os.environ.pop(LAUNCH_ENV, None)
            else:
                os.environ[LAUNCH_ENV] = previous

    def _sweep(self, arguments: List[str]) -> Any:
        sweep_dir = Path(self.config.hydra.sweep.dir)
        if sweep_dir.exists() and any(sweep_dir.iterdir()):
            _fail(f"hydra.sweep.dir={str(sweep_dir)!r} is invalid: it already holds files; "
                  f"allowed: a new directory (the default makes one per launch)")
        created = not sweep_dir.exists()
        try:
            returns = super().sweep(arguments)
        except SystemExit:
            if created and sweep_dir.exists() and {p.name for p in sweep_dir.iterdir()} <= {"multirun.yaml"}:
                shutil.rmtree(sweep_dir, ignore_errors=True)
            raise
        self._finish([r for batch in returns for r in batch], sweep_dir)
        return returns

    def validate_batch_is_legal(self, batch: Sequence[Sequence[str]]) -> None:
        from pipeline.config import validate

        loader = self.hydra_context.config_loader
        launcher = self.config.hydra.launcher
        side_by_side = jobs_side_by_side(launcher, len(batch))
        for k, overrides in enumerate(batch):
            label = f"job {k} ({' '.join(overrides)})"
            try:
                cfg = loader.load_sweep_config(master_config=self.config, sweep_overrides=list(overrides))
                typed = validate(cfg)
                check_workers(launcher, side_by_side, typed.parallel.n_jobs)
            except ConfigError as exc:
                _fail(f"{label}: {exc}")
            except (HydraException, OmegaConfBaseException) as exc:
                _fail(f"{label}: {str(exc).strip().splitlines()[0]}")

    def _finish(self, results: list, sweep_dir: Path) -> None:
        from pipeline.stages.aggregate import aggregate
        from pipeline.stages.plot import plot_tradeoff
        from pipeline.report import write_report

        failed = []
        for k, r in enumerate(results):
            status = r.return_value if isinstance(r.return_value, dict) else {}
            if status.get("status") != "complete":
                failed.append(f"job {k} ({' '.join(r.overrides)}): {status.get('reason', 'no result')}")
        completed = len(results) - len(failed)
        if completed:
            dataset = Path(self.config.paths.dataset_dir)
            try:
                report = aggregate(sweep_dir, dataset)
                if report.best is not None:
                    plot_tradeoff(report.best, sweep_dir / "tradeoff.png")
                write_report(sweep_dir)
            except (ConfigError, RunError) as exc:
                _fail(f"aggregation of {sweep_dir}: {exc}", 1)
        summary = f"{completed} of {len(results)} jobs completed"
        if failed:
            _fail(f"{summary}; failed: {'; '.join(failed)}", 1)
        log.info("%s; dataset %s", summary, self.config.paths.dataset_dir)
        print(f"sweep: {sweep_dir}\nreport: {sweep_dir / 'report.html'}\n"
              f"dataset: {self.config.paths.dataset_dir} "
              f"(from pipeline.store import read_dataset; read_dataset({str(self.config.paths.dataset_dir)!r}))")
