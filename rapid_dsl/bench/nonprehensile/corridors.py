"""Scene pieces for the corridor and opening tasks (T1, T5, T6): the table, the drawn object, walls.

Everything is a scene document's mapping in SI units (docs/scenes.md). A `Frame` places fixtures
relative to a point on the table turned by a yaw, so a task can keep its corridor square to the
object's drawn yaw where its text needs that, while the object's drawn offset still moves it
relative to the corridor.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from rapid_dsl.bench.nonprehensile.spec import Draw, FinalState, Measure
from rapid_dsl.runtime.variants.geometry import round_diameter

TABLE_X = 0.55                  # m: the table's centre, in front of the robot base
TABLE_SIZE = (1.0, 1.2, 0.75)   # m: full extents; its top is z = 0
WALL_RGBA = (0.55, 0.55, 0.6, 1.0)
# The mesh shape tasks may draw: a regular octagonal prism, 1 x 1 x 1 across its flats.
OCTAGONAL_PRISM = Path(__file__).resolve().parent / "meshes" / "octagonal_prism.obj"


@dataclass(frozen=True, slots=True)
class Frame:
    """A horizontal frame on the table: an origin (x, y) and a yaw about world up."""

    origin: tuple[float, float]
    yaw: float = 0.0

    def point(self, x: float, y: float) -> tuple[float, float]:
        """World (x, y) of the frame's local point (x, y)."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        return (self.origin[0] + c * x - s * y, self.origin[1] + s * x + c * y)

    def local(self, world: np.ndarray) -> np.ndarray:
        """Frame coordinates (x, y, z) of a world point."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        dx, dy = float(world[0]) - self.origin[0], float(world[1]) - self.origin[1]
        return np.array([c * dx + s * dy, -s * dx + c * dy, float(world[2])])


def table() -> dict[str, Any]:
    return {"name": "table", "kind": "surface", "label": "table", "shape": "box",
            "size": list(TABLE_SIZE), "pose": {"position": [TABLE_X, 0.0, -TABLE_SIZE[2] / 2]},
            "friction": 0.6}


def drawn_object(draw: Draw, *, name: str, label: str, position: tuple[float, float],
                 yaw: float, size: tuple[float, float, float], mass: float, friction: float,
                 rgba: tuple[float, float, float, float],
                 other_labels: Mapping[str, str] | None = None) -> dict[str, Any]:
    """The task's object at its demo pose moved by the draw: offset, yaw, scale, shape, mass,
    friction, colour. Flat on the table (its centre at half its drawn height). `label` is the
    box's; `other_labels` gives the other shapes' (default: the box's).

    `size` is the box's. A cylinder keeps about its footprint's area (diameter sqrt(x y)) and is
    scaled by the draw's x factor both ways, so it stays round; a mesh is the octagonal prism
    (flats facing the object's own x and y) stretched to the drawn box."""
    extents = [a * f for a, f in zip(size, draw.scale, strict=True)]
    shape: dict[str, Any] = {"shape": "box"}
    if draw.shape == "cylinder":
        diameter = round_diameter(size) * draw.scale[0]
        extents = [diameter, diameter, extents[2]]
        shape = {"shape": "cylinder"}
    elif draw.shape == "mesh":
        shape = {"shape": "mesh", "mesh": str(OCTAGONAL_PRISM)}
    elif draw.shape != "box":
        raise ValueError(f"a drawn object is a box, cylinder or mesh, not {draw.shape!r}")
    label = (other_labels or {}).get(draw.shape, label)
    return {"name": name, "kind": "object", "label": label, **shape, "size": extents,
            "pose": {"position": [position[0] + draw.offset[0], position[1] + draw.offset[1],
                                  extents[2] / 2], "yaw": yaw + draw.yaw},
            "mass": mass * draw.mass,
            "friction": friction if draw.friction is None else draw.friction,
            "rgba": list(rgba if draw.rgba is None else draw.rgba)}


def wall(name: str, label: str, frame: Frame, centre: tuple[float, float],
         size: tuple[float, float, float], friction: float = 0.5,
         turn: float = 0.0) -> dict[str, Any]:
    """A fixed block standing on the table, its own x (its length) turned by `turn` from the
    frame's x."""
    x, y = frame.point(*centre)
    return {"name": name, "kind": "fixture", "label": label, "shape": "box", "size": list(size),
            "pose": {"position": [x, y, size[2] / 2], "yaw": frame.yaw + turn},
            "friction": friction,
            "rgba": list(WALL_RGBA)}


def franka_scene(objects: list[dict[str, Any]]) -> dict[str, Any]:
    return {"robot": "franka", "floor_height": -TABLE_SIZE[2],
            "gripper_start": {"position": [0.30, 0.0, 0.10], "yaw": 0.0}, "objects": objects}


def between(state: FinalState, target: str, first: str, second: str, *,
            standing: bool = False) -> Measure:
    """The target's centre inside the volume between two parallel blocks (along the span their
    lengths share, across the gap between their inner faces, up to the lower top) and at rest;
    with `standing`, also tilted more than 60 deg (on its edge). The blocks are read from the final
    state, in the frame of `first`.

    The value is the centre's largest excess over the volume's faces [m], <= 0 inside.
    """
    a, b = state.pos(first), state.pos(second)
    size_a = state.final.entities.entities[state.index(first)].extents
    size_b = state.final.entities.entities[state.index(second)].extents
    frame = Frame((float(a[0]), float(a[1])), state.yaw(first))
    other, point = frame.local(b), frame.local(state.pos(target))
    side = 1.0 if other[1] > 0 else -1.0
    low = max(-size_a[0] / 2, other[0] - size_b[0] / 2)
    high = min(size_a[0] / 2, other[0] + size_b[0] / 2)
    near, far = size_a[1] / 2, side * other[1] - size_b[1] / 2
    floor = max(a[2] - size_a[2] / 2, b[2] - size_b[2] / 2)
    ceiling = min(a[2] + size_a[2] / 2, b[2] + size_b[2] / 2)
    across = side * point[1]
    excess = float(max(low - point[0], point[0] - high, near - across, across - far,
                       floor - point[2], point[2] - ceiling))
    settled = state.settled(target)
    tilt = state.tilt(target)
    upright = tilt > math.radians(60) or not standing
    ok = bool(excess <= 0 and settled and upright)
    where = "inside" if excess <= 0 else f"{excess * 100:.1f} cm outside"
    text = (f"centre {where} the volume between {first} and {second}; "
            f"{'settled' if settled else 'moving'}")
    if standing:
        text += f"; tilt {math.degrees(tilt):.0f} deg (needs > 60)"
    return Measure(ok, excess, text)
