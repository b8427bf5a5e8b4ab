"""Record the track of a run (`rapidc run --track`): the executed motions replayed and sampled.

The executor keeps every motion it executed as (start state, controls) (`Executor.motions`, the
same list `Executor.states` renders video from). Replaying one at the world's timestep is the
code path that executed it (`Simulator.replay`), so the frames are the executed motion bit for
bit and the last one is the run's final state. Nothing in the executor changes for this.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from rapid_dsl.runtime.demonstrations.track import FORMAT
from rapid_dsl.runtime.frames import Entity
from rapid_dsl.runtime.results import RunResult
from rapid_dsl.runtime.scenes.world import World
from rapid_dsl.runtime.simulate import Simulator

PERIOD = 0.04       # s between frames (25 Hz): a 10 s run is about 60 kB
DIGITS = {"t": 4, "position": 5, "quat": 6, "opening": 5}   # 0.1 ms, 0.01 mm, 1e-6


def record_track(world: World, motions: Sequence[tuple[np.ndarray, np.ndarray]],
                 result: RunResult | None = None) -> dict[str, Any]:
    """The track of the executed `motions` (in order, each starting where the last ended), with
    the run's phases when `result` says which phase each motion executed."""
    table = world.entities
    hand = table.index("gripper")
    objects = [e for e in table.entities if e.kind == "Object"]
    every = max(1, round(PERIOD / world.dt))
    frames: list[dict[str, Any]] = []
    spans: list[tuple[float, float]] = []
    with Simulator(world, nthread=1) as sim:
        start = sim.rollout(sim.initial_state(), world.start_ctrl[None, None],
                            record_every=1).first()
        pieces = [(0.0, start)] if not motions else \
            [(float(sim.state_time(state0)), sim.replay(state0, ctrl, record_every=every)[1])
             for state0, ctrl in motions]
    for t0, recorded in pieces:
        times = t0 + recorded.time
        spans.append((float(times[0]), float(times[-1])))
        for j, t in enumerate(times):
            if frames and _round(t, "t") <= frames[-1]["t"]:
                continue   # a motion starts where the previous one ended
            frames.append({
                "t": _round(t, "t"),
                "objects": {e.name: _pose(recorded.pos[0, j, e.index],
                                          recorded.quat[0, j, e.index]) for e in objects},
                "hand": {**_pose(recorded.pos[0, j, hand], recorded.quat[0, j, hand]),
                         # the finger joints may overlap a little when squeezed shut
                         "opening": max(0.0, _round(recorded.opening[0, j], "opening"))},
            })
    return {
        "format": FORMAT,
        "source": _source(result),
        "hand": table.entities[hand].name,
        "entities": [_entity(e, start.pos[0, 0], start.quat[0, 0]) for e in table.entities],
        "phases": _phases(result, spans) if motions else [],
        "frames": frames,
    }


def _entity(entity: Entity, positions: np.ndarray, quats: np.ndarray) -> dict[str, Any]:
    """An entity's description; static ones with their pose (the start state's)."""
    info: dict[str, Any] = {"name": entity.name, "kind": entity.kind, "shape": entity.shape,
                            "extents": [_round(x, "position") for x in entity.extents]}
    if entity.kind in ("Fixture", "Surface"):
        info["pose"] = _pose(positions[entity.index], quats[entity.index])
    return info


def _pose(position: np.ndarray, quat: np.ndarray) -> dict[str, list[float]]:
    return {"position": [_round(x, "position") for x in position],
            "quat": [_round(q, "quat") for q in quat]}


def _round(value: Any, field: str) -> float:
    return round(float(value), DIGITS[field]) + 0.0   # + 0.0: no `-0.0` in the file


def _source(result: RunResult | None) -> dict[str, Any]:
    source: dict[str, Any] = {"recorder": "rapidc run --track"}
    if result is not None:
        source |= {"program": result.program, "entry": result.entry, "scene": result.scene,
                   "seed": result.seed, "outcome": result.outcome}
    return source


def _phases(result: RunResult | None, spans: list[tuple[float, float]]) -> list[dict[str, Any]]:
    """The phases that executed a motion, each with its motion's time span; none when the
    result does not pair one to one with the motions."""
    if result is None:
        return []
    executed = [p for p in result.phases if p.end is not None]
    if len(executed) != len(spans):
        return []
    return [{"name": p.name, "primitive": p.primitive, "start": _round(start, "t"),
             "end": _round(end, "t"), "succeeded": p.succeeded}
            for p, (start, end) in zip(executed, spans, strict=True)]
