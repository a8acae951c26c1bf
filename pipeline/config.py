"""Configuration schema (Hydra structured configs) and validation beyond types.

The dataclasses below are registered in Hydra's ConfigStore as the schema of
``conf/config.yaml`` and of its groups, so ``objective.w_d=abc`` or a
misspelt key fails before any work. :func:`validate` then checks ranges and
names and raises :class:`ConfigError` with one line naming the field and the
allowed values.
"""

from __future__ import annotations

import math
import os
import secrets
from dataclasses import dataclass, field
from datetime import datetime
from functools import lru_cache
from typing import Any, Optional

from hydra.core.config_store import ConfigStore
from omegaconf import DictConfig, OmegaConf

from kinematics import MECHANISMS
from pipeline.objective import OBJECTIVES

OPTIMIZERS = ("ga", "de")
BACKENDS = ("loky", "threading", "multiprocessing", "dask")


class ConfigError(ValueError):
    """A configuration value out of range; the message is one line."""


@dataclass
class DesignSpace:
    """Design variables of the mechanism: names and box bounds (see ``Mechanism.design_variables``)."""

    names: list[str] = field(default_factory=list)
    lower: list[float] = field(default_factory=list)
    upper: list[float] = field(default_factory=list)


@dataclass
class MechanismConfig:
    """One mechanism: registry name, fixed constructor parameters, design space, workspace limits."""

    name: str = "h4"
    fixed: dict[str, Any] = field(default_factory=dict)
    design: DesignSpace = field(default_factory=DesignSpace)
    #: range (rad) of the angular pose variables; null = the mechanism's default
    orientation: Optional[list[float]] = None
    min_inverse_condition: float = 0.01
    #: characteristic length homogenising the Jacobian; null = the mechanism's default
    length: Optional[float] = None


@dataclass
class ObjectiveConfig:
    name: str = "mixed"
    w_d: float = 0.5


@dataclass
class OptimizerConfig:
    name: str = "ga"
    population: int = 30
    generations: int = 150
    seed: int = 0
    selection_q: float = 0.08
    crossover_rate: float = 0.8
    mutation_rate: float = 0.08
    mutation_shape: float = 3.0
    #: start from the best sampled designs (off for paper reproduction)
    seed_from_samples: bool = False
    seed_count: int = 5


@dataclass
class SampleConfig:
    n: int = 64
    seed: int = 0


@dataclass
class EvaluateConfig:
    #: grid points per sampled axis; null = kinematics.workspace.default_resolution
    resolution: Optional[int] = None
    #: the optimum is re-evaluated at this multiple of the resolution
    refine_factor: int = 4


@dataclass
class ParallelConfig:
    n_jobs: int = 2
    backend: str = "loky"
    #: dask only: address of a running scheduler; null starts a LocalCluster of n_jobs workers
    scheduler_address: Optional[str] = None


@dataclass
class PathsConfig:
    output_dir: str = "outputs"
    cache_dir: str = "outputs/cache"
    dataset_dir: str = "outputs/dataset"


@dataclass
class PlotConfig:
    enabled: bool = True


@dataclass
class Config:
    experiment_name: str = "default"
    mechanism: MechanismConfig = field(default_factory=MechanismConfig)
    objective: ObjectiveConfig = field(default_factory=ObjectiveConfig)
    optimizer: OptimizerConfig = field(default_factory=OptimizerConfig)
    sample: SampleConfig = field(default_factory=SampleConfig)
    evaluate: EvaluateConfig = field(default_factory=EvaluateConfig)
    parallel: ParallelConfig = field(default_factory=ParallelConfig)
    paths: PathsConfig = field(default_factory=PathsConfig)
    plot: PlotConfig = field(default_factory=PlotConfig)


@lru_cache(maxsize=1)
def run_id() -> str:
    """Name of this launch's directory: time, process id and a random token.

    Unique even when two launches start in the same second; cached so every
    use within one process (run dir, sweep dir, callbacks) agrees.
    """
    return f"{datetime.now():%Y-%m-%d_%H-%M-%S}_{os.getpid()}_{secrets.token_hex(3)}"


def register_configs() -> None:
    """Register the schema in Hydra's ConfigStore and the ``run_id`` resolver (idempotent)."""
    if not OmegaConf.has_resolver("run_id"):
        OmegaConf.register_new_resolver("run_id", run_id)
    cs = ConfigStore.instance()
    cs.store(name="config_schema", node=Config)
    cs.store(group="mechanism", name="schema", node=MechanismConfig)
    cs.store(group="objective", name="schema", node=ObjectiveConfig)
    cs.store(group="optimizer", name="schema", node=OptimizerConfig)


