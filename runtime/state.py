"""What a run carries from phase to phase: its simulators, the physics state, the grip command.

One `RunState` per run: a Simulator at the world's timestep (execution), one at the planning
timestep (the CEM's rollouts; the same object when the two are equal), the MjData and full physics
state the next phase starts from, the last gripper command, and every executed motion (for video).
"""

from __future__ import annotations

from typing import Self

import numpy as np

from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.robots import HandPose
from rapid_dsl.runtime.scenes.world import World
from rapid_dsl.runtime.simulate import Simulator


class RunState:
    def __init__(self, world: World, *, nthread: int = 2, planning_dt: float | None = None):
        self.world = world
        self.sim = Simulator(world, nthread=nthread)
        self.planner = self.sim if planning_dt in (None, world.dt) else \
            Simulator(world, nthread=nthread, timestep=planning_dt)
        self.data = world.make_data()
        self.state = self.sim.initial_state(self.data)
        self.grip = 0.0
        self.motions: list[tuple[np.ndarray, np.ndarray]] = []   # (state0, ctrl) per execution

    def frames(self) -> Frames:
        """The current state as Frames with B=1, T=1 (sensors evaluated, hand held still)."""
        pose = self.hand()
        ctrl = self.world.robot.hold(pose, self.grip)
        return self.sim.rollout(self.state, ctrl[None, None], record_every=1).first()

    def hand(self) -> HandPose:
        """The hand pose in the current state."""
        self.sim.set_state(self.data, self.state)
        return self.world.robot.hand_pose(self.data)

    def poses(self) -> dict[str, dict[str, list[float]]]:
        """Every entity's position and orientation in the current state."""
        frames = self.frames()
        return {e.name: {"position": [float(x) for x in frames.pos[0, 0, e.index]],
                         "quat": [float(x) for x in frames.quat[0, 0, e.index]]}
                for e in self.world.entities.entities}

    def close(self) -> None:
        self.sim.close()
        self.planner.close()

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
