"""Typed configuration: schema dataclasses, registered in Hydra's ConfigStore, checked before work.

The schema is the single description of the config. Each section is a
dataclass whose ``__post_init__`` checks its own ranges and raises
:class:`~pipeline.errors.ConfigError` with one line naming the field and
what is allowed. :func:`validate` turns a composed Hydra config into these
typed objects (``OmegaConf.to_object``), after refusing unknown keys, and
then checks what spans sections (the grid budget, paths, the dask
scheduler). The stages receive the typed objects.

Group options are generated from the code, not written twice:
``mechanism=<name>`` from each class of :data:`kinematics.MECHANISMS`
(design variables, bounds, fixed parameters and orientation range are class
attributes), ``optimizer=<name>`` from each optimiser's ``Config`` in
:data:`pipeline.optimizers.OPTIMIZERS`, ``objective=<name>`` from
:data:`pipeline.objective.OBJECTIVES`. Angles in the config are degrees;
they are converted to radians once, in :meth:`MechanismConfig.evaluation_options`.
"""

from __future__ import annotations

import copy
import dataclasses
import hashlib
import json
import math
import os
import re
import secrets
import socket
import sys
import tempfile
from dataclasses import dataclass, field
from datetime import datetime
from functools import lru_cache
from pathlib import Path
from typing import Any, Optional

import numpy as np
from hydra.core.config_store import ConfigStore
from omegaconf import MISSING, DictConfig, OmegaConf, open_dict
from omegaconf.errors import OmegaConfBaseException

from kinematics import MECHANISMS
from kinematics.base import Mechanism
from pipeline.errors import ConfigError, check, finite
from pipeline.objective import OBJECTIVES
from pipeline.optimizers import OPTIMIZERS, REFERENCE_OPTIMIZER, OptimizerConfig
from pipeline.optimizers.base import MAX_SEED

#: the primary config directory, shipped inside the package (works from a wheel, from any folder)
CONFIG_DIR = Path(__file__).resolve().parent / "conf"
BACKENDS = ("loky", "threading", "multiprocessing", "dask")
PLOT_FORMATS = ("png", "pdf", "svg")
#: conservative grid throughput (nodes/s per worker) for the run-time estimate
NODES_PER_SECOND = 1.0e6
_PLAIN_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,99}$")

__all__ = ["Config", "ConfigError", "MechanismConfig", "validate", "register_configs", "launch_id"]


# ------------------------------------------------------------------ sections
@dataclass
class DesignSpace:
    """Design variables: names (the class's, in order) and box bounds (design units)."""

    names: list[str] = field(default_factory=list)
    lower: list[float] = field(default_factory=list)
    upper: list[float] = field(default_factory=list)


