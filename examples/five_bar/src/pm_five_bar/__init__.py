"""A planar five-bar mechanism for pm-design, shipped as its own package (see docs/extending.md)."""

from pm_five_bar.mechanism import FiveBar

__all__ = ["FiveBar"]
