"""Scene files: what reconstruction produces and what the world is built from.

A scene is YAML (see docs/scenes.md). It is read with ruamel.yaml in round-trip mode so every node
keeps its line and column, validated with pydantic, and every problem is reported as
`file:line:col: error: field: message`. Quantities may carry units (`3cm`, `30deg`, `0.3kg`); plain
numbers are SI (m, rad, kg). After validation every value is a plain SI float, so variants can
perturb a scene with `Scene.with_object(name, ...)` without caring about units.

Conventions (also in docs/scenes.md):
- `size` is the full extent along the object's own x, y, z axes. Written per shape: box `[x, y, z]`,
  cylinder `[diameter, height]` (axis = object z), sphere `diameter` or `[diameter]`, mesh
  optional `[x, y, z]` (the hull is stretched to it; default: the mesh's own extents). Stored
  normalised as the 3 extents.
- `pose.position` is the centre of the object's extents; orientation R = Rz(yaw) Ry(pitch) Rx(roll).
- `mesh` is a path relative to the scene file; the convex hull is used for collision and inertia.
"""

from __future__ import annotations

import io
import math
import os
from collections.abc import Callable, Iterable
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
    field_validator,
    model_validator,
)
from pydantic_core import ErrorDetails, InitErrorDetails, PydanticCustomError

from rapid_dsl.runtime.units import ANGLE, LENGTH, MASS, Dim, dim_name, parse_quantity

RESERVED_NAMES = ("gripper", "floor")
ROBOTS = ("franka", "floating_gripper")
ObjectKind = Literal["object", "fixture", "surface"]
Shape = Literal["box", "cylinder", "sphere", "mesh"]

# Default colours per kind (RGBA), used when a scene gives none.
DEFAULT_RGBA: dict[str, tuple[float, float, float, float]] = {
    "object": (0.80, 0.25, 0.20, 1.0),
    "fixture": (0.45, 0.47, 0.52, 1.0),
    "surface": (0.62, 0.52, 0.40, 1.0),
}


# --- quantities ------------------------------------------------------------------------------

def _number(value: Any, dim: Dim) -> float:
    """A YAML scalar as an SI float of dimension `dim`; plain numbers are already SI."""
    if isinstance(value, bool) or value is None:
        raise ValueError(f"expected {_article(dim_name(dim))}, got `{value}`")
    if isinstance(value, (int, float)):
        number = float(value)
    elif isinstance(value, str):
        number, found = parse_quantity(value)
        if found != dim and not found.is_dimensionless:
            raise ValueError(f"`{value}` is {_article(dim_name(found))}, "
                             f"expected {_article(dim_name(dim))}")
    else:
        raise ValueError(f"expected {_article(dim_name(dim))}, got a {type(value).__name__}")
    if not math.isfinite(number):
        raise ValueError(f"`{value}` is not a finite number")
    return number


def _article(name: str) -> str:
    return ("an " if name[0] in "AEIOU" else "a ") + name


def _quantity(dim: Dim) -> Callable[[Any], float]:
    return lambda value: _number(value, dim)


def _vector(dim: Dim, length: int | None = None) -> Callable[[Any], tuple[float, ...]]:
    def parse(value: Any) -> tuple[float, ...]:
        if not isinstance(value, (list, tuple)):
            value = [value]  # a scalar where a list is allowed, e.g. a sphere's diameter
        if length is not None and len(value) != length:
            raise ValueError(f"expected {length} numbers, got {len(value)}")
        return tuple(_number(item, dim) for item in value)

    return parse


Length = Annotated[float, BeforeValidator(_quantity(LENGTH))]
Angle = Annotated[float, BeforeValidator(_quantity(ANGLE))]
Mass = Annotated[float, BeforeValidator(_quantity(MASS)), Field(gt=0)]
Real = Annotated[float, BeforeValidator(_quantity(Dim()))]
Vec3 = Annotated[tuple[float, float, float], BeforeValidator(_vector(LENGTH, 3))]
Sizes = Annotated[tuple[float, ...], BeforeValidator(_vector(LENGTH))]
Rgba = Annotated[tuple[float, float, float, float], BeforeValidator(_vector(Dim(), 4))]


# --- the model -------------------------------------------------------------------------------

class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Pose(_Strict):
    position: Vec3
    yaw: Angle = 0.0
    pitch: Angle = 0.0
    roll: Angle = 0.0


class GripperStart(_Strict):
    """Where the hand (the point between the fingertips) starts; pitch 0 = fingers down."""

    position: Vec3
    yaw: Angle = 0.0
    pitch: Angle = 0.0


