"""What every robot offers the runtime: one Manipulator, driven by hand-space controls.

Programs never see joints. A control is the hand target: the position of the point between the
fingertips (world frame, m), its yaw (rad, about world z), its pitch (rad; 0 = fingers pointing
down, > 0 tilts the fingertips toward the heading), its roll (rad, about the hand's own approach
axis, after yaw and pitch: R = Rz(yaw) Ry(-pitch) Rz(roll), hand.tool_quat) and the grip (0 open ..
1 closed). Each robot
maps that to its actuator vector `ctrl` with numpy for a whole batch; the low-level controller
(position servos or Cartesian impedance) lives inside the MuJoCo model, so rollouts stay native.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass

import mujoco
import numpy as np

from rapid_dsl.runtime.robots import hand as hand_mod


@dataclass(frozen=True, slots=True)
class HandPose:
    position: np.ndarray   # (3,) world position of the point between the fingertips [m]
    yaw: float             # [rad]
    pitch: float           # [rad]
    opening: float         # distance between the fingers [m]
    roll: float = 0.0      # [rad] about the approach axis (hand.yaw_pitch_roll_of)


class Robot(ABC):
    """A manipulator added to a scene's MjSpec; `bind` it to the compiled model before use."""

    name: str
    reach: float           # workspace radius around the base [m]

    def __init__(self, base: np.ndarray):
        self.base = np.asarray(base, dtype=float)
        self._model: mujoco.MjModel | None = None

    @property
    @abstractmethod
    def nu(self) -> int:
        """Number of actuators (= length of a ctrl vector; the robot owns every actuator)."""

    @abstractmethod
    def build(self, spec: mujoco.MjSpec) -> None:
        """Add bodies, joints, actuators and the `gripper` site to the spec."""

    @abstractmethod
    def controls(self, hand_pos: np.ndarray, yaw: np.ndarray, pitch: np.ndarray,
                 grip: np.ndarray, roll: np.ndarray | float = 0.0) -> np.ndarray:
        """Hand targets (..., 3), (...), (...), (...), (...) -> ctrl (..., nu); leading dims
        broadcast."""

    @abstractmethod
    def start_qpos(self, model: mujoco.MjModel, position: np.ndarray, yaw: float,
                   pitch: float) -> dict[str, float]:
        """Joint values (by joint name) that put the hand at the given pose, fingers open."""

    def bind(self, model: mujoco.MjModel) -> None:
        self._model = model
        self._tcp = model.site(hand_mod.NAMES.tcp_site).id
        self._fingers = [model.joint(n).qposadr[0] for n in (hand_mod.NAMES.joint_left,
                                                             hand_mod.NAMES.joint_right)]

    def hand_pose(self, data: mujoco.MjData) -> HandPose:
        """The hand pose in `data` (after mj_forward or a step)."""
        yaw, pitch, roll = hand_mod.yaw_pitch_roll_of(data.site_xmat[self._tcp])
        opening = float(data.qpos[self._fingers[0]] + data.qpos[self._fingers[1]])
        return HandPose(data.site_xpos[self._tcp].copy(), yaw, pitch, opening, roll)

    def hold(self, pose: HandPose, grip: float = 0.0) -> np.ndarray:
        """(nu,) ctrl that holds the hand where it is."""
        return self.controls(pose.position, np.array(pose.yaw), np.array(pose.pitch),
                             np.array(grip), np.array(pose.roll))
