"""Render a scene to an RGB-D frame with MuJoCo's offscreen renderer: RGB, depth in metres, one
segmentation mask per object and fixture, and the camera's intrinsics and extrinsics.

This is how test frames with known truth are made for `rapidc scene from-rgbd` (`rapidc scene
render`). Depth is MuJoCo's linear depth (z in the camera frame); pixels showing nothing (beyond
the far plane) have none. Surfaces get no mask: reconstruction finds the support as a plane.
Needs a GL back end (runtime/gl.py): call `gl.start_rendering()` before anything imports mujoco.
"""

from __future__ import annotations

from collections.abc import Callable

import mujoco
import numpy as np

from rapid_dsl.runtime.gl import RenderError, check_display, unavailable
from rapid_dsl.runtime.reconstruction.rgbd import Frame, Intrinsics, ObjectInfo, camera_pose
from rapid_dsl.runtime.render import workspace_camera
from rapid_dsl.runtime.scenes.world import World

MAX_RENDER_PIXELS = 1920 * 1080    # a float32 depth.npy of it stays under the 10 MiB input limit
MIN_SIDE, MAX_RENDER_SIDE = 16, 1920


def _orbit(azimuth: float, elevation: float, distance: float = 1.6
           ) -> Callable[[World], mujoco.MjvCamera]:
    """A camera at these angles around the workspace camera's target."""
    def make(world: World) -> mujoco.MjvCamera:
        camera = workspace_camera(world)
        camera.azimuth, camera.elevation, camera.distance = azimuth, elevation, distance
        return camera
    return make


# Named cameras: the runtime's own (videos, key frames) and three more around the same target.
CAMERAS: dict[str, Callable[[World], mujoco.MjvCamera]] = {
    "workspace": workspace_camera,        # front right of the robot, 25 deg down
    "opposite": _orbit(180.0, -35.0),     # across the table, facing the robot
    "side": _orbit(90.0, -35.0),          # from -y, looking along +y
    "top": _orbit(90.0, -89.0, 1.4),      # nearly straight down (exactly -90 has no up)
}


def render_frame(world: World, camera: str = "workspace", *, width: int = 640,
                 height: int = 480) -> Frame:
    """The world in its start state seen from a named camera (CAMERAS), as a Frame whose masks
    are the pixels of each object and fixture (those with none in view are left out) and whose
    labels give each its label and kind. Raises RenderError if no GL context can be made."""
    if camera not in CAMERAS:
        raise ValueError(f"unknown camera `{camera}` (cameras: {', '.join(CAMERAS)})")
    if not (MIN_SIDE <= width <= MAX_RENDER_SIDE and MIN_SIDE <= height <= MAX_RENDER_SIDE) \
            or width * height > MAX_RENDER_PIXELS:
        raise ValueError(f"a frame is {MIN_SIDE} to {MAX_RENDER_SIDE} pixels per side and at "
                         f"most {MAX_RENDER_PIXELS:,} pixels ({width}x{height} asked)")
    model, data = world.model, world.make_data()
    model.vis.global_.offwidth = max(model.vis.global_.offwidth, width)
    model.vis.global_.offheight = max(model.vis.global_.offheight, height)
    view = CAMERAS[camera](world)
    check_display()
    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as error:  # GL back ends fail with several exception types
        raise RenderError(unavailable(error)) from error
    try:
        renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
        renderer.update_scene(data, view)
        rgb = renderer.render().copy()
        eye = mujoco.mjv_averageCamera(renderer.scene.camera[0], renderer.scene.camera[1])
        renderer.enable_depth_rendering()
        renderer.update_scene(data, view)
        depth = renderer.render().astype(np.float32)
        renderer.disable_depth_rendering()
        renderer.enable_segmentation_rendering()
        renderer.update_scene(data, view)
        ids = renderer.render()
        # the geom id per pixel, -1 where no geom is seen
        segments = np.where(ids[:, :, 1] == mujoco.mjtObj.mjOBJ_GEOM, ids[:, :, 0], -1)
    finally:
        renderer.close()
    far = float(eye.frustum_far)
    depth[~(depth < 0.999 * far)] = np.nan       # nothing there: no measurement
    return Frame(rgb, depth, _intrinsics(eye, width, height),
                 camera_pose(np.array(eye.pos), np.array(eye.forward), np.array(eye.up)),
                 *_masks(world, segments))


def _intrinsics(eye: mujoco.MjvGLCamera, width: int, height: int) -> Intrinsics:
    """The pinhole model of an OpenGL frustum; MuJoCo widens it to the image's aspect ratio,
    so pixels are square, and its centre is the image's (pixel centres at integers)."""
    focal = height * eye.frustum_near / (eye.frustum_top - eye.frustum_bottom)
    offset = eye.frustum_center / eye.frustum_near * focal
    return Intrinsics(focal, focal, (width - 1) / 2 + offset, (height - 1) / 2, width, height)


def _masks(world: World, segments: np.ndarray
           ) -> tuple[dict[str, np.ndarray], dict[str, ObjectInfo]]:
    masks: dict[str, np.ndarray] = {}
    info: dict[str, ObjectInfo] = {}
    for obj in sorted(world.scene.objects, key=lambda o: o.name):
        if obj.kind == "surface":
            continue
        mask = segments == world.model.geom(obj.name).id
        if mask.any():
            masks[obj.name] = mask
            info[obj.name] = ObjectInfo(label=obj.label, kind=obj.kind)
    return masks, info
