"""World building: both robots compile, entities and sensors line up, the hand goes where told."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
from mesh_files import write_obj

from rapid_dsl.runtime.robots.hand import FINGER_TRAVEL
from rapid_dsl.runtime.scenes.scene import SceneError, load_scene, parse_scene
from rapid_dsl.runtime.scenes.world import build_world

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
SCENES = {"floating_gripper": EXAMPLES / "push_box.yaml",
          "franka": EXAMPLES / "push_box_franka.yaml"}


@pytest.fixture(scope="module", params=sorted(SCENES))
def world(request):
    return build_world(load_scene(SCENES[request.param]))


def test_entities_and_physics_options(world):
    names = [e.name for e in world.entities.entities]
    assert names == ["table", "box", "gripper", "floor"]
    kinds = [e.kind for e in world.entities.entities]
    assert kinds == ["Surface", "Object", "Manipulator", "Surface"]
    assert [e.index for e in world.entities.entities] == [0, 1, 2, 3]
    assert world.entities.extents[1] == pytest.approx([0.20, 0.14, 0.03])
    opt = world.model.opt
    assert opt.timestep == 0.002
    assert opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    assert opt.cone == mujoco.mjtCone.mjCONE_PYRAMIDAL
    assert opt.solver == mujoco.mjtSolver.mjSOL_NEWTON
    assert world.robot.nu == world.model.nu


def test_sensor_layout_covers_every_movable_pair(world):
    layout = world.sensors
    assert layout.pos.shape == (4, 3) and layout.quat.shape == (4, 4)
    pairs = {tuple(p) for p in layout.pairs.tolist()}
    # table-floor are both static, so they have no sensor; everything else does
    assert pairs == {(0, 1), (0, 2), (1, 2), (1, 3), (2, 3)}
    assert sorted(layout.grasp_entities.tolist()) == [0, 1]


def test_start_state_matches_scene(world):
    data = world.make_data()
    box = world.scene.object("box")
    assert data.site("box").xpos == pytest.approx(box.pose.position)
    hand = world.robot.hand_pose(data)
    assert hand.position == pytest.approx(world.scene.gripper_start.position, abs=1e-4)
    assert hand.yaw == pytest.approx(0.0, abs=1e-4) and hand.pitch == pytest.approx(0.0, abs=1e-4)
    assert hand.opening == pytest.approx(2 * FINGER_TRAVEL)


@pytest.mark.parametrize(("target", "yaw", "pitch"), [((0.45, 0.10, 0.15), 0.5, 0.3),
                                                      ((0.60, -0.20, 0.06), -1.2, 0.0)])
def test_hand_tracks_a_target(world, target, yaw, pitch):
    model, data = world.model, world.make_data()
    data.ctrl[:] = world.robot.controls(np.array(target), np.array(yaw), np.array(pitch),
                                        np.array(1.0))
    mujoco.mj_step(model, data, nstep=750)
    hand = world.robot.hand_pose(data)
    assert np.linalg.norm(hand.position - target) < 0.01
    assert hand.yaw == pytest.approx(yaw, abs=0.05)
    assert hand.pitch == pytest.approx(pitch, abs=0.08)
    assert hand.opening < 0.002   # grip 1 closes the empty hand


def test_controls_broadcast_over_batches(world):
    robot = world.robot
    ctrl = robot.controls(np.zeros((5, 7, 3)), np.zeros((5, 7)), np.zeros(7), np.array(0.5))
    assert ctrl.shape == (5, 7, robot.nu)
    assert np.isfinite(ctrl).all()


def test_mesh_and_round_objects_rest_on_the_table(tmp_path: Path):
    write_obj(tmp_path / "block.obj", extents=(0.05, 0.04, 0.06))
    scene_text = (EXAMPLES / "push_box.yaml").read_text() + """\
  - name: block
    kind: object
    shape: mesh
    mesh: block.obj
    pose: {position: [0.40, 0.25, 0.03], yaw: 20deg}
    mass: 0.2kg
  - name: can
    kind: object
    shape: cylinder
    size: [6cm, 10cm]
    pose: {position: [0.40, -0.25, 0.05]}
    mass: 0.2kg
"""
    world = build_world(parse_scene(scene_text, base_dir=tmp_path))
    data = world.make_data()
    mujoco.mj_step(world.model, data, nstep=250)
    assert data.site("block").xpos == pytest.approx([0.40, 0.25, 0.03], abs=2e-3)
    assert data.site("can").xpos == pytest.approx([0.40, -0.25, 0.05], abs=2e-3)
    assert world.model.body("block").mass[0] == pytest.approx(0.2)
    block = world.entities.index("block")
    assert world.entities.extents[block] == pytest.approx([0.05, 0.04, 0.06])


def test_restitution_makes_a_ball_bounce():
    def rebound(restitution: float) -> float:
        text = f"""\
robot: floating_gripper
gripper_start: {{position: [0, 0, 0.5]}}
objects:
  - name: ball
    kind: object
    shape: sphere
    size: 4cm
    pose: {{position: [0.5, 0, 0.12]}}
    mass: 0.05kg
    restitution: {restitution}
"""
        world = build_world(parse_scene(text))
        data = world.make_data()
        heights = []
        for _ in range(200):
            mujoco.mj_step(world.model, data, nstep=2)
            heights.append(data.site("ball").xpos[2])
        first_touch = int(np.argmin(heights[:100]))
        return max(heights[first_touch:]) - 0.02

    assert rebound(0.0) < 0.005
    assert rebound(0.8) > 0.02


def test_unreachable_start_is_a_clear_error():
    text = (EXAMPLES / "push_box_franka.yaml").read_text().replace(
        "gripper_start: {position: [0.30, 0.0, 0.10]", "gripper_start: {position: [1.5, 0.0, 0.10]")
    with pytest.raises(SceneError, match=r"far.yaml:\d+:\d+: error: gripper_start.position: "
                                         r"the hand start \[1.5, 0.0, 0.1\] is 1.503 m from"):
        parse_scene(text, "far.yaml")   # the scene is refused before any world is built
