"""T2: push a flat box to a low wall, flip it up onto its edge against the wall, and grasp it.

The box (11 x 16 x 3 cm, at least 8.8 cm both ways for every drawn scale) lies flat: wider than
the hand's 8 cm opening both ways, so a top grasp cannot close on it. Flipped up against the wall
it stands on its 3 cm edge; the wall is only 3 cm tall, so the finger on the wall's side passes
above it and the hand closes across the box's thickness.
"""

from __future__ import annotations

from typing import Any

from rapid_dsl.bench.nonprehensile import flips
from rapid_dsl.bench.nonprehensile.spec import Draw, Task

BOX_AT = (0.48, 0.0)            # m: the box's demo centre, 14.5 cm in front of the wall's face
WALL_SIZE = (flips.WALL_THICKNESS, 0.50, 0.03)   # long enough for every drawn offset and yaw


def layout(draw: Draw) -> dict[str, Any]:
    # The wall stays fixed: the strategy pushes square to its face whatever the box's pose.
    return flips.franka_scene([
        flips.table(),
        flips.block("wall", "wall", (flips.WALL_X, 0.0), WALL_SIZE, friction=0.8),
        flips.flat_box(draw, BOX_AT),
    ])


TASK = Task(
    key="T2", title="flip and grasp",
    text="Push the object toward the fixture, flip it to expose a graspable edge, and grasp it.",
    target=flips.TARGET, layout=layout, criterion=flips.grasped_box,
    criterion_text=flips.GRASPED_TEXT, strategy="t2_flip_grasp.rapid", shapes=("box",),
    support="table",
    notes=("The box lies flat and is wider than the 8 cm hand opening both ways (8.8 cm at the "
           "smallest drawn scale), so a top grasp cannot close on it.",
           "The 3 cm wall is lower than where the fingers close on the flipped box, so the finger "
           "on the wall's side passes above it."),
)
