"""T6 pivot and corridor: turn a long box to the corridor's axis, push it to the mouth and inside.

The corridor is two low parallel walls along world y, open at both ends, 4 cm wider than the box's
short side and 6 cm longer than its long side. The box starts in front of the mouth with its long
axis across the corridor (yaw 0 against the corridor's 90 deg), at least 19 cm long against an
opening of at most 16.6 cm, so it cannot enter until it is pivoted by 60 to 90 deg. The corridor
stays fixed in the world (its size follows the box's drawn size): the drawn yaw changes how far the
box must turn and the drawn offset where it starts.
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

BOX = (0.24, 0.105, 0.04)       # m: long axis, short side (8.4 cm at the smallest draw), height
BOX_AT = (0.55, -0.14)          # m: the box's demo position, in front of the corridor's mouth
CORRIDOR = Frame((0.55, 0.14), math.pi / 2)   # the mouth's centre; local x runs into the corridor
WALL_THICKNESS = 0.02
WALL_HEIGHT = 0.04              # low, so the hand's palm passes over the walls while it pushes
WIDTH_MARGIN = 0.04             # m: the corridor's inside is this much wider than the box
LENGTH_MARGIN = 0.06


def layout(draw: Draw) -> Scene:
    width = BOX[1] * draw.scale[1] + WIDTH_MARGIN
    length = BOX[0] * draw.scale[0] + LENGTH_MARGIN
    walls = [wall(f"wall_{side}", f"{side} corridor wall", CORRIDOR,
                  (length / 2, sign * (width + WALL_THICKNESS) / 2),
                  (length, WALL_THICKNESS, WALL_HEIGHT))
             for side, sign in (("left", 1.0), ("right", -1.0))]
    box = drawn_object(draw, name="box", label="long box", position=BOX_AT, yaw=0.0, size=BOX,
                       mass=0.4, friction=0.5, rgba=(0.25, 0.6, 0.35, 1.0))
    return franka_scene([table(), *walls, box])


def inside_corridor(state: FinalState) -> Measure:
    """The box's centre inside the corridor's volume and at rest (corridors.between)."""
    return between(state, "box", "wall_left", "wall_right")


TASK = Task(
    key="T6",
    title="pivot and corridor",
    text="Pivot the box to align it with the corridor, push it toward the corridor, and then move "
         "it to store it inside the corridor.",
    target="box",
    layout=layout,
    criterion=inside_corridor,
    criterion_text="the box's centre inside the corridor's volume (between the walls, within "
                   "their length, below their top) and settled",
    strategy="t6_pivot_corridor.rapid",
    shapes=("box",),
    support="table",
    notes=("The box is 24 x 10.5 cm (19.2 x 8.4 cm at the smallest draw), wider than the 8 cm "
           "hand opening both ways, and 4 cm tall: a top-down grasp cannot close on it.",
           "Its long side is at least 19 cm and the corridor at most 16.6 cm wide, so it enters "
           "only after a pivot; a cylinder would need none, so the task has boxes only."),
)
