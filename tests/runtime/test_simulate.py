"""Batched rollouts: equal to a plain mj_step loop, decode contacts and grasps, flag divergence."""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest

from rapid_dsl.bench.throughput import push_controls
from rapid_dsl.runtime import builtins as B
from rapid_dsl.runtime.scenes.scene import load_scene, parse_scene
from rapid_dsl.runtime.scenes.world import build_world
from rapid_dsl.runtime.simulate import NO_SENSORS, Simulator, hold, stepping_model

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"


@pytest.fixture(scope="module")
def world():
    return build_world(load_scene(EXAMPLES / "push_box.yaml"))


@pytest.fixture(scope="module")
def sim(world):
    with Simulator(world, nthread=2) as simulator:
        yield simulator


def oracle(world, state0, ctrl, every):
    """The slow reference: one MjData, one mj_step at a time, read the sensors by hand."""
    model = world.model
    data = mujoco.MjData(model)
    mujoco.mj_setState(model, data, state0, mujoco.mjtState.mjSTATE_FULLPHYSICS)
    positions, contacts, openings = [], [], []
    nstep = len(ctrl)
    for k in range(nstep + 1):
        if k % every == 0 or k == nstep:
            mujoco.mj_forward(model, data)
            positions.append([data.site(e.name).xpos.copy() for e in world.entities.entities])
            contacts.append(_touching(model, data, "box", "hand"))
            openings.append(data.joint("finger_left").qpos[0] + data.joint("finger_right").qpos[0])
        if k < nstep:
            data.ctrl[:] = ctrl[k]
            mujoco.mj_step(model, data)
    return np.array(positions), np.array(contacts), np.array(openings)


def _touching(model, data, body: str, subtree_root: str) -> bool:
    target = model.body(body).id
    root = model.body(subtree_root).id

    def in_subtree(b: int) -> bool:
        while b > 0:
            if b == root:
                return True
            b = model.body_parentid[b]
        return False

    for c in data.contact[: data.ncon]:
        b1, b2 = model.geom_bodyid[c.geom1], model.geom_bodyid[c.geom2]
        if (b1 == target and in_subtree(b2)) or (b2 == target and in_subtree(b1)):
            return True
    return False


def test_batch_equals_a_per_sample_step_loop(world, sim):
    ctrl = push_controls(world, 6, 400, np.random.default_rng(1))
    state0 = sim.initial_state()
    frames = sim.rollout(state0, ctrl, record_every=25)
    box, gripper = world.entities.index("box"), world.entities.index("gripper")
    assert frames.time == pytest.approx(np.arange(0, 401, 25) * world.dt)
    for sample in (0, 3, 5):
        positions, contacts, openings = oracle(world, state0, ctrl[sample], 25)
        np.testing.assert_allclose(frames.pos[sample], positions, atol=1e-12)
        np.testing.assert_array_equal(frames.contact[sample, :, box, gripper], contacts)
        np.testing.assert_allclose(frames.opening[sample], openings, atol=1e-12)
    assert not sim.unstable.any()


def test_push_moves_the_box_and_the_contacts_show_it(world, sim):
    ctrl = push_controls(world, 4, 1000, np.random.default_rng(0))
    frames = sim.rollout(sim.initial_state(), ctrl, record_every=10)
    box, gripper, table = (world.entities.index(n) for n in ("box", "gripper", "table"))
    moved = frames.pos[:, -1, box, 0] - frames.pos[:, 0, box, 0]
    assert moved[0] > 0.08 and (moved > 0.01).all()   # sample 0 is the noise-free push
    assert frames.contact[:, :, gripper, box].any(axis=1).all()
    assert not frames.contact[:, 0, gripper, box].any()      # not touching at the start
    assert frames.contact[:, 0, box, table].all()            # resting on the table
    assert (frames.contact == np.swapaxes(frames.contact, 2, 3)).all()
    assert not B.holding(frames, gripper, box).any()         # a closed hand pushes, never holds
    quat_norm = np.linalg.norm(frames.quat, axis=-1)
    assert quat_norm == pytest.approx(1.0)


def _close_and_lift(shape: str, size: str, centre: float, above: float):
    """Lower the open hand to `above` its object's centre, close, lift 10 cm; (frames, world).

    The push scene's box becomes the given shape and size, standing on the table with its centre
    `centre` above the top, unturned; knots every 0.5-1 s, linearly interpolated.
    """
    text = (EXAMPLES / "push_box.yaml").read_text().replace(
        "shape: box\n    size: [20cm, 14cm, 3cm]", f"shape: {shape}\n    size: {size}").replace(
        "1.5cm], yaw: 30deg", f"{centre * 100:g}cm]")
    world = build_world(parse_scene(text))
    with Simulator(world, nthread=1) as sim:
        at = np.array(world.scene.object("box").pose.position)
        knots = np.stack([at + [0, 0, 0.10], at + [0, 0, above], at + [0, 0, above],
                          at + [0, 0, above + 0.10]])
        t = np.linspace(0, 3.5, 1750)
        hand = np.stack([np.interp(t, [0, 1, 2, 3], knots[:, k]) for k in range(3)], axis=-1)
        grip = np.interp(t, [0, 1, 1.5, 3.5], [0, 0, 1, 1])
        ctrl = world.robot.controls(hand, np.zeros_like(t), np.zeros_like(t), grip)[None]
        return sim.rollout(sim.initial_state(), ctrl, record_every=50), world


