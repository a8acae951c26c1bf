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

from dataclasses import dataclass

import numpy as np

from pipeline.errors import check, finite
from pipeline.optimizers.base import History, OptimizationResult, Optimizer, OptimizerConfig, Problem, check_generations


@dataclass
class GAConfig(OptimizerConfig):
    """GAOT settings of seed 000 Sec. 4.5. Paper-faithful: no polish, but a
    reference optimisation (CMA-ES + polish) records how far the GA stops short."""

    name: str = "ga"
    polish: bool = False
    reference: bool = True
    #: individuals per generation (seed 000 Sec. 4.5)
    population: int = 30
    #: generations (seed 000 Sec. 4.5)
    generations: int = 150
    #: normalised geometric selection probability q
    selection_q: float = 0.08
    #: arithmetic crossover probability
    crossover_rate: float = 0.8
    #: non-uniform mutation probability
    mutation_rate: float = 0.08
    #: shape b of the non-uniform mutation
    mutation_shape: float = 3.0
    #: start from the best sampled designs (off for paper reproduction)
    seed_from_samples: bool = False
    #: how many best sampled designs seed the first population
    seed_count: int = 5

    def __post_init__(self) -> None:
        super().__post_init__()
        check_generations(self.population, self.generations, 2)
        check(
            "optimizer.selection_q", self.selection_q, finite(self.selection_q) and 0 < self.selection_q <= 1, "(0, 1]"
        )
        for name in ("crossover_rate", "mutation_rate"):
            value = getattr(self, name)
            check(f"optimizer.{name}", value, finite(value) and 0 <= value <= 1, "[0, 1]")
        check(
            "optimizer.mutation_shape",
            self.mutation_shape,
            finite(self.mutation_shape) and 0 < self.mutation_shape <= 100,
            "(0, 100]",
        )
        check(
            "optimizer.seed_count",
            self.seed_count,
            1 <= self.seed_count <= 100_000,
            "an integer in [1, 100000] (at most optimizer.population are used)",
        )


class GA(Optimizer):
    """The GAOT real-coded GA (module docstring); ``run`` keeps the operators exactly."""

    name = "ga"
    Config = GAConfig

    def expected_evaluations(self) -> int:
        c = self.config
        return c.population * (c.generations + 1)

    def run(self, problem: Problem, initial: np.ndarray | None = None) -> OptimizationResult:
        c = self.config
        return genetic_algorithm(
            problem,
            problem.lower,
            problem.upper,
            population=c.population,
            generations=c.generations,
            seed=c.seed,
            selection_q=c.selection_q,
            crossover_rate=c.crossover_rate,
            mutation_rate=c.mutation_rate,
            mutation_shape=c.mutation_shape,
            initial=initial if c.seed_from_samples else None,
        )


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


def arithmetic_crossover(rng: np.random.Generator, pop: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray]:
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


def nonuniform_mutation(
    rng: np.random.Generator,
    pop: np.ndarray,
    lower: np.ndarray,
    upper: np.ndarray,
    rate: float,
    generation: int,
    generations: int,
    shape: float,
) -> tuple[np.ndarray, np.ndarray]:
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
def genetic_algorithm(
    fitness,
    lower: np.ndarray,
    upper: np.ndarray,
    *,
    population: int = 30,
    generations: int = 150,
    seed: int = 0,
    selection_q: float = 0.08,
    crossover_rate: float = 0.8,
    mutation_rate: float = 0.08,
    mutation_shape: float = 3.0,
    initial: np.ndarray | None = None,
) -> OptimizationResult:
    """Maximise ``fitness`` over the box ``[lower, upper]`` with the GAOT operators.

    Parameters
    ----------
    fitness : Problem or callable, (P, n) -> (P,)
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
    problem = fitness if isinstance(fitness, Problem) else Problem(fitness, lower, upper)
    lower, upper = problem.lower, problem.upper
    rng = np.random.default_rng(seed)
    pop = rng.uniform(lower, upper, size=(population, lower.size))
    if initial is not None:
        initial = np.atleast_2d(np.asarray(initial, dtype=float))[:population]
        pop[: len(initial)] = np.clip(initial, lower, upper)

    history = History(generations, "ga: ")
    start_count = problem.n_evaluations
    fit = problem(pop)
    history.record(pop, fit, population)
    for gen in range(1, generations + 1):
        best_idx = int(np.argmax(fit))
        elite, elite_fit = pop[best_idx].copy(), fit[best_idx]
        chosen = select(rng, fit, selection_q)
        pop, fit = pop[chosen], fit[chosen]
        pop, crossed = arithmetic_crossover(rng, pop, crossover_rate)
        pop, mutated = nonuniform_mutation(rng, pop, lower, upper, mutation_rate, gen, generations, mutation_shape)
        pop = np.clip(pop, lower, upper)
        changed = crossed | mutated
        fit = fit.copy()
        fit[changed] = problem(pop[changed])
        worst = int(np.argmin(fit))
        pop[worst], fit[worst] = elite, elite_fit
        history.record(pop, fit, int(changed.sum()))
    best = int(np.argmax(fit))
    return OptimizationResult(
        x=pop[best].copy(),
        fun=float(fit[best]),
        history=history.frame(),
        n_evaluations=problem.n_evaluations - start_count,
        method="ga",
        message=f"{generations} generations of {population}",
    )
