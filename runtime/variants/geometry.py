"""Geometry the variant sampler needs: heights, footprints, supports and box overlap.

Every scene object is seen as a `Solid`: its centre, rotation R = Rz(yaw) Ry(pitch) Rx(roll), full
extents along its own axes, and for meshes the hull scaled to those extents. Heights (how far the
lowest and highest points lie below and above the centre) are exact per shape; overlap tests use
oriented bounding boxes, which contain every shape, so "no overlap" is conservative. No MuJoCo here.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from rapid_dsl.runtime.scenes.meshes import load_hull
from rapid_dsl.runtime.scenes.scene import Scene, SceneObject

SUPPORT_TOLERANCE = 0.002   # m: a bottom this close to a top rests on it
FLOOR = "floor"


def rotation(yaw: float, pitch: float = 0.0, roll: float = 0.0) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll), the scene files' convention."""
    cy, sy = math.cos(yaw), math.sin(yaw)
    cp, sp = math.cos(pitch), math.sin(pitch)
    cr, sr = math.cos(roll), math.sin(roll)
    rz = np.array([[cy, -sy, 0.0], [sy, cy, 0.0], [0.0, 0.0, 1.0]])
    ry = np.array([[cp, 0.0, sp], [0.0, 1.0, 0.0], [-sp, 0.0, cp]])
    rx = np.array([[1.0, 0.0, 0.0], [0.0, cr, -sr], [0.0, sr, cr]])
    return rz @ ry @ rx


def round_diameter(extents: Sequence[float] | np.ndarray) -> float:
    """The diameter a box of these extents has as a cylinder: sqrt(x y), about its footprint."""
    return math.sqrt(float(extents[0]) * float(extents[1]))


@dataclass(frozen=True)
class Solid:
    """An object's placed shape."""

    name: str
    shape: str
    centre: np.ndarray       # (3,)
    rotation: np.ndarray     # (3, 3)
    extents: np.ndarray      # (3,) full size along its own axes
    mesh: str | None = None

    @classmethod
    def of(cls, obj: SceneObject) -> Solid:
        pose = obj.pose
        return cls(obj.name, obj.shape, np.asarray(pose.position, dtype=float),
                   rotation(pose.yaw, pose.pitch, pose.roll),
                   np.asarray(obj.extents, dtype=float), obj.mesh)

    @cached_property
    def _heights(self) -> tuple[float, float]:
        """(below, above): distances from the centre down to the lowest and up to the highest
        point of the shape."""
        r, half = self.rotation, self.extents / 2
        if self.shape == "mesh" and self.mesh is not None:
            heights = (load_hull(self.mesh).scaled(self.extents) @ r.T)[:, 2]
            return float(-heights.min()), float(heights.max())
        if self.shape == "sphere":
            return float(half[0]), float(half[0])
        if self.shape == "cylinder":
            axis_z = abs(r[2, 2])
            h = axis_z * half[2] + half[0] * math.sqrt(max(0.0, 1.0 - axis_z**2))
            return h, h
        h = float(np.abs(r[2]) @ half)
        return h, h

    @property
    def bottom(self) -> float:
        return float(self.centre[2]) - self._heights[0]

    @property
    def top(self) -> float:
        return float(self.centre[2]) + self._heights[1]

    @property
    def below(self) -> float:
        """Height of the centre above the lowest point."""
        return self._heights[0]

    @property
    def is_level(self) -> bool:
        """Whether its own z axis is vertical (up or down), so its top and bottom are level."""
        return abs(abs(self.rotation[2, 2]) - 1.0) < 1e-9

    @property
    def has_flat_top(self) -> bool:
        return self.is_level and self.shape in ("box", "cylinder", "mesh")

    def corners(self) -> np.ndarray:
        """(8, 3) corners of the oriented bounding box."""
        signs = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
        return self.centre + (signs * self.extents / 2) @ self.rotation.T

    def covers(self, points_xy: np.ndarray, margin: float = 0.0) -> bool:
        """Whether every point lies over this solid's top face, at least `margin` inside it
        (level solids only: a box or mesh by its rectangle, a cylinder by its disc)."""
        local = (np.asarray(points_xy, float) - self.centre[:2]) @ self.rotation[:2, :2]
        half = self.extents[:2] / 2 - margin
        if np.any(half < 0):
            return False
        if self.shape == "cylinder":
            return bool(np.all(np.hypot(local[:, 0], local[:, 1]) <= half[0] + 1e-9))
        return bool(np.all(np.abs(local) <= half + 1e-9))


def overlap(a: Solid, b: Solid, clearance: float = 0.0, tolerance: float = 1e-6) -> bool:
    """Whether the oriented bounding boxes of `a` and `b`, each grown by clearance/2 on every side,
    overlap by more than `tolerance` (separating-axis test over the 15 candidate axes)."""
    ha, hb = a.extents / 2 + clearance / 2, b.extents / 2 + clearance / 2
    ra, rb = a.rotation, b.rotation
    d = b.centre - a.centre
    axes = [ra[:, i] for i in range(3)] + [rb[:, i] for i in range(3)]
    axes += [np.cross(ra[:, i], rb[:, j]) for i in range(3) for j in range(3)]
    for axis in axes:
        norm = float(np.linalg.norm(axis))
        if norm < 1e-9:
            continue   # parallel edges: the face axes already cover this direction
        axis = axis / norm
        reach = float(np.abs(axis @ ra) @ ha + np.abs(axis @ rb) @ hb)
        if abs(float(axis @ d)) >= reach - tolerance:
            return False
    return True


def supports(scene: Scene) -> dict[str, str | None]:
    """What each movable object rests on: the name of the object whose level top is at its bottom
    (within SUPPORT_TOLERANCE) under its centre, the highest such; `floor` if its bottom is at the
    floor; None if neither (it leans, floats or sits in something)."""
    solids = {obj.name: Solid.of(obj) for obj in scene.objects}
    found: dict[str, str | None] = {}
    for obj in scene.objects:
        if obj.kind != "object":
            continue
        solid = solids[obj.name]
        best: tuple[float, str] | None = None
        for other in solids.values():
            if other.name == obj.name or not other.has_flat_top:
                continue
            if abs(solid.bottom - other.top) <= SUPPORT_TOLERANCE \
                    and other.covers(solid.centre[None, :2]):
                if best is None or other.top > best[0]:
                    best = (other.top, other.name)
        if best is not None:
            found[obj.name] = best[1]
        elif abs(solid.bottom - scene.floor_height) <= SUPPORT_TOLERANCE:
            found[obj.name] = FLOOR
        else:
            found[obj.name] = None
    return found


def support_order(names: Sequence[str], support: dict[str, str | None]) -> list[str]:
    """`names` with every object after the movable object it rests on (file order otherwise)."""
    order: list[str] = []
    placed: set[str] = set()

    def place(name: str, seen: frozenset[str]) -> None:
        if name in placed or name in seen:
            return
        below = support.get(name)
        if below in support:   # rests on another movable object: that one first
            place(below, seen | {name})
        placed.add(name)
        order.append(name)

    for name in names:
        place(name, frozenset())
    return order
