"""A reconstruction as a scene file: meshes written next to it, the scene written atomically and
loaded back, ready for `rapidc bind` and `rapidc run`.

`scene_from_rgbd(...)` is the whole of `rapidc scene from-rgbd` as one call (for tools such as
an MCP server): it reads the frame's files, reconstructs, writes, and returns what it wrote and
how well each object was fitted. Every bad input raises RgbdError with a located message.
"""

from __future__ import annotations

import math
import os
from collections.abc import Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from rapid_dsl.language.safe_yaml import excerpt
from rapid_dsl.runtime.reconstruction.reconstruct import (
    SUPPORT_NAME,
    ObjectFit,
    Reconstruction,
    reconstruct,
)
from rapid_dsl.runtime.reconstruction.rgbd import (
    Frame,
    ObjectInfo,
    RgbdError,
    open_output,
    write_output,
)
from rapid_dsl.runtime.reconstruction.rgbd_read import read_frame
from rapid_dsl.runtime.scenes.scene import Scene, SceneError, load_scene, parse_scene, to_yaml
from rapid_dsl.runtime.scenes.schema import MASS_RANGE

ROBOTS = ("floating_gripper", "franka")


@dataclass(frozen=True)
class ReconstructedScene:
    scene: Scene                 # as loaded back from `path`
    path: Path
    meshes: tuple[Path, ...]     # written next to the scene
    reconstruction: Reconstruction

    def as_json(self) -> dict[str, Any]:
        """What was written and how each object was fitted, as JSON-ready values (SI units)."""
        support = self.reconstruction.support

        def numbers(values: Iterable[float]) -> list[float]:
            return [_round(v) for v in values]

        return {
            "scene": str(self.path),
            "meshes": [str(p) for p in self.meshes],
            "support": {"name": support.name, "height": _round(support.height),
                        "tilt_deg": round(math.degrees(support.tilt), 3),
                        "size": numbers([*support.rect.extents, support.thickness]),
                        "pixels": support.inliers, "noise": _round(support.noise, 5)},
            "floor": {"height": _round(support.floor_height), "seen": support.floor_seen},
            "objects": [{"name": o.name, "kind": o.kind, "label": o.label, "shape": o.shape,
                         "position": numbers(o.position),
                         "yaw_deg": _round(math.degrees(o.yaw), 2), "size": numbers(o.extents),
                         "mass": None if o.mass is None else _round(o.mass),
                         "rests_on": o.rests_on, "points": o.points, "outliers": o.outliers,
                         "free": _round(o.free, 3), "surface": _round(o.surface, 3)}
                        for o in self.reconstruction.objects],
            "notes": list(self.reconstruction.notes),
        }


def _round(value: float, digits: int = 4) -> float:
    """Rounded to 0.1 mm (0.1 g, 1e-4 rad), and never `-0.0`."""
    return round(float(value), digits) + 0.0


def scene_from_rgbd(rgb: str | os.PathLike[str], depth: str | os.PathLike[str],
                    intrinsics: str | os.PathLike[str], masks: str | os.PathLike[str],
                    output: str | os.PathLike[str], *,
                    labels: str | os.PathLike[str] | None = None,
                    extrinsics: str | os.PathLike[str] | None = None,
                    robot: str = "floating_gripper") -> ReconstructedScene:
    """Reconstruct a scene from one RGB-D frame and write it to `output` (meshes next to it).

    `rgb` PNG/JPEG; `depth` 16-bit PNG (mm) or float .npy (m); `intrinsics` and `extrinsics`
    JSON; `masks` a folder of `<name>.png`; `labels` JSON (docs/reconstruction.md). Raises
    RgbdError for any bad input, located at its file (and line and column for JSON).
    """
    frame = read_frame(rgb, depth, intrinsics, masks, labels=labels, extrinsics=extrinsics,
                       surfaces=[SUPPORT_NAME])
    return scene_from_frame(frame, output, robot=robot)


def scene_from_frame(frame: Frame, output: str | os.PathLike[str], *,
                     robot: str = "floating_gripper") -> ReconstructedScene:
    """Reconstruct a frame already read (or rendered) and write it as a scene file; never over
    one of the frame's files."""
    if robot not in ROBOTS:
        raise RgbdError(f"unknown robot `{excerpt(robot)}` (robots: {', '.join(ROBOTS)})")
    result = reconstruct(frame)
    return write_scene(result, output, robot=robot, inputs=list(frame.files.values()),
                       files=frame.files, support=frame.info.get(SUPPORT_NAME))


