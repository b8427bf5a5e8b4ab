"""A free-floating compliant parallel gripper: the fast robot for optimization.

A carriage whose frame is the tool point carries slide joints x, y, z, a yaw hinge (world z), a
pitch hinge (about the tool's -y) and a roll hinge (about the tool's approach axis z, after the
pitch), all through the tool point and driven by position servos inside the model, with gravity
compensation. Because every hinge passes through the tool point, the hand position is exactly
`base + slide qpos` at any yaw, pitch and roll.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rapid_dsl.runtime.robots import hand as hand_mod
from rapid_dsl.runtime.robots.base import Robot

SLIDE_KP, SLIDE_FORCE = 2000.0, 150.0     # N/m, N
HINGE_KP, HINGE_TORQUE = 40.0, 15.0       # N m/rad, N m
# Unpitched, the yaw and roll hinges turn the hand about the same (vertical) axis, in series: at
# twice HINGE_KP each, together they are as one hinge was before the roll hinge existed.
TURN_KP = 2 * HINGE_KP
JOINTS = ("hand_x", "hand_y", "hand_z", "hand_yaw", "hand_pitch", "hand_roll")


class FloatingGripper(Robot):
    name = "floating_gripper"
    reach = 1.0

    @property
    def nu(self) -> int:
        return 7

    def build(self, spec: mujoco.MjSpec) -> None:
        carriage = spec.worldbody.add_body(name="carriage", pos=self.base, gravcomp=1.0)
        axes = ([1, 0, 0], [0, 1, 0], [0, 0, 1], [0, 0, 1], [0, -1, 0], [0, 0, 1])
        for joint, axis in zip(JOINTS, axes, strict=True):
            slide = joint in JOINTS[:3]
            carriage.add_joint(
                name=joint, axis=axis, armature=0.05 if slide else 0.002,
                type=mujoco.mjtJoint.mjJNT_SLIDE if slide else mujoco.mjtJoint.mjJNT_HINGE,
            )
            act = spec.add_actuator(name=joint, target=joint, trntype=mujoco.mjtTrn.mjTRN_JOINT)
            kp = SLIDE_KP if slide else TURN_KP if joint in ("hand_yaw", "hand_roll") else HINGE_KP
            act.set_to_position(kp=kp, dampratio=1.0)
            act.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
            limit = SLIDE_FORCE if slide else HINGE_TORQUE
            act.forcerange = [-limit, limit]
        # the hand hangs above the tool point with its approach axis pointing down
        hand_mod.add_hand(spec, carriage, pos=np.array([0, 0, hand_mod.TCP_DEPTH]),
                          quat=hand_mod.FLIP_Z, gravcomp=True)
        carriage.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.005], contype=0,
                          conaffinity=0, mass=0.05, group=3)

    def controls(self, hand_pos: np.ndarray, yaw: np.ndarray, pitch: np.ndarray,
                 grip: np.ndarray, roll: np.ndarray | float = 0.0) -> np.ndarray:
        hand_pos = np.asarray(hand_pos, dtype=float)
        shape = np.broadcast_shapes(hand_pos.shape[:-1], np.shape(yaw), np.shape(pitch),
                                    np.shape(grip), np.shape(roll))
        ctrl = np.empty(shape + (7,))
        ctrl[..., :3] = hand_pos - self.base
        ctrl[..., 3] = yaw
        ctrl[..., 4] = pitch
        ctrl[..., 5] = roll
        ctrl[..., 6] = hand_mod.grip_to_ctrl(np.asarray(grip, dtype=float))
        return ctrl

    def start_qpos(self, model: mujoco.MjModel, position: np.ndarray, yaw: float,
                   pitch: float) -> dict[str, float]:
        values = np.r_[np.asarray(position) - self.base, yaw, pitch, 0.0]
        start = dict(zip(JOINTS, values.tolist(), strict=True))
        return start | {hand_mod.NAMES.joint_left: hand_mod.FINGER_TRAVEL,
                        hand_mod.NAMES.joint_right: hand_mod.FINGER_TRAVEL}
