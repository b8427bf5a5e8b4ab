"""How far scene variants may stray: per-object ranges, distractors, and the ranges file.

`VariantRanges` are the half-widths every movable object is perturbed by (its defaults are the
sampler's defaults); `Ranges` adds per-object overrides, the meshes a shape change may use and the
distractor objects to add. A ranges file (YAML, docs/variants.md) is read like a scene file:
quantities may carry units, and every problem is a `SceneProblem` at its file, line, column and
field, raised together in one `SceneError`.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Field,
    ValidationError,
    ValidationInfo,
)

from rapid_dsl.language.files import FileProblem, inside, read_text
from rapid_dsl.language.safe_yaml import YamlProblem, excerpt, read_yaml
from rapid_dsl.runtime.scenes.meshes import MeshLoadError, load_hull
from rapid_dsl.runtime.scenes.scene import (
    Angle,
    Length,
    Mass,
    Real,
    Scene,
    SceneError,
    SceneProblem,
    _plain,
    _problem,
)
from rapid_dsl.runtime.scenes.schema import Friction

ShapeName = Literal["box", "cylinder", "mesh"]   # what shape changes may produce
MAX_DISTRACTORS = 20       # per variant
MAX_MESHES = 32            # in a ranges file's `meshes:`
MAX_POSITION = 0.5         # m, half-width of the position range
MAX_RELATIVE = 0.9         # relative half-widths stay below 1, so a scale stays positive
DISTRACTOR_SIZES = (0.01, 0.5)   # m, the full extents a distractor may have


@dataclass(frozen=True, slots=True, kw_only=True)
class VariantRanges:
    """Half-widths of the uniform perturbations of one object."""

    position: float = 0.02          # m, along x and y
    yaw: float = math.radians(15)   # rad
    size: float = 0.15              # relative, per axis
    mass: float = 0.3               # relative
    friction: float = 0.3           # relative
    restitution: float = 0.05       # absolute
    colour: float = 0.1             # absolute, per red, green and blue channel
    shapes: tuple[ShapeName, ...] = ()   # shapes it may take (uniformly); () keeps its own


@dataclass(frozen=True, slots=True, kw_only=True)
class DistractorRanges:
    """Extra objects placed on the scene's surfaces, clear of everything else."""

    count: tuple[int, int] = (0, 0)                   # inclusive
    size: tuple[float, float] = (0.03, 0.08)          # m, each full extent
    mass: tuple[float, float] = (0.05, 0.3)           # kg
    friction: tuple[float, float] = (0.5, 1.0)
    shapes: tuple[ShapeName, ...] = ("box", "cylinder")
    clearance: float = 0.02                           # m, to every other object and the robot


@dataclass(frozen=True, slots=True, kw_only=True)
class Ranges:
    """Everything the sampler draws from: defaults, per-object overrides, meshes, distractors."""

    default: VariantRanges = field(default_factory=VariantRanges)
    objects: Mapping[str, VariantRanges] = field(default_factory=dict)
    meshes: tuple[str, ...] = ()    # absolute paths of hulls a `mesh` shape change may take
    distractors: DistractorRanges = field(default_factory=DistractorRanges)

    def for_object(self, name: str) -> VariantRanges:
        return self.objects.get(name, self.default)


def as_ranges(ranges: VariantRanges | Ranges | None) -> Ranges:
    if ranges is None:
        return Ranges()
    if isinstance(ranges, VariantRanges):
        return Ranges(default=ranges)
    return ranges


# --- the ranges file -------------------------------------------------------------------------

_DEFAULT = VariantRanges()
_DISTRACTOR = DistractorRanges()
NonNegLength = Annotated[Length, Field(ge=0)]


def _unique(shapes: tuple[str, ...]) -> tuple[str, ...]:
    if len(set(shapes)) != len(shapes):
        raise ValueError("a shape is listed twice")
    return shapes


Shapes = Annotated[tuple[ShapeName, ...], AfterValidator(_unique)]


def _count(value: Any) -> Any:
    """`distractors: 2` means exactly 2; booleans are not counts."""
    if isinstance(value, bool) or (isinstance(value, list) and any(isinstance(v, bool)
                                                                   for v in value)):
        raise ValueError("expected a count, or `[min, max]` counts")
    return [value, value] if isinstance(value, int) else value


