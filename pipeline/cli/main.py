"""The command line: ``pm-design`` / ``python -m pipeline`` ``[+experiment=NAME] [key=value ...]``.

Subcommands, dispatched before Hydra (``pm-design --help`` lists them):
``evaluate`` (one given design: V, GDI, SURI, η), ``aggregate`` (runs into
the dataset) and ``report`` (``report.html`` of a sweep or dataset).

The top layer: it checks a single run's overrides before Hydra creates
anything (one ``error:`` line, exit 2), hands the run to Hydra, and turns
the study's outcome into an exit status: 0 complete, 1 failed at run time,
2 bad input, 130 interrupted, 143 terminated (SIGTERM, handled like Ctrl-C). A sweep (``-m``) goes through Hydra's sweeper
(:mod:`pipeline.sweeps`), and each of its jobs through the same task
(:func:`pipeline.study.task.run_from_hydra`; the reproduction launches its sweeps with it too).
"""

from __future__ import annotations

import gc
import logging
import os
import signal
import sys

import hydra
from hydra.errors import HydraException
from omegaconf import DictConfig
from omegaconf.errors import OmegaConfBaseException

from kinematics.plugins import PluginError
from pipeline.cli.commands import one_line, subcommand
from pipeline.cli.precheck import precheck_overrides
from pipeline.config import CONFIG_DIR, register_configs
from pipeline.errors import ConfigError, RunError, Terminated, describe_fault
from pipeline.evaluation import pool
from pipeline.study.task import Interrupted, run_from_hydra

log = logging.getLogger(__name__)


def shutdown_workers() -> None:
    """End the fitness workers and joblib's reusable ones (after Ctrl-C, so none outlives the run)."""
    pool.shutdown_pools(kill=True)
    try:
        from joblib.externals.loky import get_reusable_executor

        get_reusable_executor().shutdown(wait=False, kill_workers=True)
    except Exception:  # noqa: BLE001 - best effort at exit; the process is ending anyway
        pass


def _on_sigterm(signum: int, frame: object) -> None:
    raise Terminated()


def _exit_on_interrupt(exc: KeyboardInterrupt) -> None:
    """One line and exit 130 (Ctrl-C) or 143 (SIGTERM); the workers are ended first."""
    shutdown_workers()
    cause = exc.cause if isinstance(exc, Interrupted) else exc
    what, code = ("terminated (SIGTERM)", 143) if isinstance(cause, Terminated) else ("interrupted", 130)
    where = f"; {exc.run_dir} is marked interrupted and will not be aggregated" if isinstance(exc, Interrupted) else ""
    print(f"error: {what}{where}", file=sys.stderr)
    sys.exit(code)


try:
    register_configs()
except PluginError:  # a broken plug-in: entry() registers again and reports it in one line
    pass


@hydra.main(version_base="1.3", config_path=str(CONFIG_DIR), config_name="config")
def main(cfg: DictConfig) -> dict:
    return run_from_hydra(cfg)


def entry() -> None:
    """The console script: subcommands and ``--help``, else the one-line precheck of a run, then
    Hydra; every failure one ``error:`` line.

    Exit status: 0 complete, 1 a fault at run time (disk full, ...), 2 bad
    input, 130 Ctrl-C, 143 SIGTERM (``timeout``, SLURM); an interrupted run's
    manifest says ``interrupted``. ``HYDRA_FULL_ERROR=1`` keeps Hydra's own
    tracebacks for debugging.
    """
    full_error = os.environ.get("HYDRA_FULL_ERROR") == "1"
    # Why: Hydra prints its own multi-line report of an error (a bad override under -m, a
    # config file it cannot save); with this, the error reaches the handlers below instead
    os.environ["HYDRA_FULL_ERROR"] = "1"
    # Why: a full disk must not print a traceback for every log record the log file refuses
    logging.raiseExceptions = False
    signal.signal(signal.SIGTERM, _on_sigterm)
    try:
        register_configs()
        code = subcommand(sys.argv[1:])
        if code is not None:
            sys.exit(code)
        precheck_overrides(sys.argv[1:])
        main()
    except KeyboardInterrupt as exc:
        _exit_on_interrupt(exc)
    except PluginError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    except (ConfigError, HydraException, OmegaConfBaseException) as exc:
        if full_error:
            raise
        print(f"error: {one_line(exc)}", file=sys.stderr)
        sys.exit(2)
    except (OSError, RunError) as exc:
        if full_error:
            raise
        print(f"error: {describe_fault(exc)}", file=sys.stderr)
        sys.exit(1)
    finally:
        # Why: by now every result is written; what remains is Python's teardown, whose
        # garbage collections walk every object of ~1,000 modules (numba, pandas, matplotlib):
        # ~0.5 s of every command. Frozen objects are skipped; the exit is otherwise the usual
        # one (exit handlers, workers ended, streams flushed).
        gc.disable()
        gc.freeze()
