"""The jobs of a sweep: Hydra's override grammar expanded into one list of overrides per job (config layer:
the sweeper of ``-m`` and the reproduction both expand sweeps with it).

The expansion of Hydra's basic sweeper, on Hydra's public override parser:
each key keeps the position of its first mention and the value of its last
(so a command-line override of a key replaces that key's declared sweep);
a discrete sweep (``a,b,c``, ``range(...)``, ``choice(...)``) gives one job per
value; the jobs are the product of the keys in that order (first key outermost).
"""

from __future__ import annotations

import itertools
from collections.abc import Mapping, Sequence

from hydra.core.override_parser.overrides_parser import OverridesParser

from pipeline.errors import ConfigError


def declared_overrides(params: Mapping[str, object] | None, arguments: Sequence[str]) -> list[str]:
    """``hydra.sweeper.params`` as ``key=value`` overrides, followed by the command line's."""
    return [f"{key}={value}" for key, value in (params or {}).items()] + list(arguments)


def sweep_jobs(overrides: Sequence[str], config_loader=None) -> list[list[str]]:
    """Every job's overrides, in Hydra's basic sweeper's order.

    ``["objective.w_d=0.25,0.5", "optimizer.seed=0,1"]`` gives
    ``[["objective.w_d=0.25", "optimizer.seed=0"], ...]`` (4 jobs); no overrides: one job, none.

    Raises
    ------
    ConfigError
        For a sweep that has no finite list of values (an interval sweep), naming the key.
    """
    parsed = OverridesParser.create(config_loader=config_loader).parse_overrides(list(overrides))
    values: dict[str, list[str]] = {}
    for override in parsed:
        key = override.get_key_element()
        if not override.is_sweep_override():
            values[key] = [f"{key}={override.get_value_element_as_str()}"]
        elif override.is_discrete_sweep():
            values[key] = [f"{key}={value}" for value in override.sweep_string_iterator()]
        else:
            raise ConfigError(
                f"{key} is invalid: an interval sweep has no list of values; "
                f"allowed: a list (a,b,c), range(...) or choice(...)"
            )
    return [list(job) for job in itertools.product(*values.values())]


def batches(jobs: list[list[str]], max_batch_size: int | None) -> list[list[list[str]]]:
    """``jobs`` in consecutive batches of at most ``max_batch_size`` (None or -1: one batch)."""
    if max_batch_size is None or max_batch_size == -1:
        return [jobs]
    if max_batch_size < 1:
        raise ConfigError(f"hydra.sweeper.max_batch_size={max_batch_size} is invalid: allowed >= 1, or null")
    return [jobs[k : k + max_batch_size] for k in range(0, len(jobs), max_batch_size)]


def job_label(number: int, overrides: Sequence[str]) -> str:
    """How an error names a sweep's job: ``job 1 (mechanism=rpr2 objective.w_d=0.5)``."""
    return f"job {number} ({' '.join(overrides)})"
