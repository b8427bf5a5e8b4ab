"""T1 (corridor), T5 (opening) and T6 (pivot and corridor): the scene families are valid at every
extreme of the draw, the demonstration files are layout(NOMINAL), their objects start ungraspable
(the criterion is false at the start, the control's grasp and lift fails), the criterion reads
the walls of the final state, and each strategy succeeds on its demonstration with small budgets."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from task_checks import extreme_draws, run_demo, start_state

from rapid_dsl.bench.nonprehensile import scenes as test_scenes
from rapid_dsl.bench.nonprehensile import tasks as registry
from rapid_dsl.bench.nonprehensile.corridors import Frame
from rapid_dsl.bench.nonprehensile.scenes import layout_scene, sample_test_scene
from rapid_dsl.bench.nonprehensile.spec import NOMINAL, Draw, FinalState
from rapid_dsl.runtime.scenes.world import build_world
from rapid_dsl.runtime.variants.check import inspect

KEYS = ["T1", "T5", "T6"]
OWN_SEEDS = (3, 5, 8)           # draws of the test distribution, far from the benchmark's seed


def _moved(state: FinalState, name: str, position: np.ndarray) -> FinalState:
    """The state with one entity's centre moved, for the criterion by hand."""
    pos = state.final.pos.copy()
    pos[0, 0, state.index(name)] = position
    return FinalState(dataclasses.replace(state.final, pos=pos), state.start)


@pytest.mark.parametrize("key", KEYS)
def test_the_demonstration_file_is_the_nominal_layout_and_builds(key):
    task = registry.task(key)
    assert test_scenes.demo_differences(task) == []
    world = build_world(layout_scene(task, NOMINAL))
    assert world.entities.entities[world.entities.index(task.target)].kind == "Object"


@pytest.mark.slow
@pytest.mark.parametrize("key", KEYS)
def test_the_layout_is_valid_at_every_extreme_of_the_draw(key):
    task = registry.task(key)
    for draw in extreme_draws(task.shapes):
        scene = layout_scene(task, draw)         # validates: sizes, reach, no bad numbers
        assert not inspect(scene).penetrating, draw
        box = next(o for o in scene.objects if o.name == task.target)
        assert box.shape == draw.shape
        assert min(box.extents[0], box.extents[1]) > 0.08, draw   # wider than the hand opens


@pytest.mark.parametrize("key", KEYS)
def test_the_criterion_is_false_at_the_start(key):
    task = registry.task(key)
    scenes = [layout_scene(task, NOMINAL)] + [sample_test_scene(task, seed, 0).scene
                                              for seed in OWN_SEEDS]
    for scene in scenes:
        measure = task.criterion(start_state(scene)[1])
        assert not measure.success, measure.text
        assert measure.value > 0 and math.isfinite(measure.value)


@pytest.mark.parametrize("key, first, second", [("T1", "wall_left", "wall_right"),
                                                ("T6", "wall_left", "wall_right"),
                                                ("T5", "wall", "rail")])
def test_the_criterion_holds_for_a_centre_between_the_walls_and_not_beyond_them(key, first,
                                                                                second):
    task = registry.task(key)
    for draw in (NOMINAL, Draw(yaw=0.5, scale=(1.2, 0.8, 1.1))):
        state = start_state(layout_scene(task, draw))[1]
        a, b = state.pos(first), state.pos(second)
        frame = Frame((float(a[0]), float(a[1])), state.yaw(first))
        size_b = state.final.entities.entities[state.index(second)].extents
        other = frame.local(b)
        # halfway between the blocks' centres, at the middle of the second block's length
        c, s = math.cos(frame.yaw), math.sin(frame.yaw)
        inside = np.array([a[0] + c * other[0] - s * other[1] / 2,
                           a[1] + s * other[0] + c * other[1] / 2, 0.02])
        beyond = inside + np.array([c, s, 0.0]) * (size_b[0] / 2 + 0.02)
        measure = task.criterion(_moved(state, task.target, inside))
        if key == "T5":     # flat at the start: inside, but not standing on its edge
            assert not measure.success and measure.value <= 0 and "tilt 0 deg" in measure.text
        else:
            assert measure.success, measure.text
        assert not task.criterion(_moved(state, task.target, beyond)).success


@pytest.mark.slow
@pytest.mark.parametrize("key", KEYS)
def test_the_control_fails_and_the_strategy_succeeds_on_the_demonstration(key):
    control, record, timing = run_demo(key, {"samples": 12, "iterations": 2})
    assert not control["success"], control
    assert record["success"], record["reason"]
    assert record["criterion"]["value"] <= 0
    assert np.isfinite(timing["seconds"])
