"""Seeded scene variants: the task-agnostic perturbations that verification runs programs on.

A variant is a pure function of (scene, seed, index, ranges). Every movable object (kind `object`)
changes within its ranges (runtime/variants/ranges.py): position along x and y, yaw, size per axis,
shape (opt-in: box, cylinder or a mesh stretched to its extents), mass, friction, restitution and
colour; fixtures, surfaces and the robot stay. Distractor objects may be added on the surfaces,
clear of everything else. An object keeps resting on what it rests on (variant_geometry.supports):
its bottom goes to its support's new top, an object on another movable object moves with it, and
an object that lay wholly on its support's top still does. A draw that breaks that, makes two
things interpenetrate (robot included, checked on the MuJoCo model) or is not a valid scene is
drawn again: attempt k draws from the stream [seed, index, k], up to MAX_ATTEMPTS.

A per-program filter (the program's `filter` block) decides afterwards which variants keep the
task's meaning; this module only samples.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import asdict, dataclass
from typing import Any

import numpy as np
from pydantic import ValidationError

from rapid_dsl.runtime.scenes.scene import Scene, SceneObject
from rapid_dsl.runtime.scenes.schema import (
    FRICTION_RANGE,
    MASS_RANGE,
    MAX_OBJECTS,
    RESTITUTION_RANGE,
    SIZE_RANGE,
)
from rapid_dsl.runtime.variants.check import inspect
from rapid_dsl.runtime.variants.geometry import (
    FLOOR,
    Solid,
    overlap,
    rotation,
    round_diameter,
    support_order,
    supports,
)
from rapid_dsl.runtime.variants.ranges import (
    DistractorRanges,
    Ranges,
    VariantRanges,
    as_ranges,
)

__all__ = ["MAX_SEED", "MAX_VARIANTS", "ObjectChange", "Distractor", "Variant", "VariantError",
           "Rejected", "VariantRanges", "Ranges", "VariantSampler", "sample_variant",
           "sample_variants"]

MAX_VARIANTS = 10_000     # per command run; each costs a few ms (one MuJoCo model build per draw)
MAX_SEED = 2**63 - 1
MAX_ATTEMPTS = 50         # draws per variant before giving up
PLACEMENT_TRIES = 100     # positions tried per distractor within one draw
_DRAWS = 14               # uniforms per object per draw, fixed: one range never shifts another's


@dataclass(frozen=True, slots=True)
class ObjectChange:
    name: str
    dx: float
    dy: float
    dyaw: float
    size_scale: tuple[float, float, float]   # of the extents after the shape change
    mass_scale: float
    friction_scale: float
    shape: str
    restitution: float
    rgba: tuple[float, float, float, float]


@dataclass(frozen=True, slots=True)
class Distractor:
    name: str
    support: str
    shape: str
    size: tuple[float, float, float]
    position: tuple[float, float, float]
    yaw: float
    mass: float
    friction: float
    rgba: tuple[float, float, float, float]
    mesh: str | None = None


@dataclass(frozen=True, slots=True)
class Variant:
    index: int
    seed: int
    changes: tuple[ObjectChange, ...]
    scene: Scene
    distractors: tuple[Distractor, ...] = ()
    attempts: int = 1      # draws it took

    def describe(self) -> dict[str, object]:
        """The variant's parameters, for reports."""
        return {"index": self.index, "seed": self.seed, "attempts": self.attempts,
                "objects": [asdict(change) for change in self.changes],
                "distractors": [asdict(d) for d in self.distractors]}


class VariantError(ValueError):
    """No variant can be drawn: the scene or the ranges leave no room (the message says why)."""


class Rejected(Exception):
    """One draw broke a rule; the message (without numbers) says which, for the summary."""


