"""The command line: ``pm-design`` / ``python -m pipeline`` ``[+experiment=NAME] [key=value ...]``.

The top layer: it checks a single run's overrides before Hydra creates
anything (one ``error:`` line, exit 2), hands the run to Hydra, and turns
the study's outcome into an exit status: 0 complete, 1 failed at run time,
2 bad input, 130 interrupted. A sweep (``-m``) goes through Hydra's sweeper
(:mod:`pipeline.sweeps`), and each of its jobs through the same task.
"""

from __future__ import annotations

import gc
import logging
import sys
from pathlib import Path

import hydra
from hydra.core.hydra_config import HydraConfig
from hydra.types import RunMode
from omegaconf import DictConfig
from omegaconf.errors import OmegaConfBaseException

from pipeline.config import CONFIG_DIR, register_configs, validate
from pipeline.errors import ConfigError, RunError, check_writable
from pipeline.evaluation import workers
from pipeline.store.runs import check_run_dir
from pipeline.study import run_study

log = logging.getLogger(__name__)


def one_line(exc: BaseException) -> str:
    """A Hydra or OmegaConf error as one line: its first line, plus the options it lists."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    if not lines:
        return type(exc).__name__
    text = lines[0]
    if any(ln.startswith("Available options") for ln in lines):
        start = next(k for k, ln in enumerate(lines) if ln.startswith("Available options")) + 1
        options = [ln for ln in lines[start:] if not ln.startswith(("Config search path", "provider="))]
        options = [ln.split()[0] for ln in options if ln and ":" not in ln]
        text += f"; allowed: {', '.join(options)}"
    elif len(lines) > 1 and not lines[1].startswith(("full_key", "object_type", "reference_type")):
        text += f": {lines[1]}"
    elif exc.__cause__ is not None and str(exc.__cause__).strip():
        text += f": {str(exc.__cause__).strip().splitlines()[0]}"
    return text


def precheck_overrides(argv: list[str]) -> None:
    """Compose and check a single run's config before Hydra creates anything (one line, exit 2).

    Catches composition errors (unknown group option, bad type), every
    :func:`validate` error, an unwritable or already used ``hydra.run.dir``.

    Skipped when any Hydra flag is given (``-m``, ``--help``, ...): Hydra
    handles those, and a sweep's jobs are checked by the sweeper.
    """
    if any(arg.startswith("-") for arg in argv):
        return
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException


    register_configs()
    try:
        with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
            cfg = compose(config_name="config", overrides=list(argv), return_hydra_config=True)
        validate(cfg)
        run_dir = Path(cfg.hydra.run.dir)
        check_writable("hydra.run.dir", run_dir)
        check_run_dir(run_dir)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    except (HydraException, OmegaConfBaseException, ValueError) as exc:
        print(f"error: {one_line(exc)}", file=sys.stderr)
        sys.exit(2)




def remove_if_empty(path: Path, levels: int = 3) -> None:
    """Hydra creates the run directory (and its parents) before the task starts; remove the
    empty ones it made (the run directory and up to ``levels - 1`` empty parents)."""
    for _ in range(levels):
        try:
            path.rmdir()
        except OSError:
            return
        path = path.parent


def shutdown_workers() -> None:
    """End the fitness workers and joblib's reusable ones (after Ctrl-C, so none outlives the run)."""
    workers.shutdown_workers(kill=True)
    try:
        from joblib.externals.loky import get_reusable_executor

        get_reusable_executor().shutdown(wait=False, kill_workers=True)
    except Exception:  # noqa: BLE001 - best effort at exit; the process is ending anyway
        pass


def run_from_hydra(cfg: DictConfig) -> dict:
    """The task of ``python -m pipeline``: one run, its failure reported as one line.

    Single run: bad input exits 2, a run-time failure 1, Ctrl-C 130, each with
    one ``error:`` line and no traceback. In a multirun a run-time failure is
    returned as the job's status so the other jobs go on
    (:class:`pipeline.sweeps.sweeper.CheckedSweeper` sums them up).
    """
    hc = HydraConfig.get()
    run_dir = Path(hc.runtime.output_dir)
    multirun = hc.mode == RunMode.MULTIRUN
    job = int(hc.job.num) if multirun else 0
    try:
        run_study(cfg, run_dir, job, list(hc.overrides.task))
        return {"status": "complete", "reason": ""}
    except (ConfigError, RunError) as exc:
        if isinstance(exc, ConfigError):
            remove_if_empty(run_dir)
        if multirun:
            log.error("job %d failed: %s", job, exc)
            return {"status": "failed", "reason": str(exc)}
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2 if isinstance(exc, ConfigError) else 1)
    except KeyboardInterrupt:
        shutdown_workers()
        print(f"error: interrupted; {run_dir} is marked interrupted and will not be aggregated", file=sys.stderr)
        sys.exit(130)


register_configs()


@hydra.main(version_base="1.3", config_path=str(CONFIG_DIR), config_name="config")
def main(cfg: DictConfig) -> dict:
    return run_from_hydra(cfg)


def entry() -> None:
    """The console script: the one-line precheck of a single run, then Hydra."""
    try:
        precheck_overrides(sys.argv[1:])
        main()
    finally:
        # Why: by now every result is written; what remains is Python's teardown, whose
        # garbage collections walk every object of ~1,000 modules (numba, pandas, matplotlib):
        # ~0.5 s of every command. Frozen objects are skipped; the exit is otherwise the usual
        # one (exit handlers, workers ended, streams flushed).
        gc.disable()
        gc.freeze()
