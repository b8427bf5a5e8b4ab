"""T1 corridor: push a flat object to the corridor's mouth, then from another face into it.

The corridor is two low parallel walls open at both ends, 3.5 cm wider than the box and 6 cm longer.
The box starts in front of the corridor but 17 cm beside its axis, so no single push along one of
its faces stores it: it must first be pushed sideways onto the axis, then from its back face along
the corridor. The corridor turns with the box's drawn yaw (about the box's demo position), so the
box always faces it squarely; the drawn offset moves the box relative to the corridor, and the
corridor's width and length follow the box's drawn size.

The object is a box, a round tin (a cylinder) or an octagonal tin (a mesh), drawn evenly: a push
of a flat face or of a round side stores any of them, and a corridor's walls fit each one.
"""

from __future__ import annotations

from rapid_dsl.bench.nonprehensile.corridors import (
    Frame,
    between,
    drawn_object,
    franka_scene,
    table,
    wall,
)
from rapid_dsl.bench.nonprehensile.spec import Draw, FinalState, Measure, Scene, Task

BOX = (0.12, 0.11, 0.05)        # m: wider than the 8 cm hand opening both ways, flat
BOX_AT = (0.45, 0.17)           # m: the box's demo position, beside the corridor's axis
MOUTH = 0.15                    # m: the corridor's mouth ahead of the box, along its x
AXIS = -0.17                    # m: the corridor's axis beside the box, along its y
WALL_THICKNESS = 0.02
WALL_HEIGHT = 0.04              # low, so the hand's palm passes over the walls while it pushes
WIDTH_MARGIN = 0.035            # m: the corridor's inside is this much wider than the box
LENGTH_MARGIN = 0.06
FLAT_TINS = {"cylinder": "flat round tin", "mesh": "flat octagonal tin"}


def layout(draw: Draw) -> Scene:
    frame = Frame(BOX_AT, draw.yaw)
    box = drawn_object(draw, name="box", label="flat box", position=BOX_AT, yaw=0.0, size=BOX,
                       mass=0.4, friction=0.5, rgba=(0.85, 0.45, 0.15, 1.0),
                       other_labels=FLAT_TINS)
    length = box["size"][0] + LENGTH_MARGIN
    width = box["size"][1] + WIDTH_MARGIN
    walls = [wall(f"wall_{side}", f"{side} corridor wall", frame,
                  (MOUTH + length / 2, AXIS + sign * (width + WALL_THICKNESS) / 2),
                  (length, WALL_THICKNESS, WALL_HEIGHT))
             for side, sign in (("left", 1.0), ("right", -1.0))]
    return franka_scene([table(), *walls, box])


def inside_corridor(state: FinalState, target: str = "box") -> Measure:
    """The box's centre inside the corridor's volume (between the walls, within their length, below
    their top) and at rest; the corridor is read from the walls in the final state."""
    return between(state, target, "wall_left", "wall_right")


TASK = Task(
    key="T1",
    title="corridor",
    text="Push the object toward the corridor, switch the contact face, and push it again to "
         "store it inside the corridor.",
    target="box",
    layout=layout,
    criterion=inside_corridor,
    criterion_text="the object's centre inside the corridor's volume (between the walls, within "
                   "their length, below their top) and settled",
    strategy="t1_corridor.rapid",
    shapes=("box", "cylinder", "mesh"),
    support="table",
    notes=("The box is 12 x 11 cm (9.6 x 8.8 cm at the smallest draw), wider than the 8 cm hand "
           "opening both ways, and 5 cm tall: a top-down grasp cannot close on it. The round tin "
           "(11.5 cm across, 9.2 cm at the smallest) and the octagonal tin (the box's extents "
           "across its flats) are as wide.",
           "The corridor turns with the box's drawn yaw so it stays square to the box; a push "
           "cannot turn a box by 30 deg reliably, and the task's text has no pivot."),
)
