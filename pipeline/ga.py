"""Real-coded genetic algorithm of the GAOT toolbox (Houck, Joines & Kay 1995), as in seed 000 Sec. 4.5.

"Normalized geometric selection ..., non-uniform mutation with the ratio of
0.08 and arithmetic crossover with the ratio of 0.8. Moreover, the
population size is 30 and the generations' number is set to 150."

The algorithm maximises ``fitness(designs) -> values`` over a box. One
seeded :class:`numpy.random.Generator` in the calling process drives every
random draw, in a fixed order, so the history is a function of the seed
only, whatever evaluates the fitness (in-process, loky workers, a dask
cluster). Individuals that survive a generation unchanged (copies made by
selection, the elite) keep their fitness and are not evaluated again.

Operators (per generation G = 1..Gmax):

1. normalized geometric selection: rank r = 1 for the best,
   ``P(r) = q' (1 - q)^(r - 1)`` with ``q' = q / (1 - (1 - q)^P)``; the whole new
   population is drawn with replacement;
2. arithmetic crossover on a fraction ``crossover_rate`` of the population, in
   random pairs: ``c1 = a p1 + (1 - a) p2``, ``c2 = (1 - a) p1 + a p2``, one
   ``a ~ U(0, 1)`` per pair;
3. non-uniform mutation: each individual with probability ``mutation_rate``
   has one variable moved toward its upper bound by ``(ub - x) D`` or toward
   its lower bound by ``(x - lb) D`` (probability 1/2 each),
   ``D = (r (1 - G/Gmax))^b``, ``r ~ U(0, 1)``;
4. elitism: the worst of the new population is replaced by the previous
   generation's best.
"""

from __future__ import annotations

import logging
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import pandas as pd

log = logging.getLogger(__name__)

FitnessFunction = Callable[[np.ndarray], np.ndarray]


@dataclass
class OptimizationResult:
    """Outcome of an optimiser run (in the spirit of ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    x : ndarray, shape (n,)
        Best design found.
    fun : float
        Its fitness (maximised).
    history : pandas.DataFrame
        One row per generation: ``generation``, ``best``, ``mean``, ``worst``
        fitness, ``n_evaluations`` (new evaluations in that generation),
        ``wall_time`` (s since start), and the best design ``x0 .. x{n-1}``.
    n_evaluations : int
        Fitness evaluations in total.
    method : str
    message : str
    """

    x: np.ndarray
    fun: float
    history: pd.DataFrame
    n_evaluations: int
    method: str
    message: str = ""
    extra: dict = field(default_factory=dict)


# ------------------------------------------------------------- operators
def geometric_selection_probabilities(population: int, q: float) -> np.ndarray:
    """``P(r) = q' (1 - q)^(r - 1)``, r = 1..population, ``q' = q / (1 - (1 - q)^population)``."""
    ranks = np.arange(population)
    q_norm = q / (1.0 - (1.0 - q) ** population)
    return q_norm * (1.0 - q) ** ranks


def select(rng: np.random.Generator, fitness: np.ndarray, q: float) -> np.ndarray:
    """Indices of the new population (normalized geometric selection, with replacement).

    Ties in fitness are ranked by index (a stable sort) so the draw is deterministic.
    """
    order = np.argsort(-fitness, kind="stable")  # rank 1 = best
    probs = geometric_selection_probabilities(fitness.size, q)
    cumulative = np.cumsum(probs)
    cumulative[-1] = 1.0
    draws = rng.random(fitness.size)
    return order[np.searchsorted(cumulative, draws, side="right").clip(max=fitness.size - 1)]


def arithmetic_crossover(rng: np.random.Generator, pop: np.ndarray, rate: float
                         ) -> tuple[np.ndarray, np.ndarray]:
    """Cross ``round(rate * P / 2)`` random pairs; returns children and a changed mask."""
    n_pop = pop.shape[0]
    n_pairs = int(round(rate * n_pop / 2))
    order = rng.permutation(n_pop)
    weights = rng.random(n_pairs)
    out = pop.copy()
    changed = np.zeros(n_pop, dtype=bool)
    for k in range(n_pairs):
        i, j = order[2 * k], order[2 * k + 1]
        a = weights[k]
        out[i] = a * pop[i] + (1 - a) * pop[j]
        out[j] = (1 - a) * pop[i] + a * pop[j]
        changed[[i, j]] = True
    return out, changed


def nonuniform_mutation(rng: np.random.Generator, pop: np.ndarray, lower: np.ndarray,
                        upper: np.ndarray, rate: float, generation: int, generations: int,
                        shape: float) -> tuple[np.ndarray, np.ndarray]:
    """Non-uniform mutation of one variable per mutated individual; returns children and mask."""
    n_pop, n_var = pop.shape
    mutate = rng.random(n_pop) < rate
    var = rng.integers(0, n_var, size=n_pop)
    up = rng.random(n_pop) < 0.5
    r = rng.random(n_pop)
    delta = (r * (1.0 - generation / generations)) ** shape
    out = pop.copy()
    idx = np.nonzero(mutate)[0]
    v = var[idx]
    x = out[idx, v]
    out[idx, v] = np.where(up[idx], x + (upper[v] - x) * delta[idx], x - (x - lower[v]) * delta[idx])
    return out, mutate


