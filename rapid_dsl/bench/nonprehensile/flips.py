"""Scene pieces for the flip tasks (T2, T3, T4): the table, the drawn flat box, walls and posts.

Everything is a scene document's mapping in SI units (docs/scenes.md). The box lies flat on the
table in front of a wall along world y; it is wider than the hand's 8 cm opening both ways for
every drawn scale, so it can only be grasped once flipped onto its edge.
"""

from __future__ import annotations

from typing import Any

from rapid_dsl.bench.nonprehensile import criteria
from rapid_dsl.bench.nonprehensile.spec import Draw, FinalState, Measure

TABLE_X = 0.55                  # m: the table's centre, in front of the robot base
TABLE_SIZE = (1.0, 1.2, 0.75)   # m: full extents; its top is z = 0
BOX_SIZE = (0.11, 0.16, 0.03)   # m: toward the wall, along it, thickness (x0.8: 8.8 x 12.8 cm)
BOX_MASS = 0.3                  # kg
BOX_FRICTION = 0.6
BOX_RGBA = (0.2, 0.45, 0.85, 1.0)
WALL_X = 0.70                   # m: the wall's centre; its face toward the robot at 0.68
WALL_THICKNESS = 0.04           # m
WALL_RGBA = (0.55, 0.55, 0.6, 1.0)
TARGET = "box"


def table() -> dict[str, Any]:
    return {"name": "table", "kind": "surface", "label": "table", "shape": "box",
            "size": list(TABLE_SIZE), "pose": {"position": [TABLE_X, 0.0, -TABLE_SIZE[2] / 2]},
            "friction": 0.6}


def flat_box(draw: Draw, position: tuple[float, float]) -> dict[str, Any]:
    """The task's flat box at its demo position moved by the draw, flat on the table."""
    extents = [a * f for a, f in zip(BOX_SIZE, draw.scale, strict=True)]
    return {"name": TARGET, "kind": "object", "label": "flat box", "shape": "box",
            "size": extents,
            "pose": {"position": [position[0] + draw.offset[0], position[1] + draw.offset[1],
                                  extents[2] / 2], "yaw": draw.yaw},
            "mass": BOX_MASS * draw.mass,
            "friction": BOX_FRICTION if draw.friction is None else draw.friction,
            "rgba": list(BOX_RGBA if draw.rgba is None else draw.rgba)}


def block(name: str, label: str, centre: tuple[float, float], size: tuple[float, float, float],
          friction: float) -> dict[str, Any]:
    """A fixed block standing on the table, square to the robot's x axis."""
    return {"name": name, "kind": "fixture", "label": label, "shape": "box", "size": list(size),
            "pose": {"position": [centre[0], centre[1], size[2] / 2]}, "friction": friction,
            "rgba": list(WALL_RGBA)}


def franka_scene(objects: list[dict[str, Any]]) -> dict[str, Any]:
    return {"robot": "franka", "floor_height": -TABLE_SIZE[2],
            "gripper_start": {"position": [0.30, 0.0, 0.10], "yaw": 0.0}, "objects": objects}


def grasped_box(state: FinalState) -> Measure:
    """The box held by both fingers with its lowest point at least 3 cm above the table."""
    return criteria.grasped_above(state, TARGET, "table")


GRASPED_TEXT = ("the box's lowest point at least 3 cm above the table, both fingers touching it")
