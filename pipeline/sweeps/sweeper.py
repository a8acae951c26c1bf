"""The sweeper of ``python -m pipeline -m``, on Hydra's public ``Sweeper`` plugin interface.

* **every job is validated before the first computes**: the sweep is expanded
  (:func:`pipeline.config.jobs.sweep_jobs`), each job's config is composed and
  checked (:func:`pipeline.config.validate`); a bad one stops the sweep with
  one line naming the job's overrides and the field, exit 2, nothing written;
  only then are the jobs launched, in batches of ``max_batch_size``;
* a sweep directory that already holds anything is refused (no mixing of
  stale runs into a new sweep), and so is one that cannot be created or written;
* a job that fails at run time does not stop the sweep (the task records it
  in its manifest and returns); at the end the completed jobs are
  aggregated (:func:`finish_sweep`) into ``paths.dataset_dir``, ``tradeoff.png``
  and ``report.html`` in the sweep directory (unless ``hydra.sweeper.report=false``), and a one-line summary is
  printed; the exit status is 1 if any job failed.

It takes the sweep from the command line and from ``hydra.sweeper.params``
(so an experiment file can declare its own sweep), and launches through
whatever launcher is configured (basic, joblib, submitit, ...), knowing
nothing of it: every job gets the sweep's launch id and literal sweep
directory, also in another process. How many fitness workers a job may use is
decided by the job itself, from the cores it is given
(:func:`pipeline.evaluation.worker_count`).
"""

from __future__ import annotations

import logging
import os
import shutil
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from hydra.core.plugins import Plugins
from hydra.core.utils import JobReturn
from hydra.errors import HydraException
from hydra.plugins.sweeper import Sweeper
from hydra.types import HydraContext, TaskFunction
from omegaconf import DictConfig, OmegaConf, open_dict
from omegaconf.errors import OmegaConfBaseException

from pipeline.config.jobs import batches, declared_overrides, sweep_jobs
from pipeline.errors import ConfigError, RunError, check_writable

log = logging.getLogger(__name__)


@dataclass
class CheckedSweeperConf:
    _target_: str = "hydra_plugins.pm_design.checked_sweeper.CheckedSweeper"
    max_batch_size: Optional[int] = None
    params: Optional[dict[str, str]] = None
    #: write ``tradeoff.png`` and ``report.html`` into the sweep folder at its end (the dataset is
    #: written either way); the reproduction document, which draws its own figures, turns it off
    report: bool = True


def _fail(message: str, code: int = 2) -> None:
    print(f"error: {message}", file=sys.stderr)
    sys.exit(code)


#: the commands a SLURM launcher runs (submitit submits with sbatch and detects the cluster by srun)
SLURM_COMMANDS = ("sbatch", "srun")


def check_launcher_here(config: DictConfig) -> None:
    """The configured launcher can run on this machine: a SLURM launcher needs SLURM's commands.
    Otherwise one ``error:`` line and exit 2, before the sweep folder exists (submitit raised a
    traceback after ``multirun.yaml`` was written)."""
    target = str(OmegaConf.select(config, "hydra.launcher._target_", default="") or "")
    if target.endswith("SlurmLauncher"):
        missing = [c for c in SLURM_COMMANDS if shutil.which(c) is None]
        if missing:
            _fail(
                f"hydra/launcher=submitit_slurm is invalid here: no SLURM on this machine ({', '.join(missing)} "
                f"not on PATH); allowed: a SLURM login node, or hydra/launcher=submitit_local, joblib or basic"
            )


def job_label(k: int, overrides: Sequence[str]) -> str:
    return f"job {k} ({' '.join(overrides)})"


