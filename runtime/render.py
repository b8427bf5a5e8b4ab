"""Offscreen rendering of state sequences: an MP4 video or key-frame PNGs.

MuJoCo picks its GL back end when it is first imported, so on a headless Linux machine MUJOCO_GL
must be `egl` (or `osmesa`) before anything imports mujoco; importing `rapid_dsl.runtime` sets that
default (a script that imports mujoco itself first must set it), and `rapid_dsl.runtime.gl` checks
it. If no context can be created, RenderError says so; nothing else in the runtime needs rendering.
"""

from __future__ import annotations

import os
from collections.abc import Sequence
from pathlib import Path

import mujoco
import numpy as np

from rapid_dsl.language.files import FileProblem, output_folder, replacing
from rapid_dsl.runtime.gl import RenderError, check_display, unavailable
from rapid_dsl.runtime.scenes.world import World
from rapid_dsl.runtime.simulate import STATE_SPEC

__all__ = ["RenderError", "frame_stride", "render_frames", "render_video", "save_keyframes",
           "workspace_camera"]


def workspace_camera(world: World) -> mujoco.MjvCamera:
    """A free camera looking at the movable objects from the front left, above the table."""
    camera = mujoco.MjvCamera()
    movable = [obj.pose.position for obj in world.scene.objects if obj.kind == "object"]
    base = np.asarray(world.scene.robot_base)
    target = np.mean(movable, axis=0) if movable else base + [0.5, 0.0, 0.0]
    camera.lookat[:] = (np.asarray(target) + base) / 2 + [0.15, 0.0, 0.0]
    camera.distance = 1.6
    camera.azimuth = 120.0     # from the front right of the robot, looking across the push
    camera.elevation = -25.0
    return camera


def render_frames(world: World, states: np.ndarray, *, width: int = 640, height: int = 480,
                  camera: mujoco.MjvCamera | None = None, shadows: bool = False) -> np.ndarray:
    """(T, nstate) full physics states -> (T, height, width, 3) uint8 images.

    Shadows cost ~3x the render time with software GL, so they are off unless asked for.
    """
    states = np.atleast_2d(np.asarray(states, dtype=float))
    model = world.model
    data = mujoco.MjData(model)
    camera = camera or workspace_camera(world)
    check_display()
    try:
        renderer = mujoco.Renderer(model, height=height, width=width)
    except Exception as error:  # GL back ends fail with several exception types
        raise RenderError(unavailable(error)) from error
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = shadows
    renderer.scene.flags[mujoco.mjtRndFlag.mjRND_REFLECTION] = False
    images = np.empty((len(states), height, width, 3), dtype=np.uint8)
    try:
        for i, state in enumerate(states):
            mujoco.mj_setState(model, data, state, STATE_SPEC)
            mujoco.mj_forward(model, data)
            renderer.update_scene(data, camera)
            images[i] = renderer.render()
    finally:
        renderer.close()
    return images


def render_video(world: World, states: np.ndarray, path: str | os.PathLike[str], *,
                 fps: float = 30.0, width: int = 640, height: int = 480,
                 camera: mujoco.MjvCamera | None = None,
                 inputs: Sequence[str | os.PathLike[str]] = ()) -> Path:
    """Write one frame per state to an MP4 (H.264 through imageio's ffmpeg), atomically through
    rapid_dsl/language/files.py (never through a symlink, never over one of `inputs`)."""
    import imageio.v2 as imageio

    path = Path(path)
    images = render_frames(world, states, width=width, height=height, camera=camera)
    try:
        with replacing(path, inputs=inputs) as temporary:
            imageio.mimwrite(temporary, list(images), fps=fps, macro_block_size=1)
    except FileProblem as problem:
        raise RenderError(f"cannot write video `{path}`: {problem}") from None
    except Exception as error:  # imageio/ffmpeg errors are not one type
        raise RenderError(f"cannot write video `{path}`: {error}") from error
    return path


def save_keyframes(world: World, states: np.ndarray, directory: str | os.PathLike[str], *,
                   indices: Sequence[int] | None = None, count: int = 5, prefix: str = "frame",
                   width: int = 640, height: int = 480,
                   inputs: Sequence[str | os.PathLike[str]] = ()) -> list[Path]:
    """PNG images of chosen states (default: `count` evenly spaced, first and last included), each
    written atomically through rapid_dsl/language/files.py (never through a symlink below
    `directory`, never over one of `inputs`)."""
    import imageio.v2 as imageio

    states = np.atleast_2d(np.asarray(states, dtype=float))
    if indices is None:
        indices = np.unique(np.linspace(0, len(states) - 1, min(count, len(states))).round()
                            .astype(int)).tolist()
    images = render_frames(world, states[list(indices)], width=width, height=height)
    try:
        folder = output_folder(directory, inputs=inputs)
    except FileProblem as problem:
        raise RenderError(f"cannot write key frames to `{directory}`: {problem}") from None
    paths = []
    with folder:
        for index, image in zip(indices, images, strict=True):
            name = f"{prefix}_{index:04d}.png"
            try:
                with folder.replacing(name) as temporary:
                    imageio.imwrite(temporary, image)
            except FileProblem as problem:
                raise RenderError(f"cannot write key frame `{folder.path / name}`: "
                                  f"{problem}") from None
            paths.append(folder.path / name)
    return paths


def frame_stride(world: World, fps: float) -> int:
    """Physics steps between video frames for a given frame rate."""
    return max(1, round(1.0 / (fps * world.dt)))
