"""Sweeps layer: the Hydra sweeper of ``python -m pipeline -m`` (registered by ``hydra_plugins.pm_design``)."""
