"""What every optimiser shares: its config schema, the problem, the history, the result.

Kept apart in the pymoo manner: a :class:`Problem` (box, batch fitness,
evaluation count), an :class:`Optimizer` (one class per module in this
package, with its own config dataclass), a :class:`History` callback (one
row per generation, built here only) and an :class:`OptimizationResult`.

Everything is maximised. Designs are rows: populations ``(P, n_design)``;
fitness ``(P,)`` (or ``(P, m)`` for multi-objective optimisers).
"""

from __future__ import annotations

import logging
import math
import os
import sys
import time
from abc import ABC, abstractmethod
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np
import pandas as pd

from pipeline.errors import check

log = logging.getLogger(__name__)

BatchFunction = Callable[[np.ndarray], np.ndarray]

#: the largest seed numpy's SeedSequence takes from a config without surprise
MAX_SEED = 2**32 - 1


@dataclass
class OptimizerConfig:
    """Fields every optimiser has.

    ``polish``: end with :func:`pipeline.optimizers.polish.polish` (a bounded
    compass search that lands on active bounds). ``reference``: also run the
    reference optimiser (CMA-ES + polish) and record this optimiser's gap to
    it. ``max_evaluations``: budget of the reference and of budgeted optimisers.
    """

    name: str = "?"
    #: seed of every random choice of the optimiser
    seed: int = 0
    #: end with the polish step (bounded compass search)
    polish: bool = True
    #: also run the reference optimisation and record the gap to it
    reference: bool = False
    #: evaluation budget of the polish step
    polish_evaluations: int = 150

    def __post_init__(self) -> None:
        check("optimizer.seed", self.seed, 0 <= self.seed <= MAX_SEED, f"an integer in [0, {MAX_SEED}]")
        check(
            "optimizer.polish_evaluations",
            self.polish_evaluations,
            1 <= self.polish_evaluations <= 100_000,
            "an integer in [1, 100000]",
        )


def check_generations(population: int, generations: int, min_population: int) -> None:
    """The population and generation counts of a generational optimiser (ConfigError if out of range)."""
    check(
        "optimizer.population",
        population,
        min_population <= population <= 100_000,
        f"an integer in [{min_population}, 100000]",
    )
    check("optimizer.generations", generations, 1 <= generations <= 1_000_000, "an integer in [1, 1000000]")


class Problem:
    """Box-constrained maximisation with a batch objective.

    Parameters
    ----------
    function : callable, (P, n) -> (P,) or (P, m)
        Batch objective in the design's units; NaN is read as 0 (an empty
        workspace has objective 0).
    lower, upper : array_like, shape (n,)
        Box bounds, finite, ``lower < upper``.
    n_objectives : int
        1, or m for a multi-objective problem.
    score : callable, (P, n) -> (P,), optional
        The run's scalar objective, when a multi-objective problem is solved for
        it (a Pareto front of (GDI, SURI) searched for the best η): what the
        history's ``best``/``mean``/``worst`` report. Default: the first objective.
    """

    def __init__(
        self,
        function: BatchFunction,
        lower: np.ndarray,
        upper: np.ndarray,
        n_objectives: int = 1,
        score: BatchFunction | None = None,
    ) -> None:
        self.lower = np.asarray(lower, dtype=float)
        self.upper = np.asarray(upper, dtype=float)
        if self.lower.ndim != 1 or self.lower.shape != self.upper.shape:
            raise ValueError(f"lower and upper must be 1-D of one length; got {self.lower.shape}, {self.upper.shape}")
        if not np.all(np.isfinite(self.lower) & np.isfinite(self.upper) & (self.lower < self.upper)):
            raise ValueError("bounds must be finite with lower < upper for every variable")
        self._function = function
        self.n_objectives = int(n_objectives)
        self.n_evaluations = 0
        self._score = score

    @property
    def n_var(self) -> int:
        return self.lower.size

    def __call__(self, designs: np.ndarray) -> np.ndarray:
        """Objective of designs (P, n) -> (P,) or (P, m); counts the evaluations."""
        designs = np.atleast_2d(np.asarray(designs, dtype=float))
        self.n_evaluations += designs.shape[0]
        if designs.shape[0] == 0:
            return np.empty((0,) if self.n_objectives == 1 else (0, self.n_objectives))
        values = np.nan_to_num(np.asarray(self._function(designs), dtype=float), nan=0.0)
        expected = (designs.shape[0],) if self.n_objectives == 1 else (designs.shape[0], self.n_objectives)
        if values.shape != expected:
            raise ValueError(f"objective must return shape {expected}; got {values.shape}")
        return values

    def history_values(self, designs: np.ndarray, values: np.ndarray) -> np.ndarray:
        """What :class:`History` records of a population: the scalar ``score`` of ``designs``
        (not counted as evaluations: it reads the same evaluations) or, without one, ``values``."""
        if self._score is None:
            return values
        return np.nan_to_num(np.asarray(self._score(np.atleast_2d(designs)), dtype=float), nan=0.0)


