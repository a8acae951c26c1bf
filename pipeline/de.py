"""Differential evolution on the same objective and budget as the GA (for comparison tables).

A thin wrapper of ``scipy.optimize.differential_evolution``: the initial
population is ``population`` uniform designs from the seeded generator (so
the population size is exactly the GA's), ``maxiter = generations``, batch
(vectorised) fitness evaluation with deferred updating, and no final
L-BFGS polish, so the budget is ``population * (generations + 1)``
evaluations, the GA's nominal budget.
"""

from __future__ import annotations

import time

import numpy as np
import pandas as pd
from scipy.optimize import differential_evolution as scipy_de

from pipeline.ga import FitnessFunction, OptimizationResult


def differential_evolution(fitness: FitnessFunction, lower: np.ndarray, upper: np.ndarray, *,
                           population: int = 30, generations: int = 150, seed: int = 0
                           ) -> OptimizationResult:
    """Maximise ``fitness`` (batch, (P, n) -> (P,)) over ``[lower, upper]`` with scipy's DE."""
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    rng = np.random.default_rng(seed)
    init = rng.uniform(lower, upper, size=(population, lower.size))
    start = time.perf_counter()
    rows: list[dict] = []
    count = {"n": 0}

    def negative(x_columns: np.ndarray) -> np.ndarray:
        designs = np.atleast_2d(x_columns.T) if x_columns.ndim == 2 else x_columns[None, :]
        values = np.nan_to_num(np.asarray(fitness(designs), dtype=float), nan=0.0)
        count["n"] += designs.shape[0]
        return -values

    def callback(intermediate_result) -> None:
        pop_fit = -np.asarray(intermediate_result.population_energies)
        best = int(np.argmax(pop_fit))
        row = {"generation": len(rows) + 1, "best": float(pop_fit[best]), "mean": float(pop_fit.mean()),
               "worst": float(pop_fit.min()), "n_evaluations": population,
               "wall_time": time.perf_counter() - start}
        row.update({f"x{j}": float(v) for j, v in enumerate(intermediate_result.population[best])})
        rows.append(row)

    result = scipy_de(negative, list(zip(lower, upper)), init=init, maxiter=generations,
                      seed=rng, polish=False, vectorized=True, updating="deferred",
                      callback=callback, tol=0.0, atol=0.0)
    history = pd.DataFrame(rows)
    return OptimizationResult(x=np.asarray(result.x, dtype=float), fun=float(-result.fun),
                              history=history, n_evaluations=count["n"], method="de",
                              message=str(result.message))
