"""T7 (topple and grasp) and T8 (platform edge): the scene families are valid at every extreme of
the draw, their objects start ungraspable (the criterion is false at the start, the control's
grasp and lift fails), and the strategy succeeds on the demonstration with small budgets."""

from __future__ import annotations

import math

import numpy as np
import pytest
from task_checks import extreme_draws, run_demo, start_state

from rapid_dsl.bench.nonprehensile import tasks as registry
from rapid_dsl.bench.nonprehensile.scenes import layout_scene, sample_test_scene
from rapid_dsl.bench.nonprehensile.spec import NOMINAL
from rapid_dsl.runtime.scenes.world import build_world
from rapid_dsl.runtime.variants.check import inspect

KEYS = ["T7", "T8"]
OWN_SEEDS = (3, 5, 8)           # draws of the test distribution, far from the benchmark's seed


@pytest.mark.parametrize("key", KEYS)
def test_the_demonstration_loads_and_builds(key):
    task = registry.task(key)
    world = build_world(layout_scene(task, NOMINAL))
    assert world.entities.entities[world.entities.index(task.target)].kind == "Object"


@pytest.mark.slow
@pytest.mark.parametrize("key", KEYS)
def test_the_layout_is_valid_at_every_extreme_of_the_draw(key):
    task = registry.task(key)
    for draw in extreme_draws(task.shapes):
        scene = layout_scene(task, draw)         # validates: sizes, reach, no bad numbers
        assert not inspect(scene).penetrating, draw
        target = next(o for o in scene.objects if o.name == task.target)
        assert target.shape == draw.shape
        if key == "T8":     # flat on the platform: wider than the hand opens (T7: in a rack)
            assert min(target.extents[0], target.extents[1]) > 0.08, draw


@pytest.mark.parametrize("key", KEYS)
def test_the_criterion_is_false_at_the_start(key):
    task = registry.task(key)
    scenes = [layout_scene(task, NOMINAL)] + [sample_test_scene(task, seed, 0).scene
                                              for seed in OWN_SEEDS]
    for scene in scenes:
        _, state = start_state(scene)
        measure = task.criterion(state)
        assert not measure.success, measure.text
        assert math.isfinite(measure.value)


@pytest.mark.slow
@pytest.mark.parametrize("key", KEYS)
def test_the_control_fails_and_the_strategy_succeeds_on_the_demonstration(key):
    control, record, timing = run_demo(key, {"samples": 12, "iterations": 2})
    assert not control["success"], control
    assert record["success"], record["reason"]
    assert record["criterion"]["value"] >= 0.03
    assert np.isfinite(timing["seconds"])
