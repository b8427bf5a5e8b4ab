"""stdlib grasp on the Franka for objects whose own axes say nothing about how to hold them: a flat
box stood on its edge is taken across its thickness (yaw from `narrow_side`, not its x/y axes),
and a box too wide across every side is rejected by the filter. Real MuJoCo, the real CLI, small
budgets. (The overhang grasp, pitched and rolled, runs in tests/benchmark/test_edge_tasks.py.)"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from rapid_dsl.cli import main
from rapid_dsl.runtime.scenes.scene import dump_scene, parse_scene

ROOT = Path(__file__).resolve().parents[2]
PICK = ROOT / "examples" / "pick_and_place.rapid"


def _scene(tmp_path: Path, size: list[float], pose: dict) -> Path:
    text = json.dumps({
        "robot": "franka", "floor_height": -0.75,
        "objects": [
            {"name": "table", "kind": "surface", "shape": "box", "size": [1.0, 1.2, 0.75],
             "pose": {"position": [0.55, 0.0, -0.375]}},
            {"name": "block", "kind": "object", "shape": "box", "size": size, "pose": pose,
             "mass": 0.2, "friction": 0.8},
        ]})
    path = tmp_path / "scene.yaml"
    dump_scene(parse_scene(text, str(path)), path)
    return path


def _run(program: Path, scene: Path, trace: Path) -> dict:
    code = main(["run", str(program), "--scene", str(scene), "--seed", "0", "--quiet",
                 "--trace", str(trace), "--samples", "12", "--iterations", "2"])
    result = json.loads(trace.read_text())
    assert code == (0 if result["succeeded"] else 1)
    return result


@pytest.mark.slow
@pytest.mark.parametrize("yaw", [20.0, -65.0])
def test_a_flat_box_stood_on_its_edge_is_grasped_across_its_thickness(tmp_path, yaw):
    # 14 x 10 x 3 cm turned 90 deg about its x axis: 10 cm tall, its 3 cm side horizontal; its
    # own x/y extents (14 x 10 cm) are both wider than the hand.
    scene = _scene(tmp_path, [0.14, 0.10, 0.03],
                   {"position": [0.5, 0.05, 0.05], "yaw": math.radians(yaw),
                    "roll": math.radians(90)})
    result = _run(PICK, scene, tmp_path / "trace.json")
    assert result["succeeded"], result["failure"]
    take = result["phases"][0]
    assert take["primitive"] == "grasp" and take["status"] == "succeeded"


def test_a_box_too_wide_across_every_side_is_rejected_by_the_filter(tmp_path):
    scene = _scene(tmp_path, [0.09, 0.10, 0.08], {"position": [0.5, 0.0, 0.04]})
    result = _run(PICK, scene, tmp_path / "trace.json")
    assert result["rejected"] and "7cm" in result["failure"]
