"""RGB-D frames rendered by the runtime's offscreen renderer: what they hold, that their camera
model back-projects onto the scene's true geometry, and that their files read back the same."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from rgbd_scenes import frame, scene

from rapid_dsl.commands.scene import CAMERA_HELP
from rapid_dsl.runtime.reconstruction.rgbd import (
    DEFAULT_EXTRINSICS,
    back_project,
    orbit_extrinsics,
    write_frame,
)
from rapid_dsl.runtime.reconstruction.rgbd_read import read_frame
from rapid_dsl.runtime.reconstruction.rgbd_render import CAMERAS, render_frame
from rapid_dsl.runtime.render import workspace_camera
from rapid_dsl.runtime.scenes.world import build_world


@pytest.mark.slow
def test_a_frame_holds_rgb_depth_and_a_mask_per_object_and_fixture():
    flip = frame("flip_box")
    assert flip.rgb.shape == (480, 640, 3) and flip.rgb.dtype == np.uint8
    assert flip.depth.shape == (480, 640) and flip.depth.dtype == np.float32
    assert set(flip.masks) == {"box", "wall"}          # the table is a surface: no mask
    assert {n: (i.label, i.kind) for n, i in flip.info.items()} == \
        {"box": ("flat box", "object"), "wall": ("wall", "fixture")}
    assert 1000 < flip.masks["box"].sum() < 10000
    assert np.isnan(flip.depth).any() and np.isfinite(flip.depth).mean() > 0.5  # sky: no depth
    assert not (flip.masks["box"] & flip.masks["wall"]).any()


@pytest.mark.slow
def test_back_projection_lands_on_the_true_geometry():
    """The intrinsics and extrinsics read off MuJoCo's camera put every pixel where the scene
    has a surface: the box's pixels inside the box, the table top at z = 0."""
    flip = frame("flip_box")
    box = scene("flip_box").object("box")
    points = back_project(flip, flip.masks["box"])
    low = np.subtract(box.pose.position, np.divide(box.extents, 2))
    high = np.add(box.pose.position, np.divide(box.extents, 2))
    assert (points >= low - 0.001).all() and (points <= high + 0.001).all()
    others = back_project(flip, ~(flip.masks["box"] | flip.masks["wall"]))
    table = others[(np.abs(others[:, 0] - 0.55) < 0.45) & (np.abs(others[:, 1]) < 0.55)
                   & (others[:, 2] > -0.05)]
    assert len(table) > 50_000 and np.abs(np.median(table[:, 2])) < 0.0005


@pytest.mark.slow
def test_the_default_extrinsics_are_the_runtimes_camera_on_the_standard_workspace():
    world = build_world(scene("push_box"))          # its box sits at x = 0.55, y = 0
    camera = workspace_camera(world)
    assert np.allclose(camera.lookat, [0.425, 0, 0.0075])
    pose = orbit_extrinsics(camera.lookat, camera.distance, camera.azimuth, camera.elevation)
    assert np.allclose(frame("push_box").camera_to_world, pose, atol=1e-6)
    assert np.allclose(DEFAULT_EXTRINSICS[:3, :3], pose[:3, :3])
    assert np.allclose(DEFAULT_EXTRINSICS[:3, 3], pose[:3, 3] - [0, 0, 0.0075], atol=1e-9)


@pytest.mark.slow
def test_every_named_camera_renders_and_is_in_the_help():
    world = build_world(scene("push_box"))
    for name in CAMERAS:
        assert name in CAMERA_HELP
        small = render_frame(world, name, width=64, height=48)
        assert small.rgb.shape == (48, 64, 3) and "box" in small.masks, name
        k = small.intrinsics
        assert (k.width, k.height, k.cx, k.cy) == (64, 48, 31.5, 23.5)
        assert math.isclose(k.fy, 24 / math.tan(math.radians(22.5)), rel_tol=1e-5)
    with pytest.raises(ValueError, match="unknown camera"):
        render_frame(world, "ceiling")
    with pytest.raises(ValueError, match="pixels per side"):
        render_frame(world, width=4000, height=10)


def test_written_files_read_back_as_the_same_frame(tmp_path: Path):
    flip = frame("flip_box")
    written = write_frame(flip, tmp_path / "frame")
    names = {p.relative_to(tmp_path / "frame").as_posix() for p in written}
    assert names == {"rgb.png", "depth.png", "depth.npy", "intrinsics.json", "extrinsics.json",
                     "labels.json", "masks/box.png", "masks/wall.png"}
    folder = tmp_path / "frame"
    for depth, tolerance in (("depth.npy", 0.0), ("depth.png", 0.0005)):
        back = read_frame(folder / "rgb.png", folder / depth, folder / "intrinsics.json",
                          folder / "masks", labels=folder / "labels.json",
                          extrinsics=folder / "extrinsics.json")
        assert np.array_equal(back.rgb, flip.rgb)
        assert np.array_equal(np.isnan(back.depth), np.isnan(flip.depth))
        valid = np.isfinite(flip.depth)
        assert np.abs(back.depth[valid] - flip.depth[valid]).max() <= tolerance + 1e-7
        assert back.intrinsics == flip.intrinsics
        assert np.allclose(back.camera_to_world, flip.camera_to_world, atol=1e-9)
        assert set(back.masks) == set(flip.masks)
        assert all(np.array_equal(back.masks[n], flip.masks[n]) for n in flip.masks)
        assert {n: (i.label, i.kind) for n, i in back.info.items()} == \
            {n: (i.label, i.kind) for n, i in flip.info.items()}
    assert json.loads((folder / "intrinsics.json").read_text())["width"] == 640
