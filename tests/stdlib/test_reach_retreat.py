"""`reach` and `retreat`: the hand through free space, holding nothing, on both robots.

Real MuJoCo through the real CLI, small CEM budgets. examples/hop_over.rapid takes the hand over
the push_box scene's 20 cm box to its far side, down beside it and up again; the same program runs
on the floating gripper and on the Franka arm.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

from rapid_dsl.cli import main
from rapid_dsl.frontend.driver import check_file
from rapid_dsl.runtime.scenes.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
SCENES = ROOT / "examples" / "scenes"
STDLIB = ROOT / "stdlib_primitives"
BUDGET = ("--seed", "0", "--quiet", "--samples", "12", "--iterations", "2")


def test_a_primitive_may_have_the_hand_as_its_only_role_and_not_name_it(tmp_path: Path):
    """reach and retreat judge only the hand; and a motion drives the Manipulator role whether
    or not an expression names it, so lint does not call it unused (W0101 did)."""
    for name in ("reach", "retreat", "release"):
        result = check_file(str(STDLIB / f"{name}.rapid"), lint=True)
        assert result.diagnostics == [] and result.program is not None
        assert [r.kind for r in result.program.primitive(name).roles] == ["Manipulator"]
    path = tmp_path / "hover.rapid"
    path.write_text("""primitive hover {
  goal "Hold the hand over the target"
  roles { target: Object, hand: Manipulator }
  success { settled(target) }
  cost final = speed(target) / (1cm / 1s)
  motion { keypoint over = pos(target) + 10cm * up }
}
""")
    assert check_file(str(path), lint=True).diagnostics == []


def _run(program: Path, scene: Path, trace: Path, *extra: str) -> dict:
    code = main(["run", str(program), "--scene", str(scene), *BUDGET, "--trace", str(trace),
                 *extra])
    result = json.loads(trace.read_text())
    assert code == (0 if result["succeeded"] else 1)
    return result


@pytest.mark.slow
@pytest.mark.parametrize("scene", ["push_box.yaml", "push_box_franka.yaml"])
def test_the_hand_goes_over_the_box_and_away_without_moving_it(scene: str, tmp_path: Path):
    start = load_scene(SCENES / scene).object("box").pose.position
    result = _run(ROOT / "examples" / "hop_over.rapid", SCENES / scene, tmp_path / "t.json")
    assert result["succeeded"], result["failure"]
    over, leave = result["phases"]
    assert (over["primitive"], leave["primitive"]) == ("reach", "retreat")
    assert result["warnings"] == []
    end = result["final_poses"]["box"]["position"]
    assert math.dist(start, end) < 0.01
    # the hand ends 10 cm above where `reach` brought it, beyond the box's far side
    goal = over["arguments"]["to"]
    hand = leave["end"]["hand_position"]
    assert math.dist(hand, [goal[0], goal[1], goal[2] + 0.10]) < 0.01


@pytest.mark.slow
def test_retreat_moves_aside_on_the_franka(tmp_path: Path):
    scene = SCENES / "push_box_franka.yaml"
    result = _run(STDLIB / "retreat.rapid", scene, tmp_path / "t.json",
                  "--arg", "rise=5cm", "--arg", "aside=[0cm, 8cm, 0cm]")
    assert result["succeeded"], result["failure"]
    start = load_scene(scene).gripper_start.position
    hand = result["phases"][0]["end"]["hand_position"]
    assert math.dist(hand, [start[0], start[1] + 0.08, start[2] + 0.05]) < 0.01


@pytest.mark.slow
def test_a_point_inside_the_box_is_not_reached_and_the_box_stays(tmp_path: Path):
    """The point is the box's centre: the hand cannot get there without shoving the box, and
    `undisturbed` is what the optimizer keeps; the run fails on `miss`, with the box in place."""
    scene = SCENES / "push_box.yaml"
    start = load_scene(scene).object("box").pose.position
    result = _run(STDLIB / "reach.rapid", scene, tmp_path / "t.json",
                  "--arg", f"to=[{start[0] * 100}cm, {start[1] * 100}cm, 1cm]")
    assert not result["succeeded"]
    assert result["failure"].startswith("success clause `miss < 1cm`")
    clauses = {c["text"]: c["holds"] for c in result["phases"][0]["success"]}
    assert clauses == {"miss < 1cm": False, "undisturbed(hand)": True}
    assert math.dist(start, result["final_poses"]["box"]["position"]) < 0.01


@pytest.mark.slow
def test_release_lets_go_of_a_block_set_down_on_the_franka(tmp_path: Path):
    """place_block (grasp, lift, move, move down, release) on the Franka; the floating gripper
    runs it in tests/stdlib/test_demos.py."""
    text = (SCENES / "grasp_block.yaml").read_text().replace("robot: floating_gripper",
                                                             "robot: franka")
    scene = tmp_path / "grasp_block_franka.yaml"
    scene.write_text(text)
    result = _run(ROOT / "examples" / "place_block.rapid", scene, tmp_path / "t.json")
    assert result["succeeded"], result["failure"]
    let_go = result["phases"][-1]
    assert let_go["primitive"] == "release" and let_go["end"]["holding"] == []
    assert let_go["end"]["opening"] > 0.07
