"""What a run reports: per phase the binding, arguments, CEM costs, clause values and timings.

Plain dataclasses with SI values; `RunResult.to_json()` is the trace format tools and agents read
(values in SI, each with its unit), and `format_value` gives the human form the tables show.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

PhaseStatus = Literal["succeeded", "failed", "not run"]


@dataclass(frozen=True, slots=True)
class ClauseResult:
    """One success/requires clause in the state it was judged on."""

    text: str
    origin: str
    holds: bool
    value: float | list[float] | None = None     # left side of a comparison (SI)
    bound: float | list[float] | None = None     # right side of a comparison (SI)
    unit: str = ""


@dataclass(slots=True)
class PhaseResult:
    name: str
    primitive: str
    origin: str
    binding: dict[str, str]                      # primitive role -> entity
    arguments: dict[str, float | list[float]] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    requires: list[ClauseResult] = field(default_factory=list)
    success: list[ClauseResult] = field(default_factory=list)
    status: PhaseStatus = "not run"
    failure: str | None = None
    best_cost_per_iteration: list[float] = field(default_factory=list)
    mean_cost_per_iteration: list[float] = field(default_factory=list)
    final_cost: float | None = None              # cost of the replayed best motion
    samples: int = 0
    iterations: int = 0
    rollouts: int = 0
    physics_steps: int = 0
    planning_dt: float | None = None             # timestep of the CEM's rollouts [s]
    unstable_rollouts: int = 0
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def succeeded(self) -> bool:
        return self.status == "succeeded"


@dataclass(slots=True)
class RunResult:
    program: str
    entry: str
    kind: Literal["primitive", "strategy"]
    scene: str
    seed: int
    binding: dict[str, str] = field(default_factory=dict)
    binding_note: str | None = None              # ambiguity or pins, in words
    phases: list[PhaseResult] = field(default_factory=list)
    success: list[ClauseResult] = field(default_factory=list)
    succeeded: bool = False
    failure: str | None = None
    final_poses: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (NaN and inf become null)."""
        data = asdict(self)
        for phase, result in zip(data["phases"], self.phases, strict=True):
            phase["succeeded"] = result.succeeded
        return _clean(data)


def _clean(value: Any) -> Any:
    if isinstance(value, dict):
        return {str(k): _clean(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_clean(v) for v in value]
    if isinstance(value, (np.floating, float)):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, (np.integer,)):
        return int(value)
    if isinstance(value, np.bool_):
        return bool(value)
    return value


def plain(value: Any) -> float | list[float]:
    """An evaluated value (float or (…, 3) array with leading size-1 axes) as JSON numbers."""
    array = np.asarray(value, dtype=float)
    if array.size == 1:
        return float(array.reshape(()))
    return [float(x) for x in array.reshape(-1, array.shape[-1])[0]]


# Human units for the SI ones a report shows.
_DISPLAY = {"m": ("cm", 100.0), "rad": ("deg", 180.0 / math.pi), "m/s": ("cm/s", 100.0),
            "rad/s": ("deg/s", 180.0 / math.pi)}


def format_value(value: float | list[float] | None, unit: str) -> str:
    """`0.031` m -> `3.1cm`; vectors as `[1.0, 0.0, 0.0]cm`; None -> `-`."""
    if value is None:
        return "-"
    shown, factor = _DISPLAY.get(unit, (unit, 1.0))
    if isinstance(value, list):
        return "[" + ", ".join(f"{x * factor:.3g}" for x in value) + "]" + shown
    if isinstance(value, bool):
        return str(value).lower()
    return f"{value * factor:.3g}{shown}"