Count = Annotated[int, Field(ge=0, le=MAX_DISTRACTORS)]


def _ordered(pair: tuple[float, float]) -> tuple[float, float]:
    if pair[0] > pair[1]:
        raise ValueError("expected `[min, max]` with min <= max")
    return pair


def _half_turn(angle: float) -> float:
    if not 0.0 <= angle <= math.pi + 1e-12:
        raise ValueError(f"must lie in [0deg, 180deg], got {math.degrees(angle):.4g}deg")
    return angle


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class RangeFields(_Strict):
    """The fields a ranges file sets for every object and may override per object."""

    position: Annotated[Length, Field(ge=0, le=MAX_POSITION)] = _DEFAULT.position
    yaw: Annotated[Angle, AfterValidator(_half_turn)] = _DEFAULT.yaw
    size: Annotated[Real, Field(ge=0, le=MAX_RELATIVE)] = _DEFAULT.size
    mass: Annotated[Real, Field(ge=0, le=MAX_RELATIVE)] = _DEFAULT.mass
    friction: Annotated[Real, Field(ge=0, le=MAX_RELATIVE)] = _DEFAULT.friction
    restitution: Annotated[Real, Field(ge=0, le=1)] = _DEFAULT.restitution
    colour: Annotated[Real, Field(ge=0, le=1)] = _DEFAULT.colour
    shapes: Shapes = _DEFAULT.shapes

    def over(self, base: VariantRanges) -> VariantRanges:
        """`base` with the fields this model set replaced."""
        values = {name: getattr(base, name) for name in VariantRanges.__dataclass_fields__}
        return VariantRanges(**(values | {name: getattr(self, name)
                                          for name in self.model_fields_set if name in values}))


def _distractor_sizes(pair: tuple[float, float]) -> tuple[float, float]:
    low, high = DISTRACTOR_SIZES
    if not low <= pair[0] <= pair[1] <= high:
        raise ValueError(f"distractor sizes must lie in [{low * 100:g}cm, {high * 100:g}cm]")
    return pair


class DistractorFields(_Strict):
    size: Annotated[tuple[NonNegLength, NonNegLength], AfterValidator(_ordered),
                    AfterValidator(_distractor_sizes)] = _DISTRACTOR.size
    mass: Annotated[tuple[Mass, Mass], AfterValidator(_ordered)] = _DISTRACTOR.mass
    friction: Annotated[tuple[Friction, Friction], AfterValidator(_ordered)] = \
        _DISTRACTOR.friction
    shapes: Annotated[Shapes, Field(min_length=1)] = _DISTRACTOR.shapes
    clearance: Annotated[Length, Field(ge=0, le=MAX_POSITION)] = _DISTRACTOR.clearance


def _mesh(path: str, info: ValidationInfo) -> str:
    context = info.context or {}
    base = Path(context.get("base_dir", "."))
    resolved = (base / path).resolve()
    if not inside(resolved, [base, *context.get("allowed_dirs", ())]):
        raise ValueError(f"mesh `{excerpt(path)}` lies outside the ranges file's folder"
                         + (" and the allowed folders" if context.get("allowed_dirs") else ""))
    try:
        load_hull(resolved)
    except MeshLoadError as error:
        raise ValueError(str(error)) from None
    return str(resolved)


class RangesFile(RangeFields):
    """A ranges file: the per-object fields for every movable object, and the rest."""

    objects: dict[str, RangeFields] = {}
    meshes: Annotated[tuple[Annotated[str, AfterValidator(_mesh)], ...],
                      Field(max_length=MAX_MESHES)] = ()
    distractors: Annotated[tuple[Count, Count], BeforeValidator(_count),
                           AfterValidator(_ordered)] = _DISTRACTOR.count
    distractor: DistractorFields = DistractorFields()

    def ranges(self) -> Ranges:
        default = RangeFields.over(self, VariantRanges())
        d = self.distractor
        return Ranges(
            default=default,
            objects={name: fields.over(default) for name, fields in self.objects.items()},
            meshes=self.meshes,
            distractors=DistractorRanges(count=self.distractors, size=d.size, mass=d.mass,
                                         friction=d.friction, shapes=d.shapes,
                                         clearance=d.clearance))


