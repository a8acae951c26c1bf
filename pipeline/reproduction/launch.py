"""A multirun launched from Python the way ``python -m pipeline -m OVERRIDES`` launches it.

:func:`multirun` composes the config with Hydra's compose API, lets Hydra's
plugin discovery instantiate the sweeper the config names (``hydra/sweeper:
checked``, :class:`pipeline.sweeps.sweeper.CheckedSweeper`) and, through it,
the launcher (``hydra/launcher=...``), and runs the sweep with the CLI's task
(:func:`pipeline.study.task.run_from_hydra`): every job checked before the
first runs, launched, aggregated into ``paths.dataset_dir`` at the end, exactly
as for a user. Only public Hydra API: Hydra's own multirun entry is private,
so its few steps are repeated here (compose, instantiate the sweeper, sweep
the task overrides).
"""

from __future__ import annotations

from collections.abc import Sequence

from hydra import compose, initialize_config_dir
from hydra.core.global_hydra import GlobalHydra
from hydra.core.override_parser.overrides_parser import OverridesParser
from hydra.core.plugins import Plugins
from hydra.core.utils import JobReturn
from hydra.types import HydraContext

from pipeline.config import CONFIG_DIR, register_configs
from pipeline.errors import RunError
from pipeline.study.task import run_from_hydra


class NoCallbacks:
    """The job callbacks of a launch: none (``hydra.callbacks`` is refused by the config
    guard, so a user's multirun has none either). Hydra's own container of callbacks is
    private; a launcher only calls these two hooks (also in its worker processes: picklable)."""

    def on_job_start(self, config: object, **kwargs: object) -> None:
        """Nothing to do."""

    def on_job_end(self, config: object, job_return: object, **kwargs: object) -> None:
        """Nothing to do."""


def multirun(overrides: Sequence[str]) -> list[JobReturn]:
    """Run ``python -m pipeline -m *overrides`` in this process; returns every job's result.

    Raises
    ------
    RunError
        When the sweep ends with an error (a job refused before any ran, exit 2; a job
        failed at run time, exit 1); the sweeper has printed its one ``error:`` line.
    """
    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
        # as Hydra's -m: the master config is composed without the sweeps (the compose API refuses
        # them), and hydra.mode=MULTIRUN makes each job's config say MULTIRUN, so the task leaves
        # aggregation to the end of the sweep
        parsed = OverridesParser.create().parse_overrides(list(overrides))
        fixed = [o.input_line for o in parsed if not o.is_sweep_override()]
        cfg = compose(config_name="config", overrides=[*fixed, "hydra.mode=MULTIRUN"], return_hydra_config=True)
        sweeper = Plugins.instance().instantiate_sweeper(
            config=cfg,
            hydra_context=HydraContext(config_loader=GlobalHydra.instance().config_loader(), callbacks=NoCallbacks()),
            task_function=run_from_hydra,
        )
        try:
            # the task's overrides (Hydra's own, hydra.*, stay in the master config), sweeps included
            batches = sweeper.sweep(arguments=[o.input_line for o in parsed if not o.is_hydra_override()])
        except SystemExit as exc:
            raise RunError(f"the multirun {' '.join(overrides)} ended with exit status {exc.code}") from None
    return [result for batch in batches for result in batch]
