"""What a run reports: per phase the binding, arguments, costs, clause values, motion and end state.

Plain dataclasses with SI values; `RunResult.to_json()` is the trace format tools and agents read
(values in SI, each with its unit), and `format_value` gives the human form the tables show.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any, Literal

import numpy as np

PhaseStatus = Literal["succeeded", "failed", "not run"]
Outcome = Literal["succeeded", "failed", "rejected"]
OnFail = Literal["stop", "continue"]


@dataclass(frozen=True, slots=True)
class ClauseResult:
    """One success/requires/filter clause in the state it was judged on."""

    text: str
    origin: str
    holds: bool
    value: float | list[float] | None = None     # left side of a comparison (SI)
    bound: float | list[float] | None = None     # right side of a comparison (SI)
    unit: str = ""
    at_start: bool | None = None                 # a success clause's truth in the start state


@dataclass(frozen=True, slots=True)
class RunWarning:
    """Something that makes a result less trustworthy without failing it (e.g. a vacuous clause)."""

    origin: str                                  # "file.rapid:LINE" of the clause
    message: str
    phase: str | None = None                     # None: the entry's own success block

    def text(self) -> str:
        """`file.rapid:12: warning: ...`, as printed on stderr."""
        return f"{self.origin}: warning: {self.message}"


@dataclass(frozen=True, slots=True)
class KeypointRecord:
    """One keypoint of the executed motion: its start-state value (the CEM mean) and as executed."""

    name: str
    planned: list[float]                         # position in the start state [m]
    executed: list[float]                        # planned + the chosen sample's offset [m]
    yaw: float | None = None                     # executed [rad]; None: carried over
    pitch: float | None = None
    grip: float | None = None                    # 0 open, 1 closed; None: carried over
    roll: float | None = None                    # executed [rad]; None: carried over


@dataclass(slots=True)
class EndState:
    """What the world looks like when a phase's executed motion ends."""

    contacts: list[list[str]] = field(default_factory=list)       # entity pairs that touch
    finger_contacts: dict[str, list[str]] = field(default_factory=dict)  # entity -> fingers
    holding: list[str] = field(default_factory=list)               # objects `holding` holds
    opening: float | None = None                                   # finger distance [m]
    hand_position: list[float] = field(default_factory=list)       # [m]
    hand_yaw: float | None = None                                  # [rad]
    hand_pitch: float | None = None                                # [rad]
    hand_roll: float | None = None                                 # [rad]


@dataclass(frozen=True, slots=True)
class Attempt:
    """One try of a phase: a phase with `retry N` is tried up to N + 1 times."""

    number: int                                  # 1: the first attempt
    seed: list[int]                              # the CEM's seed: [run seed] or [run seed, number]
    status: PhaseStatus
    failure: str | None = None
    moved: bool = False                          # whether it executed a motion
    arguments: dict[str, float | list[float]] = field(default_factory=dict)
    planned_cost: float | None = None
    executed_cost: float | None = None
    seconds: float = 0.0


@dataclass(slots=True)
class PhaseResult:
    name: str
    primitive: str
    origin: str
    binding: dict[str, str]                      # primitive role -> entity
    on_fail: OnFail = "stop"                     # what a failure of this phase does to the run
    arguments: dict[str, float | list[float]] = field(default_factory=dict)
    units: dict[str, str] = field(default_factory=dict)
    requires: list[ClauseResult] = field(default_factory=list)
    success: list[ClauseResult] = field(default_factory=list)
    status: PhaseStatus = "not run"
    failure: str | None = None
    best_cost_per_iteration: list[float] = field(default_factory=list)
    mean_cost_per_iteration: list[float] = field(default_factory=list)
    planned_cost: float | None = None            # the executed motion's cost at planning_dt
    executed_cost: float | None = None           # its cost as executed at the world's timestep
    planned_success: bool | None = None          # success judged on its planning rollout
    executed_elites: int = 0                     # final elites run at the world's timestep
    chosen_elite: int | None = None              # rank (0 = CEM best) of the executed one
    chosen_sample: list[float] = field(default_factory=list)   # its decision vector z
    keypoints: list[KeypointRecord] = field(default_factory=list)
    end: EndState | None = None
    samples: int = 0
    iterations: int = 0
    rollouts: int = 0
    physics_steps: int = 0
    planning_dt: float | None = None             # timestep of the CEM's rollouts [s]
    unstable_rollouts: int = 0
    seconds: dict[str, float] = field(default_factory=dict)
    retry: int = 0                               # how many more times a failure is tried
    attempts: list[Attempt] = field(default_factory=list)   # every try; the fields above: the last

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
    filters: dict[str, list[ClauseResult]] = field(default_factory=dict)  # declaration -> clauses
    rejected: bool = False                       # a filter is false: the start state is not run
    phases: list[PhaseResult] = field(default_factory=list)
    success: list[ClauseResult] = field(default_factory=list)
    succeeded: bool = False
    failure: str | None = None
    warnings: list[RunWarning] = field(default_factory=list)
    final_poses: dict[str, dict[str, list[float]]] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)

    @property
    def outcome(self) -> Outcome:
        if self.rejected:
            return "rejected"
        return "succeeded" if self.succeeded else "failed"

    def to_json(self) -> dict[str, Any]:
        """A JSON-ready dict (NaN and inf become null)."""
        data = asdict(self)
        data["outcome"] = self.outcome
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
    """`0.031` m -> `3.1cm`; vectors as `[1.0, 0.0, 0.0]cm`; None -> `-`; a quantity that is not
    finite has no unit (`NaN`, not `nancm`)."""
    if value is None:
        return "-"
    shown, factor = _DISPLAY.get(unit, (unit, 1.0))
    if isinstance(value, list):
        return "[" + ", ".join(_number(x * factor) for x in value) + "]" + shown
    if isinstance(value, bool):
        return str(value).lower()
    if not math.isfinite(value):
        return _number(value)
    return f"{_number(value * factor)}{shown}"


def _number(x: float) -> str:
    return "NaN" if math.isnan(x) else f"{x:.3g}"


def attempt_label(phase: str, number: int) -> str:
    """`tip` for a first attempt, `tip (2nd attempt)` for a later one."""
    if number == 1:
        return phase
    suffix = "th" if 10 <= number % 100 <= 20 else \
        {1: "st", 2: "nd", 3: "rd"}.get(number % 10, "th")
    return f"{phase} ({number}{suffix} attempt)"


def format_cost(cost: float | None) -> str:
    """A cost for a table: 3 significant digits, `-` when there is none."""
    return "-" if cost is None or math.isnan(cost) else f"{cost:.3g}"