# -------------------------------------------------------------- the GA
def genetic_algorithm(fitness: FitnessFunction, lower: np.ndarray, upper: np.ndarray, *,
                      population: int = 30, generations: int = 150, seed: int = 0,
                      selection_q: float = 0.08, crossover_rate: float = 0.8,
                      mutation_rate: float = 0.08, mutation_shape: float = 3.0,
                      initial: np.ndarray | None = None) -> OptimizationResult:
    """Maximise ``fitness`` over the box ``[lower, upper]`` with the GAOT operators.

    Parameters
    ----------
    fitness : callable, (P, n) -> (P,)
        Batch fitness; NaN is treated as 0 (an empty workspace has fitness 0).
    lower, upper : array_like, shape (n,)
        Box bounds, ``lower < upper``.
    population, generations : int
        30 and 150 in seed 000.
    seed : int
        Seed of the one random generator.
    selection_q, crossover_rate, mutation_rate, mutation_shape : float
        0.08, 0.8, 0.08 and b = 3 (GAOT defaults; seed 000 Sec. 4.5).
    initial : ndarray, shape (k, n), optional
        Designs placed first in the initial population (the rest is uniform).

    Returns
    -------
    OptimizationResult
    """
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    _check_ga_arguments(lower, upper, population, generations, selection_q, crossover_rate,
                        mutation_rate, mutation_shape)
    rng = np.random.default_rng(seed)
    pop = rng.uniform(lower, upper, size=(population, lower.size))
    if initial is not None:
        initial = np.atleast_2d(np.asarray(initial, dtype=float))[:population]
        pop[: len(initial)] = np.clip(initial, lower, upper)

    start = time.perf_counter()
    n_evaluations = 0

    def evaluate(x: np.ndarray) -> np.ndarray:
        nonlocal n_evaluations
        n_evaluations += x.shape[0]
        if x.shape[0] == 0:
            return np.empty(0)
        values = np.asarray(fitness(x), dtype=float).reshape(-1)
        if values.shape != (x.shape[0],):
            raise ValueError(f"fitness must return shape ({x.shape[0]},); got {values.shape}")
        return np.nan_to_num(values, nan=0.0)

    fit = evaluate(pop)
    rows = [_history_row(0, fit, pop, population, start)]
    for gen in range(1, generations + 1):
        before = n_evaluations
        best_idx = int(np.argmax(fit))
        elite, elite_fit = pop[best_idx].copy(), fit[best_idx]
        chosen = select(rng, fit, selection_q)
        pop, fit = pop[chosen], fit[chosen]
        pop, crossed = arithmetic_crossover(rng, pop, crossover_rate)
        pop, mutated = nonuniform_mutation(rng, pop, lower, upper, mutation_rate, gen,
                                           generations, mutation_shape)
        pop = np.clip(pop, lower, upper)
        changed = crossed | mutated
        fit = fit.copy()
        fit[changed] = evaluate(pop[changed])
        worst = int(np.argmin(fit))
        pop[worst], fit[worst] = elite, elite_fit
        rows.append(_history_row(gen, fit, pop, n_evaluations - before, start))
        _log_generation(gen, generations, fit, n_evaluations, start)
    history = pd.DataFrame(rows)
    best = int(np.argmax(fit))
    return OptimizationResult(x=pop[best].copy(), fun=float(fit[best]), history=history,
                              n_evaluations=n_evaluations, method="ga",
                              message=f"{generations} generations of {population}")


def _history_row(gen: int, fit: np.ndarray, pop: np.ndarray, n_new: int, start: float) -> dict:
    best = int(np.argmax(fit))
    row = {"generation": gen, "best": float(fit[best]), "mean": float(fit.mean()),
           "worst": float(fit.min()), "n_evaluations": int(n_new),
           "wall_time": time.perf_counter() - start}
    row.update({f"x{j}": float(v) for j, v in enumerate(pop[best])})
    return row


def _log_generation(gen: int, generations: int, fit: np.ndarray, n_evaluations: int,
                    start: float) -> None:
    elapsed = time.perf_counter() - start
    rate = n_evaluations / elapsed if elapsed > 0 else math.inf
    eta = elapsed / gen * (generations - gen)
    log.info("generation %d/%d best %.6g mean %.6g evaluations/s %.1f ETA %.1f s",
             gen, generations, float(fit.max()), float(fit.mean()), rate, eta)


def _check_ga_arguments(lower, upper, population, generations, q, crossover, mutation, shape):
    if lower.ndim != 1 or lower.shape != upper.shape:
        raise ValueError(f"lower and upper must be 1-D of the same length; got {lower.shape}, {upper.shape}")
    if not np.all(np.isfinite(lower) & np.isfinite(upper) & (lower < upper)):
        raise ValueError("bounds must be finite with lower < upper for every variable")
    if population < 2:
        raise ValueError(f"population must be >= 2; got {population}")
    if generations < 1:
        raise ValueError(f"generations must be >= 1; got {generations}")
    for name, value in (("selection_q", q), ("crossover_rate", crossover), ("mutation_rate", mutation)):
        if not 0.0 <= value <= 1.0 or (name == "selection_q" and value == 0.0):
            raise ValueError(f"{name} must be in (0, 1] for selection_q, [0, 1] otherwise; got {value}")
    if not shape > 0:
        raise ValueError(f"mutation_shape must be > 0; got {shape}")
