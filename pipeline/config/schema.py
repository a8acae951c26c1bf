"""Typed configuration: one dataclass per config section, each checking its own ranges.

The schema is the single description of the config. Each section's
``__post_init__`` raises :class:`~pipeline.errors.ConfigError` with one line
naming the field and what is allowed; :mod:`pipeline.config.validate` checks
what spans sections and :mod:`pipeline.config.registry` stores the schema and
the generated group options in Hydra's ConfigStore. The mechanism's section
(:class:`MechanismConfig`, the largest) is :mod:`pipeline.config.mechanism`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import re
from dataclasses import dataclass, field
from typing import Any, Optional

from omegaconf import MISSING

from pipeline.config.mechanism import MechanismConfig
from pipeline.errors import check, finite
from pipeline.objectives import OBJECTIVES
from pipeline.optimizers.base import MAX_SEED

BACKENDS = ("loky", "threading", "multiprocessing", "dask")
#: workspace integration methods of :func:`kinematics.workspace.evaluate` a run may use
#: (``evaluate.method``; its ``polar`` fits the Tricept alone and is for the reproduction)
EVALUATE_METHODS = ("grid", "midpoint")
#: kinds of run: real studies, quick looks and tests (``+debug=fast``), speed measurements
PURPOSES = ("study", "debug", "benchmark")
#: the largest ``evaluate.max_hours`` (a run's estimated wall time, hours)
MAX_HOURS = 10_000
_PLAIN_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]{0,99}$")


# ------------------------------------------------------------------ sections
@dataclass
class ObjectiveConfig:
    """The maximised objective (:data:`pipeline.objectives.OBJECTIVES`) and the GDI weight of η."""

    #: the maximised objective (the group option `objective=NAME` sets it)
    name: str = "mixed"
    #: weight of the GDI in η = w_d·GDI + (1 − w_d)·SURI, [0, 1] (seed 000 eq. 36); fixed for the
    #: other objectives at the η they equal (volume and suri 0, gdi 1)
    w_d: float = 0.5

    def __post_init__(self) -> None:
        check("objective.name", self.name, self.name in OBJECTIVES, "one of " + ", ".join(OBJECTIVES))
        check("objective.w_d", self.w_d, finite(self.w_d) and 0 <= self.w_d <= 1, "[0, 1]")
        self.w_d = float(self.w_d)
        # only the mixed index weighs the GDI: another objective's w_d is the eta it equals (volume
        # and SURI 0, the GDI 1), and a run recorded with any other w_d would claim a weight it ignored
        fixed = OBJECTIVES[self.name].default_w_d
        check(
            "objective.w_d",
            self.w_d,
            self.name == "mixed" or self.w_d == fixed,
            f"{fixed:g} with objective={self.name} (only objective=mixed uses w_d)",
        )


@dataclass
class SampleConfig:
    """Scrambled Sobol designs evaluated by the sample/evaluate stages."""

    #: number of Sobol designs, [1, 1e6]
    n: int = 64
    #: seed of the scrambled Sobol sequence
    seed: int = 0

    def __post_init__(self) -> None:
        check("sample.n", self.n, 1 <= self.n <= 1_000_000, "an integer in [1, 1000000]")
        check("sample.seed", self.seed, 0 <= self.seed <= MAX_SEED, f"an integer in [0, {MAX_SEED}]")


@dataclass
class EvaluateConfig:
    """Workspace integration: method, grid resolution and the budgets that bound it.

    ``method`` (:data:`EVALUATE_METHODS`): ``grid`` counts each cell that the
    workspace boundary cuts with the fraction of it inside (second order and
    continuous in the design, docs/accuracy.md; the cell rule is the mechanism's
    ``cell_rule``: one plane per cell, or linear margins for the Tricept and the
    Gough-Stewart); ``midpoint`` is the old
    cell-centre count (first order, it moves in steps as the boundary crosses
    a node), kept for comparison. Each method has its own default resolution
    (``grid``: the mechanism's ``grid_nodes`` budget where set).
    ``resolution``: grid points per sampled axis (``method=grid``: times the mechanism's
    ``grid_axis_nodes`` factor of an axis; null: the mechanism's
    default for the method). Below the mechanism's ``min_resolution`` the volume or GDI error
    exceeds about 3 %, so it is refused unless ``allow_coarse`` (tests, quick
    looks). ``max_nodes``: nodes of one evaluation, refined one included
    (memory and time); ``max_hours``: estimated wall time of the run.
    """

    #: workspace integration: grid (boundary fractions, second order) or midpoint (cell-centre count, first order)
    method: str = "grid"
    #: grid points per sampled axis (method grid: times the mechanism's factor of an axis where it
    #: has one, H4 1/2 along theta; null: the mechanism's default for the method)
    resolution: Optional[int] = None
    #: the optimum is re-evaluated at refine_factor × resolution, [2, 8]: the change is its error
    #: bar (1 would report an error of 0)
    refine_factor: int = 4
    #: accept a resolution below the mechanism's minimum (tests, quick looks)
    allow_coarse: bool = False
    #: nodes of one evaluation, refined one included (memory and time budget)
    max_nodes: int = 4_000_000
    #: estimated wall time of the run, hours (checked before work; the optimiser, its polish and,
    #: with optimizer.reference, the reference optimum's searches)
    max_hours: float = 12.0

    def __post_init__(self) -> None:
        check("evaluate.method", self.method, self.method in EVALUATE_METHODS, "one of " + ", ".join(EVALUATE_METHODS))
        check(
            "evaluate.resolution",
            self.resolution,
            self.resolution is None or 1 <= self.resolution <= 100_000,
            "null or an integer in [1, 100000]",
        )
        check("evaluate.refine_factor", self.refine_factor, 2 <= self.refine_factor <= 8, "an integer in [2, 8]")
        check("evaluate.max_nodes", self.max_nodes, 1_000 <= self.max_nodes <= 10**9, "an integer in [1000, 1e9]")
        check(
            "evaluate.max_hours",
            self.max_hours,
            finite(self.max_hours) and 0 < self.max_hours <= MAX_HOURS,
            f"(0, {MAX_HOURS}]",
        )


@dataclass
class ParallelConfig:
    """Fitness evaluations: joblib workers and backend (execution only: not in result files)."""

    #: parallel fitness evaluations (loky: this process plus n_jobs − 1 workers)
    n_jobs: int = 2
    #: joblib backend: loky, threading, multiprocessing, dask
    backend: str = "loky"
    #: dask only: address of a running scheduler (tcp://host:port); null starts a LocalCluster
    scheduler_address: Optional[str] = None

    def __post_init__(self) -> None:
        check("parallel.n_jobs", self.n_jobs, 1 <= self.n_jobs <= 1024, "an integer in [1, 1024]")
        check("parallel.backend", self.backend, self.backend in BACKENDS, "one of " + ", ".join(BACKENDS))
        address = self.scheduler_address
        check(
            "parallel.scheduler_address",
            address,
            address is None or re.fullmatch(r"(tcp|tls)://[^\s:/]+:\d{1,5}", address) is not None,
            "null or tcp://host:port",
        )


@dataclass
class PathsConfig:
    """Where results, the stage cache and the aggregated dataset go (must be writable)."""

    #: results root: runs/, sweeps/, cache/, dataset/ below it (relative to the working folder)
    output_dir: str = "outputs"
    #: joblib.Memory of the stages
    cache_dir: str = "${paths.output_dir}/cache"
    #: the aggregated Parquet dataset
    dataset_dir: str = "${paths.output_dir}/dataset"


@dataclass
class PlotConfig:
    """The run's figures: on/off, an extra vector format, resolution."""

    #: write the run's figures
    enabled: bool = True
    #: extra vector format beside the PNG (null: PNG only)
    format: Optional[str] = None
    #: PNG resolution, [50, 1200]
    dpi: int = 150

    def __post_init__(self) -> None:
        check("plot.format", self.format, self.format is None or self.format in ("pdf", "svg"), "null, pdf or svg")
        check("plot.dpi", self.dpi, 50 <= self.dpi <= 1200, "an integer in [50, 1200]")


@dataclass
class Config:
    #: names the run and sweep folders and the dataset rows (experiment files set it)
    experiment_name: str = "default"
    #: why the run is made (:data:`PURPOSES`): debug runs (``+debug=...``) stay out of the
    #: dataset's default view (:func:`pipeline.store.dataset.read_dataset`)
    purpose: str = "study"
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
        check(
            "experiment_name",
            self.experiment_name,
            isinstance(self.experiment_name, str) and bool(_PLAIN_NAME.match(self.experiment_name)),
            "a plain name of letters, digits, '_', '.', '-' (no '/', at most 100 characters)",
        )
        check("purpose", self.purpose, self.purpose in PURPOSES, "one of " + ", ".join(PURPOSES))

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
        return _content_hash(self.result_dict())

    def study_hash(self) -> str:
        """:func:`study_hash` of :meth:`result_dict`."""
        return study_hash(self.result_dict())


#: the fields a study varies over its runs, (section, key) of :meth:`Config.result_dict`: runs that
#: differ in these only are one study's seeds and its points along w_d (a trade-off's line)
STUDY_AXES = (("optimizer", "seed"), ("objective", "w_d"))


def _content_hash(result: dict) -> str:
    text = json.dumps(result, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def study_hash(result: dict) -> str:
    """Content hash (16 hex digits) of a result config (:meth:`Config.result_dict`, or a run
    manifest's ``config``) without its :data:`STUDY_AXES`: equal for the seeds and the w_d points
    of one study, different where anything else differs (an override of the orientation, the
    resolution or the population under the same experiment name is another study)."""
    reduced = {section: dict(part) if isinstance(part, dict) else part for section, part in result.items()}
    for section, key in STUDY_AXES:
        if isinstance(reduced.get(section), dict):
            reduced[section].pop(key, None)
    return _content_hash(reduced)