class VariantSampler:
    """Draws the variants of one scene under one set of ranges (the scene's analysis is shared)."""

    def __init__(self, scene: Scene, ranges: VariantRanges | Ranges | None = None):
        self.scene = scene
        self.ranges = as_ranges(ranges)
        self._objects = {obj.name: obj for obj in scene.objects}
        self._solids = {obj.name: Solid.of(obj) for obj in scene.objects}
        self._support = supports(scene)
        movable = [obj.name for obj in scene.objects if obj.kind == "object"]
        self._order = support_order(movable, self._support)
        self._row = {name: i for i, name in enumerate(movable)}
        self._wholly_on = {name: self._on_top(self._solids[name], below, whole=True)
                           for name, below in self._support.items()}
        self._surfaces = [self._solids[obj.name] for obj in scene.objects
                          if obj.kind == "surface" and self._solids[obj.name].has_flat_top]
        self._check_ranges(movable)
        try:
            self._base_contacts = inspect(scene).penetrating
        except ValueError as error:
            raise VariantError(str(error)) from None

    def _check_ranges(self, movable: list[str]) -> None:
        distractors = self.ranges.distractors
        if not movable and distractors.count[1] == 0:
            raise VariantError("the scene has no objects (kind `object`) to vary and the ranges "
                               "add no distractors")
        if len(self._objects) + distractors.count[1] > MAX_OBJECTS:
            raise VariantError(f"the scene has {len(self._objects)} objects: with up to "
                               f"{distractors.count[1]} distractors it would hold more than the "
                               f"{MAX_OBJECTS} a scene may hold")
        if distractors.count[1] > 0 and not self._surfaces:
            raise VariantError("the scene has no level surface (kind `surface`) to place "
                               "distractors on")
        if not self.ranges.meshes:
            wanting = [n for n in movable if "mesh" in self.ranges.for_object(n).shapes
                       and self._objects[n].shape != "mesh"]
            if wanting or ("mesh" in distractors.shapes and distractors.count[1] > 0):
                who = f"`{wanting[0]}`" if wanting else "distractors"
                raise VariantError(f"shape `mesh` for {who} needs meshes to use (`meshes:`)")

    def sample(self, seed: int, index: int) -> Variant:
        """Variant `index` of `seed`; raises VariantError after MAX_ATTEMPTS rejected draws."""
        reasons: Counter[str] = Counter()
        for attempt in range(MAX_ATTEMPTS):
            rng = np.random.default_rng([seed, index, attempt])
            try:
                scene, changes, distractors = self._draw(rng)
            except Rejected as rejected:
                reasons[str(rejected)] += 1
                continue
            return Variant(index, seed, changes, scene, distractors, attempt + 1)
        reason, times = reasons.most_common(1)[0]
        raise VariantError(f"variant {index} of seed {seed}: every one of {MAX_ATTEMPTS} draws "
                           f"was rejected, most often ({times}x) because {reason}; "
                           "narrow the ranges")

    # --- one draw --------------------------------------------------------------------------

    def _draw(self, rng: np.random.Generator
              ) -> tuple[Scene, tuple[ObjectChange, ...], tuple[Distractor, ...]]:
        uniforms = rng.random((len(self._row), _DRAWS))
        solids = dict(self._solids)
        changed: dict[str, dict[str, Any]] = {}
        changes: dict[str, ObjectChange] = {}
        for name in self._order:
            change, solid, fields = self._change(self._objects[name], uniforms[self._row[name]],
                                                 solids)
            solids[name], changed[name], changes[name] = solid, fields, change
        objects = [obj.model_dump() | changed.get(obj.name, {}) for obj in self.scene.objects]
        scene, distractors = self._complete(rng, solids, objects, self._surfaces)
        return scene, tuple(changes[n] for n in self._row), distractors

    def distract(self, rng: np.random.Generator, *, on: str | None = None
                 ) -> tuple[Scene, tuple[Distractor, ...]]:
        """The scene itself, unchanged but for the ranges' distractors (on the surface `on`,
        else on any level surface), validated and checked as a variant is; raises Rejected.
        The benchmark's test scenes (rapid_dsl/bench/nonprehensile/scenes.py) add their distractors
        so."""
        surfaces = self._surfaces
        if on is not None:
            surfaces = [s for s in self._surfaces if s.name == on]
            if not surfaces:
                raise VariantError(f"`{on}` is no level surface (kind `surface`) of the scene "
                                   "to place distractors on")
        return self._complete(rng, dict(self._solids),
                              [obj.model_dump() for obj in self.scene.objects], surfaces)

    def _complete(self, rng: np.random.Generator, solids: dict[str, Solid],
                  objects: list[dict[str, Any]], surfaces: list[Solid]
                  ) -> tuple[Scene, tuple[Distractor, ...]]:
        """Add the distractors to the drawn objects, then validate and check the scene."""
        distractors = self._distractors(rng, solids, surfaces)
        objects += [_distractor_fields(d) for d in distractors]
        try:
            scene = Scene.model_validate(self.scene.model_dump() | {"objects": objects,
                                                                    "source": self.scene.source})
        except ValidationError as error:
            first = error.errors()[0]
            where = ".".join(str(part) for part in first["loc"] if _is_key(part))
            raise Rejected(f"the variant is not a valid scene ({where}: {first['msg']})"
                            ) from None
        self._check_physics(scene, distractors)
        return scene, distractors

    def _change(self, obj: SceneObject, u: np.ndarray, solids: dict[str, Solid]
                ) -> tuple[ObjectChange, Solid, dict[str, Any]]:
        ranges = self.ranges.for_object(obj.name)
        base = self._solids[obj.name]
        shape, mesh, extents = self._shape(obj, ranges, u[12], u[13])
        scale = np.array([_between(1 - ranges.size, 1 + ranges.size, _ratio(SIZE_RANGE, e), v)
                          for e, v in zip(extents, u[0:3], strict=True)])
        if shape == "cylinder":
            scale[1] = scale[0]   # keep round things round
        elif shape == "sphere":
            scale[:] = scale[0]
        extents = extents * scale
        dx, dy, dyaw = (2 * u[3:6] - 1) * (ranges.position, ranges.position, ranges.yaw)
        below = self._support[obj.name]
        carried = np.zeros(2)
        bottom = base.bottom
        if below is not None and below != FLOOR:
            old, new = self._solids[below], solids[below]
            carried = new.centre[:2] - old.centre[:2]
            bottom = new.top + (base.bottom - old.top)   # the same gap as before (mostly none)
        pose = obj.pose
        rot = rotation(pose.yaw + dyaw, pose.pitch, pose.roll)
        xy = base.centre[:2] + carried + (dx, dy)
        solid = _standing(obj.name, shape, mesh, xy, bottom, rot, extents)
        if below is not None and below != FLOOR \
                and not self._on_top(solid, below, whole=self._wholly_on[obj.name], now=solids):
            raise Rejected(f"`{obj.name}` would leave the top of `{below}`")
        mass_scale = _between(1 - ranges.mass, 1 + ranges.mass,
                              _ratio(MASS_RANGE, obj.mass or 1.0), u[6])
        friction_scale = _between(1 - ranges.friction, 1 + ranges.friction,
                                  _ratio(FRICTION_RANGE, obj.friction), u[7])
        restitution = _round(_between(obj.restitution - ranges.restitution,
                                      obj.restitution + ranges.restitution, RESTITUTION_RANGE,
                                      u[8]))
        rgba = obj.rgba or (0.0, 0.0, 0.0, 1.0)
        red, green, blue = (_round(_between(c - ranges.colour, c + ranges.colour, (0.0, 1.0), v))
                            for c, v in zip(rgba[:3], u[9:12], strict=True))
        rgba4 = (red, green, blue, rgba[3])
        fields: dict[str, Any] = {
            "shape": shape, "mesh": mesh, "size": _size_field(shape, extents),
            "pose": pose.model_dump() | {"position": _rounded(solid.centre),
                                         "yaw": _round(pose.yaw + dyaw)},
            "friction": _round(obj.friction * friction_scale), "restitution": restitution,
            "rgba": rgba4,
        }
        if obj.mass is not None:
            fields["mass"] = _round(obj.mass * mass_scale)
        change = ObjectChange(obj.name, float(dx), float(dy), float(dyaw),
                              (float(scale[0]), float(scale[1]), float(scale[2])),
                              float(mass_scale), float(friction_scale), shape, restitution,
                              rgba4)
        return change, solid, fields

    def _shape(self, obj: SceneObject, ranges: VariantRanges, u_shape: float, u_mesh: float
               ) -> tuple[str, str | None, np.ndarray]:
        """The object's new shape, its mesh file and its extents before scaling."""
        extents = np.asarray(obj.extents, dtype=float)
        if obj.shape == "sphere" or not ranges.shapes:
            return obj.shape, obj.mesh, extents
        shape = ranges.shapes[min(int(u_shape * len(ranges.shapes)), len(ranges.shapes) - 1)]
        if shape == "cylinder":
            diameter = round_diameter(extents)
            return shape, None, np.array([diameter, diameter, extents[2]])
        if shape == "mesh":
            meshes = self.ranges.meshes
            mesh = obj.mesh if obj.mesh is not None else \
                meshes[min(int(u_mesh * len(meshes)), len(meshes) - 1)]
            return shape, mesh, extents
        return shape, None, extents

    def _on_top(self, solid: Solid, below: str | None, *, whole: bool,
                now: dict[str, Solid] | None = None) -> bool:
        """Whether `solid` lies over the top face of its support (wholly, or its centre)."""
        if below is None or below == FLOOR:
            return True
        support = (now or self._solids)[below]
        points = solid.corners()[:, :2] if whole else solid.centre[None, :2]
        return support.covers(points)

    def _distractors(self, rng: np.random.Generator, solids: dict[str, Solid],
                     surfaces: list[Solid]) -> tuple[Distractor, ...]:
        ranges = self.ranges.distractors
        low, high = ranges.count
        count = int(rng.integers(low, high + 1))
        placed: list[Distractor] = []
        taken = set(self._objects)
        for k in range(count):
            name = _free_name(f"distractor_{k}", taken)
            taken.add(name)
            distractor = self._place(name, rng, ranges, solids, surfaces)
            if distractor is None:
                raise Rejected(f"there is no room for {count} distractors on the surfaces")
            placed.append(distractor)
        return tuple(placed)

    def _place(self, name: str, rng: np.random.Generator, ranges: DistractorRanges,
               solids: dict[str, Solid], surfaces: list[Solid]) -> Distractor | None:
        shape = ranges.shapes[int(rng.integers(len(ranges.shapes)))]
        mesh = None
        if shape == "mesh":
            mesh = self.ranges.meshes[int(rng.integers(len(self.ranges.meshes)))]
        extents = np.array(_rounded(rng.uniform(*ranges.size, size=3)))
        if shape == "cylinder":
            extents[1] = extents[0]
        mass = _round(rng.uniform(*ranges.mass))
        friction = _round(rng.uniform(*ranges.friction))
        red, green, blue = _rounded(rng.uniform(0.15, 0.95, size=3))
        reach = math.hypot(extents[0], extents[1]) / 2   # fits on the top at any yaw
        for _ in range(PLACEMENT_TRIES):
            support = surfaces[int(rng.integers(len(surfaces)))]
            yaw = _round(rng.uniform(-math.pi, math.pi))
            room = support.extents[:2] / 2 - reach
            local = rng.uniform(-1.0, 1.0, size=2)
            if np.any(room < 0):
                continue
            if support.shape == "cylinder":
                if np.hypot(*local) > 1.0:
                    continue   # uniform on the disc: keep the points of the square inside it
                room = np.full(2, room[0])
            xy = np.array(_rounded(support.centre[:2] + support.rotation[:2, :2] @ (local * room)))
            solid = _standing(name, shape, mesh, xy, support.top, rotation(yaw), extents)
            z = _round(solid.centre[2])
            if any(overlap(solid, other, ranges.clearance) for other in solids.values()
                   if other.name != support.name):
                continue
            solids[name] = solid
            return Distractor(name, support.name, shape,
                              (float(extents[0]), float(extents[1]), float(extents[2])),
                              (float(xy[0]), float(xy[1]), z), yaw, mass, friction,
                              (red, green, blue, 1.0), mesh)
        return None

    def _check_physics(self, scene: Scene, distractors: tuple[Distractor, ...]) -> None:
        clearance = self.ranges.distractors.clearance
        try:
            contacts = inspect(scene, near=[d.name for d in distractors], within=clearance)
        except ValueError as error:
            raise Rejected(f"its MuJoCo model cannot be built ({error})") from None
        new = sorted(contacts.penetrating - self._base_contacts)
        if new:
            a, b = new[0]
            raise Rejected(f"`{a}` and `{b}` would interpenetrate")
        if contacts.near_robot:
            raise Rejected("a distractor would come within its clearance of the robot")


