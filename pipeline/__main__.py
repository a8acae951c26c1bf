"""``python -m pipeline``: the command line of :mod:`pipeline.cli`."""

from __future__ import annotations

import sys
from pathlib import Path

from pipeline.evaluation import compile_ahead

# first, so that a new machine's kernel compilation overlaps the imports below (no-op once compiled)
if (__name__ == "__main__" or Path(sys.argv[0]).name == "pm-design") and compile_ahead.wanted(sys.argv[1:]):
    compile_ahead.start()

from pipeline.cli import entry, main  # noqa: E402

__all__ = ["entry", "main"]

if __name__ == "__main__":
    entry()