@dataclass
class MechanismConfig:
    """One mechanism: registry name, fixed constructor parameters, design box, workspace limits.

    ``orientation`` is the range of every angular pose variable in degrees
    (null: the class's default); ``length`` the homogenising length in the
    mechanism's length unit (null: the class's default). Empty ``names``,
    ``lower``, ``upper`` and missing ``fixed`` entries take the class's values.
    """

    name: str = MISSING  # a registry name: the group options set it
    fixed: dict[str, Any] = field(default_factory=dict)
    design: DesignSpace = field(default_factory=DesignSpace)
    orientation: Optional[list[float]] = None
    min_inverse_condition: float = 0.01
    length: Optional[float] = None

    def __post_init__(self) -> None:
        check("mechanism.name", self.name, self.name in MECHANISMS, "one of " + ", ".join(MECHANISMS))
        cls = self.cls
        expected = [v.name for v in cls.design_variables]
        d = self.design
        d.names = list(d.names) or expected
        check("mechanism.design.names", d.names, d.names == expected, f"{expected}")
        d.lower = [float(v) for v in (d.lower or [v.lower for v in cls.design_variables])]
        d.upper = [float(v) for v in (d.upper or [v.upper for v in cls.design_variables])]
        for key in ("lower", "upper"):
            values = getattr(d, key)
            check(f"mechanism.design.{key}", values, len(values) == len(expected), f"{len(expected)} numbers")
        for name, lo, hi in zip(expected, d.lower, d.upper):
            check(f"mechanism.design bounds of {name}", [lo, hi], finite(lo) and finite(hi) and lo < hi,
                  "finite numbers with lower < upper")
        unknown = sorted(set(self.fixed) - set(cls.default_fixed))
        check(f"mechanism.fixed.{unknown[0] if unknown else ''}", self.fixed.get(unknown[0]) if unknown else None,
              not unknown, "keys " + ", ".join(cls.default_fixed) + f" for {self.name}")
        self.fixed = {**cls.default_fixed, **dict(self.fixed)}
        if self.orientation is not None:
            o = list(self.orientation)
            check("mechanism.orientation", o, len(o) == 2 and all(finite(v) for v in o)
                  and -360 <= o[0] <= o[1] <= 360, "null or [lo, hi] in degrees, -360 <= lo <= hi <= 360")
            self.orientation = [float(v) for v in o]
        check("mechanism.min_inverse_condition", self.min_inverse_condition,
              finite(self.min_inverse_condition) and 0 <= self.min_inverse_condition < 1, "[0, 1)")
        check("mechanism.length", self.length, self.length is None or (finite(self.length) and self.length > 0),
              "null or a finite number > 0")
        try:
            self.build(self.centre)
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"mechanism.fixed: {exc}") from None

    @property
    def cls(self) -> type[Mechanism]:
        return MECHANISMS[self.name]

    @property
    def centre(self) -> np.ndarray:
        return 0.5 * (np.asarray(self.design.lower) + np.asarray(self.design.upper))

    def build(self, design: np.ndarray) -> Mechanism:
        """The mechanism of one design vector (design units); ValueError if the design is infeasible."""
        return self.cls.from_design(np.asarray(design, dtype=float), **self.fixed)

    def orientation_rad(self) -> tuple[float, float] | None:
        """``orientation`` in radians (None: the class's default)."""
        return None if self.orientation is None else tuple(math.radians(v) for v in self.orientation)

    def evaluation_options(self) -> dict:
        """Keyword options of :func:`kinematics.workspace.evaluate` (angles in rad)."""
        options: dict = {"min_inverse_condition": float(self.min_inverse_condition)}
        if self.orientation is not None:
            options["orientation"] = self.orientation_rad()
        if self.length is not None:
            options["length"] = float(self.length)
        return options

    @classmethod
    def for_class(cls, mechanism: type[Mechanism]) -> "MechanismConfig":
        """The default config of a mechanism class (its Hydra group option)."""
        probe_orientation = None
        if any(mechanism.angular):
            lo, hi = _default_orientation(mechanism)
            probe_orientation = [round(math.degrees(lo), 9), round(math.degrees(hi), 9)]
        return cls(name=mechanism.name, fixed=dict(mechanism.default_fixed),
                   design=DesignSpace(names=[v.name for v in mechanism.design_variables],
                                      lower=[v.lower for v in mechanism.design_variables],
                                      upper=[v.upper for v in mechanism.design_variables]),
                   orientation=probe_orientation)


def _default_orientation(mechanism: type[Mechanism]) -> tuple[float, float]:
    centre = [0.5 * (v.lower + v.upper) for v in mechanism.design_variables]
    return mechanism.from_design(np.array(centre), **mechanism.default_fixed).default_orientation


@dataclass
class ObjectiveConfig:
    """The maximised objective (:data:`pipeline.objective.OBJECTIVES`) and the GDI weight of η."""

    name: str = "mixed"
    w_d: float = 0.5

    def __post_init__(self) -> None:
        check("objective.name", self.name, self.name in OBJECTIVES, "one of " + ", ".join(OBJECTIVES))
        check("objective.w_d", self.w_d, finite(self.w_d) and 0 <= self.w_d <= 1, "[0, 1]")
        self.w_d = float(self.w_d)