def sample_variant(scene: Scene, seed: int, index: int,
                   ranges: VariantRanges | Ranges | None = None) -> Variant:
    """Variant `index` of `scene` for `seed`."""
    return VariantSampler(scene, ranges).sample(seed, index)


def sample_variants(scene: Scene, count: int, *, seed: int = 0,
                    ranges: VariantRanges | Ranges | None = None) -> list[Variant]:
    """`count` perturbed copies of `scene`, reproducible from `seed`."""
    sampler = VariantSampler(scene, ranges)
    return [sampler.sample(seed, index) for index in range(count)]


def _standing(name: str, shape: str, mesh: str | None, xy: np.ndarray, bottom: float,
              rot: np.ndarray, extents: np.ndarray) -> Solid:
    """The solid placed at `xy` with its lowest point at height `bottom`."""
    probe = Solid(name, shape, np.array([xy[0], xy[1], 0.0]), rot, extents, mesh)
    return Solid(name, shape, np.array([xy[0], xy[1], bottom + probe.below]), rot, extents, mesh)


def _between(low: float, high: float, bounds: tuple[float, float], u: float) -> float:
    """`u` in [0, 1) mapped onto [low, high] cut to `bounds` (the scene files' own bounds, so a
    draw never fails validation for a number the base scene had room for)."""
    low, high = max(low, bounds[0]), min(high, bounds[1])
    return float(low + u * (high - low))


