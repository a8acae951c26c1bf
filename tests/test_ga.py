"""GA operators, convergence, determinism across workers and backends, DE."""

from __future__ import annotations

import logging

import numpy as np
import pytest
from joblib import parallel_config
from scipy import stats

from pipeline.config import MechanismConfig
from pipeline.errors import ConfigError
from pipeline.evaluation import DesignEvaluator
from pipeline.objectives import OBJECTIVES, objective_values
from pipeline.optimizers.base import Problem
from pipeline.optimizers.de import DE, DEConfig
from pipeline.optimizers.ga import (
    GAConfig,
    arithmetic_crossover,
    genetic_algorithm,
    geometric_selection_probabilities,
    nonuniform_mutation,
    select,
)

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow

LOWER = np.array([-1.0, -2.0, 0.0])
UPPER = np.array([1.0, 2.0, 5.0])
PEAK = np.array([0.3, -1.2, 4.1])


def smooth(x: np.ndarray) -> np.ndarray:
    """A smooth function with its maximum 1 at PEAK."""
    return 1.0 / (1.0 + np.sum(((x - PEAK) / (UPPER - LOWER)) ** 2, axis=1))


# ------------------------------------------------------------- operators
def test_selection_probabilities_sum_to_one_and_are_geometric():
    probs = geometric_selection_probabilities(30, 0.08)
    assert probs.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(probs[1:] / probs[:-1], 0.92)


def test_selection_draws_follow_the_geometric_law():
    rng = np.random.default_rng(0)
    fitness = rng.random(30)
    rank_of = np.empty(30, dtype=int)
    rank_of[np.argsort(-fitness)] = np.arange(30)
    counts = np.zeros(30)
    for _ in range(2000):
        np.add.at(counts, rank_of[select(rng, fitness, 0.08)], 1)
    expected = geometric_selection_probabilities(30, 0.08) * counts.sum()
    assert stats.chisquare(counts, expected).pvalue > 1e-3
    # a broken selection (uniform) is rejected by the same test
    assert stats.chisquare(np.full(30, counts.sum() / 30), expected).pvalue < 1e-6


def test_children_stay_inside_the_bounds():
    rng = np.random.default_rng(1)
    for gen in (1, 50, 150):
        pop = rng.uniform(LOWER, UPPER, size=(200, 3))
        crossed, changed = arithmetic_crossover(rng, pop, 0.8)
        assert changed.sum() == 2 * round(0.8 * 200 / 2)
        mutated, _ = nonuniform_mutation(rng, crossed, LOWER, UPPER, 1.0, gen, 150, 3.0)
        assert np.all(mutated >= LOWER) and np.all(mutated <= UPPER)


def test_crossover_is_arithmetic():
    rng = np.random.default_rng(2)
    pop = rng.uniform(LOWER, UPPER, size=(10, 3))
    kids, changed = arithmetic_crossover(rng, pop, 1.0)
    np.testing.assert_allclose(kids.sum(axis=0), pop.sum(axis=0))  # pairs keep their sum
    assert changed.all()


def test_mutation_step_shrinks_towards_the_last_generation():
    rng = np.random.default_rng(3)
    pop = rng.uniform(LOWER, UPPER, size=(5000, 3))
    steps = []
    for gen in (1, 75, 140, 150):
        mutated, mask = nonuniform_mutation(rng, pop, LOWER, UPPER, 1.0, gen, 150, 3.0)
        assert mask.all()
        steps.append(np.abs(mutated - pop).sum(axis=1).mean())
    assert steps[0] > steps[1] > steps[2] > steps[3] == 0.0
    # exactly one variable moves per mutated individual
    mutated, _ = nonuniform_mutation(rng, pop, LOWER, UPPER, 1.0, 1, 150, 3.0)
    assert np.all((mutated != pop).sum(axis=1) <= 1)


# ------------------------------------------------------------ the algorithm
def test_ga_converges_on_a_smooth_function():
    result = genetic_algorithm(smooth, LOWER, UPPER, seed=7)
    assert result.fun == pytest.approx(1.0, abs=1e-3)
    assert np.all(np.abs(result.x - PEAK) <= 0.05 * (UPPER - LOWER))
    hist = result.history
    assert list(hist.columns[:6]) == ["generation", "best", "mean", "worst", "n_evaluations", "wall_time"]
    assert len(hist) == 151 and np.all(np.diff(hist["best"]) >= 0)  # elitism


def test_unchanged_individuals_are_not_reevaluated():
    seen = []

    def counting(x):
        seen.append(x.copy())
        return smooth(x)

    result = genetic_algorithm(counting, LOWER, UPPER, population=30, generations=20, seed=1)
    per_generation = [len(s) for s in seen]
    assert per_generation[0] == 30
    assert all(n < 30 for n in per_generation[1:])  # copies and the elite are not re-evaluated
    assert result.n_evaluations == sum(per_generation) == result.history["n_evaluations"].sum()


