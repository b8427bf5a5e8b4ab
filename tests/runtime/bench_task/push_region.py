"""A small real benchmark task for the harness's tests: push a flat box 10 cm into a region.

The box is too wide for the gripper (its narrow side exceeds `grasp`'s 7 cm filter), so the
control's grasp-and-lift fails, as in the benchmark's own tasks.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rapid_dsl.bench.nonprehensile.criteria import inside_box
from rapid_dsl.bench.nonprehensile.spec import Draw, FinalState, Measure, Scene, Task

HERE = Path(__file__).resolve().parent
BOX = (0.20, 0.14, 0.03)
CENTRE = (0.55, 0.0)
PUSH = 0.10                     # m along +x
REGION = (0.03, 0.03, 0.02)     # half extents of the marked region around the goal


def layout(draw: Draw) -> Scene:
    size = [round(e * s, 9) for e, s in zip(BOX, draw.scale, strict=True)]
    x, y = CENTRE[0] + draw.offset[0], CENTRE[1] + draw.offset[1]
    return {
        "robot": "franka",
        "floor_height": -0.75,
        "gripper_start": {"position": [0.30, 0.0, 0.10], "yaw": 0.0},
        "objects": [
            {"name": "table", "kind": "surface", "label": "table", "shape": "box",
             "size": [1.0, 1.2, 0.75], "pose": {"position": [0.55, 0.0, -0.375]},
             "friction": 0.6},
            {"name": "box", "kind": "object", "label": "flat box", "shape": draw.shape,
             "size": size, "pose": {"position": [x, y, size[2] / 2],
                                    "yaw": round(0.5236 + draw.yaw, 9)},
             "mass": round(0.3 * draw.mass, 9),
             "friction": 0.5 if draw.friction is None else draw.friction,
             "rgba": list(draw.rgba or (0.85, 0.25, 0.2, 1.0))},
        ],
    }


def criterion(state: FinalState) -> Measure:
    goal = state.pos("box", start=True) + np.array([PUSH, 0.0, 0.0])
    inside = inside_box(state, "box", goal, np.array(REGION))
    off = float(np.linalg.norm(state.pos("box")[:2] - goal[:2]))
    settled = state.settled("box")
    return Measure(inside and settled, off,
                   f"centre {off * 100:.1f} cm from the goal (region +-{REGION[0] * 100:g} cm); "
                   f"{'at rest' if settled else 'still moving'}")


TASK = Task(key="P1", title="push region", text="Push the flat box 10 cm into the marked region",
            target="box", layout=layout, criterion=criterion,
            criterion_text="box centre within 3 cm of 10 cm along +x from its start, at rest",
            strategy=str(HERE / "push_region.rapid"))