def load_ranges(path: str | Path, scene: Scene | None = None, *,
                allowed_dirs: Sequence[str | os.PathLike[str]] = ()) -> Ranges:
    """Read and validate a ranges file (against `scene` when given); raises SceneError.
    Its meshes must lie in its folder tree or in one of `allowed_dirs`."""
    name = str(path)
    try:
        text = read_text(path)
    except FileProblem as problem:
        raise SceneError([SceneProblem(name, 1, 1, "", f"cannot read ranges file: {problem}")]
                         ) from None
    return parse_ranges(text, name, base_dir=Path(path).parent, scene=scene,
                        allowed_dirs=allowed_dirs)


def parse_ranges(text: str, file: str = "<ranges>", *, base_dir: str | Path = ".",
                 scene: Scene | None = None,
                 allowed_dirs: Sequence[str | os.PathLike[str]] = ()) -> Ranges:
    """Validate ranges YAML text; `file` names it in errors, meshes resolve against `base_dir`
    and must stay inside it or one of `allowed_dirs`."""
    root = _yaml_root(text, file)
    context = {"base_dir": str(base_dir), "allowed_dirs": list(allowed_dirs)}
    try:
        model = RangesFile.model_validate(_plain(root), context=context)
    except ValidationError as error:
        problems = [_problem(file, root, item) for item in error.errors()]
        raise SceneError(sorted(set(problems), key=lambda p: (p.line, p.column))) from None
    ranges = model.ranges()
    if scene is not None:
        problems = _against(scene, ranges, file, root)
        if problems:
            raise SceneError(problems)
    return ranges


def _yaml_root(text: str, file: str) -> Any:
    """The file's YAML read within the scene files' bounds (rapid_dsl/language/safe_yaml.py)."""
    try:
        root = read_yaml(text)
    except YamlProblem as problem:
        raise SceneError([SceneProblem(file, problem.line, problem.column, "",
                                       problem.message)]) from None
    if root is None:
        from ruamel.yaml.comments import CommentedMap

        return CommentedMap()   # an empty file: every default
    if not isinstance(root, dict):
        raise SceneError([SceneProblem(file, 1, 1, "", "a ranges file is a mapping of ranges "
                                                        "(see docs/variants.md)")])
    return root


def _against(scene: Scene, ranges: Ranges, file: str, root: Any) -> list[SceneProblem]:
    """What the file asks that this scene cannot give: unknown or static objects, `mesh` shapes
    without meshes, distractors without a surface."""
    problems = []

    def at(keys: tuple[str, ...], message: str) -> None:
        node, line, col = root, 1, 1
        for key in keys:
            if not (hasattr(node, "lc") and key in node):
                break
            line, col = node.lc.key(key)
            line, col = line + 1, col + 1
            node = node[key]
        problems.append(SceneProblem(file, line, col, ".".join(keys), message))

    movable = [obj.name for obj in scene.objects if obj.kind == "object"]
    for name in ranges.objects:
        if name not in {obj.name for obj in scene.objects}:
            at(("objects", name), f"the scene has no object `{name}` (its movable objects: "
                                  f"{', '.join(movable) or 'none'})")
        elif name not in movable:
            at(("objects", name), f"`{name}` is a {scene.object(name).kind}; only objects "
                                  "(kind `object`) vary")
    if not ranges.meshes:
        for name in movable:
            obj = scene.object(name)
            if "mesh" in ranges.for_object(name).shapes and obj.shape != "mesh":
                keys = ("objects", name, "shapes") if name in ranges.objects else ("shapes",)
                at(keys, f"shape `mesh` for the {obj.shape} `{name}` needs `meshes:` "
                         "(the hulls to use)")
                break
        if "mesh" in ranges.distractors.shapes and ranges.distractors.count[1] > 0:
            at(("distractor", "shapes"), "shape `mesh` for distractors needs `meshes:`")
    if ranges.distractors.count[1] > 0 and not any(obj.kind == "surface"
                                                   for obj in scene.objects):
        at(("distractors",), "the scene has no surface (kind `surface`) to place "
                             "distractors on")
    return problems