def test_ga_is_a_function_of_the_seed():
    a = genetic_algorithm(smooth, LOWER, UPPER, generations=30, seed=5)
    b = genetic_algorithm(smooth, LOWER, UPPER, generations=30, seed=5)
    c = genetic_algorithm(smooth, LOWER, UPPER, generations=30, seed=6)
    cols = [c for c in a.history.columns if c != "wall_time"]
    assert a.history[cols].equals(b.history[cols])
    assert not a.history[cols].equals(c.history[cols])


def test_ga_logs_progress_about_every_tenth(caplog):
    with caplog.at_level(logging.INFO, logger="pipeline.optimizers.base"):
        genetic_algorithm(smooth, LOWER, UPPER, generations=40, seed=0)
    lines = [r.getMessage() for r in caplog.records if r.name == "pipeline.optimizers.base"]
    assert 8 <= len(lines) <= 12
    assert "generation 40/40" in lines[-1] and "evaluations/s" in lines[-1]


def test_bad_ga_arguments():
    with pytest.raises(ValueError, match="lower < upper"):
        genetic_algorithm(smooth, UPPER, LOWER)
    with pytest.raises(ConfigError, match="optimizer.population"):
        GAConfig(population=1)
    with pytest.raises(ConfigError, match="optimizer.selection_q"):
        GAConfig(selection_q=0.0)
    with pytest.raises(ConfigError, match="optimizer.mutation_shape"):
        GAConfig(mutation_shape=float("nan"))


# ----------------------------------------------- objective and parallelism
H4 = MechanismConfig(name="h4")


def run_tiny(n_jobs: int):
    evaluator = DesignEvaluator(H4, 6, n_jobs)
    problem = Problem(lambda x: objective_values("mixed", evaluator.evaluate(x), 0.5), H4.design.lower, H4.design.upper)
    return genetic_algorithm(problem, problem.lower, problem.upper, population=8, generations=4, seed=11)


def test_ga_bit_identical_across_workers_and_dask():
    from dask.distributed import Client, LocalCluster

    one = run_tiny(1)
    two = run_tiny(2)
    three = run_tiny(3)  # this process and two worker processes
    with (
        LocalCluster(
            n_workers=2, threads_per_worker=1, processes=True, host="127.0.0.1", dashboard_address=None
        ) as cluster,
        Client(cluster),
    ):
        with parallel_config(backend="dask"):
            dask = run_tiny(2)
    cols = [c for c in one.history.columns if c != "wall_time"]
    assert one.history[cols].equals(two.history[cols])
    assert one.history[cols].equals(three.history[cols])
    assert one.history[cols].equals(dask.history[cols])
    assert one.fun == two.fun == dask.fun
    np.testing.assert_array_equal(one.x, dask.x)


def test_empty_workspace_has_fitness_zero():
    rpr3 = MechanismConfig(name="rpr3")
    rows = DesignEvaluator(rpr3, None, 1).evaluate(np.array([[300.0, 20.0], [200.0, 50.0]]))
    fit = objective_values("volume", rows, 0.0)
    assert fit[0] == 0.0 and fit[1] > 0
    assert not np.isnan(fit).any()


def test_infeasible_design_is_invalid_with_zero_objective():
    rpr2 = MechanismConfig(name="rpr2")  # q_min = 9.6 mm = q_max: the mechanism refuses it
    rows = DesignEvaluator(rpr2, 64, 1).evaluate(np.array([[5.0, 9.6]]))
    assert rows[0, -1] == 0 and objective_values("mixed", rows, 0.5)[0] == 0.0


def test_objectives_pick_the_right_field():
    rows = DesignEvaluator(H4, 12, 1).evaluate(np.array([[0.13, 0.13, 0.35]]))
    fields = dict(zip(("volume", "gdi", "inverse_condition_min", "inverse_condition_max", "suri"), rows[0]))
    for name in ("volume", "gdi", "suri"):
        assert objective_values(name, rows, 0.3)[0] == fields[name]
    mixed = objective_values("mixed", rows, 0.25)[0]
    assert mixed == pytest.approx(0.25 * fields["gdi"] + 0.75 * fields["suri"])
    assert set(OBJECTIVES) == {"volume", "gdi", "suri", "mixed"}


def test_de_uses_the_same_budget():
    problem = Problem(smooth, LOWER, UPPER)
    result = DE(DEConfig(population=20, generations=40, seed=3)).run(problem)
    assert result.n_evaluations == 20 * 41
    assert result.fun == pytest.approx(1.0, abs=1e-2)
    assert len(result.history) == 40
    with pytest.raises(ConfigError, match=r"optimizer.population=3 is invalid: allowed an integer in \[5"):
        DEConfig(population=3)
