"""Settings of a run (`RunConfig`) and the progress events it reports (`Event`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

UNSTABLE_COST = 1e6          # cost of a diverged rollout or a non-finite cost


@dataclass(frozen=True, slots=True, kw_only=True)
class RunConfig:
    seed: int | None = None          # None: the primitive's `optimize { seed }`, else 0
    samples: int | None = None       # overrides every primitive's budget when given
    iterations: int | None = None
    nthread: int = 2
    control_steps: int = 10          # physics steps per control tick
    frame_ticks: int = 5             # control ticks per recorded frame (costs use the frames)
    planning_dt: float | None = 0.004  # s, timestep of the CEM's rollouts (None: the world's)
    execute_elites: int = 0          # final CEM elites run at the world's timestep, the best of
                                     # them executed (0: all of them; 1: the CEM's best only)
    settle: float = 0.5              # s
    grip_dwell: float = 0.4          # s

    def __post_init__(self) -> None:
        if self.execute_elites < 0:
            raise ValueError(f"execute_elites must be at least 0, got {self.execute_elites}")
        if self.planning_dt is not None and not (math.isfinite(self.planning_dt)
                                                 and self.planning_dt > 0):
            raise ValueError(f"planning_dt must be a positive number of seconds, got "
                             f"{self.planning_dt}")


@dataclass(frozen=True, slots=True)
class Event:
    """Progress of a run, for a progress display."""

    kind: Literal["binding", "phase", "iteration", "execute", "phase_done"]
    phase: str = ""
    iteration: int = 0
    iterations: int = 0
    best_cost: float = math.nan        # planned (CEM) cost
    executed_cost: float = math.nan    # phase_done: the executed motion's cost
    message: str = ""
