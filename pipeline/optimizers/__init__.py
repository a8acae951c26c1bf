"""Optimiser registry: every :class:`~pipeline.optimizers.base.Optimizer` subclass in this package.

``OPTIMIZERS`` maps the registry name (``optimizer=NAME`` on the command
line) to the class; it is filled by importing every module here, so adding
an optimiser is one new module with a class that sets ``name`` and
``Config`` (its config dataclass, registered in Hydra's ``optimizer`` group
by :func:`pipeline.config.register_configs`).
"""

from __future__ import annotations

import importlib
import pkgutil

from pipeline.optimizers.base import OptimizationResult, Optimizer, OptimizerConfig, Problem


def _discover() -> dict[str, type[Optimizer]]:
    for info in pkgutil.iter_modules(__path__):
        if not info.name.startswith("_"):
            importlib.import_module(f"{__name__}.{info.name}")
    found: dict[str, type[Optimizer]] = {}
    stack = list(Optimizer.__subclasses__())
    while stack:
        cls = stack.pop()
        stack.extend(cls.__subclasses__())
        if isinstance(getattr(cls, "name", None), str):
            found[cls.name] = cls
    return dict(sorted(found.items()))


OPTIMIZERS: dict[str, type[Optimizer]] = _discover()

#: the optimiser of the reference optimisation (recorded gap of paper-faithful runs)
REFERENCE_OPTIMIZER = "cmaes"

__all__ = ["OPTIMIZERS", "REFERENCE_OPTIMIZER", "OptimizationResult", "Optimizer", "OptimizerConfig",
           "Problem"]
