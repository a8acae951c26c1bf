"""NSGA-II building blocks and a convergence check on a known front."""

from __future__ import annotations

import numpy as np
import pytest

from pipeline.optimizers.nsga2 import crowding_distance, non_dominated_ranks, nsga2

#: end-to-end runs, sweeps and subprocesses: the slow tier (`python -m pytest -m slow`)
pytestmark = pytest.mark.slow


def brute_force_ranks(values: np.ndarray) -> np.ndarray:
    remaining = list(range(len(values)))
    ranks = np.full(len(values), -1)
    rank = 0
    while remaining:
        front = [
            i
            for i in remaining
            if not any(np.all(values[j] >= values[i]) and np.any(values[j] > values[i]) for j in remaining if j != i)
        ]
        ranks[front] = rank
        remaining = [i for i in remaining if i not in front]
        rank += 1
    return ranks


def test_ranks_match_brute_force():
    rng = np.random.default_rng(0)
    for _ in range(20):
        values = rng.integers(0, 5, size=(25, 2)).astype(float)
        np.testing.assert_array_equal(non_dominated_ranks(values), brute_force_ranks(values))


def test_crowding_distance_boundaries_are_infinite():
    values = np.array([[0.0, 1.0], [0.5, 0.5], [1.0, 0.0], [0.25, 0.75]])
    dist = crowding_distance(values)
    assert np.isinf(dist[0]) and np.isinf(dist[2])
    assert np.all(np.isfinite(dist[[1, 3]]))


def test_nsga2_finds_a_known_concave_front():
    def objectives(x):  # maximise -ZDT1: front f2 = 1 - sqrt(f1) at g = 1
        g = 1 + 9 * x[:, 1:].mean(axis=1)
        return -np.column_stack([x[:, 0], g * (1 - np.sqrt(x[:, 0] / g))])

    result = nsga2(objectives, np.zeros(4), np.ones(4), population=40, generations=80, seed=1)
    f = -result.objectives[result.front]
    assert result.front.sum() >= 20
    assert np.max(np.abs(f[:, 1] - (1 - np.sqrt(f[:, 0])))) < 0.05
    again = nsga2(objectives, np.zeros(4), np.ones(4), population=40, generations=80, seed=1)
    np.testing.assert_array_equal(result.objectives, again.objectives)
