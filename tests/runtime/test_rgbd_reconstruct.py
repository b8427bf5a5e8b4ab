"""Reconstruction from frames rendered by the runtime's own renderer: boxes seen from elevated
cameras come back within 1 cm and 10 %, round things become meshes, objects rest on their support
(or on each other), and the scene written loads and builds."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from rgbd_scenes import frame, scene

from rapid_dsl.runtime.reconstruction.reconstruct import TABLE_HEIGHT, ObjectFit, reconstruct
from rapid_dsl.runtime.reconstruction.rgbd import Frame, back_project
from rapid_dsl.runtime.reconstruction.scene import scene_from_frame
from rapid_dsl.runtime.scenes.scene import SceneObject, load_scene
from rapid_dsl.runtime.scenes.world import build_world

POSITION, SIZE, YAW = 0.01, 0.10, math.radians(2)


def assert_recovers(fit: ObjectFit, true: SceneObject) -> None:
    """Position within 1 cm, every extent within 10 %, yaw within 2 deg (a box turned by a
    quarter is the same box with x and y swapped)."""
    assert fit.shape == "box", (fit.name, fit.free, fit.surface)
    quarters = round((fit.yaw - true.pose.yaw) / (math.pi / 2))
    assert abs(fit.yaw - true.pose.yaw - quarters * math.pi / 2) < YAW, fit.name
    extents = np.array(true.extents)
    if quarters % 2:
        extents = extents[[1, 0, 2]]
    assert np.linalg.norm(fit.position - true.pose.position) < POSITION, fit
    assert (np.abs(fit.extents / extents - 1) < SIZE).all(), (fit.extents, extents)


@pytest.mark.parametrize(("name", "camera"), [
    ("flip_box", "workspace"), ("push_box", "side"), ("topple_box", "workspace"),
    ("press_book", "opposite"), ("grasp_block", "side"), ("pivot_bar", "workspace"),
])
@pytest.mark.slow
def test_boxes_seen_from_an_elevated_camera_are_recovered(name: str, camera: str):
    truth = scene(name)
    result = reconstruct(frame(name, camera))
    for fit in result.objects:
        assert_recovers(fit, truth.object(fit.name))
        assert fit.rests_on == "table"
    support = result.support
    assert abs(support.height) < 0.002 and math.degrees(support.tilt) < 0.5
    assert support.floor_seen and abs(support.floor_height - truth.floor_height) < 0.005
    table = truth.object("table")
    assert np.allclose(np.sort(support.rect.extents), np.sort(table.extents[:2]), rtol=0.05)
    assert result.notes == ()


@pytest.mark.slow
def test_round_things_become_meshes_and_a_box_on_a_box_rests_on_it():
    truth = scene("mixed")
    fits = {fit.name: fit for fit in reconstruct(frame("mixed")).objects}
    assert {name: fit.shape for name, fit in fits.items()} == {
        "ball": "mesh", "can": "mesh", "crate": "box", "lid": "box", "log": "mesh"}
    assert_recovers(fits["crate"], truth.object("crate"))
    assert_recovers(fits["lid"], truth.object("lid"))
    assert fits["lid"].rests_on == "crate" and fits["lid"].kind == "fixture"
    assert fits["lid"].mass is None and fits["crate"].mass is not None
    can = fits["can"]
    assert np.linalg.norm(can.position - truth.object("can").pose.position) < POSITION
    assert abs(can.extents[2] / 0.12 - 1) < SIZE
    for fit in fits.values():   # everything stands on the table or the crate
        bottom = fit.position[2] - fit.extents[2] / 2
        assert abs(bottom - (0.08 if fit.name == "lid" else 0.0)) < 0.002, fit.name
        if fit.shape == "mesh":
            assert fit.hull is not None and len(fit.hull.faces) >= 4
            assert np.allclose(fit.hull.vertices.max(axis=0) - fit.hull.vertices.min(axis=0),
                               fit.extents)


@pytest.mark.slow
def test_an_object_below_the_support_stands_on_the_floor():
    result = reconstruct(frame("floor"))
    fits = {fit.name: fit for fit in result.objects}
    assert abs(result.support.height) < 0.002       # the table, though the floor holds more
    assert_recovers(fits["box"], scene("floor").object("box"))
    assert fits["bin"].rests_on == "floor" and fits["box"].rests_on == "table"
    bin_ = fits["bin"]
    assert abs(bin_.position[2] - bin_.extents[2] / 2 + 0.75) < 0.002
    assert abs(bin_.extents[2] - 0.4) < 0.01
    assert np.allclose(np.sort(result.support.rect.extents), [1.0, 1.2], rtol=0.05)


def test_the_written_scene_loads_builds_and_keeps_its_meshes_next_to_it(tmp_path: Path):
    written = scene_from_frame(frame("mixed"), tmp_path / "out" / "mixed.yaml")
    assert written.path == tmp_path / "out" / "mixed.yaml"
    assert sorted(p.name for p in written.meshes) == ["mixed-ball.obj", "mixed-can.obj",
                                                      "mixed-log.obj"]
    loaded = load_scene(written.path)
    assert loaded == written.scene
    assert [o.name for o in loaded.objects] == ["table", "ball", "can", "crate", "lid", "log"]
    assert {o.name: o.kind for o in loaded.objects}["table"] == "surface"
    assert "mesh: mixed-can.obj" in written.path.read_text()
    world = build_world(loaded)
    assert world.entities.index("lid") == 4
    report = written.as_json()
    assert report["floor"]["seen"] and abs(report["floor"]["height"] + 0.75) < 0.005
    assert [o["shape"] for o in report["objects"]] == ["mesh", "mesh", "box", "box", "mesh"]


def noisy(base: Frame, sigma: float, outliers: float, seed: int = 1) -> Frame:
    """Gaussian depth noise, and a share of pixels thrown up to 30 cm off (flying pixels)."""
    rng = np.random.default_rng(seed)
    depth = base.depth + rng.normal(0, sigma, base.depth.shape).astype(np.float32)
    stray = rng.random(depth.shape) < outliers
    depth[stray] += rng.uniform(-0.3, 0.3, int(stray.sum())).astype(np.float32)
    return dataclasses.replace(base, depth=depth)


@pytest.mark.parametrize(("sigma", "outliers"), [(0.001, 0.0), (0.002, 0.02)])
def test_depth_noise_and_flying_pixels_are_tolerated(sigma: float, outliers: float):
    truth = scene("flip_box")
    result = reconstruct(noisy(frame("flip_box"), sigma, outliers))
    for fit in result.objects:
        assert_recovers(fit, truth.object(fit.name))
    assert 0.5 * sigma < result.support.noise < 1.5 * sigma   # measured on the table top
    crate = {f.name: f for f in reconstruct(noisy(frame("mixed"), sigma, outliers)).objects}
    assert_recovers(crate["crate"], scene("mixed").object("crate"))


def test_a_large_frame_is_reconstructed_strided(monkeypatch: pytest.MonkeyPatch):
    from rapid_dsl.runtime.reconstruction import reconstruct as module

    monkeypatch.setattr(module, "MAX_WORK_PIXELS", 100_000)   # 640 x 480 is then large
    result = reconstruct(frame("flip_box"))
    assert result.notes == ("the frame was reconstructed from one pixel in 2 in each direction "
                            "(at most 100,000 pixels)",)
    for fit in result.objects:
        assert_recovers(fit, scene("flip_box").object(fit.name))


def test_without_a_visible_floor_the_support_reaches_down_the_table_height():
    base = frame("flip_box")
    points = back_project(base)
    floor = np.zeros(base.shape, dtype=bool)
    floor[np.isfinite(base.depth)] = points[:, 2] < -0.5
    hidden = dataclasses.replace(base, depth=np.where(floor, np.nan, base.depth))
    support = reconstruct(hidden).support
    assert not support.floor_seen
    assert math.isclose(support.floor_height, support.height - TABLE_HEIGHT, abs_tol=1e-9)
    assert math.isclose(support.thickness, TABLE_HEIGHT, abs_tol=1e-9)


@pytest.mark.slow
def test_slightly_wrong_extrinsics_are_levelled_onto_the_support():
    """A camera pose off by 3 deg tilts the table top in the world; the scene is levelled so
    that it is flat again and the objects stand on it."""
    base = frame("push_box")
    angle = math.radians(3)
    tilt = np.eye(4)
    tilt[:3, :3] = [[1, 0, 0], [0, math.cos(angle), -math.sin(angle)],
                    [0, math.sin(angle), math.cos(angle)]]
    result = reconstruct(dataclasses.replace(base, camera_to_world=tilt @ base.camera_to_world))
    assert math.isclose(math.degrees(result.support.tilt), 3, abs_tol=0.2)
    (box,) = result.objects
    assert box.shape == "box"
    assert abs(box.position[2] - box.extents[2] / 2 - result.support.height) < 1e-9
    true = scene("push_box").object("box")
    assert np.allclose(np.sort(box.extents), np.sort(true.extents), rtol=SIZE)