def _fail(field_name: str, allowed: str, value: object) -> None:
    raise ConfigError(f"{field_name}={value!r} is invalid: allowed {allowed}")


def validate(cfg: DictConfig | dict) -> dict:
    """Check ranges and names; return the resolved config as a plain dict.

    Raises
    ------
    ConfigError
        One line naming the first bad field and its allowed values.
    """
    c = OmegaConf.to_container(cfg, resolve=True) if isinstance(cfg, DictConfig) else dict(cfg)
    mech = c["mechanism"]
    if mech["name"] not in MECHANISMS:
        _fail("mechanism.name", "one of " + ", ".join(MECHANISMS), mech["name"])
    cls = MECHANISMS[mech["name"]]
    design = mech["design"]
    names = design.get("names") or [v.name for v in cls.design_variables]
    expected = [v.name for v in cls.design_variables]
    if list(names) != expected:
        _fail("mechanism.design.names", f"{expected}", names)
    lower = design.get("lower") or [v.lower for v in cls.design_variables]
    upper = design.get("upper") or [v.upper for v in cls.design_variables]
    if len(lower) != len(expected) or len(upper) != len(expected):
        _fail("mechanism.design.lower/upper", f"{len(expected)} values each", (lower, upper))
    for name, lo, hi in zip(expected, lower, upper):
        if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
            _fail(f"mechanism.design bounds of {name}", "finite with lower < upper", (lo, hi))
    design.update(names=list(expected), lower=[float(v) for v in lower], upper=[float(v) for v in upper])
    orient = mech.get("orientation")
    if orient is not None and not (len(orient) == 2 and all(math.isfinite(v) for v in orient)
                                   and orient[0] <= orient[1]):
        _fail("mechanism.orientation", "[lo, hi] in rad with lo <= hi", orient)
    if not 0.0 <= mech["min_inverse_condition"] < 1.0:
        _fail("mechanism.min_inverse_condition", "[0, 1)", mech["min_inverse_condition"])
    if mech.get("length") is not None and not mech["length"] > 0:
        _fail("mechanism.length", "> 0 or null", mech["length"])
    obj = c["objective"]
    if obj["name"] not in OBJECTIVES:
        _fail("objective.name", "one of " + ", ".join(OBJECTIVES), obj["name"])
    if not (math.isfinite(obj["w_d"]) and 0.0 <= obj["w_d"] <= 1.0):
        _fail("objective.w_d", "[0, 1]", obj["w_d"])
    opt = c["optimizer"]
    if opt["name"] not in OPTIMIZERS:
        _fail("optimizer.name", "one of " + ", ".join(OPTIMIZERS), opt["name"])
    if opt["population"] < 2:
        _fail("optimizer.population", "an integer >= 2", opt["population"])
    if opt["generations"] < 1:
        _fail("optimizer.generations", "an integer >= 1", opt["generations"])
    for key in ("selection_q", "crossover_rate", "mutation_rate"):
        if not 0.0 <= opt[key] <= 1.0:
            _fail(f"optimizer.{key}", "[0, 1]", opt[key])
    if opt["seed_count"] < 1:
        _fail("optimizer.seed_count", "an integer >= 1", opt["seed_count"])
    if c["sample"]["n"] < 1:
        _fail("sample.n", "an integer >= 1", c["sample"]["n"])
    res = c["evaluate"]["resolution"]
    if res is not None and res < 1:
        _fail("evaluate.resolution", "an integer >= 1 or null", res)
    if c["evaluate"]["refine_factor"] < 1:
        _fail("evaluate.refine_factor", "an integer >= 1", c["evaluate"]["refine_factor"])
    par = c["parallel"]
    if par["n_jobs"] < 1:
        _fail("parallel.n_jobs", "an integer >= 1", par["n_jobs"])
    if par["backend"] not in BACKENDS:
        _fail("parallel.backend", "one of " + ", ".join(BACKENDS), par["backend"])
    # the mechanism at the centre of the design box checks the fixed parameters
    centre = [(lo + hi) / 2 for lo, hi in zip(design["lower"], design["upper"])]
    try:
        cls.from_design(centre, **mech["fixed"])
    except (TypeError, ValueError) as exc:
        raise ConfigError(f"mechanism.fixed: {exc}") from None
    return c
