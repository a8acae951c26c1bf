"""Hydra plugins of pm-design (Hydra instantiates plugins only from the ``hydra_plugins`` namespace)."""
