"""The schema and the generated group options in Hydra's ConfigStore.

Group options are generated from the code, not written twice:
``mechanism=<name>`` from each class of :data:`kinematics.MECHANISMS`,
``optimizer=<name>`` from each optimiser's ``Config`` in
:data:`pipeline.optimizers.OPTIMIZERS`, ``objective=<name>`` from
:data:`pipeline.objectives.OBJECTIVES`.
"""

from __future__ import annotations

from hydra.core.config_store import ConfigStore
from omegaconf import OmegaConf

from kinematics import MECHANISMS
from pipeline.config.schema import Config, MechanismConfig, ObjectiveConfig
from pipeline.objectives import OBJECTIVES
from pipeline.optimizers import OPTIMIZERS
from pipeline.store.runs import launch_id

#: what a group option that is not a complete config needs, shown beside it where the options are listed
OPTION_NOTES = {
    ("mechanism", "path"): "a Mechanism class of your own: also set mechanism.name=package.module:Class",
}


def register_configs() -> None:
    """Register the schema and the generated group options in Hydra's ConfigStore (idempotent)."""
    if not OmegaConf.has_resolver("run_id"):
        OmegaConf.register_new_resolver("run_id", launch_id)
    cs = ConfigStore.instance()
    cs.store(name="config_schema", node=Config)
    # a class of the user's own by its path, without an entry point: mechanism=path mechanism.name=pkg.mod:Cls
    cs.store(group="mechanism", name="path", node=MechanismConfig)
    for name, cls in MECHANISMS.items():
        cs.store(group="mechanism", name=name, node=MechanismConfig.for_class(cls))
    for name, objective in OBJECTIVES.items():
        cs.store(group="objective", name=name, node=ObjectiveConfig(name=name, w_d=objective.default_w_d))
    for name, optimizer in OPTIMIZERS.items():
        cs.store(group="optimizer", name=name, node=optimizer.Config(name=name))
