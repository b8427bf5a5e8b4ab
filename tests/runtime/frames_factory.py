"""Synthetic `Frames` from numpy arrays: entity boxes at given poses, no MuJoCo involved."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from rapid_dsl.runtime.frames import Entity, EntityTable, Frames


def quat_about(axis: Sequence[float], angle: float) -> np.ndarray:
    """Unit quaternion (w x y z) rotating by `angle` about `axis`."""
    axis = np.asarray(axis, dtype=float)
    axis = axis / np.linalg.norm(axis)
    return np.concatenate([[np.cos(angle / 2)], np.sin(angle / 2) * axis])


def quat_yaw(angle: float) -> np.ndarray:
    return quat_about([0, 0, 1], angle)


def quat_mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product of (..., 4) quaternions."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    w1, v1 = a[..., 0], a[..., 1:]
    w2, v2 = b[..., 0], b[..., 1:]
    w = w1 * w2 - (v1 * v2).sum(-1)
    v = w1[..., None] * v2 + w2[..., None] * v1 + np.cross(v1, v2)
    return np.concatenate([w[..., None], v], axis=-1)


@dataclass
class Body:
    """One entity; pos/quat/linvel/angvel broadcast to (B, T, 3|4)."""

    name: str
    kind: str
    extents: Sequence[float]
    pos: Sequence[float] | np.ndarray
    quat: Sequence[float] | np.ndarray = (1.0, 0.0, 0.0, 0.0)
    shape: str = "box"
    linvel: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0)
    angvel: Sequence[float] | np.ndarray = (0.0, 0.0, 0.0)
    label: str = field(default="")


def make_frames(
    bodies: Sequence[Body],
    *,
    batch: int = 1,
    steps: int = 1,
    contacts: Sequence[tuple[str, str]] = (),
    grasped: Sequence[str] = (),
    opening: float = 0.08,
    robot_base: Sequence[float] = (0.0, 0.0, 0.0),
    robot_reach: float = 0.85,
) -> Frames:
    """Frames of B x T states in which every body has the given (broadcast) pose and velocities."""
    n = len(bodies)
    names = [b.name for b in bodies]

    def stack(attr: str, width: int) -> np.ndarray:
        return np.stack(
            [np.broadcast_to(np.asarray(getattr(b, attr), dtype=float), (batch, steps, width))
             for b in bodies], axis=2).copy()

    contact = np.zeros((batch, steps, n, n), dtype=bool)
    for a, b in contacts:
        i, j = names.index(a), names.index(b)
        contact[:, :, i, j] = contact[:, :, j, i] = True
    # a grasped body: both fingers touch it, pressing along world y (an unturned gripper's
    # opening axis) from either side
    fingers = np.zeros((batch, steps, n, 2), dtype=bool)
    normals = np.zeros((batch, steps, n, 2, 3))
    for name in grasped:
        fingers[:, :, names.index(name)] = True
        normals[:, :, names.index(name)] = [[0.0, 1.0, 0.0], [0.0, -1.0, 0.0]]
    table = EntityTable(
        entities=tuple(
            Entity(i, b.name, b.kind, b.label or b.name, b.shape, np.asarray(b.extents, float))
            for i, b in enumerate(bodies)),
        robot_base=np.asarray(robot_base, dtype=float),
        robot_reach=robot_reach,
    )
    return Frames(
        time=np.linspace(0.0, 0.1 * (steps - 1), steps),
        pos=stack("pos", 3), quat=stack("quat", 4), linvel=stack("linvel", 3),
        angvel=stack("angvel", 3), contact=contact, fingers=fingers, finger_normals=normals,
        opening=np.full((batch, steps), opening), entities=table,
    )


def tabletop(**bodies: Body) -> list[Body]:
    """A table top (1 x 1 m, top at z = 0) plus a gripper, then the given bodies."""
    base = [
        Body("table", "Surface", (1.0, 1.0, 0.04), (0.5, 0.0, -0.02)),
        Body("gripper", "Manipulator", (0.02, 0.08, 0.05), (0.3, 0.0, 0.3)),
    ]
    return base + list(bodies.values())
