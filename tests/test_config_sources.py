"""One source of truth: each default is written once, and no two experiments are the same study."""

from __future__ import annotations

import dataclasses
import inspect
import json

import yaml
from hydra import compose, initialize_config_dir
from omegaconf import OmegaConf

from kinematics import MECHANISMS
from pipeline import CONFIG_DIR
from pipeline.config import register_configs, schema
from pipeline.report.reference import SECTIONS

EXPERIMENTS = sorted(p.stem for p in (CONFIG_DIR / "experiment").glob("*.yaml"))


def _compose(overrides: list[str]):
    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        return compose(config_name="config", overrides=overrides, return_hydra_config=True)


def test_config_yaml_restates_no_default_of_the_schema():
    raw = yaml.safe_load((CONFIG_DIR / "config.yaml").read_text())
    restated = []
    for name, cls in SECTIONS:
        defaults = {f.name: f.default for f in dataclasses.fields(cls) if f.default is not dataclasses.MISSING}
        restated += [f"{name}.{k}" for k, v in (raw.get(name) or {}).items() if k in defaults and defaults[k] == v]
    if raw.get("experiment_name") == schema.Config.experiment_name:
        restated.append("experiment_name")
    assert restated == [], f"conf/config.yaml repeats the schema's defaults: {restated}"


def test_the_composed_defaults_are_the_schemas():
    cfg = _compose([])
    for name, cls in SECTIONS:
        section = OmegaConf.to_container(cfg[name], resolve=False)
        assert section == dataclasses.asdict(cls()), name


def _study_key(cfg) -> str:
    """The study an experiment computes: its config without names, Hydra's node and its sweep;
    ``w_d`` only where the objective uses it (η)."""
    study = OmegaConf.to_container(cfg, resolve=False)
    study.pop("hydra")
    study.pop("experiment_name")
    if study["objective"]["name"] != "mixed":
        study["objective"].pop("w_d")
    return json.dumps(study, sort_keys=True, default=str)


def _includes(name: str) -> list[str]:
    return [
        d
        for d in (yaml.safe_load((CONFIG_DIR / "experiment" / f"{name}.yaml").read_text()).get("defaults") or [])
        if isinstance(d, str)
    ]


def test_no_two_experiments_define_the_same_study():
    """Two experiments may compute the same study only when one is built on the other (a sweep
    over a single-run experiment names it in its defaults list); otherwise it is written twice."""
    by_study: dict[str, list[str]] = {}
    register_configs()
    with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3"):
        for name in EXPERIMENTS:
            cfg = compose(config_name="config", overrides=[f"+experiment={name}"], return_hydra_config=True)
            by_study.setdefault(_study_key(cfg), []).append(name)
    for names in by_study.values():
        roots = [n for n in names if not set(_includes(n)) & set(names)]
        assert len(roots) == 1, f"experiments {names} define the same study separately: build one on the other"


def test_mechanism_defaults_are_written_once():
    """A fixed parameter's default is the class's ``default_fixed``: where the constructor also has a
    default for it, the two agree (the config's group option is generated from ``default_fixed``)."""
    for name, cls in MECHANISMS.items():
        params = inspect.signature(cls.__init__).parameters
        for key, value in cls.default_fixed.items():
            default = params[key].default if key in params else inspect.Parameter.empty
            if default is not inspect.Parameter.empty:
                assert default == value, (
                    f"{name}: {key} defaults to {default!r} in __init__, {value!r} in default_fixed"
                )


def test_a_study_is_its_config_without_the_seed_and_w_d():
    """``Config.study_hash``: the seeds and the w_d points of one experiment are one study (one line
    of a trade-off, one group of seeds in the report), while an override of anything else (the
    orientation, the resolution) under the same experiment name is another."""
    from pipeline.config import validate

    def hashes(*overrides: str) -> tuple[str, str]:
        c = validate(_compose(["+experiment=h4_mixed", *overrides]))
        return c.study_hash(), c.config_hash()

    base, base_run = hashes()
    assert hashes("optimizer.seed=7")[0] == base and hashes("objective.w_d=0.8")[0] == base
    assert hashes("optimizer.seed=7")[1] != base_run  # another run of that study
    assert hashes("mechanism.orientation=[10,10]")[0] != base
    assert hashes("evaluate.resolution=20", "evaluate.allow_coarse=true")[0] != base
