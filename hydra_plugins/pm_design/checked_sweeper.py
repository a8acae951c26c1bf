"""Hydra's plugin module for the project's sweeper (the logic lives in :mod:`pipeline.sweeps`).

Hydra imports every module under ``hydra_plugins`` when it scans for plugins
and registers the plugin classes defined in them; importing this one also
stores the sweeper's config node (``hydra/sweeper=checked``) in the ConfigStore.
"""

from hydra.core.config_store import ConfigStore

from pipeline.sweeps import sweeper


class CheckedSweeper(sweeper.CheckedSweeper):
    """See :mod:`pipeline.sweeps.sweeper`."""


ConfigStore.instance().store(
    group="hydra/sweeper", name="checked", node=sweeper.CheckedSweeperConf, provider="pm-design"
)
