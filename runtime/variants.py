"""Seeded scene variants: the task-agnostic perturbations that verification runs programs on.

Every movable object (kind `object`) gets its horizontal position, yaw, size, mass and friction
perturbed within relative or absolute bounds; fixtures, surfaces and the robot stay. An object keeps
its height above what it rests on: when its z extent changes, its centre moves so its bottom stays.
A per-program filter (the program's `filter` block) decides afterwards which variants keep the
task's meaning; this module only samples.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from rapid_dsl.runtime.scene import Scene


@dataclass(frozen=True, slots=True, kw_only=True)
class VariantRanges:
    """Half-widths of the uniform perturbations."""

    position: float = 0.02          # m, along x and y
    yaw: float = math.radians(15)   # rad
    size: float = 0.15              # relative, per axis
    mass: float = 0.3               # relative
    friction: float = 0.3           # relative


@dataclass(frozen=True, slots=True)
class ObjectChange:
    name: str
    dx: float
    dy: float
    dyaw: float
    size_scale: tuple[float, float, float]
    mass_scale: float
    friction_scale: float


@dataclass(frozen=True, slots=True)
class Variant:
    index: int
    seed: int
    changes: tuple[ObjectChange, ...]
    scene: Scene

    def describe(self) -> dict[str, object]:
        """The variant's parameters, for reports."""
        return {"index": self.index, "seed": self.seed,
                "objects": [asdict(change) for change in self.changes]}


def sample_variants(scene: Scene, count: int, *, seed: int = 0,
                    ranges: VariantRanges | None = None) -> list[Variant]:
    """`count` perturbed copies of `scene`, reproducible from `seed`."""
    ranges = ranges or VariantRanges()
    variants = []
    for index in range(count):
        rng = np.random.default_rng([seed, index])
        changed = scene
        changes = []
        for obj in scene.objects:
            if obj.kind != "object":
                continue
            change = _draw(obj.name, rng, ranges, obj.shape)
            changed = _apply(changed, change)
            changes.append(change)
        variants.append(Variant(index, seed, tuple(changes), changed))
    return variants


def _draw(name: str, rng: np.random.Generator, ranges: VariantRanges, shape: str) -> ObjectChange:
    def around_one(width: float) -> float:
        return float(1.0 + rng.uniform(-width, width))

    scale = [around_one(ranges.size) for _ in range(3)]
    if shape in ("cylinder", "sphere"):  # keep round things round
        scale[1] = scale[0]
        if shape == "sphere":
            scale[2] = scale[0]
    return ObjectChange(
        name=name,
        dx=float(rng.uniform(-ranges.position, ranges.position)),
        dy=float(rng.uniform(-ranges.position, ranges.position)),
        dyaw=float(rng.uniform(-ranges.yaw, ranges.yaw)),
        size_scale=(scale[0], scale[1], scale[2]),
        mass_scale=around_one(ranges.mass),
        friction_scale=around_one(ranges.friction),
    )


def _apply(scene: Scene, change: ObjectChange) -> Scene:
    obj = scene.object(change.name)
    extents = obj.extents
    size = tuple(e * s for e, s in zip(extents, change.size_scale, strict=True))
    x, y, z = obj.pose.position
    z += (size[2] - extents[2]) / 2.0  # the bottom stays where it was
    pose = obj.pose.model_dump() | {"position": (x + change.dx, y + change.dy, z),
                                    "yaw": obj.pose.yaw + change.dyaw}
    changes: dict[str, object] = {"pose": pose, "friction": obj.friction * change.friction_scale}
    if obj.shape != "mesh" or obj.size is not None:
        changes["size"] = _size_field(obj.shape, size)
    if obj.mass is not None:
        changes["mass"] = obj.mass * change.mass_scale
    return scene.with_object(change.name, **changes)


def _size_field(shape: str, size: tuple[float, ...]) -> tuple[float, ...]:
    if shape == "cylinder":
        return (size[0], size[2])
    if shape == "sphere":
        return (size[0],)
    return size
