"""Exec(P) and strategies on a real MuJoCo scene, with tiny CEM budgets (16 samples x 2)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_file
from rapid_dsl.runtime.binding import BindingError
from rapid_dsl.runtime.executor import ArgumentError, Executor, RunConfig
from rapid_dsl.runtime.loader import load
from rapid_dsl.runtime.scenes.scene import load_scene
from rapid_dsl.runtime.scenes.world import build_world

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
    assert result.outcome == "succeeded" and result.warnings == []
    assert result.binding == {"object": "box", "support": "table", "hand": "gripper"}
    assert "2 bindings" in result.binding_note and "puck" in result.binding_note
    phase = result.phases[0]
    assert (phase.samples, phase.iterations, phase.rollouts) == (16, 2, 32)
    costs = phase.best_cost_per_iteration
    assert len(costs) == 2 and costs[1] <= costs[0]
    # the final elites ran at the world's timestep and the best of them was executed
    assert phase.executed_elites == 4 and 0 <= phase.chosen_elite < 4
    assert np.isfinite(phase.executed_cost) and np.isfinite(phase.planned_cost)
    assert phase.planned_success is True
    assert [c.text for c in phase.success] == ["miss < 3cm", "on(object, support)"]
    miss = phase.success[0]
    assert miss.holds and miss.value < 0.03 and miss.bound == 0.03 and miss.unit == "m"
    assert [c.at_start for c in phase.success] == [False, True]
    start_x = world.scene.object("box").pose.position[0]
    assert result.final_poses["box"]["position"][0] - start_x == pytest.approx(0.08, abs=0.03)
    assert phase.arguments == {"displacement": [0.08, 0.0, 0.0]}
    assert {e.kind for e in events} >= {"binding", "phase", "iteration", "execute", "phase_done"}
    trace = json.loads(json.dumps(result.to_json()))
    assert trace["outcome"] == "succeeded" and trace["phases"][0]["succeeded"] is True
    assert trace["phases"][0]["best_cost_per_iteration"] == costs


def test_the_trace_has_the_chosen_sample_keypoints_and_the_end_state(loaded, world):
    result = run(loaded, world, "shove", arguments={"displacement": (0.08, 0.0, 0.0)})
    phase = result.to_json()["phases"][0]
    assert len(phase["chosen_sample"]) == 9                 # three keypoints, x y z each
    names = [k["name"] for k in phase["keypoints"]]
    assert names == ["above", "behind", "through"]
    through = phase["keypoints"][2]
    offset = np.subtract(through["executed"], through["planned"])
    np.testing.assert_allclose(offset, phase["chosen_sample"][6:9])
    assert phase["keypoints"][0]["grip"] == 1.0 and through["grip"] is None
    end = phase["end"]
    assert ["table", "box"] in end["contacts"]              # the box rests on the table
    assert ["box", "gripper"] in end["contacts"]            # shove ends against the box
    assert end["opening"] == pytest.approx(0.0, abs=0.005)  # closed: the push's paddle
    # both fingers of the closed paddle press on the box, and that is no grasp
    assert end["finger_contacts"] == {"box": ["left", "right"]} and end["holding"] == []
    assert end["hand_yaw"] == pytest.approx(0.0, abs=0.05) and len(end["hand_position"]) == 3


def test_the_same_seed_gives_the_same_run(loaded, world):
    config = RunConfig(seed=3, samples=8, iterations=1)
    a = run(loaded, world, "shove", config=config, arguments={"displacement": (0.05, 0.0, 0.0)})
    b = run(loaded, world, "shove", config=config, arguments={"displacement": (0.05, 0.0, 0.0)})
    assert a.phases[0].best_cost_per_iteration == b.phases[0].best_cost_per_iteration
    assert a.final_poses == b.final_poses


def test_planning_at_twice_the_timestep_takes_half_the_steps_and_executes_at_the_worlds(
        loaded, world):
    fine, coarse = (run(loaded, world, "shove", arguments={"displacement": (0.05, 0.0, 0.0)},
                        config=RunConfig(seed=0, samples=8, iterations=2, planning_dt=dt,
                                         execute_elites=1))
                    for dt in (None, 2 * world.dt))
    assert fine.phases[0].physics_steps == 2 * coarse.phases[0].physics_steps
    assert (fine.phases[0].planning_dt, coarse.phases[0].planning_dt) == (world.dt, 2 * world.dt)
    # planned at the world's timestep, the execution is the best sample itself
    assert fine.phases[0].executed_cost == fine.phases[0].best_cost_per_iteration[-1]
    assert fine.phases[0].planned_cost == fine.phases[0].executed_cost
    # planned coarser, the execution is a real run at the world's timestep: close, not equal
    executed, planned = coarse.phases[0].executed_cost, coarse.phases[0].planned_cost
    assert planned == coarse.phases[0].best_cost_per_iteration[-1]
    assert executed != planned and executed == pytest.approx(planned, rel=0.5, abs=0.05)
    with pytest.raises(ValueError, match="must divide the control period"):
        Executor(loaded.program, world, config=RunConfig(planning_dt=0.003))


def test_a_plan_that_fails_on_execution_is_a_failed_phase_with_both_costs(
        loaded, world, monkeypatch):
    """Plan and execution made to differ: the CEM plans on a world whose box slides as usual,
    the motion is executed on one whose box weighs 200 kg (the hand cannot move it)."""
    from rapid_dsl.runtime import state as state_module
    from rapid_dsl.runtime.simulate import Simulator

    heavy = build_world(world.scene.with_object("box", mass=100.0))

    def planner_on_the_light_world(_world, *, nthread=2, timestep=None):
        return Simulator(world if timestep is not None else _world, nthread=nthread,
                         timestep=timestep)
    monkeypatch.setattr(state_module, "Simulator", planner_on_the_light_world)
    result = run(loaded, heavy, "shove", arguments={"displacement": (0.06, 0.0, 0.0)},
                 config=RunConfig(seed=0, samples=16, iterations=2))
    phase = result.phases[0]
    assert phase.planned_success is True and phase.status == "failed"
    assert phase.executed_cost > 10 * phase.planned_cost
    assert "the planned motion met every success clause at the 4 ms planning timestep but not " \
           "as executed at 2 ms" in phase.failure
    assert f"planned cost {phase.planned_cost:.3g}, executed cost " \
           f"{phase.executed_cost:.3g}" in phase.failure
    assert not result.succeeded and result.failure.startswith("success clause `miss < 3cm`")


def test_a_false_relation_is_a_reported_failure(loaded, world):
    result = run(loaded, world, "shove", pins={"object": "puck", "support": "table"},
                 arguments={"displacement": (0.05, 0.0, 0.0)})
    assert not result.succeeded and not result.phases
    assert "on(object, support)" in result.failure


def test_an_argument_out_of_range_fails_its_phase_with_a_clear_report(loaded, world):
    result = run(loaded, world, "shove_then_reach", config=RunConfig(seed=0, samples=8,
                                                                      iterations=1))
    push, hover = result.phases
    assert push.rollouts == 8 and hover.rollouts == 0 and push.succeeded
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


def test_video_states_cover_every_executed_motion(loaded, world):
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
