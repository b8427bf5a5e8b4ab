"""RGB-D frames: what `rapidc scene from-rgbd` reads and `rapidc scene render` writes.

A frame is one camera image with its depth, the camera's intrinsics and pose, and one binary mask
per object (docs/reconstruction.md gives the formats):
- RGB: a PNG or JPEG, 8 bits per channel;
- depth: a 16-bit single-channel PNG in millimetres (0 = no measurement), or a 2-D float .npy in
  metres (NaN, inf and values <= 0 = no measurement); the z coordinate in the camera frame, not
  the distance along the ray, as RGB-D cameras and MuJoCo give it;
- intrinsics: JSON `{"fx", "fy", "cx", "cy", "width", "height"}`, pinhole, pixels, with pixel
  centres at integer coordinates (OpenCV's convention);
- extrinsics: JSON `{"camera_to_world": 4x4 rows}`, camera axes as OpenCV's (x right, y down,
  z forward); default `DEFAULT_EXTRINSICS`, the runtime's own workspace camera;
- masks: a folder of PNGs, one per object, named `<object name>.png`, non-zero = the object;
- labels: optional JSON `{"<name>": "label"}` or `{"<name>": {"label", "kind", "mass",
  "friction"}}`, checked by the scene schema.

runtime/reconstruction/rgbd_read.py reads and checks these files (`read_frame`); this module holds
the frame, back-projection and `write_frame`.
"""

from __future__ import annotations

import io
import json
import math
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from rapid_dsl.language.files import FileProblem, OutputFolder, output_folder
from rapid_dsl.language.safe_yaml import excerpt

INTRINSIC_FIELDS = ("fx", "fy", "cx", "cy", "width", "height")
MM = 0.001                         # depth PNG unit [m]


class RgbdError(ValueError):
    """A frame input is missing, unreadable or inconsistent; str() is the located message."""


def problem(where: str | os.PathLike[str], message: str, *, line: int | None = None,
            column: int | None = None) -> RgbdError:
    """An RgbdError `file[:line:column]: error: message` (the file name made printable)."""
    place = excerpt(os.fspath(where), 200)
    if line is not None:
        place += f":{line}:{column or 1}"
    return RgbdError(f"{place}: error: {message}")


# --- the frame -------------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class Intrinsics:
    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int

    def as_json(self) -> dict[str, float | int]:
        return {name: getattr(self, name) for name in INTRINSIC_FIELDS}


@dataclass(frozen=True, slots=True)
class ObjectInfo:
    """What labels.json says about one object (None: not given)."""

    label: str | None = None
    kind: str | None = None
    mass: float | None = None
    friction: float | None = None


@dataclass(frozen=True)
class Frame:
    rgb: np.ndarray                    # (H, W, 3) uint8
    depth: np.ndarray                  # (H, W) float32 [m], NaN where nothing was measured
    intrinsics: Intrinsics
    camera_to_world: np.ndarray        # (4, 4), OpenCV camera axes
    masks: dict[str, np.ndarray]       # object name -> (H, W) bool, sorted by name
    info: dict[str, ObjectInfo] = field(default_factory=dict)   # from labels.json
    files: dict[str, str] = field(default_factory=dict)   # what each part was read from
    # (`rgb`, `depth`, `intrinsics`, `extrinsics`, `labels`, and `mask:<name>` per mask)

    @property
    def shape(self) -> tuple[int, int]:
        return self.depth.shape  # type: ignore[return-value]

    def strided(self, step: int) -> Frame:
        """Every `step`-th pixel in each direction: the same camera at a lower resolution (pixel
        u of the new image is pixel step * u of this one, so fx, fy, cx, cy divide by step)."""
        if step == 1:
            return self
        k = self.intrinsics
        depth = self.depth[::step, ::step]
        small = Intrinsics(k.fx / step, k.fy / step, k.cx / step, k.cy / step,
                           depth.shape[1], depth.shape[0])
        return replace(self, rgb=self.rgb[::step, ::step], depth=depth, intrinsics=small,
                       masks={n: m[::step, ::step] for n, m in self.masks.items()})

    def mask_file(self, name: str) -> str:
        """Where an object's mask came from, for messages."""
        return self.files.get(f"mask:{name}", f"mask `{name}`")


def orbit_extrinsics(lookat: Sequence[float], distance: float, azimuth: float,
                     elevation: float) -> np.ndarray:
    """Camera-to-world (OpenCV axes) of a camera orbiting `lookat` as MuJoCo's free camera does
    (angles in degrees: azimuth about world z from +x, elevation below the horizon < 0)."""
    az, el = math.radians(azimuth), math.radians(elevation)
    forward = np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    up = np.array([-math.sin(el) * math.cos(az), -math.sin(el) * math.sin(az), math.cos(el)])
    return camera_pose(np.asarray(lookat, dtype=float) - distance * forward, forward, up)


