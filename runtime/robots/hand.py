"""The parallel-jaw hand shared by both robots (Panda-hand-like dimensions).

Hand frame: origin at the mounting flange, +z along the fingers (approach), fingers slide along
±y. The tool point `gripper` (the point between the fingertips, 1 cm above their ends) carries the
convention programs see: at yaw 0 and pitch 0 its frame is the world frame, so the fingers point
along its -z axis (down) and open along its y axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

TCP_DEPTH = 0.1034          # flange -> tool point along the approach axis [m] (Panda TCP)
FINGER_BASE = 0.0584        # flange -> finger root [m]
FINGER_LENGTH = 0.055       # finger root -> fingertip [m]; the tool point is 1 cm above the tips
FINGER_TRAVEL = 0.04        # each finger opens 0..4 cm, so the hand opens 0..8 cm
FINGER_OVERTRAVEL = 0.002   # joint range beyond the targets at both ends [m]
PAD_THICKNESS = 0.012       # finger thickness along the opening axis [m]
PAD_WIDTH = 0.02            # finger width across the opening axis [m]
HAND_MASS = 0.73            # kg (Panda hand)
FINGER_MASS = 0.015         # kg each
GRIP_KP = 2000.0            # N/m on the finger tendon; saturates at GRIP_FORCE beyond 2 cm
GRIP_FORCE = 40.0           # N, per the tendon (Panda: 70 N continuous)
ROBOT_FRICTION = 1.0        # finger and link friction (rubber pads)
ROBOT_PRIORITY = 2          # above objects (1): the pads' friction governs their contacts
# With priority the pads also set the contact's softness: stiffer than MuJoCo's default so that a
# high-friction pyramidal contact under a firm grip does not sink millimetres into the object.
PAD_SOLREF = [0.01, 1.0]
PAD_SOLIMP = [0.95, 0.99, 0.001, 0.5, 2.0]

# Collision classes: scene geoms are contype 1; robot geoms contype 2, so robot links never collide
# with each other but every robot geom collides with the scene (conaffinity 1).
SCENE_CONTYPE, ROBOT_CONTYPE = 1, 2

# Extents of the `gripper` entity: the fingertip block around the tool point, fully open.
GRIPPER_EXTENTS = np.array([PAD_WIDTH, 2 * (FINGER_TRAVEL + PAD_THICKNESS), 0.02])

FLIP_Z = np.array([0.0, 1.0, 0.0, 0.0])  # quaternion: pi about x (z -> -z, y -> -y)


@dataclass(frozen=True, slots=True)
class HandNames:
    """Names of the hand's elements in the model."""

    hand: str = "hand"
    finger_left: str = "finger_left"
    finger_right: str = "finger_right"
    joint_left: str = "finger_left"
    joint_right: str = "finger_right"
    tcp_site: str = "gripper"
    actuator: str = "grip"


NAMES = HandNames()


def add_hand(spec: mujoco.MjSpec, parent: mujoco.MjsBody, *, pos: np.ndarray, quat: np.ndarray,
             gravcomp: bool) -> mujoco.MjsBody:
    """Add hand, fingers, finger tendon, equality and grip actuator under `parent`."""
    robot_rgba = [0.92, 0.92, 0.95, 1.0]
    dark = [0.25, 0.25, 0.28, 1.0]
    hand = parent.add_body(name=NAMES.hand, pos=pos, quat=quat, gravcomp=float(gravcomp))
    _robot_geom(hand, type=mujoco.mjtGeom.mjGEOM_BOX, size=[0.025, 0.095, 0.022],
                pos=[0, 0, FINGER_BASE - 0.022], mass=HAND_MASS, rgba=robot_rgba)
    _robot_geom(hand, type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.04, 0.008], pos=[0, 0, 0.008],
                mass=0.0, rgba=dark)
    for side, sign in (("left", 1.0), ("right", -1.0)):
        finger = hand.add_body(name=getattr(NAMES, f"finger_{side}"), pos=[0, 0, FINGER_BASE],
                               gravcomp=float(gravcomp))
        finger.add_joint(name=getattr(NAMES, f"joint_{side}"), type=mujoco.mjtJoint.mjJNT_SLIDE,
                         axis=[0, sign, 0],
                         range=[-FINGER_OVERTRAVEL, FINGER_TRAVEL + FINGER_OVERTRAVEL],
                         limited=mujoco.mjtLimited.mjLIMITED_TRUE, armature=0.01, damping=2.0)
        # inner face at y = q: the fingers touch when both joints are 0. The range exceeds the
        # targets (0 .. FINGER_TRAVEL) a little at both ends, so no limit constraint sits exactly
        # at a resting finger: one that does flips between active and inactive from step to step
        # and costs Newton iterations (a closed hand pushing a box: ~5 % of the rollout rate).
        _robot_geom(finger, type=mujoco.mjtGeom.mjGEOM_BOX,
                    size=[PAD_WIDTH / 2, PAD_THICKNESS / 2, FINGER_LENGTH / 2],
                    pos=[0, sign * PAD_THICKNESS / 2, FINGER_LENGTH / 2], mass=FINGER_MASS,
                    rgba=dark)
    hand.add_site(name=NAMES.tcp_site, pos=[0, 0, TCP_DEPTH], quat=FLIP_Z, size=[0.006] * 3,
                  rgba=[0.1, 0.8, 0.2, 0.6], group=3)
    tendon = spec.add_tendon(name=NAMES.actuator)
    tendon.wrap_joint(NAMES.joint_left, 0.5)
    tendon.wrap_joint(NAMES.joint_right, 0.5)
    spec.add_equality(type=mujoco.mjtEq.mjEQ_JOINT, name1=NAMES.joint_left, name2=NAMES.joint_right,
                      data=np.r_[0.0, 1.0, np.zeros(10)])
    grip = spec.add_actuator(name=NAMES.actuator, target=NAMES.actuator,
                             trntype=mujoco.mjtTrn.mjTRN_TENDON)
    grip.set_to_position(kp=GRIP_KP, dampratio=1.0)
    grip.forcelimited = mujoco.mjtLimited.mjLIMITED_TRUE
    grip.forcerange = [-GRIP_FORCE, GRIP_FORCE]
    grip.ctrllimited = mujoco.mjtLimited.mjLIMITED_TRUE
    grip.ctrlrange = [0.0, FINGER_TRAVEL]
    return hand


