"""The benchmark's registry and test scenes: determinism, the draw's bounds, distractors, the
demonstration files, and the shared criteria on hand-made states."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from frames_factory import Body, make_frames, tabletop
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rapid_dsl.bench.nonprehensile import tasks as registry
from rapid_dsl.bench.nonprehensile.criteria import grasped_above, inside_box, lowest_point
from rapid_dsl.bench.nonprehensile.scenes import (
    FRICTION,
    MASS,
    OFFSET,
    SCALE,
    TEST_SEED,
    YAW,
    demo_differences,
    demo_scene,
    draw,
    sample_test_scene,
    scene_name,
    task_seed,
    test_scene,
    write_scene,
)
from rapid_dsl.bench.nonprehensile.spec import FinalState, Task
from rapid_dsl.language.files import output_folder
from rapid_dsl.runtime.scenes.scene import load_scene

OWN = Path(__file__).parent / "bench_task" / "push_region.py"
TASKS = [registry.load(str(OWN)), *registry.available()]
IDS = [t.key for t in TASKS]


def test_the_registry_names_the_eight_tasks_in_order():
    assert registry.keys() == [f"T{i}" for i in range(1, 9)]
    assert registry.NAMES[0] == "t1_corridor" and registry.NAMES[-1] == "t8_platform_edge"
    for task in registry.available():
        assert registry.MODULES[task.key].endswith(registry.NAMES[int(task.key[1:]) - 1])


def test_an_unknown_or_missing_task_is_a_clear_error(monkeypatch):
    with pytest.raises(registry.MissingTask, match="no task `T9`; the tasks are T1, T2"):
        registry.task("T9")
    monkeypatch.setitem(registry.MODULES, "T5", "rapid_dsl.bench.nonprehensile.tasks.nowhere")
    with pytest.raises(registry.MissingTask,
                       match=r"the task module rapid_dsl\.bench\.nonprehensile\.tasks\.nowhere "
                             "does not exist"):
        registry.task("T5")
    with pytest.raises(registry.MissingTask, match="does not exist"):
        registry.load("/nonexistent/t5_opening.py")


@pytest.mark.parametrize("task", TASKS, ids=IDS)
def test_the_demonstration_file_is_the_layout_of_nominal(task: Task):
    assert task.demo_path.is_file(), f"{task.key}: {task.demo_path} is missing"
    assert demo_differences(task) == []


@pytest.mark.parametrize("task", TASKS, ids=IDS)
def test_test_scenes_are_deterministic_and_differ_by_index(task: Task):
    seed = task_seed(task)
    first = test_scene(task, seed, 0)
    assert test_scene(task, seed, 0) == first
    assert test_scene(task, seed, 1) != first
    assert sample_test_scene(task, seed, 0).draw == sample_test_scene(task, seed, 0).draw


@pytest.mark.parametrize("task", TASKS, ids=IDS)
@settings(max_examples=6, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                HealthCheck.function_scoped_fixture])
@given(index=st.integers(min_value=0, max_value=10_000))
def test_every_test_scene_loads_with_its_object_in_the_drawn_bounds(task: Task, index: int,
                                                                    tmp_path: Path):
    seed = task_seed(task)
    drawn = sample_test_scene(task, seed, index)
    with output_folder(tmp_path) as folder:
        loaded = load_scene(write_scene(drawn.scene, folder, scene_name(task, index)).source
                            or "")
    distractors = [o for o in loaded.objects if o.label == "distractor"]
    assert 1 <= len(distractors) <= 3
    assert all(d.name.startswith("distractor_") for d in distractors)
    demo, obj = demo_scene(task).object(task.target), loaded.object(task.target)
    shift = np.subtract(obj.pose.position[:2], demo.pose.position[:2])
    assert np.all(np.abs(shift) <= OFFSET + 1e-6)
    assert abs(math.remainder(obj.pose.yaw - demo.pose.yaw, 2 * math.pi)) <= YAW + 1e-6
    assert obj.shape in task.shapes
    if obj.shape == "cylinder":   # round, its footprint about the box's: sqrt(x y) scaled
        diameter = math.sqrt(demo.extents[0] * demo.extents[1])
        assert obj.extents[0] == obj.extents[1]
        ratio = np.divide(obj.extents, (diameter, diameter, demo.extents[2]))
    else:
        ratio = np.divide(obj.extents, demo.extents)
    assert np.all((ratio >= SCALE[0] - 1e-6) & (ratio <= SCALE[1] + 1e-6))
    assert MASS[0] - 1e-6 <= (obj.mass or 0) / (demo.mass or 1) <= MASS[1] + 1e-6
    assert FRICTION[0] <= obj.friction <= FRICTION[1]


def test_the_draw_covers_its_ranges():
    task = TASKS[0]
    draws = [draw(task, np.random.default_rng([TEST_SEED, i])) for i in range(400)]
    offsets = np.array([d.offset for d in draws])
    assert offsets.min() < -0.8 * OFFSET and offsets.max() > 0.8 * OFFSET
    masses = np.array([d.mass for d in draws])
    assert masses.min() >= MASS[0] and masses.max() <= MASS[1]
    assert np.mean(masses < 1.0) == pytest.approx(0.5, abs=0.1)   # log-uniform about 1
    assert {d.shape for d in draws} == set(task.shapes)


def test_the_robot_can_be_replaced_and_tasks_draw_from_their_own_seeds():
    task = TASKS[0]
    drawn = sample_test_scene(task, task_seed(task), 0, robot="floating_gripper")
    assert drawn.scene.robot == "floating_gripper" and drawn.attempts >= 1
    assert sample_test_scene(task, task_seed(task), 0).scene.robot == "franka"
    assert [task_seed(t) for t in registry.available()] == \
        [TEST_SEED + int(t.key[1:]) for t in registry.available()]


# ---------------------------------------------------------------------- criteria by hand

def _state(box_z: float, *, grasped: bool) -> FinalState:
    bodies = tabletop(box=Body("box", "Object", (0.05, 0.05, 0.05), (0.5, 0.0, box_z)))
    start = make_frames(tabletop(box=Body("box", "Object", (0.05, 0.05, 0.05),
                                          (0.5, 0.0, 0.025))))
    final = make_frames(bodies, grasped=["box"] if grasped else [])
    return FinalState(final, start)


def test_a_lifted_grasped_box_passes_and_a_resting_one_fails():
    lifted = grasped_above(_state(0.025 + 0.05, grasped=True), "box", "table")
    assert lifted.success and lifted.value == pytest.approx(0.05)
    assert "both fingers touch" in lifted.text
    resting = grasped_above(_state(0.025, grasped=True), "box", "table")
    assert not resting.success and resting.value == pytest.approx(0.0, abs=1e-9)
    dropped = grasped_above(_state(0.1, grasped=False), "box", "table")
    assert not dropped.success and "fingers do not both touch" in dropped.text


def _cylinder_state(tilt: float, centre_z: float) -> FinalState:
    """A 6 cm wide, 2 cm tall cylinder turned by `tilt` about the world x axis."""
    quat = (math.cos(tilt / 2), math.sin(tilt / 2), 0.0, 0.0)
    body = Body("disc", "Object", (0.06, 0.06, 0.02), (0.5, 0.0, centre_z), quat, shape="cylinder")
    frames = make_frames(tabletop(disc=body))
    return FinalState(frames, frames)


@pytest.mark.parametrize("tilt", [0.0, 0.3, math.pi / 4, 1.2, math.pi / 2, 2.5])
def test_a_cylinders_lowest_point_is_its_rims_not_its_boxs(tilt: float):
    state = _cylinder_state(tilt, 0.2)
    # the rim's lowest point, found by walking around both rims
    angles = np.linspace(0.0, 2 * math.pi, 20_001)
    rims = [np.stack([0.03 * np.cos(angles), 0.03 * np.sin(angles), np.full_like(angles, h)])
            for h in (-0.01, 0.01)]
    rot = state.solid("disc").rotation
    lowest = min(float((rot @ rim)[2].min()) for rim in rims) + 0.2
    assert lowest_point(state, "disc") == pytest.approx(lowest, abs=1e-7)
    assert lowest_point(state, "disc") >= float(state.corners("disc")[:, 2].min()) - 1e-12


@pytest.mark.parametrize("tilt", [0.0, 0.4, math.pi / 2, 2.0])
def test_a_meshs_lowest_point_is_its_hulls(tilt: float):
    """The octagonal prism, 10 x 8 x 2 cm and tilted about x: its lowest vertex, read from the
    file with trimesh (not the runtime's hull), is the criterion's lowest point."""
    import trimesh

    from rapid_dsl.bench.nonprehensile.corridors import OCTAGONAL_PRISM

    extents = np.array([0.10, 0.08, 0.02])
    quat = (math.cos(tilt / 2), math.sin(tilt / 2), 0.0, 0.0)
    body = Body("plate", "Object", extents, (0.5, 0.0, 0.2), quat, shape="mesh")
    frames = make_frames(tabletop(plate=body))
    state = FinalState(frames, frames, {"plate": str(OCTAGONAL_PRISM)})
    mesh = trimesh.load(OCTAGONAL_PRISM)
    lo, hi = mesh.vertices.min(axis=0), mesh.vertices.max(axis=0)
    vertices = (mesh.vertices - (lo + hi) / 2) * extents / (hi - lo)
    c, s = math.cos(tilt), math.sin(tilt)
    lowest = 0.2 + float((vertices @ np.array([[1, 0, 0], [0, c, s], [0, -s, c]]))[:, 2].min())
    assert lowest_point(state, "plate") == pytest.approx(lowest, abs=1e-9)
    assert lowest_point(state, "plate") >= float(state.corners("plate")[:, 2].min()) - 1e-12


def test_inside_box_reads_the_centre_in_the_region_frame():
    state = _state(0.025, grasped=False)
    assert inside_box(state, "box", np.array([0.5, 0.0, 0.0]), np.array([0.01, 0.01, 0.03]))
    assert not inside_box(state, "box", np.array([0.52, 0.0, 0.0]), np.array([0.01, 0.01, 0.03]))
    assert inside_box(state, "box", np.array([0.52, 0.0, 0.0]), np.array([0.03, 0.001, 0.03]),
                      yaw=0.0)


def test_docs_list_every_registered_task_with_its_criterion():
    text = (Path(__file__).parents[2] / "docs" / "benchmark.md").read_text(encoding="utf-8")
    for task in registry.available():
        row = f"| {task.key} | {task.title} | {task.text} | {task.criterion_text} |"
        assert row in text, f"docs/benchmark.md: the row of {task.key} differs from the registry"


def test_the_distractor_placement_the_benchmark_shares_leaves_variants_as_they_were(
        tmp_path: Path):
    """`rapidc variants` writes the bytes it wrote before `VariantSampler.distract` was split
    out of its draw (the digest of 20 variants with 1 to 3 distractors each, made then)."""
    import hashlib

    from rapid_dsl.cli import main

    ranges = tmp_path / "ranges.yaml"
    ranges.write_text("distractors: [1, 3]\n", encoding="utf-8")
    scene = Path(__file__).parents[2] / "examples" / "scenes" / "push_box_franka.yaml"
    assert main(["variants", str(scene), "-n", "20", "--seed", "3", "--ranges", str(ranges),
                 "-o", str(tmp_path / "out"), "-q"]) == 0
    files = sorted((tmp_path / "out").glob("push_box_franka-3-*.yaml"))
    digest = hashlib.sha256(b"".join(f.read_bytes() for f in files)).hexdigest()
    assert digest == "9982368e8c64e10f1b90f3d5b47eff11c009287c7ac77d005396c0984b0ff53f"
