"""The cross-entropy method in numpy over a real decision vector, with an explicit seeded generator.

Each iteration samples a population around a diagonal Gaussian (sample 0 is the mean itself, so the
current best guess is always evaluated), keeps the lowest-cost elites, and refits the mean and the
standard deviation to them. Elites carry over to the next iteration's selection without being
evaluated again (rollouts are deterministic), so the best cost never gets worse. A floor on the
standard deviation keeps the search from collapsing onto one point too early. The result keeps the
final elites, best first, so a caller can judge more than the single best (the executor runs them
at the world's timestep and executes the best of those).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

CostFn = Callable[[np.ndarray], np.ndarray]   # (N, D) samples -> (N,) costs


@dataclass(frozen=True, slots=True, kw_only=True)
class CEMConfig:
    samples: int = 64           # population per iteration, sample 0 included
    elites: int = 8
    iterations: int = 6
    std_floor: float = 0.05     # minimum std as a fraction of the initial std, per dimension
    smoothing: float = 0.0      # weight of the previous mean/std in each refit (0 = plain CEM)

    def __post_init__(self) -> None:
        if self.samples < 1:
            raise ValueError(f"samples must be at least 1, got {self.samples}")
        if not 0 < self.elites <= self.samples:
            raise ValueError(f"elites must be in (0, samples={self.samples}], got {self.elites}")
        if self.iterations < 1:
            raise ValueError(f"iterations must be at least 1, got {self.iterations}")
        if not 0.0 <= self.std_floor <= 1.0:
            raise ValueError(f"std_floor must be in [0, 1], got {self.std_floor}")
        if not 0.0 <= self.smoothing < 1.0:
            raise ValueError(f"smoothing must be in [0, 1), got {self.smoothing}")


@dataclass(frozen=True, slots=True)
class CEMResult:
    best: np.ndarray                    # (D,) lowest-cost sample seen
    best_cost: float
    mean: np.ndarray                    # (D,) final mean (a warm start for a later solve)
    std: np.ndarray                     # (D,) final standard deviation
    best_cost_per_iteration: tuple[float, ...]
    mean_cost_per_iteration: tuple[float, ...] = field(default=())  # over finite costs
    elites: np.ndarray = field(default_factory=lambda: np.empty((0, 0)))  # (E, D) best first
    elite_costs: np.ndarray = field(default_factory=lambda: np.empty(0))  # (E,), +inf if failed


def optimize(
    cost: CostFn,
    mean: np.ndarray,
    std: np.ndarray,
    *,
    config: CEMConfig,
    rng: np.random.Generator,
    on_iteration: Callable[[int, float], None] | None = None,
) -> CEMResult:
    """Minimize `cost` over vectors of mean's shape, starting from N(mean, std^2).

    Args:
        cost: evaluates a (N, D) population at once; non-finite costs count as +inf.
        mean: (D,) initial mean (warm start).
        std: (D,) initial standard deviation; 0 freezes a dimension.
        config: population sizes and schedule.
        rng: the only source of randomness.
        on_iteration: called with (iteration, best cost so far) after each iteration.
    """
    mean = np.array(mean, dtype=float).reshape(-1)
    std = np.broadcast_to(np.asarray(std, dtype=float), mean.shape).copy()
    if np.any(std < 0) or not np.all(np.isfinite(std)):
        raise ValueError("std must be finite and non-negative")
    floor = config.std_floor * std
    kept = np.empty((0, mean.size))
    kept_cost = np.empty(0)
    best, best_cost = mean.copy(), math.inf
    best_costs: list[float] = []
    mean_costs: list[float] = []
    for iteration in range(config.iterations):
        population = mean + std * rng.standard_normal((config.samples, mean.size))
        population[0] = mean
        costs = np.asarray(cost(population), dtype=float).reshape(-1)
        if costs.shape != (config.samples,):
            raise ValueError(f"cost must return {config.samples} values, got shape {costs.shape}")
        costs = np.where(np.isfinite(costs), costs, math.inf)
        finite = costs[np.isfinite(costs)]
        mean_costs.append(float(finite.mean()) if finite.size else math.inf)
        pool = np.concatenate([kept, population])
        pool_cost = np.concatenate([kept_cost, costs])
        order = np.argsort(pool_cost, kind="stable")[: config.elites]
        kept, kept_cost = pool[order], pool_cost[order]
        if kept_cost[0] < best_cost:
            best, best_cost = kept[0].copy(), float(kept_cost[0])
        best_costs.append(best_cost)
        if on_iteration is not None:
            on_iteration(iteration, best_cost)
        elite = kept[np.isfinite(kept_cost)]
        if elite.shape[0] == 0:
            continue  # every sample failed: keep searching with the same distribution
        a = config.smoothing
        mean = a * mean + (1 - a) * elite.mean(axis=0)
        spread = elite.std(axis=0) if elite.shape[0] > 1 else std
        std = np.maximum(a * std + (1 - a) * spread, floor)
    return CEMResult(best, best_cost, mean, std, tuple(best_costs), tuple(mean_costs),
                     elites=kept.copy(), elite_costs=kept_cost.copy())
