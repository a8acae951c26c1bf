"""What config may instantiate or change in the process: Hydra's own node, checked before Hydra runs.

Hydra instantiates whatever a config names under ``hydra.*`` (callbacks,
launcher, sweeper, logging handlers) and exports ``hydra.job.env_set`` into
the environment of the job and its workers, before any task code runs. A
command-line override or an experiment file could thereby run any callable
(``+hydra.callbacks.x._target_=shutil.copyfile``) or plant code in the
workers (``+hydra.job.env_set.PYTHONPATH=...``). So:

* an override may not set ``_target_``, a logging ``class`` or ``()``
  factory anywhere under ``hydra.*``, nor any ``hydra.callbacks`` entry;
* ``hydra.job.env_set`` keys are limited to :data:`ENV_ALLOWED` (thread counts);
* in the composed config (command line and experiment files together),
  every callback is one of the project's own (:data:`CALLBACK_PREFIXES`), and
  the launcher's and sweeper's ``_target_`` are Hydra's or an installed Hydra
  plugin's (:data:`PLUGIN_PREFIXES`).

Each refusal is one :class:`~pipeline.errors.ConfigError` line naming the key.
"""

from __future__ import annotations

import re
from collections.abc import Iterable

from omegaconf import DictConfig, OmegaConf

from pipeline.errors import ConfigError

#: environment variables a config may set for a job (``hydra.job.env_set``): thread counts only
ENV_ALLOWED = ("OMP_NUM_THREADS", "MKL_NUM_THREADS", "OPENBLAS_NUM_THREADS", "NUMBA_NUM_THREADS")
#: callbacks (``hydra.callbacks.*._target_``) allowed: the project's own
CALLBACK_PREFIXES = ("pipeline.", "hydra_plugins.pm_design.")
#: other ``_target_`` under ``hydra.*`` allowed: Hydra's own classes and installed Hydra plugins
PLUGIN_PREFIXES = ("hydra.", "hydra_plugins.")
#: logging handler and formatter classes allowed (``class``, ``()`` in Hydra's logging config)
LOGGING_PREFIXES = ("logging.", "hydra.", "hydra_plugins.", "colorlog.")
#: key segments that make Hydra or logging.config call something
_CALLABLE_KEYS = {"_target_", "class", "()", "factory"}


def check_override_key(key: str, value: str = "") -> None:
    """Refuse an override of ``hydra.*`` that could run code or change the workers' environment.

    ``key`` is the override's key (``hydra.callbacks.x._target_``) without
    its ``+``/``++``/``~`` prefix; ``value`` its value as written.
    """
    if not (key == "hydra" or key.startswith(("hydra.", "hydra/"))):
        return
    parts = re.split(r"[./]", key)
    if "callbacks" in parts[:2]:
        raise ConfigError(
            f"{key} is refused: hydra.callbacks cannot be set from the command line "
            f"(they run code); allowed: the project's own callbacks in its config files"
        )
    found = _CALLABLE_KEYS.intersection(parts)
    if found:
        raise ConfigError(
            f"{key} is refused: '{found.pop()}' under hydra.* names code to run; "
            f"allowed: plain values and Hydra's config groups (hydra/launcher=joblib)"
        )
    if key.startswith("hydra.job.env_set"):
        name = key[len("hydra.job.env_set") :].lstrip(".")
        if name not in ENV_ALLOWED:
            raise ConfigError(
                f"{key} is refused: a job's environment is not set from the command line "
                f"(PYTHONPATH and the like would run code in the workers); "
                f"allowed keys: {', '.join(ENV_ALLOWED)}"
            )
        if value and not value.isdigit():
            raise ConfigError(f"{key}={value!r} is invalid: allowed a positive integer")
    if key.startswith("hydra.job.env_copy"):
        raise ConfigError(f"{key} is refused: a job's environment is not set from the command line")


def check_hydra_node(hydra: DictConfig) -> None:
    """The composed ``hydra`` node instantiates only the project's callbacks and Hydra's plugins.

    Covers what experiment files set as well as the command line.
    """
    callbacks = hydra.get("callbacks") or {}
    for name in callbacks:
        target = str(OmegaConf.select(callbacks, f"{name}._target_", default=""))
        if not target.startswith(CALLBACK_PREFIXES):
            raise ConfigError(
                f"hydra.callbacks.{name}._target_={target!r} is refused: allowed callbacks "
                f"under {', '.join(CALLBACK_PREFIXES)}"
            )
    for path, key, target in _targets(OmegaConf.to_container(hydra, resolve=False), "hydra"):
        if path.startswith("hydra.callbacks."):
            continue
        allowed = PLUGIN_PREFIXES if key == "_target_" else LOGGING_PREFIXES
        if not str(target).startswith(allowed):
            raise ConfigError(f"{path}={target!r} is refused: allowed under {', '.join(allowed)}")
    for name, value in (hydra.get("job", {}).get("env_set") or {}).items():
        check_override_key(f"hydra.job.env_set.{name}", str(value))


def _targets(node: object, path: str) -> Iterable[tuple[str, str, object]]:
    """``(dotted path, key, value)`` of every ``_target_`` and logging ``class``/``()``/``factory``
    below ``node`` (plain containers)."""
    if isinstance(node, dict):
        for key, value in node.items():
            sub = f"{path}.{key}"
            if key in _CALLABLE_KEYS and not isinstance(value, (dict, list)):
                yield sub, key, value
            else:
                yield from _targets(value, sub)
    elif isinstance(node, list):
        for k, item in enumerate(node):
            yield from _targets(item, f"{path}[{k}]")
