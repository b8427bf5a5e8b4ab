"""The rollout benchmark runs and reports consistent numbers (tiny budget; no speed assertion)."""

from __future__ import annotations

import numpy as np
import pytest

from rapid_dsl.bench.throughput import bench_rollouts, raw_step_rate, settled_data
from rapid_dsl.runtime.simulate import stepping_model


def test_bench_reports_rates_and_ratios():
    result = bench_rollouts("floating_gripper", samples=4, nstep=100, repeats=1)
    assert result["raw_steps_per_s"] > 0 and result["rollout_steps_per_s"] > 0
    assert result["limit_steps_per_s"] == pytest.approx(result["raw_steps_per_s"] * result["cores"])
    assert result["ratio"] == pytest.approx(result["rollout_steps_per_s"]
                                            / result["limit_steps_per_s"])
    assert result["unstable"] == 0


def test_bench_rejects_unknown_robots():
    with pytest.raises(ValueError, match="unknown robot"):
        bench_rollouts("ur5")


def test_raw_rate_times_the_scene_at_rest_on_any_copy_of_its_model():
    from rapid_dsl.bench.examples import SCENES
    from rapid_dsl.runtime.scenes.scene import load_scene
    from rapid_dsl.runtime.scenes.world import build_world

    world = build_world(load_scene(SCENES / "push_box.yaml"))
    box = world.model.body("box").id
    for model in (world.model, stepping_model(world, 0.004)):
        data = settled_data(world, model)
        # the box rests where the scene put it and the hand holds its start pose
        assert np.linalg.norm(data.cvel[box]) < 1e-3
        assert data.xpos[box] == pytest.approx(world.make_data().xpos[box], abs=1e-3)
        assert world.robot.hand_pose(data).position == pytest.approx(
            world.robot.hand_pose(world.make_data()).position, abs=1e-3)
        assert raw_step_rate(world, model=model, repeats=1) > 0
