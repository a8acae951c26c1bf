"""The one-line check of a run's overrides, before Hydra creates or instantiates anything.

:func:`precheck_overrides` composes the config with Hydra's compose API and
validates it (a single run), or composes a probe of every swept value (a
sweep, ``-m``; the sweeper checks every job again). Bad input: one ``error:``
line, exit 2.
"""

from __future__ import annotations

import math
import re
import sys
from pathlib import Path

from hydra.errors import HydraException
from omegaconf import DictConfig
from omegaconf.errors import OmegaConfBaseException

from pipeline.cli.commands import one_line, suggestion
from pipeline.cli.explain import explain
from pipeline.config import CONFIG_DIR, guard, register_configs, validate
from pipeline.config.jobs import job_label
from pipeline.errors import ConfigError, check_writable
from pipeline.store.runs import check_run_dir

#: Hydra flags that print and exit without running the task (nothing to check)
INFO_FLAGS = (
    "--help",
    "-h",
    "--hydra-help",
    "--version",
    "--cfg",
    "-c",
    "--resolve",
    "--package",
    "-p",
    "--info",
    "-i",
    "--shell-completion",
    "-sc",
)
#: Hydra flags that run the task: the overrides are checked as for a single run
MULTIRUN_FLAGS = ("-m", "--multirun")


def precheck_overrides(argv: list[str]) -> None:
    """Check the overrides before Hydra creates or instantiates anything (one ``error:`` line, exit 2).

    Single run: composes the config, :func:`validate` it, refuses an
    unwritable or already used ``hydra.run.dir``. Sweep (``-m``): composes
    the first job and, one at a time, every value of each swept key (each
    job is checked again by the sweeper), then the config Hydra composes
    before the sweep (a shared ``mechanism.fixed.*`` override of a sweep over
    ``mechanism`` is told to use ``++``), and refuses an unwritable
    ``hydra.sweep.dir``. Both: what the config may
    instantiate (:mod:`pipeline.config.guard`). Flags that only print
    (``--help``, ``--cfg``, ...) skip the check; flags that would load config
    from elsewhere (``--config-dir``, ``--experimental-rerun``, ...) are refused.
    """
    flags = [a.split("=", 1)[0] for a in argv if a.startswith("-")]
    if any(f in INFO_FLAGS for f in flags):
        return
    overrides = [a for a in argv if not a.startswith("-")]
    try:
        unknown = [f for f in flags if f not in MULTIRUN_FLAGS]
        if unknown:
            raise ConfigError(
                f"{unknown[0]} is refused: the config comes from conf/ and +experiment=NAME; "
                f"allowed flags: {', '.join(MULTIRUN_FLAGS + INFO_FLAGS)}"
            )
        if flags:
            # each job's values are validated by the sweeper, which names the job
            try:
                for number, job_overrides in _probe_jobs(overrides):
                    guard.check_hydra_node(_compose_job(job_overrides, number).hydra)
                sweep = _compose_sweep(overrides)
            except (HydraException, OmegaConfBaseException) as exc:
                message = shared_fixed_message(exc, overrides)
                if message is None:
                    raise
                raise ConfigError(message) from None
            # as hydra.run.dir below: the sweeper would create it only after composing every job
            check_writable("hydra.sweep.dir", Path(sweep.hydra.sweep.dir))
            return
        _probe_jobs(overrides)  # the keys' check
        cfg = _compose_job(overrides, None)
        guard.check_hydra_node(cfg.hydra)
        validate(cfg)
        run_dir = Path(cfg.hydra.run.dir)
        check_writable("hydra.run.dir", run_dir)
        check_run_dir(run_dir)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    except (HydraException, OmegaConfBaseException, ValueError) as exc:
        print(f"error: {one_line(exc)}{suggestion(exc, argv)}", file=sys.stderr)
        sys.exit(2)


def _compose_job(overrides: list[str], number: int | None) -> DictConfig:
    """:func:`_compose`, its override errors as one :class:`ConfigError` line (naming the sweep's
    job ``number``, as the sweeper does)."""
    try:
        return _compose(overrides)
    except (HydraException, OmegaConfBaseException) as exc:
        message = explain(exc, overrides, _compose)
        if message is None:
            raise
        raise ConfigError(message if number is None else f"{job_label(number, overrides)}: {message}") from None