def test_closing_on_a_cube_is_a_grasp():
    frames, world = _close_and_lift("box", "[4cm, 4cm, 4cm]", 0.02, 0.005)
    box, gripper = world.entities.index("box"), world.entities.index("gripper")
    held = B.holding(frames, gripper, box)[0]
    assert not held[:10].any() and held[-1]
    assert frames.fingers[0, -1, box].all()
    assert frames.opening[0, -1] == pytest.approx(0.04, abs=0.003)
    assert frames.pos[0, -1, box, 2] > 0.06                   # lifted with the hand


@pytest.mark.parametrize("shape, size, centre, above, lifts", [
    ("box", "[4cm, 4cm, 6cm]", 0.03, 0.0, True),        # fingers around the box
    ("box", "[4cm, 4cm, 6cm]", 0.03, 0.037, False),     # fingertips over its top edge (3 mm)
    ("sphere", "[5cm]", 0.025, 0.0, True),              # fingertips below the ball's equator
    ("sphere", "[5cm]", 0.025, 0.015, False),           # pinched above it: normals tilted
])
def test_holding_is_true_for_a_grasp_that_lifts_and_false_for_a_fingertip_pinch(
        shape, size, centre, above, lifts):
    frames, world = _close_and_lift(shape, size, centre, above)
    box, gripper = world.entities.index("box"), world.entities.index("gripper")
    closed = 19                                       # 1.9 s: closed, before the lift
    assert frames.fingers[0, closed, box].all()       # both fingers touch it either way
    assert bool(B.holding(frames, gripper, box)[0, closed]) is lifts
    risen = frames.pos[0, -1, box, 2] - frames.pos[0, 0, box, 2]
    assert bool(risen > 0.08) is lifts


def test_replay_and_trajectory_match_the_batch(world, sim):
    ctrl = push_controls(world, 3, 300, np.random.default_rng(2))
    state0 = sim.initial_state()
    frames = sim.rollout(state0, ctrl, record_every=30)
    data = mujoco.MjData(world.model)
    final, single = sim.replay(state0, ctrl[2], record_every=30, data=data)
    np.testing.assert_array_equal(single.pos[0], frames.pos[2])
    assert single.batch == 1
    assert data.time == pytest.approx(300 * world.dt)
    assert data.site("box").xpos == pytest.approx(frames.pos[2, -1, world.entities.index("box")])
    states = sim.trajectory(state0, ctrl[2], every=30)
    assert states.shape == (11, sim.nstate)
    np.testing.assert_array_equal(states[0], state0)
    np.testing.assert_array_equal(states[-1], final)


def test_record_index_keeps_the_final_state_and_per_sample_starts(world, sim):
    state0 = sim.initial_state()
    ctrl = np.repeat(world.start_ctrl[None, None], 2, axis=0).repeat(25, axis=1)
    frames = sim.rollout(np.stack([state0, state0]), ctrl, record_every=10)
    assert frames.time == pytest.approx([0.0, 0.02, 0.04, 0.05])
    assert frames.pos.shape == (2, 4, 4, 3)


def test_divergence_is_flagged_not_raised(world, sim):
    ctrl = push_controls(world, 3, 200, np.random.default_rng(3))
    ctrl[1, 100:] = np.nan          # NaN controls make MuJoCo reset that simulation
    frames = sim.rollout(sim.initial_state(), ctrl, record_every=20)
    assert sim.unstable.tolist() == [False, True, False]
    assert np.isfinite(frames.pos[[0, 2]]).all()
    assert np.isfinite(frames.pos[1, :6]).all()
    assert np.isnan(frames.pos[1, -1]).all()


def test_bad_shapes_are_value_errors(world, sim):
    state0 = sim.initial_state()
    with pytest.raises(ValueError, match="ctrl must be"):
        sim.rollout(state0, np.zeros((2, 10)), record_every=1)
    with pytest.raises(ValueError, match="state0 must be"):
        sim.rollout(state0[:-1], np.zeros((2, 10, world.model.nu)), record_every=1)
    with pytest.raises(ValueError, match="record_every"):
        sim.rollout(state0, np.zeros((2, 10, world.model.nu)), record_every=0)


def test_a_coarser_timestep_simulates_a_copy_of_the_model(world):
    ctrl = push_controls(world, 2, 100, np.random.default_rng(4))
    with Simulator(world, nthread=1, timestep=2 * world.dt) as coarse:
        frames = coarse.rollout(coarse.initial_state(), ctrl, record_every=25)
        assert coarse.dt == 2 * world.dt and world.model.opt.timestep == world.dt
        assert frames.time == pytest.approx([0.0, 0.1, 0.2, 0.3, 0.4])
        assert not coarse.unstable.any() and coarse.steps == 200
    with pytest.raises(ValueError, match="timestep must be positive"):
        Simulator(world, timestep=-1.0)


def test_rollouts_step_a_sensorless_copy_of_the_world(world):
    stepped = stepping_model(world, 0.004)
    assert stepped.opt.timestep == 0.004 and stepped.opt.disableflags & NO_SENSORS
    assert world.model.opt.timestep == world.dt and not world.model.opt.disableflags & NO_SENSORS
    assert stepping_model(world).opt.timestep == world.dt


def test_hold_repeats_each_control():
    coarse = np.arange(6.0).reshape(1, 3, 2)
    fine = hold(coarse, 4)
    assert fine.shape == (1, 12, 2)
    assert (fine[0, 4:8] == coarse[0, 1]).all()
