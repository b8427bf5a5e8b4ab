"""T8: slide a flat box to the side of a raised platform so an edge overhangs it, grasp that edge
top and bottom, and take the box off the platform.

The box (16 x 12 x 2 cm, at least 12.8 x 9.6 cm for every drawn scale) lies flat on a 14 cm tall
platform, 4 cm in from its near side (the robot's): wider than the hand's 8 cm opening both ways,
so a top grasp cannot close on it, and 2 cm thin on the platform, so no finger gets under it from
the side. Slid toward the near side until part of it overhangs, its edge can be squeezed top and
bottom by the hand turned to open vertically (pitched 90 deg, rolled 90 deg); the platform is
tall enough that the rolled hand's palm (19 cm along the opening) clears the table.

The platform follows the box's drawn pose (offset and yaw) and its drawn length (the box always
starts 4 cm in from the near side, square to it): the task is about the edge, and a box yawed
30 deg against the side would overhang by a corner, not an edge.

The object is a box, a round plate (a cylinder) or an octagonal plate (a mesh), drawn evenly:
each overhangs the side with a part the hand can squeeze top and bottom.
"""

from __future__ import annotations

from rapid_dsl.bench.nonprehensile import criteria
from rapid_dsl.bench.nonprehensile.corridors import Frame, drawn_object, franka_scene, table
from rapid_dsl.bench.nonprehensile.spec import Draw, FinalState, Measure, Scene, Task

TARGET = "box"
BOX = (0.16, 0.12, 0.02)        # m: toward the near side, along it, thickness
BOX_AT = (0.66, 0.0)            # m: its demo centre: the rolled hand works well out from the base
BOX_MASS = 0.15                 # kg: light enough to hang from an edge grasp (x2: 0.3 kg)
PLATFORM = (0.26, 0.40, 0.14)   # m: depth (away from the robot), width, height
INSET = 0.04                    # m: the box's near edge in from the platform's near side
PLATFORM_RGBA = (0.5, 0.5, 0.55, 1.0)
HAND_START = (0.30, 0.0, 0.30)  # m: above the platform's height, in front of it
FLAT_PLATES = {"cylinder": "flat round plate", "mesh": "flat octagonal plate"}


def layout(draw: Draw) -> Scene:
    box = drawn_object(draw, name=TARGET, label="flat box", position=BOX_AT, yaw=0.0, size=BOX,
                       mass=BOX_MASS, friction=0.6, rgba=(0.85, 0.35, 0.3, 1.0),
                       other_labels=FLAT_PLATES)
    length = box["size"][0]
    x, y, z = box["pose"]["position"]
    box["pose"]["position"] = [x, y, z + PLATFORM[2]]
    # The platform moves and turns with the drawn box: its near side INSET in front of the box.
    frame = Frame((x, y), draw.yaw)
    cx, cy = frame.point(-(length / 2 + INSET) + PLATFORM[0] / 2, 0.0)
    platform = {"name": "platform", "kind": "surface", "label": "raised platform",
                "shape": "box", "size": list(PLATFORM),
                "pose": {"position": [cx, cy, PLATFORM[2] / 2], "yaw": draw.yaw},
                "friction": 0.6, "rgba": list(PLATFORM_RGBA)}
    scene = franka_scene([table(), platform, box])
    scene["gripper_start"] = {"position": list(HAND_START), "yaw": 0.0}
    return scene


def grasped_off_platform(state: FinalState) -> Measure:
    return criteria.grasped_above(state, TARGET, "platform")


TASK = Task(
    key="T8",
    title="platform edge",
    text="Move the object to the side of the platform to expose a graspable edge, and grasp it.",
    target=TARGET,
    layout=layout,
    criterion=grasped_off_platform,
    criterion_text="the object's lowest point at least 3 cm above the platform's top, both "
                   "fingers touching it",
    strategy="t8_platform_edge.rapid",
    shapes=("box", "cylinder", "mesh"),
    support="platform",
    notes=("The box lies flat on the platform, wider than the 8 cm opening both ways (9.6 cm at "
           "the smallest draw) and 2 cm thin (1.6-2.4 cm), so neither a top grasp nor a side "
           "pinch on the platform can close on it. The round plate (13.9 cm across, 11.1 cm at "
           "the smallest) and the octagonal plate (the box's extents across its flats) are as "
           "wide and as thin.",
           "The platform follows the box's drawn pose and length, so the box starts square to "
           "its near side, 4 cm in from it."),
)