def write_scene(result: Reconstruction, output: str | os.PathLike[str], *, robot: str,
                inputs: Iterable[str | os.PathLike[str]] = (),
                files: dict[str, str] | None = None,
                support: ObjectInfo | None = None) -> ReconstructedScene:
    """Write the meshes (`<scene stem>-<object>.obj` next to the scene) and the scene, each
    atomically through rapid_dsl/language/files.py (never through a symlink, never over one of
    `inputs`); the scene text is validated before it is written and loaded back after. `support`:
    the support's label and friction."""
    path = Path(output)
    folder = path.parent
    with open_output(folder, inputs) as out:
        meshes: dict[str, Path] = {}
        for obj in result.objects:
            if obj.hull is not None:
                meshes[obj.name] = write_output(out, f"{_stem(path)}-{obj.name}.obj",
                                                _obj_text(obj))
        text = _scene_text(result, robot, meshes, path, files or {}, support or ObjectInfo())
        try:
            parse_scene(text, str(path), base_dir=folder)
        except SceneError as error:   # a limit no earlier check knew of: say which
            raise RgbdError("the reconstructed scene is not valid:\n" + str(error)) from None
        write_output(out, path.name, text)
    try:
        scene = load_scene(path)
    except SceneError as error:   # changed under our feet between the write and the read
        raise RgbdError("the written scene does not load back:\n" + str(error)) from None
    return ReconstructedScene(scene, path, tuple(meshes.values()), result)


def _stem(path: Path) -> str:
    name = path.name
    for suffix in (".yaml", ".yml"):
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)]
    return name


def _obj_text(obj: ObjectFit) -> str:
    """The hull as a Wavefront .obj in the object's frame [m]."""
    assert obj.hull is not None
    lines = [f"# convex hull of `{obj.name}`, reconstructed from an RGB-D frame (m)"]
    lines += [f"v {x:.6f} {y:.6f} {z:.6f}" for x, y, z in obj.hull.vertices]
    lines += [f"f {a + 1} {b + 1} {c + 1}" for a, b, c in obj.hull.faces]
    return "\n".join(lines) + "\n"


def _scene_text(result: Reconstruction, robot: str, meshes: dict[str, Path], path: Path,
                files: dict[str, str], info: ObjectInfo) -> str:
    support = result.support
    objects: list[dict[str, Any]] = [{
        "name": support.name, "kind": "surface", "label": info.label or support.name,
        "shape": "box",
        "size": [_round(v) for v in (*support.rect.extents, support.thickness)],
        "pose": {"position": [_round(v) for v in (*support.rect.centre,
                                                  support.height - support.thickness / 2)],
                 "yaw": _round(support.rect.yaw)},
    }]
    if info.friction is not None:
        objects[0]["friction"] = info.friction
    for obj in result.objects:
        item: dict[str, Any] = {
            "name": obj.name, "kind": obj.kind, "label": obj.label, "shape": obj.shape,
            "size": [_round(v) for v in obj.extents],
            "pose": {"position": [_round(v) for v in obj.position], "yaw": _round(obj.yaw)},
            "rgba": list(obj.rgba)}
        if obj.name in meshes:
            item["mesh"] = str(meshes[obj.name].resolve())
        if obj.mass is not None:
            item["mass"] = max(_round(obj.mass), MASS_RANGE[0])
        if obj.friction is not None:
            item["friction"] = obj.friction
        objects.append(item)
    data = {"robot": robot, "floor_height": _round(support.floor_height), "objects": objects}
    try:
        scene = Scene.model_validate(data)
    except ValueError as error:   # pydantic's ValidationError: name the part that broke
        raise RgbdError(f"the reconstructed scene is not valid: {_first(error)}") from None
    source = files.get("rgb")
    header = "# Reconstructed from one RGB-D frame by `rapidc scene from-rgbd`" + (
        f" ({excerpt(source, 200)})" if source else "") + "\n"
    return header + to_yaml(scene, relative_to=path.parent.resolve())


def _first(error: ValueError) -> str:
    errors = getattr(error, "errors", None)
    if not callable(errors):
        return str(error)
    item = errors()[0]
    where = ".".join(str(p) for p in item["loc"] if not isinstance(p, str) or "[" not in p)
    return f"{where}: {item['msg'].removeprefix('Value error, ')}"


__all__ = ["ROBOTS", "ReconstructedScene", "scene_from_frame", "scene_from_rgbd", "write_scene"]
