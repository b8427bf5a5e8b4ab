"""Scene files: what reconstruction produces and what the world is built from.

A scene is YAML (see docs/scenes.md). It is read within bounds by `safe_yaml.read_yaml`, which
keeps every node's line and column, validated by the pydantic models of `scene_schema`
(re-exported here), and every problem is reported as `file:line:col: error: field: message`.
Quantities may carry units (`3cm`, `30deg`, `0.3kg`); plain numbers are SI (m, rad, kg). After
validation every value is a plain SI float, so variants can perturb a scene with
`Scene.with_object(name, ...)` without caring about units.

Conventions (also in docs/scenes.md):
- `size` is the full extent along the object's own x, y, z axes. Written per shape: box `[x, y, z]`,
  cylinder `[diameter, height]` (axis = object z), sphere `diameter` or `[diameter]`, mesh
  optional `[x, y, z]` (the hull is stretched to it; default: the mesh's own extents). Stored
  normalised as the 3 extents.
- `pose.position` is the centre of the object's extents; orientation R = Rz(yaw) Ry(pitch) Rx(roll).
- `mesh` is a path relative to the scene file, inside its folder tree (or an allowed folder); the
  convex hull is used for collision and inertia.
"""

from __future__ import annotations

import io
import os
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pydantic import ValidationError
from pydantic_core import ErrorDetails

from rapid_dsl.language.files import FileProblem, read_text
from rapid_dsl.language.safe_yaml import YamlProblem, excerpt, read_yaml
from rapid_dsl.runtime.scenes.schema import (
    DEFAULT_RGBA,
    Angle,
    GripperStart,
    Length,
    Mass,
    ObjectKind,
    Pose,
    Real,
    Scene,
    SceneObject,
    Shape,
)

__all__ = ["DEFAULT_RGBA", "Angle", "GripperStart", "Length", "Mass", "ObjectKind", "Pose", "Real",
           "Scene", "SceneError", "SceneObject", "SceneProblem", "Shape", "dump_scene",
           "load_scene", "parse_scene", "to_yaml"]


# --- errors ----------------------------------------------------------------------------------

@dataclass(frozen=True, slots=True)
class SceneProblem:
    file: str
    line: int      # 1-based
    column: int    # 1-based
    field: str     # e.g. `objects[0].pose.yaw`; empty for the whole file
    message: str

    def __str__(self) -> str:
        where = f"{self.field}: " if self.field else ""
        return f"{self.file}:{self.line}:{self.column}: error: {where}{self.message}"


class SceneError(Exception):
    """A scene file is invalid; `problems` lists every problem with its location."""

    def __init__(self, problems: list[SceneProblem]):
        self.problems = problems
        super().__init__("\n".join(str(p) for p in problems))


# --- loading ---------------------------------------------------------------------------------

def load_scene(path: str | os.PathLike[str], *,
               allowed_dirs: Sequence[str | os.PathLike[str]] = ()) -> Scene:
    """Read, validate and normalise a scene file; raises SceneError naming file, line and field.

    Mesh paths must stay inside the scene file's folder tree or one of `allowed_dirs` (symlinks
    resolved). The file must be a regular file of at most 10 MiB (rapid_dsl/language/files.py).
    """
    path = Path(path)
    name = str(path)
    try:
        text = read_text(path)
    except FileProblem as problem:
        raise SceneError([SceneProblem(name, 1, 1, "", f"cannot read scene file: {problem}")]) \
            from None
    return parse_scene(text, name, base_dir=path.parent, allowed_dirs=allowed_dirs)


def parse_scene(text: str, file: str = "<scene>", *, base_dir: str | os.PathLike[str] = ".",
                allowed_dirs: Sequence[str | os.PathLike[str]] = ()) -> Scene:
    """Validate scene YAML text; `file` names it in errors, meshes resolve against `base_dir` and
    must stay inside it or one of `allowed_dirs`."""
    try:
        root = read_yaml(text)
    except YamlProblem as problem:
        raise SceneError([SceneProblem(file, problem.line, problem.column, "",
                                       problem.message)]) from None
    if not isinstance(root, dict):
        raise SceneError([SceneProblem(file, 1, 1, "", "a scene file is a mapping with `robot:` "
                                                        "and `objects:`")])
    context = {"base_dir": str(base_dir), "roots": [base_dir, *allowed_dirs], "meshes": {}}
    try:
        return Scene.model_validate(_plain(root) | {"source": file}, context=context)
    except ValidationError as error:
        problems = [_problem(file, root, item) for item in error.errors()]
        raise SceneError(sorted(set(problems), key=lambda p: (p.line, p.column))) from None


def _plain(node: Any) -> Any:
    """ruamel round-trip nodes -> plain dicts, lists and scalars."""
    if isinstance(node, dict):
        return {str(k): _plain(v) for k, v in node.items()}
    if isinstance(node, list):
        return [_plain(v) for v in node]
    if isinstance(node, float):
        return float(node)  # ScalarFloat keeps formatting; pydantic wants a float
    if isinstance(node, bool):
        return bool(node)
    if isinstance(node, int):
        return int(node)
    if isinstance(node, str):
        return str(node)
    return node


