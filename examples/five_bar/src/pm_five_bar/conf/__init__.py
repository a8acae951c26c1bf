"""Hydra config groups of pm_five_bar (``experiment/``), on pm-design's search path as ``pkg://pm_five_bar.conf``."""