@dataclass
class SampleConfig:
    """Scrambled Sobol designs evaluated by the sample/evaluate stages."""

    n: int = 64
    seed: int = 0

    def __post_init__(self) -> None:
        check("sample.n", self.n, 1 <= self.n <= 1_000_000, "an integer in [1, 1000000]")
        check("sample.seed", self.seed, 0 <= self.seed <= MAX_SEED, f"an integer in [0, {MAX_SEED}]")


@dataclass
class EvaluateConfig:
    """Workspace integration: grid resolution and the budgets that bound it.

    ``resolution``: grid points per sampled axis (null: the mechanism's
    default). Below the mechanism's ``min_resolution`` the volume or GDI error
    exceeds about 3 %, so it is refused unless ``allow_coarse`` (tests, quick
    looks). ``max_nodes``: nodes of one evaluation, refined one included
    (memory and time); ``max_hours``: estimated wall time of the run.
    """

    resolution: Optional[int] = None
    refine_factor: int = 4
    allow_coarse: bool = False
    max_nodes: int = 4_000_000
    max_hours: float = 12.0

    def __post_init__(self) -> None:
        check("evaluate.resolution", self.resolution, self.resolution is None or 1 <= self.resolution <= 100_000,
              "null or an integer in [1, 100000]")
        check("evaluate.refine_factor", self.refine_factor, 1 <= self.refine_factor <= 8, "an integer in [1, 8]")
        check("evaluate.max_nodes", self.max_nodes, 1_000 <= self.max_nodes <= 10**9, "an integer in [1000, 1e9]")
        check("evaluate.max_hours", self.max_hours, finite(self.max_hours) and 0 < self.max_hours <= 10_000,
              "(0, 10000]")


@dataclass
class ParallelConfig:
    """Fitness evaluations: joblib workers and backend (execution only: not in result files)."""

    n_jobs: int = 2
    backend: str = "loky"
    #: dask only: address of a running scheduler (tcp://host:port); null starts a LocalCluster
    scheduler_address: Optional[str] = None

    def __post_init__(self) -> None:
        check("parallel.n_jobs", self.n_jobs, 1 <= self.n_jobs <= 1024, "an integer in [1, 1024]")
        check("parallel.backend", self.backend, self.backend in BACKENDS, "one of " + ", ".join(BACKENDS))
        address = self.scheduler_address
        check("parallel.scheduler_address", address,
              address is None or re.fullmatch(r"(tcp|tls)://[^\s:/]+:\d{1,5}", address) is not None,
              "null or tcp://host:port")


@dataclass
class PathsConfig:
    """Where results, the stage cache and the aggregated dataset go (must be writable)."""

    output_dir: str = "outputs"
    cache_dir: str = "outputs/cache"
    dataset_dir: str = "outputs/dataset"


@dataclass
class PlotConfig:
    enabled: bool = True
    #: extra vector format beside the PNG (null: PNG only)
    format: Optional[str] = None
    dpi: int = 150

    def __post_init__(self) -> None:
        check("plot.format", self.format, self.format is None or self.format in ("pdf", "svg"), "null, pdf or svg")
        check("plot.dpi", self.dpi, 50 <= self.dpi <= 1200, "an integer in [50, 1200]")


