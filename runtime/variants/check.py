"""The physics check of a sampled variant, on its own MuJoCo model in its start state.

A contact deeper than PENETRATION is an interpenetration (robot geometry included); a pair that
already interpenetrates in the base scene is the scene's own and not held against a variant.
Distractors must also keep their clearance from the robot's geometry (exact geom distances).
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass

import mujoco

from rapid_dsl.runtime.scenes.scene import Scene
from rapid_dsl.runtime.scenes.world import World, build_world

PENETRATION = 1e-4   # m: contacts deeper than this interpenetrate
ROBOT = "robot"
FLOOR = "floor"


def _owners(world: World) -> list[str]:
    """Per geom, the scene object it belongs to, `floor` (the world body) or `robot`."""
    names = {obj.name for obj in world.scene.objects}
    model = world.model
    owners = []
    for geom in range(model.ngeom):
        body = int(model.geom_bodyid[geom])
        name = model.body(body).name
        owners.append(FLOOR if body == 0 else name if name in names else ROBOT)
    return owners


@dataclass(frozen=True, slots=True)
class Contacts:
    penetrating: frozenset[tuple[str, str]]   # sorted name pairs
    near_robot: dict[str, float]              # object -> distance, for those closer than asked


def inspect(scene: Scene, *, near: Iterable[str] = (), within: float = 0.0) -> Contacts:
    """The pairs that interpenetrate in the scene's start state, and which of the objects `near`
    lie closer than `within` to the robot's geometry. Raises ValueError when the scene's world
    cannot be built (see `build_world`)."""
    world = build_world(scene)
    data = world.make_data()
    model = world.model
    owners = _owners(world)
    pairs = set()
    for i in range(data.ncon):
        contact = data.contact[i]
        if contact.dist < -PENETRATION:
            a, b = sorted((owners[contact.geom1], owners[contact.geom2]))
            pairs.add((a, b))
    wanted = set(near)
    robot = [g for g in range(model.ngeom) if owners[g] == ROBOT
             and (model.geom_contype[g] or model.geom_conaffinity[g])] if wanted else []
    close: dict[str, float] = {}
    for geom in range(model.ngeom):
        if owners[geom] not in wanted:
            continue
        for other in robot:
            distance = float(mujoco.mj_geomDistance(model, data, geom, other, within, None))
            if distance < within:
                close[owners[geom]] = min(distance, close.get(owners[geom], math.inf))
    return Contacts(frozenset(pairs), close)
