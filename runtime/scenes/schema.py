"""The scene schema: what a valid scene is, down to the bounds MuJoCo and the robots need.

Every value a scene file may hold is checked here, so that a scene that validates always builds a
MuJoCo model for either robot (`world.build_world`). The bounds are in one table below and in
docs/scenes.md; quantities may carry units (`3cm`, `30deg`, `0.3kg`), plain numbers are SI, and
after validation every value is a plain SI float.

Two checks need the robot and world builders (MuJoCo): reserved names (every name the built model
uses besides the objects' own, for either robot) and whether the robot can put its hand at
`gripper_start`. They are imported when a scene is validated, not when this module is.
"""

from __future__ import annotations

import math
import os
from collections.abc import Callable, Iterable
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
from pydantic_core import InitErrorDetails, PydanticCustomError

from rapid_dsl.language.files import inside
from rapid_dsl.language.limits import WORKSPACE
from rapid_dsl.language.safe_yaml import excerpt
from rapid_dsl.language.units import ANGLE, LENGTH, MASS, UNITS, Dim, dim_name, parse_quantity
from rapid_dsl.runtime.scenes.meshes import MESH_SUFFIXES, MeshHull, load_hull

ObjectKind = Literal["object", "fixture", "surface"]
Shape = Literal["box", "cylinder", "sphere", "mesh"]

# --- bounds (docs/scenes.md lists them; a test keeps the two in step) ------------------------
MASS_RANGE = (0.001, 100.0)        # kg: 1 g .. 100 kg
SIZE_RANGE = (0.005, 2.0)          # m, every full extent: 5 mm .. 2 m
FRICTION_RANGE = (0.0, 2.0)        # above 2, pyramidal contacts soften: a resting ball sinks mm
RESTITUTION_RANGE = (0.0, 0.8)     # above 0.8, a 2 ms step makes the contact spring gain energy
MAX_ANGLE = 4 * math.pi            # rad: yaw, pitch and roll within +-720deg
MAX_OBJECTS = 64                   # contact sensors grow with the square of the count
MAX_NAME = 64                      # characters
MAX_LABEL = 100                    # characters
MAX_PATH = 1024                    # characters of a `mesh:` path
MAX_MESH_BYTES = 8 * 1024 * 1024   # all the mesh files of one scene together: parsing and
                                   # their hulls take about 0.4 s per MiB of .obj

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
    if isinstance(value, int):
        try:
            number = float(value)
        except OverflowError:
            raise ValueError(f"`{excerpt(value)}` is too large") from None
    elif isinstance(value, float):
        number = value
    elif isinstance(value, str):
        try:
            if len(value) > 64:
                raise ValueError
            number, found = parse_quantity(value)
        except ValueError:
            raise ValueError(f"`{excerpt(value)}` is not a number with an optional unit "
                             f"({', '.join(UNITS)})") from None
        if found != dim and not found.is_dimensionless:
            raise ValueError(f"`{excerpt(value)}` is {_article(dim_name(found))}, "
                             f"expected {_article(dim_name(dim))}")
    else:
        raise ValueError(f"expected {_article(dim_name(dim))}, got a {type(value).__name__}")
    if not math.isfinite(number):
        raise ValueError(f"`{excerpt(value)}` is not a finite number")
    return number


def _article(name: str) -> str:
    return ("an " if name[0] in "AEIOU" else "a ") + name


def show(value: float, dim: Dim) -> str:
    """An SI value with its unit, for messages: `0.001 kg`, `2 m`, `720deg`."""
    if dim == ANGLE:
        return f"{math.degrees(value):.4g}deg"
    unit = {LENGTH: " m", MASS: " kg"}.get(dim, "")
    return f"{value:.4g}{unit}"


def _quantity(dim: Dim, bounds: tuple[float, float] | None = None) -> Callable[[Any], float]:
    def parse(value: Any) -> float:
        number = _number(value, dim)
        if bounds is not None:
            _check_range(number, bounds, dim)
        return number

    return parse