def _ratio(bounds: tuple[float, float], value: float) -> tuple[float, float]:
    """The scale factors that keep `value` within `bounds`."""
    if value <= 0:
        return (-math.inf, math.inf)
    return (bounds[0] / value, bounds[1] / value)


def _round(value: float) -> float:
    """Sampled numbers keep 9 decimals (nm, nrad, ug): the file a variant is written to holds
    exactly the numbers of the in-memory scene."""
    return round(float(value), 9)


def _rounded(values: Any) -> tuple[float, ...]:
    return tuple(_round(v) for v in values)


def _distractor_fields(d: Distractor) -> dict[str, Any]:
    return {"name": d.name, "kind": "object", "label": "distractor", "shape": d.shape,
            "mesh": d.mesh, "size": _size_field(d.shape, d.size),
            "pose": {"position": d.position, "yaw": d.yaw}, "mass": d.mass,
            "friction": d.friction, "rgba": d.rgba}


def _size_field(shape: str, size: Any) -> tuple[float, ...]:
    """Full extents as a scene file writes them for the shape."""
    if shape == "cylinder":
        return _rounded((size[0], size[2]))
    if shape == "sphere":
        return _rounded((size[0],))
    return _rounded(size[:3])


def _free_name(name: str, taken: set[str]) -> str:
    candidate, n = name, 1
    while candidate in taken:
        candidate, n = f"{name}_{n}", n + 1
    return candidate


def _is_key(part: object) -> bool:
    # pydantic puts validator tags such as `function-after[...]` into locations; they are no keys
    return isinstance(part, int) or ("[" not in str(part) and "-" not in str(part))
