"""Exec(P) and strategies on a real MuJoCo scene, with tiny CEM budgets (16 samples x 2)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rapid_dsl.compiler import compile_program
from rapid_dsl.driver import check_file
from rapid_dsl.runtime.binding import BindingError
from rapid_dsl.runtime.executor import ArgumentError, Executor, RunConfig
from rapid_dsl.runtime.loader import load
from rapid_dsl.runtime.scene import load_scene
from rapid_dsl.runtime.world import build_world

DATA = Path(__file__).resolve().parents[1] / "data" / "run"


@pytest.fixture(scope="module")
def loaded():
    result = check_file(str(DATA / "shove.rapid"))
    assert result.program is not None, [d.message for d in result.diagnostics]
    return load(compile_program(result.program).source, "shove")


@pytest.fixture(scope="module")
def world():
    return build_world(load_scene(DATA / "tabletop.yaml"))


def run(loaded, world, entry, *, config=None, events=None, **kwargs):
    executor = Executor(loaded.program, world, config=config or RunConfig(seed=0),
                        on_event=events.append if events is not None else None,
                        locate=loaded.locate)
    return executor.run(entry, **kwargs)


def test_primitive_push_moves_the_box_and_reports_everything(loaded, world):
    events = []
    result = run(loaded, world, "shove", events=events,
                 arguments={"displacement": (0.08, 0.0, 0.0)})
    assert result.succeeded, result.failure
    assert result.binding == {"object": "box", "support": "table", "hand": "gripper"}
    assert "2 bindings" in result.binding_note and "puck" in result.binding_note
    phase = result.phases[0]
    assert (phase.samples, phase.iterations, phase.rollouts) == (16, 2, 32)
    costs = phase.best_cost_per_iteration
    assert len(costs) == 2 and costs[1] <= costs[0]
    assert np.isfinite(phase.final_cost)   # the best sample replayed at the world's timestep
    assert [c.text for c in phase.success] == ["miss < 3cm", "on(object, support)"]
    miss = phase.success[0]
    assert miss.holds and miss.value < 0.03 and miss.bound == 0.03 and miss.unit == "m"
    start_x = world.scene.object("box").pose.position[0]
    assert result.final_poses["box"]["position"][0] - start_x == pytest.approx(0.08, abs=0.03)
    assert phase.arguments == {"displacement": [0.08, 0.0, 0.0]}
    assert {e.kind for e in events} >= {"binding", "phase", "iteration", "replay", "phase_done"}
    trace = json.loads(json.dumps(result.to_json()))
    assert trace["phases"][0]["succeeded"] is True
    assert trace["phases"][0]["best_cost_per_iteration"] == costs


def test_the_same_seed_gives_the_same_run(loaded, world):
    config = RunConfig(seed=3, samples=8, iterations=1)
    a = run(loaded, world, "shove", config=config, arguments={"displacement": (0.05, 0.0, 0.0)})
    b = run(loaded, world, "shove", config=config, arguments={"displacement": (0.05, 0.0, 0.0)})
    assert a.phases[0].best_cost_per_iteration == b.phases[0].best_cost_per_iteration
    assert a.final_poses == b.final_poses


def test_planning_at_twice_the_timestep_takes_half_the_steps_and_replays_at_the_worlds(
        loaded, world):
    fine, coarse = (run(loaded, world, "shove", arguments={"displacement": (0.05, 0.0, 0.0)},
                        config=RunConfig(seed=0, samples=8, iterations=2, planning_dt=dt))
                    for dt in (None, 2 * world.dt))
    assert fine.phases[0].physics_steps == 2 * coarse.phases[0].physics_steps
    # planned at the world's timestep, the replay is the best sample itself
    assert fine.phases[0].final_cost == pytest.approx(fine.phases[0].best_cost_per_iteration[-1])
    # planned coarser, the replay is a real run at the world's timestep: close, not equal
    replayed, planned = coarse.phases[0].final_cost, coarse.phases[0].best_cost_per_iteration[-1]
    assert replayed != planned and replayed == pytest.approx(planned, rel=0.5, abs=0.05)
    with pytest.raises(ValueError, match="must divide the control period"):
        Executor(loaded.program, world, config=RunConfig(planning_dt=0.003))


def test_a_false_relation_is_a_reported_failure(loaded, world):
    result = run(loaded, world, "shove", pins={"object": "puck", "support": "table"},
                 arguments={"displacement": (0.05, 0.0, 0.0)})
    assert not result.succeeded and not result.phases
    assert "on(object, support)" in result.failure


def test_an_argument_out_of_range_fails_its_phase_with_a_clear_report(loaded, world):
    result = run(loaded, world, "shove_then_reach", config=RunConfig(seed=0, samples=8,
                                                                      iterations=1))
    push, hover = result.phases
    assert push.rollouts == 8 and hover.rollouts == 0
    assert hover.status == "failed"
    assert "clearance = 69.5cm is outside its range [2cm, 10cm]" in hover.failure
    assert result.failure.startswith("phase `hover`")
    assert not result.succeeded
    assert [c.text for c in result.success] == ["on(box, table)"]


def test_bad_input_raises(loaded, world):
    with pytest.raises(BindingError, match="no entity `crate`"):
        run(loaded, world, "shove", pins={"object": "crate"},
            arguments={"displacement": (0.05, 0.0, 0.0)})
    with pytest.raises(ArgumentError, match="needs --arg for: displacement"):
        run(loaded, world, "shove")
    with pytest.raises(ArgumentError, match="no param `angle`"):
        run(loaded, world, "shove", arguments={"angle": 1.0, "displacement": (0, 0, 0)})


def test_video_states_cover_every_replayed_motion(loaded, world):
    executor = Executor(loaded.program, world, config=RunConfig(seed=0, samples=4, iterations=1))
    executor.run("shove", arguments={"displacement": (0.05, 0.0, 0.0)})
    states = executor.states(every=50)
    ctrl_steps = executor.motions[0][1].shape[0]
    assert states.shape[0] == int(np.ceil(ctrl_steps / 50)) + 1


def test_a_failed_solve_is_a_phase_failure_that_names_the_line(world):
    result = check_file(str(DATA / "infeasible.rapid"))
    assert result.program is not None, [d.message for d in result.diagnostics]
    loaded = load(compile_program(result.program).source, "infeasible")
    outcome = run(loaded, world, "impossible_push")
    phase = outcome.phases[0]
    assert phase.status == "failed" and phase.rollouts == 0
    assert "infeasible.rapid:9" in phase.failure and "solve for `d` failed" in phase.failure
    assert not outcome.succeeded and outcome.failure.startswith("phase `push`")
