"""IPOP-CMA-ES (Auger & Hansen 2005) through the ``cma`` package, Hansen's reference code.

Why ``cma`` and not our own: it is the algorithm's reference implementation,
pure Python on numpy, well kept, and its ask/tell interface lets us keep our
parallel batch evaluation: each generation's ``popsize`` designs are
evaluated as one batch.

Adapter choices:

* the search runs in the unit box ``u = (x - lower) / (upper - lower)``, so one
  step size ``sigma0`` (a fraction of every range) fits all variables;
* bounds by ``cma``'s BoundTransform; it approaches a bound but lands on it only
  by chance, which is why the default ends with the polish step (it snaps);
* IPOP restarts: each restart doubles the population, until the evaluation
  budget ``max_evaluations`` is spent or ``restarts`` are done;
* determinism: every normal draw comes from one seeded
  :class:`numpy.random.Generator` (``cma``'s ``randn`` option), never from
  numpy's global state, so a run is a function of ``seed`` only.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from typing import Optional

import numpy as np

from pipeline.errors import check, finite
from pipeline.optimizers.base import History, OptimizationResult, Optimizer, OptimizerConfig, Problem


@dataclass
class CMAESConfig(OptimizerConfig):
    """IPOP-CMA-ES settings; the default is the fast optimiser of users' own studies."""

    name: str = "cmaes"
    #: evaluations of the CMA-ES part (the polish step has its own budget). In
    #: benchmarks/optimisers.py the slowest of 12 runs needed 231 to come within
    #: 0.1 % of the reference; a run is a prefix of a longer-budget run (the
    #: budget only stops it), so 300 keeps that with a margin
    max_evaluations: int = 300
    #: initial step, a fraction of every variable's range
    sigma0: float = 0.3
    #: first population; null = cma's default 4 + 3 ln(n)
    popsize: Optional[int] = None
    #: IPOP restarts (population doubled at each)
    restarts: int = 4

    def __post_init__(self) -> None:
        super().__post_init__()
        check("optimizer.max_evaluations", self.max_evaluations, 10 <= self.max_evaluations <= 10_000_000,
              "an integer in [10, 10000000]")
        check("optimizer.sigma0", self.sigma0, finite(self.sigma0) and 0 < self.sigma0 <= 1, "(0, 1]")
        check("optimizer.popsize", self.popsize, self.popsize is None or 2 <= self.popsize <= 10_000,
              "null or an integer in [2, 10000]")
        check("optimizer.restarts", self.restarts, 0 <= self.restarts <= 20, "an integer in [0, 20]")


class CMAES(Optimizer):
    name = "cmaes"
    Config = CMAESConfig

    def expected_evaluations(self) -> int:
        return self.config.max_evaluations

    def run(self, problem: Problem, initial: np.ndarray | None = None) -> OptimizationResult:
        import cma  # imports scipy.stats and pyplot (~1 s): only when a CMA-ES run starts

        c = self.config
        lower, span = problem.lower, problem.upper - problem.lower
        rng = np.random.default_rng(c.seed)
        start_count = problem.n_evaluations
        best_x, best_f = None, -np.inf
        x0 = (np.clip(np.atleast_2d(initial)[0], problem.lower, problem.upper) - lower) / span \
            if initial is not None and len(initial) else np.full(problem.n_var, 0.5)
        popsize = c.popsize or 4 + int(3 * np.log(problem.n_var))
        history = History(max(c.max_evaluations // popsize, 1), "cmaes: ")
        messages = []
        for restart in range(c.restarts + 1):
            left = c.max_evaluations - (problem.n_evaluations - start_count)
            if left < popsize:
                break
            options = {"bounds": [0.0, 1.0], "popsize": popsize, "maxfevals": left, "verbose": -9,
                       "seed": np.nan, "randn": lambda *shape: rng.standard_normal(shape),
                       "tolfun": 1e-11, "tolx": 1e-9, "CMA_stds": None}
            with warnings.catch_warnings():  # cma warns about its own restarts and flat fitness
                warnings.simplefilter("ignore")
                es = cma.CMAEvolutionStrategy(x0 if restart == 0 else rng.uniform(0, 1, problem.n_var),
                                              c.sigma0, options)
                while not es.stop():
                    unit = np.asarray(es.ask())
                    # ask() returns bound-transformed (feasible) points; clip only rounding
                    designs = lower + np.clip(unit, 0.0, 1.0) * span
                    values = problem(designs)
                    es.tell(list(unit), list(-values))
                    history.record(designs, values, len(designs), restart=restart)
                    k = int(np.argmax(values))
                    if values[k] > best_f:
                        best_x, best_f = designs[k].copy(), float(values[k])
            messages.append(f"restart {restart} (popsize {popsize}): " + ", ".join(es.stop()))
            popsize *= 2
        if best_x is None:  # budget below one generation: evaluate the start
            best_x = lower + x0 * span
            best_f = float(problem(best_x[None])[0])
        return OptimizationResult(x=best_x, fun=best_f, history=history.frame(),
                                  n_evaluations=problem.n_evaluations - start_count, method="cmaes",
                                  message="; ".join(messages))
