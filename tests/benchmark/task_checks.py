"""What the task tests share: the corners of the test draw, a scene's start state, and one run of
a task's control and strategy on its demonstration scene."""

from __future__ import annotations

import itertools
from typing import Any

from rapid_dsl.api.compilation import compile_file
from rapid_dsl.bench.nonprehensile import scenes as test_scenes
from rapid_dsl.bench.nonprehensile import tasks as registry
from rapid_dsl.bench.nonprehensile.harness import final_state
from rapid_dsl.bench.nonprehensile.job import BenchJob, Trial
from rapid_dsl.bench.nonprehensile.scenes import layout_scene
from rapid_dsl.bench.nonprehensile.spec import NOMINAL, TASKS_DIR, Draw, FinalState
from rapid_dsl.runtime.scenes.world import World, build_world


def extreme_draws(shapes: tuple[str, ...] = ("box",)) -> list[Draw]:
    """Every corner of offset, yaw and per-axis scale for each shape, with the mass and friction
    limits."""
    o, y = test_scenes.OFFSET, test_scenes.YAW
    return [Draw(offset=(dx, dy), yaw=yaw, scale=(sx, sy, sz), shape=shape,
                 mass=test_scenes.MASS[i % 2], friction=test_scenes.FRICTION[i // 2 % 2])
            for i, (shape, dx, dy, yaw, sx, sy, sz) in enumerate(itertools.product(
                shapes, (-o, o), (-o, o), (-y, y), *[test_scenes.SCALE] * 3))]


def start_state(scene: Any) -> tuple[World, FinalState]:
    """The scene's world and its start state, as the criteria read it."""
    world = build_world(scene)
    return world, final_state(world)


def run_demo(key: str, budget: dict[str, int | None], draw: Draw = NOMINAL
             ) -> tuple[dict[str, Any], dict[str, Any], dict[str, float]]:
    """(control record, strategy record, strategy timing) on the task's demonstration scene, or
    on the layout of another draw."""
    task = registry.task(key)
    strategy, _ = compile_file(str(task.strategy_path))
    control, _ = compile_file(str(TASKS_DIR / "control.rapid"))
    runner = BenchJob({key: strategy}, control, {key: registry.MODULES[key]}, budget).runner(1)
    scene = layout_scene(task, draw)
    control_record, _ = runner.run(f"{key}/000/control", Trial(key, 0, None, 1, scene, "demo.yaml"))
    record, timing = runner.run(f"{key}/000/0", Trial(key, 0, 0, 1, scene, "demo.yaml"))
    return control_record, record, timing