def grip_to_ctrl(grip: np.ndarray) -> np.ndarray:
    """grip 0 (open) .. 1 (closed) -> each finger's opening target [m]."""
    return (1.0 - np.clip(grip, 0.0, 1.0)) * FINGER_TRAVEL


def _robot_geom(body: mujoco.MjsBody, **kwargs) -> mujoco.MjsGeom:
    return body.add_geom(contype=ROBOT_CONTYPE, conaffinity=SCENE_CONTYPE,
                         friction=[ROBOT_FRICTION, 0.005, 0.0001], priority=ROBOT_PRIORITY,
                         solref=PAD_SOLREF, solimp=PAD_SOLIMP, **kwargs)


def tool_quat(yaw: np.ndarray, pitch: np.ndarray, roll: np.ndarray | float = 0.0) -> np.ndarray:
    """(..., 4) world quaternion (w x y z) of the tool frame for a yaw, pitch and roll.

    R = Rz(yaw) Ry(-pitch) Rz(roll): pitch > 0 tilts the fingertips toward the heading (+x at
    yaw 0); roll, last, turns the hand about its own approach axis (the tool's z).
    """
    cy, sy = np.cos(np.asarray(yaw) / 2), np.sin(np.asarray(yaw) / 2)
    cp, sp = np.cos(np.asarray(pitch) / 2), np.sin(np.asarray(pitch) / 2)
    cr, sr = np.cos(np.asarray(roll) / 2), np.sin(np.asarray(roll) / 2)
    # qz(yaw) qy(-pitch), then times qz(roll)
    w, x, y, z = cy * cp, sy * sp, -cy * sp, sy * cp
    return np.stack([w * cr - z * sr, x * cr + y * sr, y * cr - x * sr, z * cr + w * sr], axis=-1)


# Below this tilt of the approach axis from vertical, roll and yaw turn the hand about nearly the
# same axis and the split between them is noise (a Franka holds pitch 0 only to a degree or so):
# the turn is read as yaw. Between ROLL_TILT and twice that, the read roll fades in.
ROLL_TILT = math.radians(5.0)


def yaw_pitch_roll_of(xmat: np.ndarray) -> tuple[float, float, float]:
    """Inverse of `tool_quat` for a (9,) or (3, 3) rotation matrix: (yaw, pitch, roll) [rad].

    Of the two equivalent answers, (y, p, r) and (y + pi, -p, r + pi), the one with |roll| <= pi/2
    (so a hand that was never rolled reads roll 0, as before roll existed). A nearly vertical hand
    reads roll 0 (ROLL_TILT); its yaw and pitch then describe it to within its tilt.
    """
    r = np.asarray(xmat, dtype=float).reshape(3, 3)
    tilt = math.atan2(math.hypot(r[0, 2], r[1, 2]), r[2, 2])       # in [0, pi]
    # ZYZ with the pitch >= 0: the approach axis (column z) is (-cy sp, -sy sp, cp)
    yaw = math.atan2(-r[1, 2], -r[0, 2])
    roll = math.atan2(-r[2, 1], r[2, 0])
    pitch = tilt
    if abs(roll) > math.pi / 2 + 1e-6:   # at exactly pi/2 both do: keep pitch >= 0
        yaw, pitch, roll = yaw + math.pi, -pitch, roll - math.copysign(math.pi, roll)
    weight = min(max(min(tilt, math.pi - tilt) / ROLL_TILT - 1.0, 0.0), 1.0)
    if weight < 1.0:
        # keep `weight` of the roll; yaw and pitch then fit the rest, as for a hand with no roll
        roll *= weight
        rest = r @ _rz(-roll)
        yaw = math.atan2(-rest[0, 1], rest[1, 1])
        pitch = math.atan2(rest[2, 0], rest[2, 2])
    return _wrap(yaw), pitch, roll


def _rz(angle: float) -> np.ndarray:
    c, s = math.cos(angle), math.sin(angle)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _wrap(angle: float) -> float:
    """angle in (-pi, pi]."""
    return math.pi - (math.pi - angle) % (2 * math.pi)
