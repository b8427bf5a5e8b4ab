"""T2 (flip and grasp), T3 (obstacles) and T4 (reposition): the scene families are valid at every
extreme of the draw and keep their meaning there (the box too wide to grasp flat, the post in the
way, the wall covering the box), the criterion is false at the start, and on the demonstration the
control's grasp and lift fails while the strategy succeeds, with small budgets."""

from __future__ import annotations

import math

import numpy as np
import pytest
from task_checks import extreme_draws, run_demo, start_state

from rapid_dsl.bench.nonprehensile import flips
from rapid_dsl.bench.nonprehensile import tasks as registry
from rapid_dsl.bench.nonprehensile.scenes import demo_differences, layout_scene, sample_test_scene
from rapid_dsl.bench.nonprehensile.spec import NOMINAL
from rapid_dsl.runtime.robots.hand import FINGER_TRAVEL
from rapid_dsl.runtime.scenes.world import build_world
from rapid_dsl.runtime.variants.check import inspect

KEYS = ["T2", "T3", "T4"]
OWN_SEEDS = (2, 4, 7)           # draws of the test distribution, far from the benchmark's seed
BUDGET = {"samples": None, "iterations": None}   # the default budgets: the benchmark's own


def _span_y(obj) -> tuple[float, float]:
    """The world y interval of a scene object's footprint (a box turned about z)."""
    x, y, _ = obj.pose.position
    c, s = abs(math.cos(obj.pose.yaw)), abs(math.sin(obj.pose.yaw))
    half = (s * obj.extents[0] + c * obj.extents[1]) / 2
    return y - half, y + half


@pytest.mark.parametrize("key", KEYS)
def test_the_demonstration_is_the_nominal_layout_and_builds(key):
    task = registry.task(key)
    assert demo_differences(task) == []
    world = build_world(layout_scene(task, NOMINAL))
    assert world.entities.entities[world.entities.index(task.target)].kind == "Object"


@pytest.mark.parametrize("key", KEYS)
def test_the_layout_is_valid_and_keeps_its_meaning_at_every_extreme_of_the_draw(key):
    task = registry.task(key)
    for draw in extreme_draws():
        scene = layout_scene(task, draw)         # validates: sizes, reach, no bad numbers
        assert not inspect(scene).penetrating, draw
        box = scene.object(flips.TARGET)
        # flat and wider than the open hand both ways: no top grasp closes on it
        assert min(box.extents[:2]) > 2 * FINGER_TRAVEL, draw
        box_y = _span_y(box)
        if key == "T3":      # the post stands in the box's way to the wall
            post_y = _span_y(scene.object("post"))
            assert post_y[0] < box_y[1] and box_y[0] < post_y[1], draw
        if key == "T4":      # the wall covers the box, taller than the box stands when flipped
            wall = scene.object("wall")
            wall_y = _span_y(wall)
            assert wall_y[0] < box_y[0] and box_y[1] < wall_y[1], draw
            assert wall.extents[2] > box.extents[0], draw


@pytest.mark.parametrize("key", KEYS)
def test_the_criterion_is_false_at_the_start(key):
    task = registry.task(key)
    scenes = [layout_scene(task, NOMINAL)] + [sample_test_scene(task, seed, 0).scene
                                              for seed in OWN_SEEDS]
    for scene in scenes:
        measure = task.criterion(start_state(scene)[1])
        assert not measure.success, measure.text
        assert math.isfinite(measure.value)


@pytest.mark.slow
@pytest.mark.parametrize("key", KEYS)
def test_the_control_fails_and_the_strategy_succeeds_on_the_demonstration(key):
    control, record, timing = run_demo(key, BUDGET)
    assert not control["success"], control
    assert record["success"], record["reason"]
    assert record["criterion"]["value"] >= 0.03
    assert np.isfinite(timing["seconds"])
