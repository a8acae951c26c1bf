"""Hydra entry point: ``python -m pipeline [+experiment=NAME] [key=value ...]`` (``-m`` for sweeps)."""

from __future__ import annotations

import hydra
from hydra.core.hydra_config import HydraConfig
from omegaconf import DictConfig

from pipeline.config import register_configs
from pipeline.run import run_from_hydra

register_configs()


@hydra.main(version_base="1.3", config_path="../conf", config_name="config")
def main(cfg: DictConfig) -> None:
    run_from_hydra(cfg, HydraConfig.get().runtime.output_dir)


if __name__ == "__main__":
    main()
