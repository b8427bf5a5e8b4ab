"""Rollout throughput against the machine's own limit (see shared research/perf_anchors.md).

limit = best raw single-thread `mj_step(m, d, nstep=500)` rate of the scene's model (the robot
holding its start pose, the box at rest) x cores. The measured rate is a CEM-like batch (64 samples
x 1000 steps of smooth random pushes) through `Simulator.rollout` with 2 native threads, Frames
decoding included. Both sides take the best of `repeats` runs, since on a shared machine other
processes only ever slow a run down; the median rollout rate is reported too.

Contact-rich steps (a box sliding under a push) cost more than the raw states, so the report also
gives the workload limit: the same batch stepped natively on one thread, x cores. The rollout rate
against it is the runtime's own efficiency (threads, buffers, Frames decoding).
"""

from __future__ import annotations

import os
import statistics
import time
from pathlib import Path

import mujoco
import numpy as np

from rapid_dsl.runtime.scenes.scene import load_scene
from rapid_dsl.runtime.scenes.world import World, build_world
from rapid_dsl.runtime.simulate import Simulator

SCENES = {
    "floating_gripper": "push_box.yaml",
    "franka": "push_box_franka.yaml",
}
PUSH_NOISE = 0.04   # m, std of the knot offsets (CEM starts at ~6 cm and narrows)
SETTLE_STEPS = 250  # steps the scene rests before the raw rate is timed
SCENE_DIR = Path(__file__).resolve().parents[2] / "examples" / "scenes"


def bench_rollouts(robot_name: str, *, samples: int = 64, nstep: int = 1000,
                   record_every: int = 10, repeats: int = 5, nthread: int = 2,
                   seed: int = 0) -> dict[str, float | int | str]:
    """Steps per second: raw single thread, the limit (x cores), batched rollouts with Frames."""
    if robot_name not in SCENES:
        raise ValueError(f"unknown robot `{robot_name}`; known: {', '.join(SCENES)}")
    world = build_world(load_scene(SCENE_DIR / SCENES[robot_name]))
    cores = os.cpu_count() or 2
    raw = raw_step_rate(world, repeats=repeats)
    ctrl = push_controls(world, samples, nstep, np.random.default_rng(seed))
    with Simulator(world, nthread=nthread) as sim:
        state0 = sim.initial_state()
        sim.rollout(state0, ctrl[:, :50], record_every=record_every)  # warm the buffers and threads
        times = []
        for _ in range(repeats):
            start = time.perf_counter()
            frames = sim.rollout(state0, ctrl, record_every=record_every)
            times.append(time.perf_counter() - start)
        unstable = int(sim.unstable.sum())
    # the same physics on one thread, natively: what the batch costs without any parallelism
    with Simulator(world, nthread=0) as single:
        part = ctrl[: max(1, samples // 4)]
        single.rollout(state0, part[:, :50], record_every=record_every)
        best = min(_timed(lambda: single.rollout(state0, part, record_every=record_every))
                   for _ in range(max(1, repeats // 2)))
        workload = part.shape[0] * nstep / best
    box = world.entities.index("box")
    moved = np.linalg.norm(frames.pos[:, -1, box, :2] - frames.pos[:, 0, box, :2], axis=-1)
    # best of the repeats on both sides: interference from other processes only slows a run
    rate = samples * nstep / min(times)
    limit = raw * cores
    return {
        "robot": robot_name,
        "cores": cores,
        "raw_steps_per_s": raw,
        "limit_steps_per_s": limit,
        "rollout_steps_per_s": rate,
        "ratio": rate / limit,
        "rollout_median_steps_per_s": samples * nstep / statistics.median(times),
        "workload_1thread_steps_per_s": workload,
        "ratio_to_workload_limit": rate / (workload * cores),
        "samples": samples,
        "nstep": nstep,
        "nthread": nthread,
        "unstable": unstable,
        "box_moved_mean_m": float(np.nanmean(moved)),
    }


def _timed(run) -> float:
    start = time.perf_counter()
    run()
    return time.perf_counter() - start


def raw_step_rate(world: World, *, model: mujoco.MjModel | None = None,
                  repeats: int = 5) -> float:
    """The raw single-thread rate: best `mj_step(nstep=500)` of `model` (default: the scene's
    own) from `settled_data`: the robot holding its start pose, the objects at rest."""
    model = world.model if model is None else model
    data = settled_data(world, model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(model, spec))
    mujoco.mj_getState(model, data, state, spec)
    best = 0.0
    for _ in range(repeats):
        mujoco.mj_setState(model, data, state, spec)
        began = time.perf_counter()
        mujoco.mj_step(model, data, nstep=500)
        best = max(best, 500 / (time.perf_counter() - began))
    return best


def settled_data(world: World, model: mujoco.MjModel) -> mujoco.MjData:
    """The world's start state stepped SETTLE_STEPS on `model` with the start controls held, so
    that timed steps see the scene at rest rather than its first contacts forming."""
    start = world.make_data()
    data = mujoco.MjData(model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    state = np.empty(mujoco.mj_stateSize(world.model, spec))
    mujoco.mj_getState(world.model, start, state, spec)
    mujoco.mj_setState(model, data, state, spec)
    data.ctrl[:] = start.ctrl
    mujoco.mj_step(model, data, nstep=SETTLE_STEPS)
    return data


def push_controls(world: World, samples: int, nstep: int, rng: np.random.Generator) -> np.ndarray:
    """(samples, nstep, nu) smooth random pushes: approach behind the box, push it ~10 cm along +x.

    Like a CEM population: 6 knots of hand-position offsets, linearly interpolated, sample 0 the
    noise-free mean.
    """
    box = np.array(world.scene.object("box").pose.position)
    hand0 = world.robot.hand_pose(world.make_data()).position
    knots_t = np.linspace(0.0, 1.0, 6)
    approach = box + [-0.14, 0.0, 0.0]
    mean = np.stack([hand0, approach + [0, 0, 0.05], approach, approach + [0.05, 0, 0],
                     approach + [0.15, 0, 0], approach + [0.24, 0, 0]])
    noise = rng.normal(0.0, PUSH_NOISE, size=(samples, 6, 3))
    noise[:, :2] = 0.0
    noise[:, :, 2] *= 0.1
    noise[0] = 0.0
    knots = mean + noise
    t = np.linspace(0.0, 1.0, nstep)
    upper = np.clip(np.searchsorted(knots_t, t, side="right"), 1, 5)
    w = ((t - knots_t[upper - 1]) / (knots_t[upper] - knots_t[upper - 1]))[None, :, None]
    hand = knots[:, upper - 1] * (1 - w) + knots[:, upper] * w
    zeros = np.zeros((samples, nstep))
    return world.robot.controls(hand, zeros, zeros, zeros)