@dataclass
class Config:
    experiment_name: str = "default"
    # group options fill these (mechanism=..., objective=..., optimizer=...); no default to merge into
    mechanism: MechanismConfig = MISSING
    objective: ObjectiveConfig = MISSING
    optimizer: Any = MISSING
    sample: SampleConfig = field(default_factory=SampleConfig)
    evaluate: EvaluateConfig = field(default_factory=EvaluateConfig)
    parallel: ParallelConfig = field(default_factory=ParallelConfig)
    paths: PathsConfig = field(default_factory=PathsConfig)
    plot: PlotConfig = field(default_factory=PlotConfig)

    def __post_init__(self) -> None:
        check("experiment_name", self.experiment_name,
              isinstance(self.experiment_name, str) and bool(_PLAIN_NAME.match(self.experiment_name)),
              "a plain name of letters, digits, '_', '.', '-' (no '/', at most 100 characters)")

    #: sections that say how to run, not what to compute: kept out of result files
    EXECUTION_SECTIONS = ("parallel", "paths", "plot")

    def result_dict(self) -> dict:
        """The resolved config without the execution sections (stored with every result)."""
        out = dataclasses.asdict(self)
        for name in self.EXECUTION_SECTIONS:
            out.pop(name)
        return out

    def config_hash(self) -> str:
        """Content hash (16 hex digits) of :meth:`result_dict`: equal for equal studies."""
        text = json.dumps(self.result_dict(), sort_keys=True, default=str)
        return hashlib.sha256(text.encode()).hexdigest()[:16]


# --------------------------------------------------------------- validation
def _refuse_unknown_keys(node: DictConfig, schema: type, prefix: str) -> None:
    allowed = {f.name for f in dataclasses.fields(schema)}
    for key in node.keys():
        if key == "hydra" and not prefix:
            continue
        if key not in allowed:
            raise ConfigError(f"{prefix}{key} is an unknown key: allowed {', '.join(sorted(allowed))}")
        child = node._get_node(key)
        child_type = OmegaConf.get_type(node, key) if isinstance(child, DictConfig) else None
        if isinstance(child, DictConfig) and dataclasses.is_dataclass(child_type):
            _refuse_unknown_keys(child, child_type, f"{prefix}{key}.")


def validate(cfg: DictConfig | Config) -> Config:
    """The typed config of a composed Hydra config, checked before any work.

    Raises
    ------
    ConfigError
        One line naming the first bad field and what is allowed.
    """
    if isinstance(cfg, DictConfig):
        _refuse_unknown_keys(cfg, Config, "")
        optimizer = cfg.get("optimizer")
        name = optimizer.get("name") if isinstance(optimizer, DictConfig) else None
        check("optimizer.name", name, name in OPTIMIZERS, "one of " + ", ".join(OPTIMIZERS))
        if OmegaConf.get_type(optimizer) is not OPTIMIZERS[name].Config:
            raise ConfigError(f"optimizer.name={name!r} is invalid: choose the optimiser with "
                              f"optimizer={name} (allowed: {', '.join(OPTIMIZERS)})")
        try:
            if "hydra" in cfg:  # a sweep job's config carries Hydra's own node
                cfg = copy.deepcopy(cfg)
                with open_dict(cfg):
                    del cfg["hydra"]
            typed = OmegaConf.to_object(cfg)
        except OmegaConfBaseException as exc:
            key = getattr(exc, "full_key", None) or "config"
            raise ConfigError(f"{key} is invalid: {str(exc).splitlines()[0]}") from None
    else:
        typed = cfg
    _check_budget(typed)
    _check_parallel(typed.parallel)
    _check_kernels()
    for key in ("output_dir", "cache_dir", "dataset_dir"):
        check_writable(f"paths.{key}", getattr(typed.paths, key))
    return typed


