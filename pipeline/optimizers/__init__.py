"""Optimiser registry: every :class:`~pipeline.optimizers.base.Optimizer` subclass in this package.

``OPTIMIZERS`` maps the registry name (``optimizer=NAME`` on the command
line) to the class; it is filled by importing every module here, so adding
an optimiser is one new module with a class that sets ``name`` and
``Config`` (its config dataclass, registered in Hydra's ``optimizer`` group
by :func:`pipeline.config.register_configs`).
"""

from __future__ import annotations

from kinematics.registry import discover
from pipeline.optimizers.base import OptimizationResult, Optimizer, OptimizerConfig, Problem
from pipeline.optimizers.polish import PolishResult, polish

OPTIMIZERS: dict[str, type[Optimizer]] = discover(__name__, __path__, Optimizer)

#: the recommended optimiser (multi-start IPOP-CMA-ES); its runs make up most of the reference
#: optimum of a study (:func:`pipeline.optimizers.reference.best_known`, several searches)
REFERENCE_OPTIMIZER = "cmaes"
#: the budget of one :func:`reference_optimum` run (before its polish): the recommended default
REFERENCE_EVALUATIONS = 800


def reference_optimum(problem: Problem, seed: int) -> PolishResult:
    """One strong search of ``problem``: :data:`REFERENCE_OPTIMIZER` with
    :data:`REFERENCE_EVALUATIONS` evaluations, then the polish step from its best design.

    For a study's reference use :func:`pipeline.optimizers.reference.best_known`
    (the best of several searches); this single search is for callers that run
    many problems (the reproduction's readings study)."""
    cls = OPTIMIZERS[REFERENCE_OPTIMIZER]
    found = cls(cls.Config(name=REFERENCE_OPTIMIZER, seed=seed, max_evaluations=REFERENCE_EVALUATIONS)).run(problem)
    return polish(problem, found.x, found.fun)


__all__ = [
    "OPTIMIZERS",
    "REFERENCE_EVALUATIONS",
    "REFERENCE_OPTIMIZER",
    "OptimizationResult",
    "Optimizer",
    "OptimizerConfig",
    "Problem",
    "reference_optimum",
]
