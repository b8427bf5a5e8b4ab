"""T3: move a flat box sideways clear of the posts in its way, push it to a low wall, flip it up
onto its edge against the wall, and grasp it.

A post stands between the box and the wall, so a straight push to the wall is blocked; a second
post stands beside the box on the other side, so only one way along the wall is free. The box is
the flat box of T2 (wider than the 8 cm hand opening both ways), so it must be flipped first.
"""

from __future__ import annotations

from typing import Any

from rapid_dsl.bench.nonprehensile import flips
from rapid_dsl.bench.nonprehensile.spec import Draw, Task

BOX_AT = (0.44, 0.0)            # m: the box's demo centre, 18.5 cm in front of the wall's face
WALL_SIZE = (flips.WALL_THICKNESS, 0.60, 0.03)   # from y = -0.20 to +0.40: room on the free side
WALL_Y = 0.10
POST_X = 0.63                   # m: the post's centre, between the box and the wall's face (0.68)
POST_SIZE = (0.04, 0.04, 0.04)  # lower than the hand's palm while it pushes (6 cm up)
POST_DY = -0.02                 # m: the post sits off the box's centre line toward the blocked side
SIDE_DX, SIDE_DY = 0.02, -0.17  # m: the side post, beyond the box's reach along -y at every draw


def layout(draw: Draw) -> dict[str, Any]:
    # The wall stays fixed. Both posts follow the box's drawn y, so that they block it in every
    # scene; the post before the wall keeps its x (it must stay clear of the wall's face), the
    # side post follows the box's x too.
    y = BOX_AT[1] + draw.offset[1]
    x = BOX_AT[0] + draw.offset[0]
    return flips.franka_scene([
        flips.table(),
        flips.block("wall", "wall", (flips.WALL_X, WALL_Y), WALL_SIZE, friction=0.8),
        flips.block("post", "post obstacle", (POST_X, y + POST_DY), POST_SIZE, friction=0.5),
        flips.block("block", "side obstacle", (x + SIDE_DX, y + SIDE_DY), POST_SIZE,
                    friction=0.5),
        flips.flat_box(draw, BOX_AT),
    ])


TASK = Task(
    key="T3", title="obstacles",
    text=("Move the object away from the obstacles, push it toward the fixture, flip it to expose "
          "a graspable edge, and grasp it."),
    target=flips.TARGET, layout=layout, criterion=flips.grasped_box,
    criterion_text=flips.GRASPED_TEXT, strategy="t3_obstacles.rapid", shapes=("box",),
    support="table",
    notes=("The box lies flat and is wider than the 8 cm hand opening both ways, so a top grasp "
           "cannot close on it.",
           "A post between the box and the wall blocks the straight push to the wall; a second "
           "post beside the box leaves one way free along the wall."),
)