def _check_budget(c: Config) -> None:
    """Grid resolution between the mechanism's minimum and the node and time budgets."""
    from kinematics.workspace import default_resolution, sampled_axes

    mech = c.mechanism.build(c.mechanism.centre)
    orientation = c.mechanism.orientation_rad() or mech.default_orientation
    n_axes = max(len(sampled_axes(mech, orientation)), 1)
    res = c.evaluate.resolution
    if res is not None and res < mech.min_resolution and not c.evaluate.allow_coarse:
        raise ConfigError(f"evaluate.resolution={res} is invalid: allowed >= {mech.min_resolution} for "
                          f"{c.mechanism.name} (coarser grids err by more than ~3 % in V or GDI; "
                          f"evaluate.allow_coarse=true to accept that)")
    res = res or default_resolution(mech, orientation)
    refined_nodes = float(res * c.evaluate.refine_factor) ** n_axes
    if refined_nodes > c.evaluate.max_nodes:
        top = int(c.evaluate.max_nodes ** (1 / n_axes) / c.evaluate.refine_factor)
        raise ConfigError(f"evaluate.resolution={res} is invalid: allowed <= {top} for {c.mechanism.name} "
                          f"({n_axes} sampled axes x refine_factor {c.evaluate.refine_factor} give "
                          f"{refined_nodes:.3g} nodes > evaluate.max_nodes={c.evaluate.max_nodes})")
    evaluations = c.sample.n + OPTIMIZERS[c.optimizer.name](c.optimizer).expected_evaluations()
    hours = evaluations * float(res) ** n_axes / (NODES_PER_SECOND * c.parallel.n_jobs) / 3600
    if hours > c.evaluate.max_hours:
        raise ConfigError(f"evaluate.resolution={res} is invalid: the run is estimated at {hours:.3g} h "
                          f"> evaluate.max_hours={c.evaluate.max_hours} ({evaluations} evaluations of "
                          f"{float(res) ** n_axes:.3g} nodes at {NODES_PER_SECOND:.0e} nodes/s/worker)")


def _check_kernels() -> None:
    """The environment's kernel choice (``PM_DESIGN_KERNELS``, kinematics/kernels.py) is known."""
    from kinematics import kernels

    try:
        kernels.compiled()
    except ValueError as exc:
        raise ConfigError(str(exc)) from None


def _check_parallel(p: ParallelConfig) -> None:
    """dask installed and its scheduler reachable (within 5 s), before any work."""
    if p.backend != "dask":
        return
    try:
        import distributed  # noqa: F401  (only when the dask backend is asked for)
    except ImportError:
        raise ConfigError("parallel.backend='dask' is invalid: dask.distributed is not installed "
                          "(pip install -e \".[dask]\"); allowed without it: loky, threading, multiprocessing") from None
    if p.scheduler_address:
        host, port = p.scheduler_address.split("://", 1)[1].rsplit(":", 1)
        try:
            socket.create_connection((host, int(port)), timeout=5).close()
        except OSError as exc:
            raise ConfigError(f"parallel.scheduler_address={p.scheduler_address!r} is invalid: no scheduler "
                              f"answers there ({exc.strerror or exc}); allowed: a reachable "
                              f"tcp://host:port or null for a local cluster") from None


def check_writable(field_name: str, path: str | os.PathLike) -> Path:
    """``path`` is (or can be created as) a writable directory.

    Nothing is left behind: the nearest existing directory is probed with an
    anonymous temporary file (a permission check alone is not enough: root
    passes it on read-only or pseudo file systems).
    """
    p = Path(path).expanduser()
    probe = p
    while not probe.exists() and not probe.is_symlink():
        if probe.parent == probe:
            break
        probe = probe.parent
    if not probe.is_dir():
        raise ConfigError(f"{field_name}={str(path)!r} is invalid: {probe} is not a directory; "
                          f"allowed: a writable directory")
    try:
        with tempfile.TemporaryFile(dir=probe):
            pass
    except OSError as exc:
        raise ConfigError(f"{field_name}={str(path)!r} is invalid: {probe} is not writable "
                          f"({exc.strerror or exc}); allowed: a writable directory") from None
    return p


