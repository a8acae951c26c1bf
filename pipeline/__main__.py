"""Entry point: ``pm-design`` or ``python -m pipeline`` ``[+experiment=NAME] [key=value ...]`` (``-m`` for sweeps)."""

from __future__ import annotations

import gc
import sys
from pathlib import Path

from pipeline import compile_ahead

# first, so that a new machine's kernel compilation overlaps the imports below (no-op once compiled)
if (__name__ == "__main__" or Path(sys.argv[0]).name == "pm-design") and compile_ahead.wanted(sys.argv[1:]):
    compile_ahead.start()

import hydra  # noqa: E402
from omegaconf import DictConfig  # noqa: E402

from pipeline.config import CONFIG_DIR, precheck_overrides, register_configs  # noqa: E402
from pipeline.run import run_from_hydra  # noqa: E402

register_configs()


@hydra.main(version_base="1.3", config_path=str(CONFIG_DIR), config_name="config")
def main(cfg: DictConfig) -> dict:
    return run_from_hydra(cfg)


def entry() -> None:
    """The console script: the one-line precheck of a single run, then Hydra."""
    try:
        precheck_overrides(sys.argv[1:])
        main()
    finally:
        # Why: by now every result is written; what remains is Python's teardown, whose
        # garbage collections walk every object of ~1,000 modules (numba, pandas, matplotlib):
        # ~0.5 s of every command. Frozen objects are skipped; the exit is otherwise the usual
        # one (exit handlers, workers ended, streams flushed).
        gc.disable()
        gc.freeze()


if __name__ == "__main__":
    entry()
