"""T7: topple a tall carton standing in a tight rack, then grasp it where it lies, and lift it.

The carton (10.5 x 5 x 16 cm) stands between two blocks 1 cm taller than it, 4 mm off its broad
faces: no finger fits beside those faces, and across its other side it is 10.5 cm (8.4 cm at the
smallest drawn scale), wider than the hand's 8 cm opening, so it cannot be grasped standing. Its
front and back faces are free: pushed high from the back (the robot's side) it tips forward out
of the rack and lies beyond it with its 5 cm side horizontal, graspable from above.

The rack follows the carton's drawn pose (offset and yaw) and its drawn size (the blocks are as
long as the carton, 1 cm taller, 4 mm off its faces), so the carton always stands in it.
"""

from __future__ import annotations

from rapid_dsl.bench.nonprehensile import criteria
from rapid_dsl.bench.nonprehensile.corridors import Frame, drawn_object, franka_scene, table, wall
from rapid_dsl.bench.nonprehensile.spec import Draw, FinalState, Measure, Scene, Task

TARGET = "carton"
CARTON = (0.105, 0.05, 0.16)    # m: along the topple, across the rack, height
CARTON_AT = (0.46, 0.0)         # m: its demo centre; it falls away from the robot, to x < 0.77
BLOCK_THICKNESS = 0.03          # m
BLOCK_GAP = 0.004               # m: between the carton and each block, less than a finger
BLOCK_RISE = 0.01               # m: the blocks stand this much taller than the carton
HAND_START = (0.30, 0.0, 0.25)  # m: above the rack's top at every drawn pose and size


def layout(draw: Draw) -> Scene:
    carton = drawn_object(draw, name=TARGET, label="tall carton", position=CARTON_AT, yaw=0.0,
                          size=CARTON, mass=0.3, friction=0.7, rgba=(0.3, 0.7, 0.35, 1.0))
    length, width, height = carton["size"]
    # The rack moves and turns with the drawn carton.
    frame = Frame((carton["pose"]["position"][0], carton["pose"]["position"][1]), draw.yaw)
    side = width / 2 + BLOCK_GAP + BLOCK_THICKNESS / 2
    blocks = [wall(f"rack_{name}", f"{name} rack block", frame, (0.0, sign * side),
                   (length, BLOCK_THICKNESS, height + BLOCK_RISE), friction=0.5)
              for name, sign in (("left", 1.0), ("right", -1.0))]
    scene = franka_scene([table(), *blocks, carton])
    scene["gripper_start"] = {"position": list(HAND_START), "yaw": 0.0}
    return scene


def grasped_carton(state: FinalState) -> Measure:
    return criteria.grasped_above(state, TARGET, "table")


TASK = Task(
    key="T7",
    title="topple and grasp",
    text="Topple the object to expose an edge and grasp it.",
    target=TARGET,
    layout=layout,
    criterion=grasped_carton,
    criterion_text="the carton's lowest point at least 3 cm above the table, both fingers "
                   "touching it",
    strategy="t7_topple_grasp.rapid",
    shapes=("box",),
    support="table",
    notes=("Standing, the carton is blocked on its 5 cm side by the rack (blocks 4 mm off its "
           "faces and 1 cm taller than it) and wider than the 8 cm opening across its other side "
           "(8.4 cm at the smallest draw): a top grasp cannot close on it.",
           "Toppled forward out of the rack it lies with its 5 cm side horizontal, clear of the "
           "blocks.",
           "The rack follows the carton's drawn pose and size, so the carton always stands in it."),
)
