"""T5 opening: push a flat box to a wall, flip it up onto its edge, and slide it into a slot.

The opening is a slot between the wall and a rail standing parallel to it, further along the wall:
7 cm wide, narrower than the flat box's width (11.2 cm at the smallest draw) and wider than its
thickness (3.6 cm at the largest), so the box enters it only standing on its edge against the wall.
The wall and the rail turn with the box's drawn yaw (about the box's demo position), so the box
faces the wall squarely; the drawn offset moves the box relative to them, and the rail's length
follows the box's drawn length.
"""

from __future__ import annotations

import math

from rapid_dsl.bench.nonprehensile.corridors import (
    Frame,
    between,
    drawn_object,
    franka_scene,
    table,
    wall,
)
from rapid_dsl.bench.nonprehensile.spec import Draw, FinalState, Measure, Scene, Task

BOX = (0.14, 0.20, 0.03)        # m: toward the wall, along it, thickness
BOX_AT = (0.48, -0.12)          # m: the box's demo position
WALL_FACE = 0.17                # m: the wall's face ahead of the box's demo centre, along its x
WALL = (0.04, 0.80, 0.10)       # m: thickness, length (past the slot's end), height
WALL_MIDDLE = 0.075             # m: the wall's centre along it, from the box's demo centre
SLOT = 0.07                     # m: the slot's width, between the wall's face and the rail's
RAIL_THICKNESS = 0.03
RAIL_HEIGHT = 0.10
RAIL_START = 0.22               # m: the slot's mouth along the wall, from the box's demo centre


def layout(draw: Draw) -> Scene:
    frame = Frame(BOX_AT, draw.yaw)
    rail_length = BOX[1] * draw.scale[1]
    # both run along the frame's y (the wall's face looks back at the box)
    fixtures = [
        wall("wall", "wall", frame, (WALL_FACE + WALL[0] / 2, WALL_MIDDLE),
             (WALL[1], WALL[0], WALL[2]), friction=0.8, turn=math.pi / 2),
        wall("rail", "slot rail", frame,
             (WALL_FACE - SLOT - RAIL_THICKNESS / 2, RAIL_START + rail_length / 2),
             (rail_length, RAIL_THICKNESS, RAIL_HEIGHT), friction=0.5, turn=math.pi / 2),
    ]
    box = drawn_object(draw, name="box", label="flat box", position=BOX_AT, yaw=0.0, size=BOX,
                       mass=0.3, friction=0.6, rgba=(0.2, 0.45, 0.85, 1.0))
    return franka_scene([table(), *fixtures, box])


def inside_opening(state: FinalState) -> Measure:
    """The box's centre inside the slot's volume, standing on its edge (tilt > 60 deg), at rest."""
    return between(state, "box", "wall", "rail", standing=True)


TASK = Task(
    key="T5",
    title="opening",
    text="Push the object toward the fixture, flip it to align with the opening, and move it "
         "into the opening for storage.",
    target="box",
    layout=layout,
    criterion=inside_opening,
    criterion_text="the box's centre inside the slot's volume (between the wall and the rail, "
                   "within the rail's length, below their top), standing on its edge (tilt > 60 "
                   "deg) and settled",
    strategy="t5_opening.rapid",
    shapes=("box",),
    support="table",
    notes=("The box lies flat and is 14 x 20 cm (11.2 x 16 cm at the smallest draw), wider than "
           "the 8 cm hand opening both ways: a top-down grasp cannot close on it.",
           "The slot is 7 cm wide: the flat box cannot enter it, the box standing on its 3 cm "
           "edge can."),
)
