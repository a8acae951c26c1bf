"""A mechanism class named by its ``package.module:Class`` path in the config (no entry point needed)."""

from __future__ import annotations

import pytest
from hydra import compose, initialize_config_dir

from kinematics.rpr2 import RPR2
from pipeline import CONFIG_DIR
from pipeline.config import register_configs, validate
from pipeline.errors import ConfigError
from pipeline.evaluation import DesignEvaluator


def _validated(overrides: list[str], tmp_path):
    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        cfg = compose(config_name="config", overrides=[*overrides, f"paths.output_dir={tmp_path}"])
    return validate(cfg)


def test_a_class_path_builds_and_evaluates_like_its_registry_name(tmp_path):
    by_path = _validated(["mechanism=path", "mechanism.name=kinematics.rpr2:RPR2", "evaluate.resolution=64"], tmp_path)
    by_name = _validated(["mechanism=rpr2", "evaluate.resolution=64"], tmp_path)
    assert by_path.mechanism.cls is RPR2
    assert by_path.mechanism.design.names == by_name.mechanism.design.names
    designs = [[5.0, 6.0], [4.0, 7.0]]
    a = DesignEvaluator(by_path.mechanism, 64, 1).evaluate(designs)
    b = DesignEvaluator(by_name.mechanism, 64, 1).evaluate(designs)
    assert (a == b).all() and a[:, 0].min() > 0


@pytest.mark.parametrize(
    "path, says",
    [
        ("no_such_package.mod:Thing", "no_such_package"),
        ("kinematics.rpr2:NoSuchClass", "NoSuchClass"),
        ("kinematics.base:DesignVariable", "Mechanism"),
    ],
)
def test_a_bad_class_path_is_one_line_naming_the_key(tmp_path, path, says):
    with pytest.raises(ConfigError) as info:
        _validated(["mechanism=path", f"mechanism.name={path}"], tmp_path)
    message = str(info.value)
    assert message.startswith("mechanism.name=") and says in message and "\n" not in message
