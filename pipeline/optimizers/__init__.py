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

#: the optimiser of the reference optimisation (recorded gap of paper-faithful runs)
REFERENCE_OPTIMIZER = "cmaes"
#: its evaluation budget (before its polish): more generous than the fast default's, since
#: the reference is meant as the best we can find
REFERENCE_EVALUATIONS = 420


def reference_optimum(problem: Problem, seed: int) -> PolishResult:
    """The reference optimisation of ``problem``: :data:`REFERENCE_OPTIMIZER` with
    :data:`REFERENCE_EVALUATIONS` evaluations, then the polish step from its best design."""
    cls = OPTIMIZERS[REFERENCE_OPTIMIZER]
    found = cls(cls.Config(name=REFERENCE_OPTIMIZER, seed=seed, max_evaluations=REFERENCE_EVALUATIONS)).run(problem)
    return polish(problem, found.x, found.fun)


__all__ = ["OPTIMIZERS", "REFERENCE_EVALUATIONS", "REFERENCE_OPTIMIZER", "OptimizationResult", "Optimizer",
           "OptimizerConfig", "Problem", "reference_optimum"]
