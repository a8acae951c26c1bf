"""Hydra's plugin name for :class:`pipeline.sweeper.CheckedSweeper` (the logic lives there)."""

from pipeline.sweeper import CheckedSweeper as _CheckedSweeper


class CheckedSweeper(_CheckedSweeper):
    """See :mod:`pipeline.sweeper`."""
