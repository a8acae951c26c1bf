"""Entry point: ``pm-design`` or ``python -m pipeline`` ``[+experiment=NAME] [key=value ...]`` (``-m`` for sweeps)."""

from __future__ import annotations

import sys

import hydra
from omegaconf import DictConfig

from pipeline.config import CONFIG_DIR, precheck_overrides, register_configs
from pipeline.run import run_from_hydra

register_configs()


@hydra.main(version_base="1.3", config_path=str(CONFIG_DIR), config_name="config")
def main(cfg: DictConfig) -> dict:
    return run_from_hydra(cfg)


def entry() -> None:
    """The console script: the one-line precheck of a single run, then Hydra."""
    precheck_overrides(sys.argv[1:])
    main()


if __name__ == "__main__":
    entry()
