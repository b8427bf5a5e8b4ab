"""Offscreen rendering: key frames and a short video from a real trajectory."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from rapid_dsl.runtime.render import RenderError, render_frames, render_video, save_keyframes
from rapid_dsl.runtime.scenes.scene import load_scene
from rapid_dsl.runtime.scenes.world import build_world
from rapid_dsl.runtime.simulate import Simulator

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"


@pytest.fixture(scope="module")
def run():
    world = build_world(load_scene(EXAMPLES / "push_box.yaml"))
    with Simulator(world, nthread=1) as sim:
        target = np.array(world.scene.object("box").pose.position) + [0.0, 0.0, 0.08]
        ctrl = world.robot.controls(np.repeat(target[None], 200, axis=0), np.zeros(200),
                                    np.zeros(200), np.zeros(200))
        states = sim.trajectory(sim.initial_state(), ctrl, every=50)
    return world, states


def test_frames_show_the_scene_and_change_as_the_hand_moves(run):
    world, states = run
    try:
        images = render_frames(world, states[[0, -1]], width=96, height=72)
    except RenderError as error:
        pytest.skip(f"no offscreen GL here: {error}")
    assert images.shape == (2, 72, 96, 3) and images.dtype == np.uint8
    assert images.std() > 10                      # not a blank image
    assert np.abs(images[0].astype(int) - images[1]).sum() > 0   # the hand moved


@pytest.mark.slow
def test_keyframes_and_video_are_written(run, tmp_path: Path):
    world, states = run
    try:
        paths = save_keyframes(world, states, tmp_path / "keys", count=2, width=64, height=48)
        video = render_video(world, states, tmp_path / "run.mp4", fps=10, width=64, height=48)
    except RenderError as error:
        pytest.skip(f"no offscreen GL here: {error}")
    assert [p.name for p in paths] == ["frame_0000.png", "frame_0004.png"]
    assert all(p.stat().st_size > 0 for p in paths)
    assert video.stat().st_size > 0