def _compose_sweep(overrides: list[str]) -> DictConfig:
    """The config Hydra composes for a sweep (``-m``) before its sweeper runs: the overrides that
    sweep nothing, with each swept group at its default (Hydra's own loader, in multirun mode)."""
    from hydra import initialize_config_dir
    from hydra.core.global_hydra import GlobalHydra
    from hydra.types import RunMode

    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
        loader = GlobalHydra.instance().config_loader()
        return loader.load_configuration(config_name="config", overrides=list(overrides), run_mode=RunMode.MULTIRUN)


#: Hydra's errors about a ``mechanism.fixed.*`` override: the key is missing (``=``) or already there (``+``)
_FIXED_KEY = re.compile(r"(?:Could not override|An item is already at) '(mechanism\.fixed\.[^']+)'")


def shared_fixed_message(exc: BaseException, overrides: list[str]) -> str | None:
    """The one line for a ``mechanism.fixed.KEY`` override that a sweep over ``mechanism`` shares
    (None: another error).

    Hydra sets such an override twice: on the config composed before the sweep (the default
    mechanism's parameters), then on each job's (the swept mechanism's). ``KEY=V`` fails where a
    mechanism lacks the key, ``+KEY=V`` where it has it, and Hydra's advice swaps one for the
    other; ``++KEY=V`` sets or adds it in both (a job whose mechanism lacks the key is then
    refused by :func:`pipeline.config.validate`, naming the mechanism and the key).
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser

    found = _FIXED_KEY.search(str(exc))
    if found is None:
        return None
    parsed = OverridesParser.create().parse_overrides(overrides)
    if not any(o.key_or_group == "mechanism" and o.is_sweep_override() for o in parsed):
        return None
    key = found.group(1)
    typed = next((o.input_line for o in parsed if o.key_or_group == key), None)
    if typed is None:
        return None
    value = typed.split("=", 1)[1]
    return (
        f"{typed} is invalid in a sweep over mechanism: Hydra sets it on the default mechanism before "
        f"the sweep and on each job's, and = or + fails on one of them; allowed: ++{key}={value} "
        f"(each swept mechanism must have {key.rpartition('.')[2]})"
    )


def _compose(overrides: list[str]) -> DictConfig:
    """The config of one job (with Hydra's node), as Hydra's compose API builds it."""
    from hydra import compose, initialize_config_dir

    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
        return compose(config_name="config", overrides=list(overrides), return_hydra_config=True)


def _probe_jobs(overrides: list[str]) -> list[tuple[int, list[str]]]:
    """Jobs that together hold every override and every swept value, with their numbers in the
    sweep: the first job (each sweep at its first value), then each further value of each sweep
    with the others at their first.

    Every override's key is checked by :func:`pipeline.config.guard.check_override_key` first.
    A sweep that cannot be listed (an interval, a glob) leaves its key out: the sweeper checks it.
    The numbers are those of :func:`pipeline.config.jobs.sweep_jobs` (keys in order of first
    mention, the first outermost).
    """
    from hydra.core.override_parser.overrides_parser import OverridesParser

    parsed = OverridesParser.create().parse_overrides(overrides)
    values: dict[str, list[str]] = {}
    for o in parsed:
        guard.check_override_key(o.key_or_group, "" if o.is_sweep_override() else o.get_value_element_as_str())
        key = o.get_key_element()
        if not o.is_sweep_override():
            values[key] = [o.input_line]
        elif o.is_discrete_sweep() and o.value_type.name != "GLOB_CHOICE_SWEEP":
            values[key] = [f"{key}={v}" for v in o.sweep_string_iterator()] or [o.input_line]
        else:
            values.pop(key, None)
    keys = list(values)
    strides = {k: math.prod(len(values[later]) for later in keys[i + 1 :]) for i, k in enumerate(keys)}
    jobs = [(0, [values[k][0] for k in keys])]
    for key in keys:
        for j in range(1, len(values[key])):
            jobs.append((j * strides[key], [values[k][j if k == key else 0] for k in keys]))
    return jobs
