"""Differential evolution (scipy) on the GA's population and budget.

A thin adapter of ``scipy.optimize.differential_evolution``: the initial
population is ``population`` uniform designs from the seeded generator,
``maxiter = generations``, batch (vectorised) evaluation with deferred
updating (so our parallel batch evaluation is used), scipy's own L-BFGS
polish off (our :mod:`~pipeline.optimizers.polish` step replaces it). The
budget is ``population * (generations + 1)`` evaluations.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import differential_evolution as scipy_de

from pipeline.errors import check, finite
from pipeline.optimizers.base import History, OptimizationResult, Optimizer, OptimizerConfig, Problem, check_generations


@dataclass
class DEConfig(OptimizerConfig):
    """scipy DE settings; ``population >= 5`` (scipy needs five members for its mutation)."""

    name: str = "de"
    #: individuals per generation
    population: int = 30
    #: generations
    generations: int = 150
    #: differential weight F
    mutation: float = 0.5
    #: crossover probability CR
    recombination: float = 0.7

    def __post_init__(self) -> None:
        super().__post_init__()
        check_generations(self.population, self.generations, 5)
        check("optimizer.mutation", self.mutation, finite(self.mutation) and 0 < self.mutation < 2, "(0, 2)")
        check(
            "optimizer.recombination",
            self.recombination,
            finite(self.recombination) and 0 <= self.recombination <= 1,
            "[0, 1]",
        )


class DE(Optimizer):
    name = "de"
    Config = DEConfig

    def expected_evaluations(self) -> int:
        return self.config.population * (self.config.generations + 1)

    def run(self, problem: Problem, initial: np.ndarray | None = None) -> OptimizationResult:
        c = self.config
        rng = np.random.default_rng(c.seed)
        init = rng.uniform(problem.lower, problem.upper, size=(c.population, problem.n_var))
        history = History(c.generations, "de: ")
        start_count = problem.n_evaluations

        def negative(columns: np.ndarray) -> np.ndarray:
            designs = np.atleast_2d(columns.T) if columns.ndim == 2 else columns[None, :]
            return -problem(designs)

        def callback(intermediate_result) -> None:  # scipy dispatches on this name
            history.record(
                np.asarray(intermediate_result.population),
                -np.asarray(intermediate_result.population_energies),
                c.population,
            )

        result = scipy_de(
            negative,
            list(zip(problem.lower, problem.upper)),
            init=init,
            maxiter=c.generations,
            mutation=c.mutation,
            recombination=c.recombination,
            seed=rng,
            polish=False,
            vectorized=True,
            updating="deferred",
            callback=callback,
            tol=0.0,
            atol=0.0,
        )
        return OptimizationResult(
            x=np.asarray(result.x, dtype=float),
            fun=float(-result.fun),
            history=history.frame(),
            n_evaluations=problem.n_evaluations - start_count,
            method="de",
            message=str(result.message),
        )
