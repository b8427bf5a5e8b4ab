"""Every task that draws its object as something other than a box (T1's tins, T8's plates):
the control cannot lift that shape and the strategy succeeds on it, by the task's own criterion,
at the benchmark's budgets (with 12 x 2 the octagonal plate's edge grasp can miss)."""

from __future__ import annotations

import pytest
from task_checks import run_demo

from rapid_dsl.bench.nonprehensile import tasks as registry
from rapid_dsl.bench.nonprehensile.spec import Draw

DEFAULT_BUDGET = {"samples": None, "iterations": None}   # the benchmark's own budgets
SHAPED = [(task.key, shape) for task in registry.available() for shape in task.shapes
          if shape != "box"]


def test_the_corridor_and_platform_tasks_draw_more_than_boxes():
    assert {key for key, _ in SHAPED} == {"T1", "T8"}


@pytest.mark.slow
@pytest.mark.parametrize("key, shape", SHAPED, ids=[f"{k}-{s}" for k, s in SHAPED])
def test_the_strategy_succeeds_on_a_shape_the_control_cannot_lift(key: str, shape: str):
    control, record, _ = run_demo(key, DEFAULT_BUDGET, Draw(shape=shape))
    assert not control["success"], control
    assert record["success"], record["reason"]
    assert record["criterion"]["success"], record["criterion"]
