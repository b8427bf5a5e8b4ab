"""The hand's roll on both robots in MuJoCo: commanded through the motion's hand targets, the hand
reaches pitched-and-rolled poses (fingers horizontal, opening axis vertical) and holds them, the
Franka without flipping at its rotation-vector wrap; a run's trace carries the roll."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest

from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_text
from rapid_dsl.runtime.executor import Executor, RunConfig
from rapid_dsl.runtime.loader import load
from rapid_dsl.runtime.motion import KeypointSet, Timing, hand_targets
from rapid_dsl.runtime.program import Keypoint
from rapid_dsl.runtime.robots.hand import tool_quat
from rapid_dsl.runtime.scenes.scene import load_scene
from rapid_dsl.runtime.scenes.world import World, build_world

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
SCENES = {"floating_gripper": EXAMPLES / "push_box.yaml",
          "franka": EXAMPLES / "push_box_franka.yaml"}
DEG = math.pi / 180


@pytest.fixture(scope="module", params=sorted(SCENES))
def world(request) -> World:
    return build_world(load_scene(SCENES[request.param]))


def drive(world: World, position: tuple[float, ...], yaw: float, pitch: float,
          roll: float) -> tuple[mujoco.MjData, list[float]]:
    """Move the hand from its start to the pose over 2 s as a one-keypoint motion, then hold 1 s;
    returns the data and the orientation error [deg] at every control tick of the hold."""
    data = world.make_data()
    plan = KeypointSet.from_keypoints((Keypoint("k", np.array(position), yaw, pitch, None,
                                                roll),))
    timing = Timing(dt=world.dt)
    pos, yaws, pitches, rolls, grip = hand_targets(plan, np.zeros((1, 6)),
                                                   world.robot.hand_pose(data), 0.0,
                                                   duration=2.0, timing=timing)
    ctrl = world.robot.controls(pos, yaws, pitches, grip, rolls)[0]
    held: list[float] = []
    for k, c in enumerate(ctrl):
        data.ctrl[:] = c
        mujoco.mj_step(world.model, data, nstep=timing.control_steps)
        if k * timing.control_dt >= 2.5:
            held.append(turn_from(data, world, yaw, pitch, roll))
    for _ in range(25):
        mujoco.mj_step(world.model, data, nstep=timing.control_steps)
        held.append(turn_from(data, world, yaw, pitch, roll))
    return data, held


def turn_from(data: mujoco.MjData, world: World, yaw: float, pitch: float, roll: float) -> float:
    """Angle [deg] from the tool frame to the pose, or to it turned by pi about the approach axis
    (the parallel hand looks the same)."""
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, data.site_xmat[world.robot._tcp])
    dot = max(abs(float(quat @ tool_quat(np.array(yaw), np.array(pitch), np.array(roll + turn))))
              for turn in (0.0, math.pi))
    return math.degrees(2 * math.acos(min(1.0, dot)))


@pytest.mark.parametrize("roll", [90 * DEG, -90 * DEG])
@pytest.mark.parametrize(("position", "yaw"), [((0.45, 0.15, 0.15), 90 * DEG),
                                               ((0.45, -0.15, 0.15), -90 * DEG)])
def test_pitch_and_roll_90_put_the_fingers_horizontal_and_their_opening_vertical(
        world, position, yaw, roll):
    # yaw 90 + pitch 90 + roll 90 (and -90, -90) is a rotation by exactly pi from the home frame:
    # the Franka's rotation-vector target wraps there, and before such rolls were taken the
    # other half turn round (motion._carry_rolls) the hand ended 8-9 cm and 30 deg off
    data, held = drive(world, position, yaw, 90 * DEG, roll)
    tool = data.site_xmat[world.robot._tcp].reshape(3, 3)
    assert np.linalg.norm(data.site_xpos[world.robot._tcp] - position) < 0.005
    assert max(held) < 3.0                                   # reached, and held without a flip
    assert abs(tool[2, 2]) < math.sin(3 * DEG)               # fingers (-z) horizontal
    assert abs(tool[2, 1]) > math.cos(3 * DEG)               # opening axis (y) vertical
    heading = -tool[:, 2]
    assert heading @ [math.cos(yaw), math.sin(yaw), 0.0] > math.cos(3 * DEG)
    pose = world.robot.hand_pose(data)
    assert pose.pitch == pytest.approx(90 * DEG, abs=3 * DEG)
    assert abs(pose.roll) == pytest.approx(90 * DEG, abs=3 * DEG)   # roll or roll + pi


def test_the_franka_reaches_a_large_combined_rotation():
    world = build_world(load_scene(SCENES["franka"]))
    position = (0.45, 0.10, 0.20)
    data, held = drive(world, position, 90 * DEG, 60 * DEG, -45 * DEG)
    assert np.linalg.norm(data.site_xpos[world.robot._tcp] - position) < 0.005
    assert max(held) < 3.0
    pose = world.robot.hand_pose(data)
    assert (pose.yaw, pose.pitch, pose.roll) == pytest.approx(
        (90 * DEG, 60 * DEG, -45 * DEG), abs=3 * DEG)


def test_the_floating_gripper_has_a_roll_servo():
    world = build_world(load_scene(SCENES["floating_gripper"]))
    assert world.robot.nu == world.model.nu == 7
    ctrl = world.robot.controls(np.zeros((4, 3)), np.zeros(4), np.zeros(4), np.zeros(4),
                                np.full(4, 0.7))
    assert ctrl.shape == (4, 7) and np.all(ctrl[:, 5] == 0.7)
    # `hold` keeps a rolled hand rolled
    data, _ = drive(world, (0.5, 0.0, 0.2), 0.0, 50 * DEG, 30 * DEG)
    pose = world.robot.hand_pose(data)
    data.ctrl[:] = world.robot.hold(pose)
    mujoco.mj_step(world.model, data, nstep=250)
    assert world.robot.hand_pose(data).roll == pytest.approx(30 * DEG, abs=0.5 * DEG)


def test_the_floating_gripper_is_as_stiff_about_the_vertical_as_before_it_had_a_roll_hinge():
    # unpitched, the yaw and roll hinges turn the hand about the same axis, in series: at the
    # pitch hinge's 40 N m/rad each, 2 N m turned the hand 5.7 deg, twice the 2.9 deg of one hinge
    world = build_world(load_scene(SCENES["floating_gripper"]))
    data = world.make_data()
    data.ctrl[:] = world.robot.hold(world.robot.hand_pose(data))
    mujoco.mj_step(world.model, data, nstep=500)
    before = world.robot.hand_pose(data).yaw
    data.xfrc_applied[world.model.body("hand").id, 3:] = [0.0, 0.0, 2.0]
    mujoco.mj_step(world.model, data, nstep=500)
    assert math.degrees(world.robot.hand_pose(data).yaw - before) == pytest.approx(2.86, abs=0.2)


PINCH = """\
primitive pinch {
  goal "Hold the hand above the box, pitched and rolled"
  roles { box: Object, hand: Manipulator }
  success { distance(hand, box) > 5cm }
  cost final = abs(distance(hand, box) - 15cm) / 1cm
  motion {
    keypoint side = pos(box) + 15cm * up pitch 40deg roll 30deg
    spread 1cm
    spread_angle 5deg
    duration 1s
  }
  optimize { samples 4; elites 2; iterations 1 }
}
"""


def test_the_trace_carries_the_roll(tmp_path):
    result = check_text(PINCH, str(tmp_path / "pinch.rapid"))
    assert result.program is not None, [d.message for d in result.diagnostics]
    loaded = load(compile_program(result.program).source, "pinch")
    world = build_world(load_scene(Path(__file__).resolve().parents[1] / "data" / "run"
                                   / "tabletop.yaml"))
    run = Executor(loaded.program, world, config=RunConfig(seed=0),
                   locate=loaded.locate).run("pinch", pins={"box": "box"})
    phase = run.to_json()["phases"][0]
    [side] = phase["keypoints"]
    assert side["roll"] == pytest.approx(30 * DEG + phase["chosen_sample"][-1])
    assert side["pitch"] == pytest.approx(40 * DEG + phase["chosen_sample"][-2])
    assert len(phase["chosen_sample"]) == 3 + 2
    assert phase["end"]["hand_roll"] == pytest.approx(side["roll"], abs=2 * DEG)
    assert phase["end"]["hand_pitch"] == pytest.approx(side["pitch"], abs=2 * DEG)
