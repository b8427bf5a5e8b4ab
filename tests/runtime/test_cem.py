"""The cross-entropy method on numpy-only problems (no MuJoCo)."""

from __future__ import annotations

import numpy as np
import pytest

from rapid_dsl.runtime.cem import CEMConfig, optimize

TARGET = np.array([0.3, -0.2, 0.05])


def quadratic(population: np.ndarray) -> np.ndarray:
    return ((population - TARGET) ** 2).sum(axis=1)


def test_finds_the_minimum_of_a_quadratic():
    result = optimize(quadratic, np.zeros(3), np.full(3, 0.2),
                      config=CEMConfig(samples=64, elites=8, iterations=12),
                      rng=np.random.default_rng(0))
    np.testing.assert_allclose(result.best, TARGET, atol=0.02)
    assert result.best_cost < 1e-3
    assert len(result.best_cost_per_iteration) == 12
    # elites carry over, so the best cost never gets worse
    assert all(np.diff(result.best_cost_per_iteration) <= 0)


def test_sample_zero_is_the_mean_and_is_evaluated():
    seen = []

    def cost(population):
        seen.append(population.copy())
        return quadratic(population)

    optimize(cost, TARGET.copy(), np.full(3, 0.1),
             config=CEMConfig(samples=8, elites=2, iterations=1), rng=np.random.default_rng(1))
    np.testing.assert_array_equal(seen[0][0], TARGET)


def test_same_seed_same_result_and_different_seed_differs():
    config = CEMConfig(samples=16, elites=4, iterations=3)
    a = optimize(quadratic, np.zeros(3), np.ones(3), config=config, rng=np.random.default_rng(5))
    b = optimize(quadratic, np.zeros(3), np.ones(3), config=config, rng=np.random.default_rng(5))
    c = optimize(quadratic, np.zeros(3), np.ones(3), config=config, rng=np.random.default_rng(6))
    np.testing.assert_array_equal(a.best, b.best)
    assert not np.array_equal(a.best, c.best)


def test_std_floor_keeps_exploring():
    config = CEMConfig(samples=16, elites=4, iterations=20, std_floor=0.25)
    result = optimize(quadratic, np.zeros(3), np.full(3, 0.4), config=config,
                      rng=np.random.default_rng(2))
    assert np.all(result.std >= 0.1 - 1e-12)


def test_zero_std_freezes_a_dimension_and_non_finite_costs_are_rejected():
    def cost(population):
        costs = quadratic(population)
        costs[population[:, 0] > 0.35] = np.nan       # "unstable rollouts"
        return costs

    result = optimize(cost, np.zeros(3), np.array([0.2, 0.2, 0.0]),
                      config=CEMConfig(samples=32, elites=4, iterations=8),
                      rng=np.random.default_rng(3))
    assert result.best[2] == 0.0
    assert np.isfinite(result.best_cost)
    assert result.best[0] <= 0.35


@pytest.mark.parametrize("kwargs, message", [
    (dict(samples=4, elites=8), "elites"),
    (dict(iterations=0), "iterations"),
    (dict(std_floor=2.0), "std_floor"),
])
def test_config_is_validated(kwargs, message):
    with pytest.raises(ValueError, match=message):
        CEMConfig(**kwargs)


def test_cost_shape_is_checked():
    with pytest.raises(ValueError, match="must return 4 values"):
        optimize(lambda p: np.zeros(3), np.zeros(2), np.ones(2),
                 config=CEMConfig(samples=4, elites=2, iterations=1), rng=np.random.default_rng(0))