class History:
    """One row per generation (the shared callback of every optimiser).

    Columns: ``generation``, ``best``, ``mean``, ``worst`` (of the first
    objective over the population), ``n_evaluations`` (new evaluations in
    that generation), ``wall_time`` (s since start; dropped from result
    files so they depend on the config only) and the best design ``x0..``.

    Progress: on a terminal, one tqdm bar (generations, evaluations/s, ETA,
    best so far); otherwise (CI, SLURM, a log file) one log line about every
    10 % of the expected generations, with the best so far (and the
    generation's best) and the evaluation rate since the first generation (the
    first generation's time includes start-up). Every generation is logged at DEBUG.
    """

    def __init__(self, expected_generations: int | None = None, label: str = "") -> None:
        self.rows: list[dict] = []
        self.start = time.perf_counter()
        self.expected = expected_generations
        self.label = label
        self._last_logged = -1
        self._bar = None
        if progress_bars_enabled():
            from tqdm import tqdm

            self._bar = tqdm(
                total=expected_generations,
                desc=label.strip(" :") or "optimise",
                unit="gen",
                leave=False,
                dynamic_ncols=True,
            )

    def record(self, population: np.ndarray, values: np.ndarray, n_new: int, **extra: float) -> None:
        values = np.asarray(values, dtype=float)
        first = values if values.ndim == 1 else values[:, 0]
        best = int(np.argmax(first))
        row = {
            "generation": len(self.rows),
            "best": float(first[best]),
            "mean": float(first.mean()),
            "worst": float(first.min()),
            "n_evaluations": int(n_new),
            "wall_time": time.perf_counter() - self.start,
        }
        row.update({f"x{j}": float(v) for j, v in enumerate(population[best])})
        row.update(extra)
        self.rows.append(row)
        self._progress(row)

    def _progress(self, row: dict) -> None:
        evaluations = sum(r["n_evaluations"] for r in self.rows)
        # best so far: a generation's best drops (an IPOP restart's wide population) without the
        # run losing anything; the rate runs from the first generation's end, so it leaves out the
        # start-up (process pool, compilation) that the first generation's time includes
        so_far = max(r["best"] for r in self.rows)
        first = self.rows[0]
        since = row["wall_time"] - first["wall_time"]
        rate = (evaluations - first["n_evaluations"]) / since if since > 0 else math.nan
        log.debug(
            "%sgeneration %d: best %.6g, mean %.6g, %d evaluations",
            self.label,
            row["generation"],
            row["best"],
            row["mean"],
            evaluations,
        )
        if self._bar is not None:
            if row["generation"] > 0:
                self._bar.update(1)
            postfix = {"best_so_far": f"{so_far:.5g}"}
            if math.isfinite(rate):
                postfix["evals_s"] = f"{rate:.0f}"
            self._bar.set_postfix(postfix, refresh=False)
            return
        gen, total = row["generation"], self.expected
        if total:
            step = max(total // 10, 1)
            if gen // step == self._last_logged and gen != total:
                return
            self._last_logged = gen // step
        of = f"/{total}" if total else ""
        if len(self.rows) == 1:
            speed = f"{evaluations} evaluations in {row['wall_time']:.2g} s (with start-up)"
        else:
            speed = f"{rate:.0f} evaluations/s after the first generation"
        log.info(
            "%sgeneration %d%s: best so far %.6g (this generation %.6g), %s",
            self.label,
            gen,
            of,
            so_far,
            row["best"],
            speed,
        )

    def frame(self) -> pd.DataFrame:
        """The rows as a DataFrame (closes the progress bar: the run is over)."""
        if self._bar is not None:
            self._bar.close()
            self._bar = None
        return pd.DataFrame(self.rows)


def progress_bars_enabled() -> bool:
    """Bars only on an interactive terminal (not in CI, SLURM, pipes or log files)."""
    return sys.stderr.isatty() and os.environ.get("CI") is None


@dataclass
class OptimizationResult:
    """Outcome of an optimiser run (in the spirit of ``scipy.optimize.OptimizeResult``).

    Attributes
    ----------
    x : ndarray, shape (n,)
        Best design found (design units).
    fun : float
        Its objective (maximised; the first objective for multi-objective runs).
    history : pandas.DataFrame
        :class:`History` rows.
    n_evaluations : int
    method : str
    message : str
    front : (designs (K, n), values (K, m)) or None
        The non-dominated set of a multi-objective optimiser.
    """

    x: np.ndarray
    fun: float
    history: pd.DataFrame
    n_evaluations: int
    method: str
    message: str = ""
    front: tuple[np.ndarray, np.ndarray] | None = field(default=None, repr=False)


class Optimizer(ABC):
    """A registered optimiser: subclass it in a new module of this package.

    Class attributes: ``name`` (registry key and ``optimizer=`` option),
    ``Config`` (its config dataclass, a subclass of :class:`OptimizerConfig`)
    and ``n_objectives`` (1, or 2 for a Pareto optimiser). ``run`` maximises
    ``problem`` from an optional set of starting designs.
    """

    name: ClassVar[str]
    Config: ClassVar[type[OptimizerConfig]]
    n_objectives: ClassVar[int] = 1

    def expected_evaluations(self) -> int:
        """Evaluations a run will take (for progress and for the cost estimate)."""
        return 0

    def __init__(self, config: OptimizerConfig) -> None:
        self.config = config

    @abstractmethod
    def run(self, problem: Problem, initial: np.ndarray | None = None) -> OptimizationResult:
        """Maximise ``problem``; ``initial`` (k, n) designs may seed the start."""
