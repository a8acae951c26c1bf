"""Multi-start IPOP-CMA-ES (Auger & Hansen 2005) through the ``cma`` package, Hansen's reference code.

Why ``cma`` and not our own: it is the algorithm's reference implementation,
pure Python on numpy, well kept, and its ask/tell interface lets us keep our
parallel batch evaluation: each generation's ``popsize`` designs are
evaluated as one batch.

Why a multi-start (issue 23): one CMA-ES run from the box centre settles in
whichever basin its first steps see. On the 3-RPR mixed index 4 of 10 seeds
stopped in a second basin 0.12 % below the best known. The run is therefore:

1. scout: ``scout`` scrambled-Sobol designs (seeded; at most a quarter of the
   budget) plus any ``initial`` designs, evaluated as one batch, show the
   basins of the box;
2. local runs: CMA-ES from the heads of up to ``starts`` distinct basins among
   the scouts (:func:`distinct_basins`: the best scout, then the scouts with no
   better scout within ``basin_radius`` in the unit box), with
   the small step ``local_sigma``, each stopping when its step is below
   ``tolx`` (then the polish step finishes the job) or its budget share is spent;
3. IPOP restarts: the budget left goes to restarts from uniform random designs
   with step ``sigma0``, each doubling the population (the IPOP rule), until
   ``max_evaluations`` is spent or ``restarts`` are done.

With ``scout=0`` and ``starts=0`` the run is plain IPOP-CMA-ES from the centre.

Adapter choices:

* the search runs in the unit box ``u = (x - lower) / (upper - lower)``, so one
  step size (a fraction of every range) fits all variables;
* bounds by ``cma``'s BoundTransform; it approaches a bound but lands on it only
  by chance, which is why the default ends with the polish step (it snaps);
* determinism: every random draw comes from one seeded
  :class:`numpy.random.Generator` (``cma``'s ``randn`` option) or the seeded
  Sobol sequence, never from numpy's global state, so a run is a function of
  ``seed`` only.
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
    """Multi-start IPOP-CMA-ES settings; the default is the recommended optimiser of users' studies.

    Budget: ``max_evaluations`` for scout + local runs + restarts, then the
    polish step's ``polish_evaluations``; 800 + 150 keeps a run within 1,000
    evaluations (benchmarks/optimiser_seeds.py measures seeds 0-9 per problem).
    """

    name: str = "cmaes"
    #: evaluation budget of the scout, the local runs and the restarts (the polish step's comes on top)
    max_evaluations: int = 800
    #: initial step of the IPOP restarts, a fraction of every variable's range
    sigma0: float = 0.3
    #: first population; null = cma's default 4 + 3 ln(n)
    popsize: Optional[int] = None
    #: IPOP restarts (population doubled at each)
    restarts: int = 4
    #: scrambled-Sobol designs evaluated first to find the basins (rounded down to a power of two;
    #: 0: start from the centre)
    scout: int = 32
    #: local CMA-ES runs from the best scouts in distinct basins
    starts: int = 3
    #: unit-box (Euclidean, ranges scaled to 1) distance: a scout with a better one closer shares its basin
    basin_radius: float = 0.2
    #: initial step of the local runs, a fraction of every range
    local_sigma: float = 0.1
    #: a run stops when its step is below this fraction of every range (the polish step refines)
    tolx: float = 1e-3

    def __post_init__(self) -> None:
        super().__post_init__()
        check(
            "optimizer.max_evaluations",
            self.max_evaluations,
            10 <= self.max_evaluations <= 10_000_000,
            "an integer in [10, 10000000]",
        )
        check("optimizer.sigma0", self.sigma0, finite(self.sigma0) and 0 < self.sigma0 <= 1, "(0, 1]")
        check(
            "optimizer.popsize",
            self.popsize,
            self.popsize is None or 2 <= self.popsize <= 10_000,
            "null or an integer in [2, 10000]",
        )
        check("optimizer.restarts", self.restarts, 0 <= self.restarts <= 20, "an integer in [0, 20]")
        check("optimizer.scout", self.scout, 0 <= self.scout <= 100_000, "an integer in [0, 100000]")
        check("optimizer.starts", self.starts, 0 <= self.starts <= 100, "an integer in [0, 100]")
        check(
            "optimizer.basin_radius",
            self.basin_radius,
            finite(self.basin_radius) and 0 <= self.basin_radius <= 2,
            "[0, 2]",
        )
        check(
            "optimizer.local_sigma", self.local_sigma, finite(self.local_sigma) and 0 < self.local_sigma <= 1, "(0, 1]"
        )
        check("optimizer.tolx", self.tolx, finite(self.tolx) and 0 < self.tolx < 1, "(0, 1)")


def distinct_basins(unit: np.ndarray, values: np.ndarray, count: int, radius: float) -> np.ndarray:
    """Indices of up to ``count`` designs that head distinct basins (nearest-better clustering).

    ``unit`` (K, n) designs in the unit box, ``values`` (K,) their objective
    (maximised). Each design's nearest-better distance is its distance to the
    closest design with a higher value (infinite for the best); a design far
    from every better one tops a basin of its own (Preuss 2010, nearest-better
    clustering). Returned: the best design, then the designs whose
    nearest-better distance is at least ``radius``, farthest first (ties by
    value): so a narrow peak away from a broad one is kept, even when the broad
    peak's slopes hold many designs better than it.
    """
    values = np.asarray(values, dtype=float)
    distance = np.linalg.norm(unit[:, None, :] - unit[None, :, :], axis=2)
    better = values[None, :] > values[:, None]
    nearest_better = np.where(better, distance, np.inf).min(axis=1)
    order = np.lexsort((-values, -nearest_better))  # farthest first, then best
    chosen = [int(k) for k in order if nearest_better[k] >= radius]
    return np.array(chosen[:count], dtype=int)


class CMAES(Optimizer):
    name = "cmaes"
    Config = CMAESConfig

    def expected_evaluations(self) -> int:
        return self.config.max_evaluations

    def run(self, problem: Problem, initial: np.ndarray | None = None) -> OptimizationResult:
        from scipy.stats import qmc

        c = self.config
        lower, span = problem.lower, problem.upper - problem.lower
        rng = np.random.default_rng(c.seed)
        start_count = problem.n_evaluations
        popsize = c.popsize or 4 + int(3 * np.log(problem.n_var))
        history = History(max(c.max_evaluations // popsize, 1), "cmaes: ")
        best = {"x": None, "f": -np.inf}

        def evaluate(unit: np.ndarray, **extra: float) -> np.ndarray:
            # cma's ask() returns bound-transformed (feasible) points; clip only rounding
            designs = lower + np.clip(unit, 0.0, 1.0) * span
            values = problem(designs)
            history.record(designs, values, len(designs), **extra)
            k = int(np.argmax(values))
            if values[k] > best["f"]:
                best["x"], best["f"] = designs[k].copy(), float(values[k])
            return values

        def left() -> int:
            return c.max_evaluations - (problem.n_evaluations - start_count)

        starts = []
        given = (
            (np.clip(np.atleast_2d(initial), problem.lower, problem.upper) - lower) / span
            if initial is not None and len(initial)
            else np.empty((0, problem.n_var))
        )
        # the scout takes at most a quarter of the budget (a tiny budget still leaves local steps)
        # (a power of two: the Sobol sequence's balance holds for those)
        n_scout = min(c.scout, c.max_evaluations // 4 - len(given))
        n_scout = 2 ** int(np.log2(n_scout)) if n_scout >= 2 else 0
        if n_scout:
            sobol = qmc.Sobol(d=problem.n_var, scramble=True, seed=rng).random(n_scout)
            scouts = np.vstack([given, sobol])
            values = evaluate(scouts, restart=-1)
            starts = [
                (scouts[k], c.local_sigma, popsize) for k in distinct_basins(scouts, values, c.starts, c.basin_radius)
            ]
        elif len(given):
            starts = [(given[0], c.sigma0, popsize)]
        else:
            starts = [(np.full(problem.n_var, 0.5), c.sigma0, popsize)]
        # then IPOP: restarts from uniform designs, the population doubling each time
        restarts = [(None, c.sigma0, popsize * 2 ** (k + 1)) for k in range(c.restarts)]
        messages = []
        queue = starts + restarts
        for run, (x0, sigma, size) in enumerate(queue):
            local_runs_left = max(len(starts) - run, 0)
            # a local run gets its share of the budget; restarts take what is left
            budget = left() // local_runs_left if local_runs_left else left()
            if budget < size:
                if run < len(starts):
                    continue
                break
            x0 = rng.uniform(0, 1, problem.n_var) if x0 is None else x0
            messages.append(self._one_run(x0, sigma, size, budget, rng, evaluate, run))
        if best["x"] is None:  # budget below one generation: evaluate the start
            evaluate(np.full((1, problem.n_var), 0.5), restart=0)
        return OptimizationResult(
            x=best["x"],
            fun=best["f"],
            history=history.frame(),
            n_evaluations=problem.n_evaluations - start_count,
            method="cmaes",
            message="; ".join(messages),
        )

    def _one_run(
        self, x0: np.ndarray, sigma: float, popsize: int, budget: int, rng: np.random.Generator, evaluate, run: int
    ) -> str:
        """One CMA-ES run in the unit box from ``x0``; returns its stop message."""
        import cma  # imports scipy.stats and pyplot (~1 s): only when a CMA-ES run starts

        options = {
            "bounds": [0.0, 1.0],
            "popsize": popsize,
            "maxfevals": budget,
            "verbose": -9,
            "seed": np.nan,
            "randn": lambda *shape: rng.standard_normal(shape),
            "tolfun": 0.0,
            "tolfunhist": 0.0,
            "tolx": self.config.tolx,
            "CMA_stds": None,
        }
        with warnings.catch_warnings():  # cma warns about its own restarts and flat fitness
            warnings.simplefilter("ignore")
            es = cma.CMAEvolutionStrategy(np.clip(x0, 0.0, 1.0), sigma, options)
            # cma checks its budget after a generation: stop before one would overshoot it
            while not es.stop() and es.countevals + popsize <= budget:
                unit = np.asarray(es.ask())
                values = evaluate(unit, restart=run)
                es.tell(list(unit), list(-values))
        return f"run {run} (popsize {popsize}, sigma {sigma:g}): " + (", ".join(es.stop()) or "budget")