def _check_range(number: float, bounds: tuple[float, float], dim: Dim) -> None:
    lo, hi = bounds
    if not lo <= number <= hi:
        raise ValueError(f"must lie in [{show(lo, dim)}, {show(hi, dim)}], "
                         f"got {show(number, dim)}")


def _vector(dim: Dim, length: int | None = None, *, most: int = 3,
            bounds: tuple[float, float] | None = None) -> Callable[[Any], tuple[float, ...]]:
    def parse(value: Any) -> tuple[float, ...]:
        if not isinstance(value, (list, tuple)):
            value = [value]  # a scalar where a list is allowed, e.g. a sphere's diameter
        if length is not None and len(value) != length:
            raise ValueError(f"expected {length} numbers, got {len(value)}")
        if len(value) > most:
            raise ValueError(f"expected at most {most} numbers, got {len(value)}")
        numbers = tuple(_number(item, dim) for item in value)
        if bounds is not None:
            for number in numbers:
                _check_range(number, bounds, dim)
        return numbers

    return parse


# Unbounded (finite) quantities, for other files read like scenes; the scene's own fields are
# bounded below.
Length = Annotated[float, BeforeValidator(_quantity(LENGTH))]
Angle = Annotated[float, BeforeValidator(_quantity(ANGLE))]
Real = Annotated[float, BeforeValidator(_quantity(Dim()))]
Mass = Annotated[float, BeforeValidator(_quantity(MASS, MASS_RANGE))]

_WORKSPACE = (-WORKSPACE, WORKSPACE)
Height = Annotated[float, BeforeValidator(_quantity(LENGTH, _WORKSPACE))]
PoseAngle = Annotated[float, BeforeValidator(_quantity(ANGLE, (-MAX_ANGLE, MAX_ANGLE)))]
Friction = Annotated[float, BeforeValidator(_quantity(Dim(), FRICTION_RANGE))]
Restitution = Annotated[float, BeforeValidator(_quantity(Dim(), RESTITUTION_RANGE))]
Position = Annotated[tuple[float, float, float],
                     BeforeValidator(_vector(LENGTH, 3, bounds=_WORKSPACE))]
Sizes = Annotated[tuple[float, ...], BeforeValidator(_vector(LENGTH))]
Rgba = Annotated[tuple[float, float, float, float],
                 BeforeValidator(_vector(Dim(), 4, most=4, bounds=(0.0, 1.0)))]


# --- the model -------------------------------------------------------------------------------

class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Pose(_Strict):
    position: Position
    yaw: PoseAngle = 0.0
    pitch: PoseAngle = 0.0
    roll: PoseAngle = 0.0


class GripperStart(_Strict):
    """Where the hand (the point between the fingertips) starts; pitch 0 = fingers down."""

    position: Position
    yaw: PoseAngle = 0.0
    pitch: PoseAngle = 0.0


class SceneObject(_Strict):
    name: str = Field(min_length=1, max_length=MAX_NAME, pattern=r"^[A-Za-z_][A-Za-z0-9_]*$")
    kind: ObjectKind
    label: str = Field("", max_length=MAX_LABEL)
    shape: Shape
    size: Sizes | None = None
    mesh: str | None = Field(None, max_length=MAX_PATH)
    pose: Pose
    mass: Mass | None = None
    friction: Friction = 0.8
    restitution: Restitution = 0.0
    rgba: Rgba | None = None

    @field_validator("name")
    @classmethod
    def _not_reserved(cls, name: str) -> str:
        from rapid_dsl.runtime.scenes.world import reserved_names

        used = reserved_names().get(name)
        if used is not None:
            raise ValueError(f"`{name}` is reserved: {used}")
        return name

    @field_validator("label")
    @classmethod
    def _plain_label(cls, label: str) -> str:
        if not label.isprintable():
            raise ValueError("a label is one line of plain text (no control or format "
                             "characters)")
        return label

    @field_validator("mesh")
    @classmethod
    def _resolve_mesh(cls, mesh: str | None, info: ValidationInfo) -> str | None:
        """Check a mesh path where it is written; a file's paths stay inside its folder tree."""
        if mesh is None:
            return None
        if not mesh.isprintable():
            raise ValueError("a mesh path is one line of plain text (no control characters)")
        if Path(mesh).suffix.lower() not in MESH_SUFFIXES:
            raise ValueError(f"`{excerpt(mesh)}` is not a {', '.join(MESH_SUFFIXES)} file")
        context = info.context or {}
        base = Path(context.get("base_dir", "."))
        path = base / mesh
        roots = context.get("roots")
        if roots is not None and not inside(path, roots):
            raise ValueError(f"`{excerpt(mesh)}` is outside the scene file's folder"
                             + (" and the allowed folders" if len(roots) > 1 else ""))
        meshes = context.get("meshes")
        real = os.path.realpath(path)
        if meshes is not None and real not in meshes:
            # one scene's mesh files together stay within a budget, checked before each is read
            meshes[real] = _file_size(real)
            if sum(meshes.values()) > MAX_MESH_BYTES:
                raise ValueError(f"the scene's mesh files are larger than "
                                 f"{MAX_MESH_BYTES >> 20} MiB together")
        load_hull(path)
        return str(Path(real))

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
            where: tuple[str, ...] = ("size",) if self.size is not None else \
                ("mesh",) if self.mesh is not None else ()
            problems.append((where, str(error)))
        if problems:
            raise validation_error(problems, self)
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


