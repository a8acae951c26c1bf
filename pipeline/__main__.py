"""``python -m pipeline``: the command line of :mod:`pipeline.cli`."""

from __future__ import annotations

from pipeline.cli import entry, main

__all__ = ["entry", "main"]

if __name__ == "__main__":
    entry()
