"""Optimiser registry, CMA-ES, polish, the sensitivity probe, and NSGA-II against pymoo."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.config import MechanismConfig
from pipeline.errors import ConfigError
from pipeline.evaluation import DesignEvaluator
from pipeline.objectives import objective_values
from pipeline.optimizers import OPTIMIZERS, Optimizer, OptimizerConfig
from pipeline.optimizers.base import Problem
from pipeline.optimizers.cmaes import CMAES, CMAESConfig
from pipeline.optimizers.nsga2 import NSGA2, NSGA2Config
from pipeline.optimizers.polish import polish
from pipeline.optimizers.sensitivity import flat_intervals

LOWER = np.array([0.0, -1.0, 2.0])
UPPER = np.array([1.0, 1.0, 5.0])
CORNER = np.array([1.0, 0.3, 2.0])  # optimum on two faces of the box


def corner_peak(x: np.ndarray) -> np.ndarray:
    """Maximum 1 outside the box beyond CORNER in two variables: the box optimum is on its faces."""
    target = CORNER + np.array([0.2, 0.0, -0.5])
    return 1.0 / (1.0 + np.sum(((x - target) / (UPPER - LOWER)) ** 2, axis=1))


def test_registry_holds_every_optimizer_module():
    assert {"ga", "de", "cmaes", "nsga2"} <= set(OPTIMIZERS)
    for name, cls in OPTIMIZERS.items():
        assert issubclass(cls, Optimizer) and cls.name == name
        assert issubclass(cls.Config, OptimizerConfig) and cls.Config().name == name


def test_cmaes_is_deterministic_and_polish_lands_on_the_bounds():
    runs = []
    for _ in range(2):
        problem = Problem(corner_peak, LOWER, UPPER)
        result = CMAES(CMAESConfig(seed=4)).run(problem)
        runs.append(result)
        polished = polish(problem, result.x, result.fun)
        assert polished.fun >= result.fun
        assert polished.x[0] == UPPER[0] and polished.x[2] == LOWER[2]  # exactly on the bounds
        assert abs(polished.x[1] - CORNER[1]) < 1e-3
    np.testing.assert_array_equal(runs[0].x, runs[1].x)
    assert runs[0].n_evaluations <= CMAESConfig().max_evaluations + 20


def test_cmaes_config_is_checked():
    with pytest.raises(ConfigError, match="optimizer.sigma0"):
        CMAESConfig(sigma0=0.0)
    with pytest.raises(ConfigError, match="optimizer.seed=-1"):
        CMAESConfig(seed=-1)


def test_polish_never_worsens_and_respects_its_budget():
    problem = Problem(corner_peak, LOWER, UPPER)
    start = np.array([0.5, 0.0, 3.0])
    f0 = float(corner_peak(start[None])[0])
    result = polish(problem, start, f0, max_evaluations=40)
    assert result.n_evaluations <= 40 and result.fun >= f0
    assert result.improvement == pytest.approx(result.fun - f0)


def test_sensitivity_probe_finds_a_flat_variable_and_its_interval():
    def flat_in_y(x):  # does not depend on x[:, 1]; flat in x[:, 0] only above 0.5
        return -((x[:, 2] - 3.0) ** 2) + np.minimum(x[:, 0], 0.5)

    problem = Problem(flat_in_y, LOWER, UPPER)
    out = flat_intervals(problem, np.array([0.75, 0.2, 3.0]), 0.5, ["a", "b", "c"])
    assert out["flat_variables"] == "a,b"
    assert (out["b_flat_lower"], out["b_flat_upper"]) == (-1.0, 1.0)
    assert out["a_flat_lower"] == 0.5 and out["a_flat_upper"] == 1.0
    assert out["c_flat_lower"] == out["c_flat_upper"] == 3.0


def test_nsga2_front_matches_pymoo_on_zdt1():
    """Our NSGA-II and pymoo's reach the same ZDT1 front (maximising the negated objectives)."""
    from pymoo.algorithms.moo.nsga2 import NSGA2 as PymooNSGA2
    from pymoo.optimize import minimize
    from pymoo.problems import get_problem

    zdt1 = get_problem("zdt1", n_var=6)

    def negated(x):
        return -zdt1.evaluate(x)

    ours = NSGA2(NSGA2Config(population=40, generations=120, seed=1)).run(
        Problem(negated, np.zeros(6), np.ones(6), n_objectives=2)
    )
    theirs = minimize(zdt1, PymooNSGA2(pop_size=40), ("n_gen", 121), seed=1, verbose=False)
    ours_f = -ours.front[1]

    def front_error(f):  # distance to the true front f2 = 1 - sqrt(f1)
        return np.mean(np.abs(f[:, 1] - (1 - np.sqrt(np.clip(f[:, 0], 0, 1)))))

    def spread(f):
        return f[:, 0].max() - f[:, 0].min()

    assert front_error(ours_f) < 0.05 and front_error(theirs.F) < 0.05
    assert front_error(ours_f) < 3 * front_error(theirs.F) + 0.01
    assert spread(ours_f) > 0.8 * spread(theirs.F)