def _file_size(path: str) -> int:
    """Bytes of the file at `path`; 0 if it cannot be read (reading it then says why)."""
    try:
        return os.stat(path).st_size
    except OSError:
        return 0


def _normalise_size(shape: str, size: tuple[float, ...] | None,
                    mesh: str | None) -> tuple[float, ...]:
    extents = _extents(shape, size, mesh)
    lo, hi = SIZE_RANGE
    if not all(lo <= e <= hi for e in extents):
        shown = ", ".join(show(e, LENGTH) for e in extents)
        origin = "the mesh file's extents (its units taken as m) are" \
            if size is None and mesh is not None else "full extents are"
        raise ValueError(f"{origin} [{shown}]; each must lie in "
                         f"[{show(lo, LENGTH)}, {show(hi, LENGTH)}]")
    return extents


def _extents(shape: str, size: tuple[float, ...] | None, mesh: str | None) -> tuple[float, ...]:
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
    hull: MeshHull = load_hull(mesh)
    return tuple(float(e) for e in hull.extents)


class Scene(_Strict):
    robot: Literal["franka", "floating_gripper"]
    robot_base: Position = (0.0, 0.0, 0.0)
    gripper_start: GripperStart | None = None
    floor_height: Height = 0.0
    objects: tuple[SceneObject, ...]
    source: str | None = Field(default=None, exclude=True)  # file it was loaded from, for errors

    @field_validator("objects", mode="before")
    @classmethod
    def _not_too_many(cls, objects: Any) -> Any:
        if isinstance(objects, (list, tuple)) and len(objects) > MAX_OBJECTS:
            raise ValueError(f"a scene holds at most {MAX_OBJECTS} objects, this one "
                             f"{len(objects)}")
        return objects

    @model_validator(mode="after")
    def _check_scene(self) -> Scene:
        seen: set[str] = set()
        problems: list[tuple[tuple[Any, ...], str]] = []
        if not self.objects:
            problems.append((("objects",), "a scene needs at least one object"))
        for index, obj in enumerate(self.objects):
            if obj.name in seen:
                problems.append((("objects", index, "name"), f"duplicate object name `{obj.name}`"))
            seen.add(obj.name)
        from rapid_dsl.runtime.scenes.world import start_problem

        unreachable = start_problem(self)
        if unreachable is not None:
            problems.append(unreachable)
        if problems:
            raise validation_error(problems, self)
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


def validation_error(problems: Iterable[tuple[tuple[Any, ...], str]],
                     value: Any) -> ValidationError:
    """Problems found by a validator, each at a location inside the model being validated."""
    details = [
        InitErrorDetails(
            type=PydanticCustomError("scene", "{message}", {"message": message}),
            loc=loc,
            input=value,
        )
        for loc, message in problems
    ]
    return ValidationError.from_exception_data("Scene", details)