class CheckedSweeper(Sweeper):
    """See the module docstring. Hydra calls :meth:`setup`, then :meth:`sweep` with the command line's overrides."""

    def __init__(
        self, max_batch_size: Optional[int] = None, params: Optional[dict[str, str]] = None, report: bool = True
    ) -> None:
        super().__init__()
        self.max_batch_size = max_batch_size
        self.report = report
        self.params = dict(params or {})
        self.hydra_context: Optional[HydraContext] = None
        self.config: Optional[DictConfig] = None
        self.launcher = None

    def setup(self, *, hydra_context: HydraContext, task_function: TaskFunction, config: DictConfig) -> None:
        self.hydra_context = hydra_context
        self.config = config
        self.launcher = Plugins.instance().instantiate_launcher(
            hydra_context=hydra_context, task_function=task_function, config=config
        )

    def sweep(self, arguments: list[str]) -> list[Sequence[JobReturn]]:
        from pipeline.store.runs import LAUNCH_ENV, launch_id

        # one launch id and one literal sweep dir for every job, also for launchers
        # that run jobs in other processes (they would resolve ${run_id:} afresh)
        previous = os.environ.get(LAUNCH_ENV)
        os.environ[LAUNCH_ENV] = launch_id()
        try:
            with open_dict(self.config):
                self.config.hydra.sweep.dir = str(self.config.hydra.sweep.dir)
            sweep_dir = Path(self.config.hydra.sweep.dir)
            if sweep_dir.exists() and any(sweep_dir.iterdir()):
                _fail(
                    f"hydra.sweep.dir={str(sweep_dir)!r} is invalid: it already holds files; "
                    f"allowed: a new directory (the default makes one per launch)"
                )
            try:
                # before any job is composed: the mkdir below would fail after the checks, with a
                # bare OSError (a launch that bypasses the command line's precheck, the reproduction's)
                check_writable("hydra.sweep.dir", sweep_dir)
                jobs = sweep_jobs(declared_overrides(self.params, arguments), self.hydra_context.config_loader)
                planned = batches(jobs, self.max_batch_size)
            except ConfigError as exc:
                _fail(str(exc))
            except (HydraException, OmegaConfBaseException) as exc:
                _fail(str(exc).strip().splitlines()[0])
            self.validate_batch_is_legal(jobs)  # all of them, before the first batch runs
            check_launcher_here(self.config)
            sweep_dir.mkdir(parents=True, exist_ok=True)
            OmegaConf.save(self.config, sweep_dir / "multirun.yaml")
            returns: list[Sequence[JobReturn]] = []
            first = 0
            for batch in planned:
                returns.append(self.launcher.launch(batch, initial_job_idx=first))
                first += len(batch)
        finally:
            if previous is None:
                os.environ.pop(LAUNCH_ENV, None)
            else:
                os.environ[LAUNCH_ENV] = previous
        finish_sweep(
            [r for batch in returns for r in batch], sweep_dir, Path(self.config.paths.dataset_dir), self.report
        )
        return returns

    def validate_batch_is_legal(self, batch: Sequence[Sequence[str]]) -> None:
        """Compose and validate each job's config; the first bad one: one ``error:`` line, exit 2."""
        from pipeline.config import validate

        loader = self.hydra_context.config_loader
        for k, overrides in enumerate(batch):
            try:
                validate(loader.load_sweep_config(master_config=self.config, sweep_overrides=list(overrides)))
            except ConfigError as exc:
                _fail(f"{job_label(k, overrides)}: {exc}")
            except (HydraException, OmegaConfBaseException) as exc:
                _fail(f"{job_label(k, overrides)}: {str(exc).strip().splitlines()[0]}")


def job_status(result: JobReturn) -> tuple[bool, str]:
    """(completed, reason of the failure) of one job: its task's returned status, or the exception it raised."""
    try:
        value = result.return_value
    except Exception as exc:  # noqa: BLE001 - a job's own failure, reported in the summary line
        return False, f"{type(exc).__name__}: {exc}"
    status = value if isinstance(value, dict) else {}
    if status.get("status") == "complete":
        return True, ""
    return False, str(status.get("reason", "no result"))


def finish_sweep(results: Sequence[JobReturn], sweep_dir: Path, dataset: Path, report: bool = True) -> None:
    """Aggregate the completed jobs into ``dataset``, write ``tradeoff.png`` and ``report.html``
    into ``sweep_dir`` (``report``), log the summary; one ``error:`` line and exit 1 if any job failed."""
    from pipeline.report import write_report
    from pipeline.stages.aggregate import aggregate
    from pipeline.stages.plot import plot_tradeoff

    failed = []
    for k, result in enumerate(results):
        completed, reason = job_status(result)
        if not completed:
            failed.append(f"{job_label(k, result.overrides)}: {reason}")
    completed = len(results) - len(failed)
    if completed:
        try:
            added = aggregate(sweep_dir, dataset)
            if report:
                if added.best is not None:
                    plot_tradeoff(added.best, sweep_dir / "tradeoff.png")
                write_report(sweep_dir)
        except (ConfigError, RunError) as exc:
            _fail(f"aggregation of {sweep_dir}: {exc}", 1)
    summary = f"{completed} of {len(results)} jobs completed"
    if failed:
        _fail(f"{summary}; failed: {'; '.join(failed)}", 1)
    log.info("%s; dataset %s", summary, dataset)
    shown = f"report: {sweep_dir / 'report.html'}\n" if report else ""
    print(
        f"sweep: {sweep_dir}\n{shown}"
        f"dataset: {dataset} (from pipeline.store import read_dataset; read_dataset({str(dataset)!r}))"
    )