def one_line(exc: BaseException) -> str:
    """A Hydra or OmegaConf error as one line: its first line, plus the options it lists."""
    lines = [ln.strip() for ln in str(exc).splitlines() if ln.strip()]
    if not lines:
        return type(exc).__name__
    text = lines[0]
    if any(ln.startswith("Available options") for ln in lines):
        start = next(k for k, ln in enumerate(lines) if ln.startswith("Available options")) + 1
        options = [ln for ln in lines[start:] if not ln.startswith(("Config search path", "provider="))]
        options = [ln.split()[0] for ln in options if ln and ":" not in ln]
        text += f"; allowed: {', '.join(options)}"
    elif len(lines) > 1 and not lines[1].startswith(("full_key", "object_type", "reference_type")):
        text += f": {lines[1]}"
    elif exc.__cause__ is not None and str(exc.__cause__).strip():
        text += f": {str(exc.__cause__).strip().splitlines()[0]}"
    return text


def precheck_overrides(argv: list[str]) -> None:
    """Compose and check a single run's config before Hydra creates anything (one line, exit 2).

    Catches composition errors (unknown group option, bad type), every
    :func:`validate` error, an unwritable or already used ``hydra.run.dir``.

    Skipped when any Hydra flag is given (``-m``, ``--help``, ...): Hydra
    handles those, and a sweep's jobs are checked by the sweeper.
    """
    if any(arg.startswith("-") for arg in argv):
        return
    from hydra import compose, initialize_config_dir
    from hydra.errors import HydraException

    from pipeline.run import check_run_dir

    register_configs()
    try:
        with initialize_config_dir(config_dir=str(CONFIG_DIR), version_base="1.3", job_name="pm-design"):
            cfg = compose(config_name="config", overrides=list(argv), return_hydra_config=True)
        validate(cfg)
        run_dir = Path(cfg.hydra.run.dir)
        check_writable("hydra.run.dir", run_dir)
        check_run_dir(run_dir)
    except ConfigError as exc:
        print(f"error: {exc}", file=sys.stderr)
        sys.exit(2)
    except (HydraException, OmegaConfBaseException, ValueError) as exc:
        print(f"error: {one_line(exc)}", file=sys.stderr)
        sys.exit(2)


# ------------------------------------------------------------- registration
#: environment variable carrying a sweep's launch id to jobs run in other processes
#: (joblib, submitit and SLURM launchers), set by the sweeper for the sweep's duration
LAUNCH_ENV = "PM_DESIGN_LAUNCH_ID"


def launch_id() -> str:
    """This launch's id: time, process id and a random token (unique even within one second).

    Inside a sweep it is the sweep's id (``PM_DESIGN_LAUNCH_ID``), whichever
    process runs the job, so every job of the sweep lands in one sweep
    directory; otherwise this process's id, cached so every use within one
    process (run dir, sweep dir, manifests) agrees.
    """
    return os.environ.get(LAUNCH_ENV) or _process_launch_id()


@lru_cache(maxsize=1)
def _process_launch_id() -> str:
    return f"{datetime.now():%Y-%m-%d_%H-%M-%S}_{os.getpid()}_{secrets.token_hex(3)}"


def register_configs() -> None:
    """Register the schema and the generated group options in Hydra's ConfigStore (idempotent)."""
    if not OmegaConf.has_resolver("run_id"):
        OmegaConf.register_new_resolver("run_id", launch_id)
    cs = ConfigStore.instance()
    cs.store(name="config_schema", node=Config)
    for name, cls in MECHANISMS.items():
        cs.store(group="mechanism", name=name, node=MechanismConfig.for_class(cls))
    for name, objective in OBJECTIVES.items():
        cs.store(group="objective", name=name, node=ObjectiveConfig(name=name, w_d=objective.default_w_d))
    for name, optimizer in OPTIMIZERS.items():
        cs.store(group="optimizer", name=name, node=optimizer.Config(name=name))
    from pipeline.sweeper import register_sweeper

    register_sweeper(cs)


__all__ += ["REFERENCE_OPTIMIZER", "OptimizerConfig"]
