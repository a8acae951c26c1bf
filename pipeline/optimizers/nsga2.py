"""NSGA-II (Deb et al. 2002): the Pareto front of two objectives, (GDI, SURI) by default.

Why our own and not pymoo: the algorithm is ~100 lines of vectorised numpy
(non-dominated sorting, crowding distance, binary tournament, SBX and
polynomial mutation), it reuses the project's batch evaluation (parallel,
deterministic) and seeding discipline, and avoids a runtime dependency with
compiled extensions. ``tests/test_nsga2.py`` checks its front against
pymoo's NSGA-II (pymoo is in the dev extra only).

All objectives are maximised; one seeded generator drives every draw.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from pipeline.errors import check, finite
from pipeline.objectives import OBJECTIVES
from pipeline.optimizers.base import History, OptimizationResult, Optimizer, OptimizerConfig, Problem, check_generations


@dataclass
class NSGA2Config(OptimizerConfig):
    """NSGA-II settings; ``objectives`` names two of :data:`pipeline.objectives.OBJECTIVES`."""

    name: str = "nsga2"
    polish: bool = False
    #: individuals per generation
    population: int = 40
    #: generations
    generations: int = 40
    #: the two maximised objectives (names of objective options)
    objectives: list[str] = field(default_factory=lambda: ["gdi", "suri"])
    #: distribution index of simulated binary crossover
    eta_crossover: float = 15.0
    #: distribution index of polynomial mutation
    eta_mutation: float = 20.0
    #: crossover probability
    crossover_rate: float = 0.9

    def __post_init__(self) -> None:
        super().__post_init__()
        check_generations(self.population, self.generations, 4)
        names = list(self.objectives)
        check(
            "optimizer.objectives",
            names,
            len(names) == 2 and len(set(names)) == 2 and all(n in OBJECTIVES for n in names),
            "two different names of " + ", ".join(OBJECTIVES),
        )
        for name in ("eta_crossover", "eta_mutation"):
            value = getattr(self, name)
            check(f"optimizer.{name}", value, finite(value) and 0 < value <= 1000, "(0, 1000]")
        check(
            "optimizer.crossover_rate",
            self.crossover_rate,
            finite(self.crossover_rate) and 0 <= self.crossover_rate <= 1,
            "[0, 1]",
        )


class NSGA2(Optimizer):
    """Pareto optimiser: ``run`` returns the front and, as ``x``, its best member on the first objective."""

    name = "nsga2"
    Config = NSGA2Config
    n_objectives = 2

    def expected_evaluations(self) -> int:
        return self.config.population * (self.config.generations + 1)

    def run(self, problem: Problem, initial: np.ndarray | None = None) -> OptimizationResult:
        c = self.config
        start_count = problem.n_evaluations
        history = History(c.generations, "nsga2: ")
        result = nsga2(
            problem,
            problem.lower,
            problem.upper,
            population=c.population,
            generations=c.generations,
            seed=c.seed,
            eta_crossover=c.eta_crossover,
            eta_mutation=c.eta_mutation,
            crossover_rate=c.crossover_rate,
            history=history,
            history_values=problem.history_values,
        )
        designs, values = result.designs[result.front], result.objectives[result.front]
        order = np.lexsort((values[:, 1], values[:, 0]))  # deterministic row order
        designs, values = designs[order], values[order]
        best = int(np.argmax(values[:, 0]))
        return OptimizationResult(
            x=designs[best].copy(),
            fun=float(values[best, 0]),
            history=history.frame(),
            n_evaluations=problem.n_evaluations - start_count,
            method="nsga2",
            message=f"{int(result.front.sum())} non-dominated designs",
            front=(designs, values),
        )


@dataclass
class ParetoResult:
    """Final population: designs (P, n), objectives (P, m), and which are non-dominated."""

    designs: np.ndarray
    objectives: np.ndarray
    front: np.ndarray  # bool mask of rank-0 individuals
    n_evaluations: int


def non_dominated_ranks(values: np.ndarray) -> np.ndarray:
    """Pareto rank (0 = non-dominated) of each row of ``values`` (P, m), all maximised."""
    n = values.shape[0]
    ge = np.all(values[:, None, :] >= values[None, :, :], axis=2)
    gt = np.any(values[:, None, :] > values[None, :, :], axis=2)
    dominates = ge & gt  # dominates[i, j]: i dominates j
    dominated_by = dominates.sum(axis=0)
    ranks = np.full(n, -1)
    current = np.nonzero(dominated_by == 0)[0]
    rank = 0
    remaining = dominated_by.copy()
    while current.size:
        ranks[current] = rank
        remaining = remaining - dominates[current].sum(axis=0)
        remaining[ranks >= 0] = -1
        current = np.nonzero(remaining == 0)[0]
        rank += 1
    return ranks


def crowding_distance(values: np.ndarray) -> np.ndarray:
    """Crowding distance of each row of one front (P, m); boundary points get infinity."""
    n, m = values.shape
    dist = np.zeros(n)
    if n <= 2:
        return np.full(n, np.inf)
    for j in range(m):
        order = np.argsort(values[:, j], kind="stable")
        span = values[order[-1], j] - values[order[0], j]
        dist[order[[0, -1]]] = np.inf
        if span > 0:
            dist[order[1:-1]] += (values[order[2:], j] - values[order[:-2], j]) / span
    return dist


def _survivors(values: np.ndarray, size: int) -> np.ndarray:
    ranks = non_dominated_ranks(values)
    chosen: list[int] = []
    for rank in range(ranks.max() + 1):
        members = np.nonzero(ranks == rank)[0]
        if len(chosen) + members.size <= size:
            chosen.extend(members.tolist())
        else:
            crowd = crowding_distance(values[members])
            order = np.argsort(-crowd, kind="stable")
            chosen.extend(members[order[: size - len(chosen)]].tolist())
            break
    return np.array(chosen)


def nsga2(
    objectives: Callable[[np.ndarray], np.ndarray],
    lower: np.ndarray,
    upper: np.ndarray,
    *,
    population: int = 40,
    generations: int = 40,
    seed: int = 0,
    eta_crossover: float = 15.0,
    eta_mutation: float = 20.0,
    crossover_rate: float = 0.9,
    history: History | None = None,
    history_values: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
) -> ParetoResult:
    """Maximise the objectives (batch, (P, n) -> (P, m)) over ``[lower, upper]``.

    ``history`` records each generation's population by ``history_values(designs,
    objectives)`` (:meth:`Problem.history_values`: the run's scalar objective, e.g. η
    of a (GDI, SURI) front) or, without it, by the first objective.
    """
    if history_values is None:
        history_values = lambda designs, values: values  # noqa: E731
    lower = np.asarray(lower, dtype=float)
    upper = np.asarray(upper, dtype=float)
    rng = np.random.default_rng(seed)
    n_var = lower.size
    pop = rng.uniform(lower, upper, size=(population, n_var))
    vals = np.asarray(objectives(pop), dtype=float)
    n_eval = population
    if history is not None:
        history.record(
            pop, history_values(pop, vals), population, front_size=float(np.sum(non_dominated_ranks(vals) == 0))
        )
    for _ in range(generations):
        ranks = non_dominated_ranks(vals)
        crowd = np.zeros(population)
        for r in np.unique(ranks):
            idx = np.nonzero(ranks == r)[0]
            crowd[idx] = crowding_distance(vals[idx])
        # binary tournament on (rank, -crowding)
        a, b = rng.integers(0, population, size=(2, population))
        better = (ranks[a] < ranks[b]) | ((ranks[a] == ranks[b]) & (crowd[a] >= crowd[b]))
        parents = pop[np.where(better, a, b)]
        # simulated binary crossover on consecutive pairs
        kids = parents.copy()
        u = rng.random((population // 2, n_var))
        beta = np.where(
            u <= 0.5, (2 * u) ** (1 / (eta_crossover + 1)), (1 / (2 * (1 - u))) ** (1 / (eta_crossover + 1))
        )
        cross = rng.random(population // 2) < crossover_rate
        p1, p2 = parents[0 : 2 * (population // 2) : 2], parents[1 : 2 * (population // 2) : 2]
        c1 = 0.5 * ((1 + beta) * p1 + (1 - beta) * p2)
        c2 = 0.5 * ((1 - beta) * p1 + (1 + beta) * p2)
        kids[0 : 2 * (population // 2) : 2] = np.where(cross[:, None], c1, p1)
        kids[1 : 2 * (population // 2) : 2] = np.where(cross[:, None], c2, p2)
        # polynomial mutation, probability 1/n_var per variable
        mutate = rng.random(kids.shape) < 1.0 / n_var
        u = rng.random(kids.shape)
        delta = np.where(
            u < 0.5, (2 * u) ** (1 / (eta_mutation + 1)) - 1, 1 - (2 * (1 - u)) ** (1 / (eta_mutation + 1))
        )
        kids = np.where(mutate, kids + delta * (upper - lower), kids)
        kids = np.clip(kids, lower, upper)
        kid_vals = np.asarray(objectives(kids), dtype=float)
        n_eval += population
        merged = np.vstack([pop, kids])
        merged_vals = np.vstack([vals, kid_vals])
        keep = _survivors(merged_vals, population)
        pop, vals = merged[keep], merged_vals[keep]
        if history is not None:
            history.record(
                pop, history_values(pop, vals), population, front_size=float(np.sum(non_dominated_ranks(vals) == 0))
            )
    front = non_dominated_ranks(vals) == 0
    return ParetoResult(designs=pop, objectives=vals, front=front, n_evaluations=n_eval)
