"""What one benchmark task is: a scene family, a criterion the strategy never sees, a strategy.

A task lays out its scene from a `Draw` (the object's pose offset, size, shape, mass, friction and
colour): `layout(NOMINAL)` is the demonstration scene, and test scenes are layouts of seeded draws
(rapid_dsl/bench/nonprehensile/scenes.py adds the distractors and rejects draws that
interpenetrate). Fixtures, corridors, openings and platforms belong to the layout, so they move with
the object where the task needs them to. The criterion reads the final physical state through
`FinalState`, measured by the harness, independently of the strategy's own success block.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from rapid_dsl.runtime.builtins import IMPLEMENTATIONS, _rot
from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.variants.geometry import Solid

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
    meshes: Mapping[str, str] = field(default_factory=dict)   # mesh objects' files, by name

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

    def solid(self, name: str) -> Solid:
        """The object's placed shape in the final state (its exact heights, its box's corners)."""
        e = self.index(name)
        entity = self.final.entities.entities[e]
        return Solid(name, entity.shape, self.final.pos[0, 0, e], _rot(self.final, e)[0, 0],
                     entity.extents, self.meshes.get(name))

    def corners(self, name: str) -> np.ndarray:
        """(8, 3) world corners of the object's box (its extents about its centre)."""
        return self.solid(name).corners()


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
