"""Scenes and rendered RGB-D frames for the reconstruction tests (each frame rendered once)."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from rapid_dsl.runtime.reconstruction.rgbd import Frame
from rapid_dsl.runtime.reconstruction.rgbd_render import render_frame
from rapid_dsl.runtime.scenes.scene import Scene, load_scene, parse_scene
from rapid_dsl.runtime.scenes.world import build_world

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"

# Boxes (one resting on another), an upright cylinder, a sphere and a lying cylinder on a table.
MIXED = """\
robot: floating_gripper
floor_height: -0.75m
objects:
  - {name: table, kind: surface, shape: box, size: [1.0m, 1.2m, 0.75m],
     pose: {position: [0.55, 0.0, -0.375]}}
  - {name: can, kind: object, shape: cylinder, size: [7cm, 12cm],
     pose: {position: [0.45, 0.2, 0.06]}, mass: 0.3kg}
  - {name: ball, kind: object, shape: sphere, size: 8cm, pose: {position: [0.65, -0.2, 0.04]},
     mass: 0.1kg}
  - {name: crate, kind: object, shape: box, size: [16cm, 12cm, 8cm],
     pose: {position: [0.6, 0.05, 0.04], yaw: 40deg}, mass: 0.5kg}
  - {name: lid, kind: fixture, shape: box, size: [10cm, 8cm, 2cm],
     pose: {position: [0.6, 0.05, 0.09], yaw: 40deg}}
  - {name: log, kind: object, shape: cylinder, size: [5cm, 20cm],
     pose: {position: [0.4, -0.15, 0.025], roll: 90deg}, mass: 0.2kg}
"""

# A box on the table and a bin on the floor beside it (the table hides part of the bin).
FLOOR = """\
robot: floating_gripper
floor_height: -0.75m
objects:
  - {name: table, kind: surface, shape: box, size: [1.0m, 1.2m, 0.75m],
     pose: {position: [0.55, 0.0, -0.375]}}
  - {name: box, kind: object, shape: box, size: [14cm, 20cm, 3cm],
     pose: {position: [0.55, 0.0, 0.015]}, mass: 0.3kg}
  - {name: bin, kind: fixture, shape: box, size: [30cm, 30cm, 40cm],
     pose: {position: [1.35, 0.3, -0.55], yaw: 20deg}}
"""
TEXTS = {"mixed": MIXED, "floor": FLOOR}


def scene(name: str) -> Scene:
    """An example scene by file stem, or one of TEXTS."""
    if name in TEXTS:
        return parse_scene(TEXTS[name], f"{name}.yaml")
    return load_scene(EXAMPLES / f"{name}.yaml")


@lru_cache(maxsize=16)
def frame(name: str, camera: str = "workspace") -> Frame:
    """The scene rendered at 640 x 480 from a named camera (read-only: shared between tests)."""
    return render_frame(build_world(scene(name)), camera)
