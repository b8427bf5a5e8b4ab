"""T4: push a flat box to a tall wall, flip it up against it, slide it along the wall past the
wall's end so that an edge is free, and grasp it.

Flipped against the tall wall the box leans on it over its whole height: no finger can pass
between them, and the box is wider than the 8 cm hand opening along the wall. Slid along the wall
until its centre is past the wall's end, it can be grasped across its thickness there.
"""

from __future__ import annotations

from typing import Any

from rapid_dsl.bench.nonprehensile import flips
from rapid_dsl.bench.nonprehensile.spec import Draw, Task

BOX_AT = (0.48, 0.0)            # m: the box's demo centre, 14.5 cm in front of the wall's face
WALL_HEIGHT = 0.18              # m: above the flipped box at every drawn scale (13.2 cm at most)
WALL_FROM, WALL_TO = -0.25, 0.12   # m: the wall's span along y about the box's drawn y


def layout(draw: Draw) -> dict[str, Any]:
    # The wall stays at a fixed x; its span follows the box's drawn y, so that it covers the box
    # (its end 2 cm past the box's end at the largest drawn size) in every scene.
    y = BOX_AT[1] + draw.offset[1]
    size = (flips.WALL_THICKNESS, WALL_TO - WALL_FROM, WALL_HEIGHT)
    return flips.franka_scene([
        flips.table(),
        flips.block("wall", "wall", (flips.WALL_X, y + (WALL_FROM + WALL_TO) / 2), size,
                    friction=0.4),
        flips.flat_box(draw, BOX_AT),
    ])


TASK = Task(
    key="T4", title="reposition",
    text=("Push the object toward the fixture, flip it, reposition it to expose a graspable edge, "
          "and grasp it."),
    target=flips.TARGET, layout=layout, criterion=flips.grasped_box,
    criterion_text=flips.GRASPED_TEXT, strategy="t4_reposition.rapid", shapes=("box",),
    support="table",
    notes=("The box lies flat and is wider than the 8 cm hand opening both ways, so a top grasp "
           "cannot close on it.",
           "Flipped, it leans on a wall taller than itself: no finger passes between them until "
           "it is slid along the wall past the wall's end."),
)