def camera_pose(position: np.ndarray, forward: np.ndarray, up: np.ndarray) -> np.ndarray:
    """Camera-to-world (OpenCV axes: x right, y down, z forward) from a position and the view's
    forward and up directions (OpenGL's camera description)."""
    forward = np.asarray(forward, dtype=float) / np.linalg.norm(forward)
    right = np.cross(forward, np.asarray(up, dtype=float))
    right /= np.linalg.norm(right)
    pose = np.eye(4)
    pose[:3, :3] = np.stack([right, np.cross(forward, right), forward], axis=1)
    pose[:3, 3] = np.asarray(position, dtype=float)
    return pose


# The runtime's own camera (render.workspace_camera) for the standard workspace: the robot base
# at the origin and the objects around x = 0.55 m, y = 0 on the table top z = 0.
DEFAULT_EXTRINSICS = orbit_extrinsics((0.425, 0.0, 0.0), 1.6, 120.0, -25.0)


def back_project(frame: Frame, mask: np.ndarray | None = None) -> np.ndarray:
    """(N, 3) world points of the pixels of `mask` (default: all) that have a depth."""
    valid = np.isfinite(frame.depth)
    if mask is not None:
        valid &= mask
    v, u = np.nonzero(valid)
    z = frame.depth[v, u].astype(float)
    k = frame.intrinsics
    camera = np.stack([(u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z], axis=1)
    rotation, origin = frame.camera_to_world[:3, :3], frame.camera_to_world[:3, 3]
    return camera @ rotation.T + origin


# --- writing ---------------------------------------------------------------------------------

def encode_png(array: np.ndarray) -> bytes:
    """PNG bytes of a uint8 (H, W[, 3]) or uint16 (H, W) image."""
    from PIL import Image

    stream = io.BytesIO()
    Image.fromarray(array).save(stream, format="PNG")
    return stream.getvalue()


def depth_png(depth: np.ndarray) -> np.ndarray:
    """Metres -> uint16 millimetres, 0 where nothing was measured or beyond 65.535 m."""
    mm = np.where(np.isfinite(depth), np.rint(np.nan_to_num(depth) / MM), 0)
    return np.where((mm > 0) & (mm <= 65535), mm, 0).astype(np.uint16)


def write_frame(frame: Frame, folder: str | os.PathLike[str], *,
                inputs: Iterable[str | os.PathLike[str]] = ()) -> list[Path]:
    """Write a frame as the files `read_frame` reads: rgb.png, depth.png (mm), depth.npy (m),
    intrinsics.json, extrinsics.json, labels.json and masks/<name>.png, each atomically through
    rapid_dsl/language/files.py (never through a symlink below `folder`, never over one of
    `inputs`). Raises RgbdError naming the file."""
    stream = io.BytesIO()
    np.save(stream, frame.depth.astype(np.float32), allow_pickle=False)
    labels = {name: {key: value for key, value in (("label", info.label), ("kind", info.kind),
                                                     ("mass", info.mass),
                                                     ("friction", info.friction))
                     if value is not None}
              for name, info in frame.info.items()}
    rows = [json.dumps([round(float(x), 12) + 0.0 for x in row])
            for row in frame.camera_to_world]
    pose = '{"camera_to_world": [\n  ' + ",\n  ".join(rows) + "\n]}\n"
    files: list[tuple[str, bytes | str]] = [
        ("rgb.png", encode_png(frame.rgb)),
        ("depth.png", encode_png(depth_png(frame.depth))),
        ("depth.npy", stream.getvalue()),
        ("intrinsics.json", json.dumps(frame.intrinsics.as_json(), indent=2) + "\n"),
        ("extrinsics.json", pose),
        ("labels.json", json.dumps(labels, indent=2) + "\n"),
    ]
    files += [(f"masks/{name}.png", encode_png(mask.astype(np.uint8) * 255))
              for name, mask in frame.masks.items()]
    with open_output(folder, inputs) as out:
        for name, data in files:
            write_output(out, name, data)
    return [Path(folder) / name for name, _ in files]


def open_output(folder: str | os.PathLike[str],
                inputs: Iterable[str | os.PathLike[str]]) -> OutputFolder:
    """The output folder, made if missing; RgbdError saying why not."""
    try:
        return output_folder(folder, inputs=inputs)
    except FileProblem as error:
        raise problem(error.path or folder, error.reason) from None


def write_output(out: OutputFolder, name: str, data: bytes | str) -> Path:
    """Write the file `name` below `out`; RgbdError naming it and saying why not."""
    try:
        return out.write(name, data)
    except FileProblem as error:   # the file itself, or a folder on the way to it
        if error.path is not None:
            raise problem(error.path, error.reason) from None
        raise problem(out.path / name, f"cannot write: {error.reason}") from None
