"""The benchmark harness on real runs: the criterion reads the executed motion's real final state
(MuJoCo's finger contacts), a filter's rejection is a failed trial with its reason, and seeds
are pure functions of the scene and the trial."""

from __future__ import annotations

from pathlib import Path

import pytest

from rapid_dsl.api.compilation import compile_file
from rapid_dsl.bench.nonprehensile import tasks as registry
from rapid_dsl.bench.nonprehensile.job import BenchJob, Trial, run_key, run_seed
from rapid_dsl.bench.nonprehensile.scenes import TEST_SEED, layout_scene
from rapid_dsl.bench.nonprehensile.spec import NOMINAL, TASKS_DIR, Draw

OWN = Path(__file__).parent / "bench_task" / "push_region.py"


@pytest.fixture(scope="module")
def runner():
    task = registry.load(str(OWN))
    strategy, _ = compile_file(str(task.strategy_path))
    control, _ = compile_file(str(TASKS_DIR / "control.rapid"))
    job = BenchJob({"P1": strategy}, control, {"P1": str(OWN)}, {"samples": 8, "iterations": 2})
    return job.runner(1)


def _trial(scene, trial: int | None) -> Trial:
    return Trial("P1", 0, trial, run_seed(TEST_SEED, 0, trial), scene, "scene.yaml")


@pytest.mark.slow
def test_the_control_lifting_a_graspable_box_passes_on_real_finger_contacts(runner):
    # a 6 x 4 cm box is graspable: the control's grasp and lift hold it above the table
    small = Draw(scale=(0.3, 0.3, 1.5))
    scene = layout_scene(runner.tasks["P1"], small, robot="floating_gripper")
    record, timing = runner.run("P1/000/control", _trial(scene, None))
    assert record["binding"]["target"] == "box" and record["outcome"] == "succeeded"
    assert record["criterion"]["success"] and record["success"], record["reason"]
    assert record["criterion"]["value"] >= 0.03 and "both fingers touch" in \
        record["criterion"]["text"]
    assert record["final_poses"]["box"]["position"][2] > 0.05
    assert timing["seconds"] > 0


def test_a_run_rejected_by_a_filter_is_a_failed_trial_with_its_reason(tmp_path: Path):
    program = tmp_path / "tiny_only.rapid"
    program.write_text("""use stdlib.push

strategy tiny_only {
  goal "Push the box, if it is tiny"
  roles { box: Object, table: Surface, hand: Manipulator }
  filter { extents(box).x < 1cm }
  phase shove: push(target=box, support=table, hand=hand) { displacement = [10cm, 0cm, 0cm] }
}
""", encoding="utf-8")
    strategy, _ = compile_file(str(program))
    control, _ = compile_file(str(TASKS_DIR / "control.rapid"))
    runner = BenchJob({"P1": strategy}, control, {"P1": str(OWN)}, {"samples": 4}).runner(1)
    scene = layout_scene(runner.tasks["P1"], NOMINAL)
    record, _ = runner.run("P1/000/0", _trial(scene, 0))
    assert record["outcome"] == "rejected" and record["success"] is False
    assert record["reason"].startswith("rejected by a filter:") and "1cm" in record["reason"]
    assert record["criterion"]["success"] is False   # measured all the same, on the start state
    assert record["phases"] == []   # nothing ran


@pytest.mark.slow
def test_a_failed_phase_is_a_failed_trial_whatever_the_criterion(runner):
    scene = layout_scene(runner.tasks["P1"], NOMINAL)   # 14 x 20 cm: no grasp holds it
    record, _ = runner.run("P1/000/control", _trial(scene, None))
    assert record["success"] is False and record["reason"]
    assert record["criterion"] is not None and record["criterion"]["success"] is False


def test_seeds_and_keys_are_pure_functions_of_scene_and_trial():
    assert run_seed(TEST_SEED, 3, 1) == run_seed(TEST_SEED, 3, 1)
    seeds = {run_seed(TEST_SEED, s, t) for s in range(5) for t in (0, 1, 2, None)}
    assert len(seeds) == 20 and all(0 <= s < 2**32 for s in seeds)
    assert run_key("T1", 3, 0) == "T1/003/0" and run_key("T1", 3, None) == "T1/003/control"
