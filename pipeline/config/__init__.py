"""Configuration layer: the typed schema, its validation and its registration with Hydra.

Imports no stage: the stages, the study and the sweeps import this layer.
"""

from pipeline import CONFIG_DIR
from pipeline.config.mechanism import DesignSpace, MechanismConfig
from pipeline.config.registry import register_configs
from pipeline.config.schema import (
    Config,
    EvaluateConfig,
    ObjectiveConfig,
    ParallelConfig,
    PathsConfig,
    PlotConfig,
    SampleConfig,
    study_hash,
)
from pipeline.config.validate import NODES_PER_SECOND, validate
from pipeline.errors import ConfigError
from pipeline.optimizers import REFERENCE_OPTIMIZER, OptimizerConfig

__all__ = [
    "CONFIG_DIR",
    "Config",
    "ConfigError",
    "DesignSpace",
    "EvaluateConfig",
    "MechanismConfig",
    "NODES_PER_SECOND",
    "ObjectiveConfig",
    "OptimizerConfig",
    "ParallelConfig",
    "PathsConfig",
    "PlotConfig",
    "REFERENCE_OPTIMIZER",
    "SampleConfig",
    "register_configs",
    "study_hash",
    "validate",
]
