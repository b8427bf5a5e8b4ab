"""Recorded states of a batch of rollouts: what builtins and compiled costs read.

`Frames` holds B rollouts x T recorded time points of every scene entity. Builtins take a `Frames`
and entity indices and return arrays shaped (B, T) for quantities and (B, T, 3) for vectors, so one
call evaluates a whole CEM population over the whole trajectory at once. Index 0 in time is always
the state at the running primitive's start; `start` keeps it when a view drops the other time
points.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Literal

import numpy as np

from rapid_dsl.language.kinds import KIND_PARENTS, is_subkind  # noqa: F401 - re-exported

EntityKind = Literal["Object", "Fixture", "Surface", "Manipulator"]

@dataclass(frozen=True, slots=True)
class Entity:
    """A scene entity as programs see it."""

    index: int
    name: str
    kind: EntityKind
    label: str
    shape: str                      # box | cylinder | sphere | mesh | plane | gripper
    extents: np.ndarray             # (3,) full size along the body's own axes [m]


@dataclass(frozen=True, slots=True)
class EntityTable:
    entities: tuple[Entity, ...]
    robot_base: np.ndarray          # (3,) world position of the robot's base [m]
    robot_reach: float              # workspace radius around the base [m]

    def index(self, name: str) -> int:
        for entity in self.entities:
            if entity.name == name:
                return entity.index
        raise KeyError(name)

    @property
    def extents(self) -> np.ndarray:
        """(E, 3) full sizes of every entity."""
        return np.stack([e.extents for e in self.entities])


@dataclass(frozen=True, slots=True)
class Frames:
    """B rollouts x T time points of E entities."""

    time: np.ndarray                # (T,) seconds since the primitive's start
    pos: np.ndarray                 # (B, T, E, 3) world position of each entity's centre [m]
    quat: np.ndarray                # (B, T, E, 4) world orientation, w x y z
    linvel: np.ndarray              # (B, T, E, 3) [m/s]
    angvel: np.ndarray              # (B, T, E, 3) [rad/s]
    contact: np.ndarray             # (B, T, E, E) bool, symmetric: MuJoCo contact between entities
    fingers: np.ndarray             # (B, T, E, 2) bool: the left/right finger touches entity e
    finger_normals: np.ndarray      # (B, T, E, 2, 3) normal of that finger's deepest contact with
                                    # e, world frame, from the finger toward e (0 where none)
    opening: np.ndarray             # (B, T) distance between the gripper fingers [m]
    entities: EntityTable
    start: Frames | None = field(default=None, repr=False)  # T=1 view of the first time point

    @property
    def batch(self) -> int:
        return self.pos.shape[0]

    @property
    def steps(self) -> int:
        return self.pos.shape[1]

    def first(self) -> Frames:
        """The state at the primitive's start, as a T=1 view."""
        if self.start is not None:
            return self.start
        return self._slice(slice(0, 1), start=None)

    def last(self) -> Frames:
        """The terminal state, as a T=1 view that still knows the start."""
        return self._slice(slice(-1, None), start=self.first())

    def _slice(self, index: slice, *, start: Frames | None) -> Frames:
        return replace(
            self,
            time=self.time[index],
            pos=self.pos[:, index],
            quat=self.quat[:, index],
            linvel=self.linvel[:, index],
            angvel=self.angvel[:, index],
            contact=self.contact[:, index],
            fingers=self.fingers[:, index],
            finger_normals=self.finger_normals[:, index],
            opening=self.opening[:, index],
            start=start,
        )

    def take(self, sample: int) -> Frames:
        """One rollout of the batch, keeping B=1."""
        pick = slice(sample, sample + 1)
        start = self.start.take(sample) if self.start is not None else None
        return replace(
            self,
            pos=self.pos[pick], quat=self.quat[pick], linvel=self.linvel[pick],
            angvel=self.angvel[pick], contact=self.contact[pick], fingers=self.fingers[pick],
            finger_normals=self.finger_normals[pick], opening=self.opening[pick], start=start,
        )
