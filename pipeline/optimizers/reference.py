"""The reference optimum of a problem: the best of several independent searches.

Issue 23: a gap measured against one CMA-ES run is understated whenever that
run stops short. :func:`best_known` runs, on one problem,

* the recommended optimiser (multi-start IPOP-CMA-ES, :mod:`~pipeline.optimizers.cmaes`)
  with each of ``seeds``, then the polish step;
* differential evolution (:mod:`~pipeline.optimizers.de`, seed 0), then the polish step;
* where the dimension allows (``grid_points ** n <= max_grid``), a dense grid
  over the design box, then the polish step from the best ``grid_polish``
  grid points in distinct basins;

and returns the best design with how it was found, every search's value and
how many of the searches agree with the best within ``agreement`` (a
search that lands elsewhere says the landscape has a second basin). It is
expensive (several thousand evaluations): the pipeline computes it once per
problem as a cached stage (pipeline.stages.optimise.reference_stage) and
benchmarks/best_known.py records the golden values.
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass, field

import numpy as np

from pipeline.optimizers.base import Problem
from pipeline.optimizers.cmaes import CMAES, CMAESConfig, distinct_basins
from pipeline.optimizers.de import DE, DEConfig
from pipeline.optimizers.polish import polish

#: CMA-ES seeds of the reference
REFERENCE_SEEDS = (0, 1, 2, 3)
#: DE's population and generations in the reference (scipy DE, then polish)
REFERENCE_DE = (20, 60)
#: grid points per variable of the dense-grid search, and the largest grid it runs
REFERENCE_GRID_POINTS = 9
REFERENCE_MAX_GRID = 6561
#: polish budget of each search of the reference (more generous than a run's)
REFERENCE_POLISH = 300
#: grid points (best, in distinct basins) the dense grid's polish starts from
REFERENCE_GRID_POLISH = 3


@dataclass
class Search:
    """One search of the reference: ``method`` (e.g. ``"cmaes seed 2 + polish"``), its best
    ``value`` and design ``x`` (design units), and the ``n_evaluations`` it spent."""

    method: str
    value: float
    x: np.ndarray
    n_evaluations: int


@dataclass
class BestKnown:
    """The reference optimum: ``x`` (design units), ``fun`` (the objective), ``found_by`` (the
    method of the best search), ``n_evaluations`` (all searches), ``agreeing`` (searches within
    the agreement tolerance of ``fun``) and every search."""

    x: np.ndarray
    fun: float
    found_by: str
    n_evaluations: int
    agreeing: int
    searches: list[Search] = field(default_factory=list)

    def summary(self) -> str:
        """One line: the method of the best search and how many of the searches reach it."""
        return f"{self.found_by} (best of {len(self.searches)} searches; {self.agreeing} agree within 0.1 %)"


def expected_evaluations(n_var: int) -> int:
    """Evaluations :func:`best_known` spends at most, with its defaults, on a problem of ``n_var``
    design variables (each search's budget and each polish's)."""
    polish_evaluations = REFERENCE_POLISH
    total = len(REFERENCE_SEEDS) * (CMAES(CMAESConfig()).expected_evaluations() + polish_evaluations)
    total += DE(DEConfig(population=REFERENCE_DE[0], generations=REFERENCE_DE[1])).expected_evaluations()
    total += polish_evaluations
    if REFERENCE_GRID_POINTS**n_var <= REFERENCE_MAX_GRID:
        total += REFERENCE_GRID_POINTS**n_var + REFERENCE_GRID_POLISH * polish_evaluations
    return int(total)


def best_known(
    problem: Problem,
    *,
    seeds: tuple[int, ...] = REFERENCE_SEEDS,
    de: tuple[int, int] | None = REFERENCE_DE,
    grid_points: int = REFERENCE_GRID_POINTS,
    max_grid: int = REFERENCE_MAX_GRID,
    grid_polish: int = REFERENCE_GRID_POLISH,
    polish_evaluations: int = REFERENCE_POLISH,
    agreement: float = 1e-3,
) -> BestKnown:
    """Best of several independent searches of ``problem`` (maximised); see the module docstring.

    Parameters
    ----------
    problem : Problem
        Box and batch objective (design units).
    seeds : tuple of int
        Seeds of the CMA-ES searches (recommended config, each then polished).
    de : (population, generations) or None
        The DE search's size; None skips it.
    grid_points, max_grid : int
        Grid points per variable, and the largest grid (points) searched; a
        larger dimension skips the grid.
    grid_polish : int
        Grid points (best, in distinct basins) the polish step starts from.
    polish_evaluations : int
        Budget of each polish.
    agreement : float
        Relative tolerance of ``agreeing``.
    """
    searches: list[Search] = []

    def record(method: str, x: np.ndarray, value: float, since: int) -> None:
        polished = polish(problem, x, value, max_evaluations=polish_evaluations)
        searches.append(Search(f"{method} + polish", polished.fun, polished.x, problem.n_evaluations - since))

    for seed in seeds:
        since = problem.n_evaluations
        found = CMAES(CMAESConfig(seed=seed)).run(problem)
        record(f"cmaes seed {seed}", found.x, found.fun, since)
    if de is not None:
        since = problem.n_evaluations
        found = DE(DEConfig(seed=0, population=de[0], generations=de[1])).run(problem)
        record(f"de {de[0]}x{de[1]}", found.x, found.fun, since)
    if grid_points**problem.n_var <= max_grid:
        since = problem.n_evaluations
        unit_axes = [np.linspace(0.0, 1.0, grid_points)] * problem.n_var
        unit = np.array(list(itertools.product(*unit_axes)))
        grid = problem.lower + unit * (problem.upper - problem.lower)
        values = problem(grid)
        best = None
        for k in distinct_basins(unit, values, grid_polish, 1.5 / (grid_points - 1)):
            polished = polish(problem, grid[k], float(values[k]), max_evaluations=polish_evaluations)
            if best is None or polished.fun > best.fun:
                best = polished
        searches.append(
            Search(f"grid {grid_points}^{problem.n_var} + polish", best.fun, best.x, problem.n_evaluations - since)
        )
    top = max(searches, key=lambda s: s.value)  # the first of equals: the order above
    tolerance = agreement * abs(top.value)
    agreeing = sum(top.value - s.value <= tolerance for s in searches)
    return BestKnown(
        x=top.x,
        fun=top.value,
        found_by=top.method,
        n_evaluations=sum(s.n_evaluations for s in searches),
        agreeing=int(agreeing),
        searches=searches,
    )