def test_cmaes_reaches_a_dense_reference_on_a_real_objective():
    """H4 max volume on a coarse grid: CMA-ES + polish within 0.1 % of a dense grid + polish."""
    h4 = MechanismConfig(name="h4")
    evaluator = DesignEvaluator(h4, 12, 1)
    problem = Problem(
        lambda x: objective_values("volume", evaluator.evaluate(x), 0.0), h4.design.lower, h4.design.upper
    )
    axes = [np.linspace(lo, hi, 6) for lo, hi in zip(h4.design.lower, h4.design.upper)]
    grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    values = problem(grid)
    reference = polish(problem, grid[int(np.argmax(values))], float(values.max()), max_evaluations=300).fun
    found = CMAES(CMAESConfig(seed=0)).run(problem)
    best = polish(problem, found.x, found.fun).fun
    assert best >= reference * (1 - 1e-3)


def test_nsga2_history_reports_the_scalar_score_of_the_population():
    """A Pareto search for a scalar objective (η of (GDI, SURI)) records that scalar per generation,
    not its first objective: the run's optimum is read against this history."""

    def pair(x):
        return np.column_stack([x[:, 0], 1 - x[:, 0] ** 2])

    def score(x):  # the scalar the front is searched for: peaks inside the front
        f = pair(x)
        return 0.3 * f[:, 0] + 0.7 * f[:, 1]

    problem = Problem(pair, np.zeros(2), np.ones(2), n_objectives=2, score=score)
    result = NSGA2(NSGA2Config(population=8, generations=3, seed=2, polish=False)).run(problem)
    history = result.history
    front_scores = score(result.front[0])
    assert history["best"].iloc[-1] >= front_scores.max() - 1e-12
    assert history["best"].iloc[-1] <= 0.7 + 0.3**2 / (4 * 0.7) + 1e-12  # max of the score on [0, 1]
    best_design = history[["x0", "x1"]].to_numpy()
    np.testing.assert_allclose(score(best_design), history["best"])  # best is that design's score
    assert (history["worst"] <= history["mean"]).all() and (history["mean"] <= history["best"]).all()
    # without a score: the first objective, as before
    plain = NSGA2(NSGA2Config(population=8, generations=3, seed=2, polish=False)).run(
        Problem(pair, np.zeros(2), np.ones(2), n_objectives=2)
    )
    np.testing.assert_allclose(pair(plain.history[["x0", "x1"]].to_numpy())[:, 0], plain.history["best"])


def test_progress_line_logs_the_best_so_far_and_a_rate_without_start_up(caplog, monkeypatch):
    """A generation's best drops (0.2714 -> 0.2626) without the run losing anything; the first
    generation's 10 s include the pool's start-up, which is not the evaluation rate."""
    import logging

    from pipeline.optimizers import base

    clock = iter([0.0, 10.0, 11.0, 12.0, 13.0])  # History start, then the end of each generation
    monkeypatch.setattr(base.time, "perf_counter", lambda: next(clock))
    monkeypatch.setattr(base, "progress_bars_enabled", lambda: False)
    with caplog.at_level(logging.INFO, logger="pipeline.optimizers.base"):
        history = base.History(3, "cmaes: ")
        for best in (0.2696, 0.2714, 0.2626, 0.2704):
            history.record(np.zeros((10, 2)), np.array([best] + [0.2] * 9), 10)
    lines = [r.getMessage() for r in caplog.records if r.name == "pipeline.optimizers.base"]
    assert (
        lines[0]
        == "cmaes: generation 0/3: best so far 0.2696 (this generation 0.2696), 10 evaluations in 10 s (with start-up)"
    )
    assert (
        lines[2]
        == "cmaes: generation 2/3: best so far 0.2714 (this generation 0.2626), 10 evaluations/s after the first generation"
    )
    assert "best so far 0.2714" in lines[-1]
