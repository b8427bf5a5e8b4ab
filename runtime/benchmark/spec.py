"""What one benchmark task is: a scene family, a criterion the strategy never sees, a strategy.

A task lays out its scene from a `Draw` (the object's pose offset, size, shape, mass, friction and
colour): `layout(NOMINAL)` is the demonstration scene, and test scenes are layouts of seeded draws
(runtime/benchmark/scenes.py adds the distractors and rejects draws that interpenetrate). Fixtures,
corridors, openings and platforms belong to the layout, so they move with the object where the
task needs them to. The criterion reads the final physical state through `FinalState`, measured
by the harness, independently of the strategy's own success block.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rapid_dsl.runtime.builtins import IMPLEMENTATIONS
from rapid_dsl.runtime.frames import Frames

TASKS_DIR = Path(__file__).resolve().parent / "tasks"

Scene = dict[str, Any]          # a scene document, as a scene file's YAML mapping (SI numbers)


@dataclass(frozen=True, slots=True)
class Draw:
    """One test scene's perturbation of the task's object (NOMINAL: the demonstration)."""

    offset: tuple[float, float] = (0.0, 0.0)        # x, y of the object's position [m]
    yaw: float = 0.0                                # added to the object's yaw [rad]
    scale: tuple[float, float, float] = (1.0, 1.0, 1.0)   # factor per extent
    shape: str = "box"                              # box | cylinder | mesh
    mass: float = 1.0                               # factor on the demo's mass
    friction: float | None = None                   # absolute; None keeps the demo's
    rgba: tuple[float, float, float, float] | None = None   # None keeps the demo's


NOMINAL = Draw()


@dataclass(frozen=True, slots=True)
class Measure:
    """The criterion's verdict on one run."""

    success: bool
    value: float                # the criterion's quantity in SI units (m, rad, ...)
    text: str                   # e.g. "lowest point 4.2 cm above table; both fingers touch"


@dataclass(frozen=True, slots=True)
class FinalState:
    """The world after a run (and at its start), for criteria: entity names, SI values.

    `final` and `start` are B=1, T=1 frames of the executed motion's last and first state; the
    relations are the runtime builtins', so a criterion means what the language's words mean.
    """

    final: Frames
    start: Frames

    def index(self, name: str) -> int:
        return self.final.entities.index(name)

    def _call(self, name: str, *args: Any, start: bool = False) -> Any:
        frames = self.start if start else self.final
        value = IMPLEMENTATIONS[name](frames, *args)
        return np.asarray(value)[0, 0]

    def pos(self, name: str, *, start: bool = False) -> np.ndarray:
        return self._call("pos", self.index(name), start=start)

    def bottom(self, name: str) -> float:
        return float(self._call("bottom", self.index(name)))

    def top(self, name: str) -> float:
        return float(self._call("top", self.index(name)))

    def tilt(self, name: str) -> float:
        return float(self._call("tilt", self.index(name)))

    def yaw(self, name: str) -> float:
        return float(self._call("yaw", self.index(name)))

    def speed(self, name: str) -> float:
        return float(self._call("speed", self.index(name)))

    def settled(self, name: str) -> bool:
        return bool(self._call("settled", self.index(name)))

    def touching(self, a: str, b: str) -> bool:
        return bool(self._call("touching", self.index(a), self.index(b)))

    def holding(self, name: str) -> bool:
        return bool(self._call("holding", self.index("gripper"), self.index(name)))

    def fingers_touch(self, name: str) -> bool:
        """Both fingers are in contact with the object."""
        return bool(self.final.fingers[0, 0, self.index(name)].all())

    def shape(self, name: str) -> str:
        return self.final.entities.entities[self.index(name)].shape

    def rotation(self, name: str) -> np.ndarray:
        """(3, 3) the object's world rotation (its columns: its own x, y, z axes)."""
        w, x, y, z = self.final.quat[0, 0, self.index(name)]
        return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)],
                         [2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)],
                         [2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)]])

    def extents(self, name: str) -> np.ndarray:
        return self.final.entities.entities[self.index(name)].extents

    def corners(self, name: str) -> np.ndarray:
        """(8, 3) world corners of the object's box (its extents about its centre)."""
        half = self.extents(name) / 2
        signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
        return self.final.pos[0, 0, self.index(name)] + (signs * half) @ self.rotation(name).T


@dataclass(frozen=True, slots=True)
class Task:
    """One benchmark task (docs/benchmark.md lists the eight)."""

    key: str                                # "T1" .. "T8"
    title: str                              # short name, e.g. "corridor"
    text: str                               # the task's sentence (the paper's)
    target: str                             # the manipulated object's name in every scene
    layout: Callable[[Draw], Scene]         # the scene for a draw; NOMINAL: the demonstration
    criterion: Callable[[FinalState], Measure]
    criterion_text: str                     # the criterion in words, for docs and the table
    strategy: str                           # file in TASKS_DIR, e.g. "t1_corridor.rapid"
    shapes: tuple[str, ...] = ("box",)      # shapes test scenes may give the object
    support: str = "table"                  # what the distractors stand on
    notes: tuple[str, ...] = field(default=())   # why the object starts ungraspable, etc.

    @property
    def strategy_path(self) -> Path:
        """The strategy file (`strategy` is relative to TASKS_DIR, or absolute)."""
        return TASKS_DIR / self.strategy

    @property
    def demo_path(self) -> Path:
        """The demonstration scene beside the strategy: `<name>.yaml`, equal to layout(NOMINAL)."""
        return self.strategy_path.with_suffix(".yaml")