class SceneObject(_Strict):
    name: str = Field(min_length=1, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")
    kind: ObjectKind
    label: str = ""
    shape: Shape
    size: Sizes | None = None
    mesh: str | None = None
    pose: Pose
    mass: Mass | None = None
    friction: Annotated[Real, Field(ge=0)] = 0.8
    restitution: Annotated[Real, Field(ge=0, lt=1)] = 0.0
    rgba: Rgba | None = None

    @field_validator("name")
    @classmethod
    def _not_reserved(cls, name: str) -> str:
        if name in RESERVED_NAMES:
            raise ValueError(f"`{name}` is reserved for the scene's own `{name}` entity")
        return name

    @field_validator("rgba")
    @classmethod
    def _unit_rgba(cls, rgba: tuple[float, ...] | None) -> tuple[float, ...] | None:
        if rgba is not None and not all(0.0 <= c <= 1.0 for c in rgba):
            raise ValueError("rgba components must lie in [0, 1]")
        return rgba

    @field_validator("mesh")
    @classmethod
    def _resolve_mesh(cls, mesh: str | None, info: ValidationInfo) -> str | None:
        if mesh is None:
            return None
        base = Path((info.context or {}).get("base_dir", "."))
        path = (base / mesh).resolve()
        from rapid_dsl.runtime.meshes import load_hull  # validates the file now, at its line

        load_hull(path)
        return str(path)

    @model_validator(mode="after")
    def _check_shape(self) -> SceneObject:
        problems: list[tuple[tuple[str, ...], str]] = []
        if self.shape == "mesh" and self.mesh is None:
            problems.append(((), "shape `mesh` needs a `mesh:` file"))
        if self.shape != "mesh" and self.mesh is not None:
            problems.append((("mesh",), f"`mesh:` only applies to shape `mesh`, "
                                        f"not `{self.shape}`"))
        if self.kind == "object" and self.mass is None:
            problems.append(((), "an object needs a `mass`"))
        if self.kind != "object" and self.mass is not None:
            problems.append((("mass",), f"a {self.kind} is static; `mass` only applies to objects"))
        size = None
        try:
            size = _normalise_size(self.shape, self.size, self.mesh)
        except ValueError as error:
            problems.append((("size",) if self.size is not None else (), str(error)))
        if problems:
            raise _validation_error(problems, self)
        object.__setattr__(self, "size", size)  # frozen model: normalise in place once
        if not self.label:
            object.__setattr__(self, "label", self.name.replace("_", " "))
        if self.rgba is None:
            object.__setattr__(self, "rgba", DEFAULT_RGBA[self.kind])
        return self

    @property
    def extents(self) -> tuple[float, float, float]:
        """Full size along the object's own axes [m]."""
        assert self.size is not None and len(self.size) == 3
        return self.size  # type: ignore[return-value]

    @property
    def is_static(self) -> bool:
        return self.kind != "object"


def _normalise_size(shape: str, size: tuple[float, ...] | None,
                    mesh: str | None) -> tuple[float, ...]:
    if size is not None and any(s <= 0 for s in size):
        raise ValueError("sizes must be positive")
    if shape == "box":
        if size is None or len(size) != 3:
            raise ValueError("a box needs `size: [x, y, z]` (full extents)")
        return size
    if shape == "cylinder":
        if size is None or len(size) not in (2, 3):
            raise ValueError("a cylinder needs `size: [diameter, height]`")
        if len(size) == 3 and not math.isclose(size[0], size[1], rel_tol=1e-9):
            raise ValueError("a cylinder's x and y extents are its diameter and must be equal")
        return (size[0], size[0], size[-1])
    if shape == "sphere":
        if size is None or len(size) not in (1, 3) or len(set(size)) != 1:
            raise ValueError("a sphere needs `size: diameter`")
        return (size[0],) * 3
    # mesh: the hull's own extents unless stretched to a given size
    if size is not None:
        if len(size) != 3:
            raise ValueError("a mesh's `size` is its full extents `[x, y, z]`")
        return size
    if mesh is None:
        raise ValueError("shape `mesh` needs a `mesh:` file")
    from rapid_dsl.runtime.meshes import load_hull

    return tuple(float(e) for e in load_hull(mesh).extents)


class Scene(_Strict):
    robot: Literal["franka", "floating_gripper"]
    robot_base: Vec3 = (0.0, 0.0, 0.0)
    gripper_start: GripperStart | None = None
    floor_height: Length = 0.0
    objects: tuple[SceneObject, ...]
    source: str | None = Field(default=None, exclude=True)  # file it was loaded from, for errors

    @model_validator(mode="after")
    def _unique_names(self) -> Scene:
        seen: set[str] = set()
        problems: list[tuple[tuple[Any, ...], str]] = []
        if not self.objects:
            problems.append((("objects",), "a scene needs at least one object"))
        for index, obj in enumerate(self.objects):
            if obj.name in seen:
                problems.append((("objects", index, "name"), f"duplicate object name `{obj.name}`"))
            seen.add(obj.name)
        if problems:
            raise _validation_error(problems, self)
        return self

    def object(self, name: str) -> SceneObject:
        for obj in self.objects:
            if obj.name == name:
                return obj
        raise KeyError(name)

    def with_object(self, name: str, **changes: Any) -> Scene:
        """A copy with one object's fields replaced (SI values or unit strings), re-validated.

        `pose` may be a Pose or a dict; e.g. `scene.with_object("box", mass=0.5,
        pose={"position": (0.5, 0, 0.02), "yaw": 0.3})`.
        """
        objects = [
            obj.model_dump() | changes if obj.name == name else obj.model_dump()
            for obj in self.objects
        ]
        if name not in {obj.name for obj in self.objects}:
            raise KeyError(name)
        return Scene.model_validate(self.model_dump() | {"objects": objects, "source": self.source})


def _validation_error(problems: Iterable[tuple[tuple[Any, ...], str]],
                      value: Any) -> ValidationError:
    details = [
        InitErrorDetails(
            type=PydanticCustomError("scene", "{message}", {"message": message}),
            loc=loc,
            input=value,
        )
        for loc, message in problems
    ]
    return ValidationError.from_exception_data("Scene", details)


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

def load_scene(path: str | os.PathLike[str]) -> Scene:
    """Read, validate and normalise a scene file; raises SceneError naming file, line and field."""
    path = Path(path)
    name = str(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        problem = SceneProblem(name, 1, 1, "", f"cannot read scene file: {error.strerror}")
        raise SceneError([problem]) from None
    except UnicodeDecodeError:
        raise SceneError([SceneProblem(name, 1, 1, "", "not UTF-8 text")]) from None
    return parse_scene(text, name, base_dir=path.parent)


def parse_scene(text: str, file: str = "<scene>", *, base_dir: str | Path = ".") -> Scene:
    """Validate scene YAML text; `file` names it in errors, meshes resolve against `base_dir`."""
    from ruamel.yaml import YAML
    from ruamel.yaml.error import MarkedYAMLError, YAMLError

    try:
        root = YAML(typ="rt").load(text)
    except MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        line, col = (mark.line + 1, mark.column + 1) if mark else (1, 1)
        message = " ".join(filter(None, (error.context, error.problem))) or "invalid YAML"
        raise SceneError([SceneProblem(file, line, col, "", f"YAML syntax: {message}")]) from None
    except YAMLError as error:
        raise SceneError([SceneProblem(file, 1, 1, "", f"YAML syntax: {error}")]) from None
    if not isinstance(root, dict):
        raise SceneError([SceneProblem(file, 1, 1, "", "a scene file is a mapping with `robot:` "
                                                        "and `objects:`")])
    plain = _plain(root)
    try:
        return Scene.model_validate(plain | {"source": file}, context={"base_dir": str(base_dir)})
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
    """Map one pydantic error to the YAML node it is about."""
    from ruamel.yaml.comments import CommentedMap, CommentedSeq

    node, line, col = root, 1, 1
    fields: list[str] = []
    path = [part for part in error["loc"] if _is_data_key(part)]
    for depth, part in enumerate(path):
        last = depth == len(path) - 1
        if isinstance(node, CommentedMap) and isinstance(part, str) and part in node:
            is_extra = last and error["type"] == "extra_forbidden"
            line, col = node.lc.key(part) if is_extra else node.lc.value(part)
            node = node[part]
            fields.append(("." if fields else "") + part)
        elif isinstance(node, CommentedSeq) and isinstance(part, int) and 0 <= part < len(node):
            line, col = node.lc.item(part)
            node = node[part]
            fields.append(f"[{part}]")
        else:
            fields.append(("." if fields and isinstance(part, str) else "") +
                          (f"[{part}]" if isinstance(part, int) else str(part)))
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


def _is_data_key(part: Any) -> bool:
    # pydantic inserts validator tags like `function-after[...]` into locations; they are not keys
    return isinstance(part, int) or ("[" not in part and "-" not in part)


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
    """Write the scene to `path` (mesh paths relative to it)."""
    path = Path(path)
    path.write_text(to_yaml(scene, relative_to=path.parent.resolve()), encoding="utf-8")
