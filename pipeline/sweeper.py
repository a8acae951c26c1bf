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
whatever launcher is configured (basic, joblib, submitit).
"""

from __future__ import annotations

import logging
import shutil
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Dict, List, Optional, Sequence

from hydra._internal.core_plugins.basic_sweeper import BasicSweeper
from hydra.errors import HydraException
from hydra.plugins.sweeper import Sweeper
from omegaconf.errors import OmegaConfBaseException

from pipeline.errors import ConfigError, RunError

log = logging.getLogger(__name__)


@dataclass
class CheckedSweeperConf:
    _target_: str = "hydra_plugins.pm_design.checked_sweeper.CheckedSweeper"
    max_batch_size: Optional[int] = None
    params: Optional[Dict[str, str]] = None


def register_sweeper(cs) -> None:
    cs.store(group="hydra/sweeper", name="checked", node=CheckedSweeperConf, provider="pm-design")


def _fail(message: str, code: int = 2) -> None:
    print(f"error: {message}", file=sys.stderr)
    sys.exit(code)


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
        for k, overrides in enumerate(batch):
            label = f"job {k} ({' '.join(overrides)})"
            try:
                cfg = loader.load_sweep_config(master_config=self.config, sweep_overrides=list(overrides))
                validate(cfg)
            except ConfigError as exc:
                _fail(f"{label}: {exc}")
            except (HydraException, OmegaConfBaseException) as exc:
                _fail(f"{label}: {str(exc).strip().splitlines()[0]}")

    def _finish(self, results: list, sweep_dir: Path) -> None:
        from pipeline.aggregate import aggregate
        from pipeline.plot import plot_tradeoff
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