def _problem(file: str, root: Any, error: ErrorDetails) -> SceneProblem:
    """Map one pydantic error to the YAML node it is about (round-trip nodes with `.lc`)."""
    from ruamel.yaml.comments import CommentedMap, CommentedSeq

    node, line, col = root, 1, 1
    fields: list[str] = []
    path = [part for part in error["loc"] if _is_data_key(node, part)]
    for depth, part in enumerate(path):
        last = depth == len(path) - 1
        if isinstance(node, CommentedMap) and isinstance(part, str) and part in node:
            is_extra = last and error["type"] == "extra_forbidden"
            line, col = node.lc.key(part) if is_extra else node.lc.value(part)
            node = node[part]
            fields.append(("." if fields else "") + _field(part))
        elif isinstance(node, CommentedSeq) and isinstance(part, int) and 0 <= part < len(node):
            line, col = node.lc.item(part)
            node = node[part]
            fields.append(f"[{part}]")
        else:
            fields.append(("." if fields and isinstance(part, str) else "") +
                          (f"[{part}]" if isinstance(part, int) else _field(str(part))))
            break
    else:
        line, col = line + 1, col + 1
        return SceneProblem(file, line, col, "".join(fields), _message(error))
    # the field is missing: point at the mapping that should hold it
    if hasattr(node, "lc"):
        line, col = node.lc.line + 1, node.lc.col + 1
    else:
        line, col = line + 1, col + 1
    return SceneProblem(file, line, col, "".join(fields), _message(error))


def _is_data_key(root: Any, part: Any) -> bool:
    # pydantic inserts validator tags like `function-after[...]` into locations; they are not keys
    return isinstance(part, int) or ("[" not in part and "-" not in part) or _written(root, part)


def _written(root: Any, key: str) -> bool:
    """Whether `key` is a key somewhere in the file (an unknown field may look like a tag)."""
    stack = [root]
    while stack:
        node = stack.pop()
        if isinstance(node, dict):
            if key in node:
                return True
            stack.extend(node.values())
        elif isinstance(node, list):
            stack.extend(node)
    return False


def _field(key: str) -> str:
    """A key as it appears in a field path: written keys are file content, so kept short."""
    return key if key.isidentifier() and len(key) <= 40 else f"`{excerpt(key)}`"


def _message(error: ErrorDetails) -> str:
    kind, message = error["type"], error["msg"]
    if kind == "missing":
        return "required field is missing"
    if kind == "extra_forbidden":
        return "unknown field"
    if message.startswith("Value error, "):
        message = message[len("Value error, "):]
    if message.startswith("Assertion failed, "):
        message = message[len("Assertion failed, "):]
    return message


# --- writing ---------------------------------------------------------------------------------

def to_yaml(scene: Scene, *, relative_to: str | Path | None = None) -> str:
    """The scene as YAML in SI units (m, rad, kg), readable back by `parse_scene`.

    Mesh paths are written relative to `relative_to` (a directory) when given.
    """
    from ruamel.yaml import YAML
    from ruamel.yaml.comments import CommentedMap, CommentedSeq

    def flow(values: Iterable[float]) -> CommentedSeq:
        seq = CommentedSeq(round(float(v), 9) for v in values)
        seq.fa.set_flow_style()
        return seq

    def flow_map(items: dict[str, Any]) -> CommentedMap:
        out = CommentedMap(items)
        out.fa.set_flow_style()
        return out

    root = CommentedMap()
    root["robot"] = scene.robot
    root["robot_base"] = flow(scene.robot_base)
    if scene.gripper_start is not None:
        start = scene.gripper_start
        root["gripper_start"] = flow_map({"position": flow(start.position), "yaw": start.yaw,
                                          "pitch": start.pitch})
    root["floor_height"] = scene.floor_height
    objects = CommentedSeq()
    for obj in scene.objects:
        item = CommentedMap()
        item["name"] = obj.name
        item["kind"] = obj.kind
        item["label"] = obj.label
        item["shape"] = obj.shape
        size = obj.extents
        item["size"] = flow({"cylinder": (size[0], size[2]), "sphere": (size[0],)}
                            .get(obj.shape, size))
        if obj.mesh is not None:
            mesh = Path(obj.mesh)
            if relative_to is not None:
                mesh = Path(os.path.relpath(mesh, Path(relative_to).resolve()))
            item["mesh"] = mesh.as_posix()
        pose = {"position": flow(obj.pose.position), "yaw": obj.pose.yaw}
        if obj.pose.pitch or obj.pose.roll:
            pose |= {"pitch": obj.pose.pitch, "roll": obj.pose.roll}
        item["pose"] = flow_map(pose)
        if obj.mass is not None:
            item["mass"] = obj.mass
        item["friction"] = obj.friction
        if obj.restitution:
            item["restitution"] = obj.restitution
        item["rgba"] = flow(obj.rgba or DEFAULT_RGBA[obj.kind])
        objects.append(item)
    root["objects"] = objects
    stream = io.StringIO()
    stream.write("# units: SI (m, rad, kg)\n")
    yaml = YAML(typ="rt")
    yaml.indent(mapping=2, sequence=4, offset=2)
    yaml.dump(root, stream)
    return stream.getvalue()


def dump_scene(scene: Scene, path: str | os.PathLike[str]) -> None:
    """Write the scene to `path` (mesh paths relative to it), atomically
    (rapid_dsl/language/files.py)."""
    from rapid_dsl.language.files import write_atomic

    path = Path(path)
    write_atomic(path, to_yaml(scene, relative_to=path.parent.resolve()))
