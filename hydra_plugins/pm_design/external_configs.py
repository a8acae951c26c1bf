"""Hydra search path of the config groups that external mechanism packages ship.

A package declaring an entry point in the group ``pm_design.configs`` (value:
an importable package such as ``pm_five_bar.conf`` holding
``experiment/five_bar_mixed.yaml``) gets that package appended to Hydra's
config search path as ``pkg://pm_five_bar.conf``, so that
``pm-design +experiment=five_bar_mixed`` composes once the package is
installed. Hydra calls every ``SearchPathPlugin`` in the ``hydra_plugins``
namespace whenever it builds a search path (``@hydra.main`` and ``compose``
alike); see :func:`kinematics.plugins.config_search_paths`.
"""

from __future__ import annotations

from functools import lru_cache

from hydra.core.config_search_path import ConfigSearchPath
from hydra.plugins.search_path_plugin import SearchPathPlugin

from kinematics.plugins import config_search_paths


@lru_cache(maxsize=1)
def _search_paths() -> tuple[str, ...]:
    """Why cached: Hydra builds a search path several times per command (the precheck, the run,
    each sweep job), and each scan reads every installed distribution's entry points."""
    return tuple(config_search_paths())


class ExternalMechanismConfigs(SearchPathPlugin):
    """Appends ``pkg://<package>`` of every ``pm_design.configs`` entry point."""

    def manipulate_search_path(self, search_path: ConfigSearchPath) -> None:
        for path in _search_paths():
            search_path.append(provider="pm-design-plugins", path=path)
