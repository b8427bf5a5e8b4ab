"""A 7-DoF Panda-like arm with a parallel gripper and a Cartesian impedance controller in the model.

Kinematics follow the published Panda modified-DH table (Craig convention: a_{i-1}, d_i,
alpha_{i-1}); joint limits, torque limits and link masses are the published ones; geometry is
primitive (capsules), and only links 5-7 and the hand collide.

Control runs inside MuJoCo so batched rollouts stay native: six `general` actuators with a site
transmission on the tool point and `refsite` = a world-aligned site at the base act as springs with
dampers (affine bias) on the tool's position (kp 2000 N/m, kv 90 N s/m) and on its rotation vector
relative to the base frame (kp 150 N m/rad, kv 12 N m s/rad). Gravity is compensated per body;
weak joint springs to the ready posture settle the null space. Passive dead-band springs keep the
joints off their limits and the wrist roll within +-1.2 rad, so that the arm recovers after a
collision has pushed it there (see SPRING_BANDS). The start posture comes from
damped-least-squares IK.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np

from rapid_dsl.runtime.robots import hand as hand_mod
from rapid_dsl.runtime.robots.base import Robot

# (a_{i-1}, d_i, alpha_{i-1}) per joint, then the flange offset along link 7's z.
DH = ((0.0, 0.333, 0.0), (0.0, 0.0, -math.pi / 2), (0.0, 0.316, math.pi / 2),
      (0.0825, 0.0, math.pi / 2), (-0.0825, 0.384, -math.pi / 2), (0.0, 0.0, math.pi / 2),
      (0.088, 0.0, math.pi / 2))
FLANGE = 0.107
JOINT_LIMITS = ((-2.8973, 2.8973), (-1.7628, 1.7628), (-2.8973, 2.8973), (-3.0718, -0.0698),
                (-2.8973, 2.8973), (-0.0175, 3.7525), (-2.8973, 2.8973))
TORQUE_LIMITS = (87.0, 87.0, 87.0, 87.0, 12.0, 12.0, 12.0)
LINK_MASSES = (4.970684, 0.646926, 3.228604, 3.587895, 1.225946, 1.666555, 0.735522)
HOME = (0.0, -math.pi / 4, 0.0, -3 * math.pi / 4, 0.0, math.pi / 2, math.pi / 4)
JOINTS = tuple(f"joint{i}" for i in range(1, 8))
COLLIDING_LINKS = (5, 6, 7)

POS_KP, POS_KV = 2000.0, 90.0      # N/m, N s/m
ROT_KP, ROT_KV = 150.0, 12.0       # N m/rad, N m s/rad
NULL_STIFFNESS = 0.5               # N m/rad, joint springs to HOME
JOINT_DAMPING, ARMATURE = 1.0, 0.1

# Joint-limit barriers and the wrist's posture band (docs/physics.md, "Franka: limits and
# posture"): a passive spring per joint on a one-joint tendon whose rest length is a range, so it
# pushes only outside that range (a dead band) and never fights the Cartesian task inside it.
LIMIT_MARGIN = 0.1                 # rad inside each joint limit where its barrier starts, except:
MARGINS = {
    # wider at the two limits where the Cartesian (Jacobian-transpose) controller gets stuck: the
    # straight elbow (the task force has no moment to bend it) and the wrist pitched forward
    # (joint 6 at its upper limit, joint 5 rolled over to +-2.8 rad)
    (4, 1): 0.2, (6, 1): 0.2,
    # none at the folded elbow: hand starts near the base need it there (q4 = -3.03 at
    # (0.30, 0, 0.10) m), and a barrier would move the hand from its start
    (4, 0): 0.0,
}                                  # (joint, 0 lower / 1 upper limit) -> rad
LIMIT_STIFFNESS = 100.0            # N m/rad beyond a barrier's start
WRIST_BAND = 1.2                   # rad: joint 5 (wrist roll) is pulled back inside +-this ...
WRIST_STIFFNESS = 50.0             # N m/rad: ... (its band replaces its barrier)


def _spring_band(joint: int) -> tuple[float, float, float]:
    """(low, high, stiffness beyond them) of joint `joint`'s dead-band spring [rad, N m/rad]."""
    if joint == 5:
        return -WRIST_BAND, WRIST_BAND, WRIST_STIFFNESS
    lo, hi = JOINT_LIMITS[joint - 1]
    return (lo + MARGINS.get((joint, 0), LIMIT_MARGIN), hi - MARGINS.get((joint, 1), LIMIT_MARGIN),
            LIMIT_STIFFNESS)


SPRING_BANDS = tuple(_spring_band(joint) for joint in range(1, 8))

# Link geometry in each link's frame: capsules (from, to, radius).
LINK_CAPSULES: dict[int, tuple[tuple[tuple[float, ...], tuple[float, ...], float], ...]] = {
    1: (((0, 0, -0.19), (0, 0, -0.01), 0.06),),
    2: (((0, 0, -0.06), (0, 0, 0.06), 0.06), ((0, 0, 0), (0, -0.19, 0), 0.06)),
    3: (((0, 0, -0.12), (0, 0, 0), 0.06), ((0, 0, 0), (0.0825, 0, 0), 0.055)),
    4: (((0, 0, -0.06), (0, 0, 0.06), 0.055), ((0, 0, 0), (-0.0825, 0.12, 0), 0.055)),
    5: (((0, 0, -0.26), (0, 0, -0.02), 0.05),),
    6: (((0, 0, -0.05), (0, 0, 0.03), 0.05), ((0, 0, 0), (0.088, 0, 0), 0.045)),
    7: (((0, 0, -0.02), (0, 0, 0.08), 0.045),),
}


class Franka(Robot):
    name = "franka"
    reach = 0.855

    @property
    def nu(self) -> int:
        return 7

    def build(self, spec: mujoco.MjSpec) -> None:
        white, dark = [0.93, 0.93, 0.95, 1.0], [0.25, 0.25, 0.28, 1.0]
        base = spec.worldbody.add_body(name="link0", pos=self.base)
        base.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[0.07, 0.07], pos=[0, 0, 0.07],
                      contype=0, conaffinity=0, rgba=white)
        spec.worldbody.add_site(name="cartesian_ref", pos=self.base, size=[0.01] * 3, group=4)
        parent = base
        for i, ((a, d, alpha), limits, mass) in enumerate(
                zip(DH, JOINT_LIMITS, LINK_MASSES, strict=True), start=1):
            quat = np.array([math.cos(alpha / 2), math.sin(alpha / 2), 0.0, 0.0])
            pos = [a, -math.sin(alpha) * d, math.cos(alpha) * d]
            link = parent.add_body(name=f"link{i}", pos=pos, quat=quat, gravcomp=1.0)
            link.add_joint(name=JOINTS[i - 1], axis=[0, 0, 1], range=list(limits),
                           armature=ARMATURE, damping=JOINT_DAMPING, stiffness=NULL_STIFFNESS,
                           springref=HOME[i - 1], actfrclimited=mujoco.mjtLimited.mjLIMITED_TRUE,
                           actfrcrange=[-TORQUE_LIMITS[i - 1], TORQUE_LIMITS[i - 1]])
            collide = i in COLLIDING_LINKS
            capsules = LINK_CAPSULES[i]
            for k, (start, end, radius) in enumerate(capsules):
                link.add_geom(type=mujoco.mjtGeom.mjGEOM_CAPSULE, fromto=[*start, *end],
                              size=[radius, 0, 0], mass=mass / len(capsules),
                              contype=hand_mod.ROBOT_CONTYPE if collide else 0,
                              conaffinity=hand_mod.SCENE_CONTYPE if collide else 0,
                              friction=[hand_mod.ROBOT_FRICTION, 0.005, 0.0001],
                              rgba=dark if k == 0 and i in (2, 4, 6) else white)
            low, high, stiffness = SPRING_BANDS[i - 1]
            band = spec.add_tendon()   # unnamed, so that scene objects may take any name
            band.wrap_joint(JOINTS[i - 1], 1.0)
            band.stiffness = [stiffness, 0.0, 0.0]   # linear, no higher-order terms
            band.springlength = [low, high]
            parent = link
        hand_quat = np.array([math.cos(-math.pi / 8), 0.0, 0.0, math.sin(-math.pi / 8)])
        hand_mod.add_hand(spec, parent, pos=np.array([0, 0, FLANGE]), quat=hand_quat,
                          gravcomp=True)
        gears = np.eye(6)
        for row, (kind, kp, kv) in enumerate((("pos", POS_KP, POS_KV), ("rot", ROT_KP, ROT_KV))):
            for k, axis in enumerate("xyz"):
                gear = gears[3 * row + k]
                act = spec.add_actuator(name=f"{kind}_{axis}", target=hand_mod.NAMES.tcp_site,
                                        trntype=mujoco.mjtTrn.mjTRN_SITE, refsite="cartesian_ref",
                                        gear=gear)
                act.set_to_position(kp=kp, kv=kv)

    def bind(self, model: mujoco.MjModel) -> None:
        super().bind(model)
        names = ["pos_x", "pos_y", "pos_z", "rot_x", "rot_y", "rot_z", hand_mod.NAMES.actuator]
        self._order = np.array([model.actuator(n).id for n in names])
        self._qadr = np.array([model.joint(j).qposadr[0] for j in JOINTS])
        self._dadr = np.array([model.joint(j).dofadr[0] for j in JOINTS])

    def controls(self, hand_pos: np.ndarray, yaw: np.ndarray, pitch: np.ndarray,
                 grip: np.ndarray, roll: np.ndarray | float = 0.0) -> np.ndarray:
        hand_pos = np.asarray(hand_pos, dtype=float)
        yaw, pitch = np.asarray(yaw, dtype=float), np.asarray(pitch, dtype=float)
        roll = np.asarray(roll, dtype=float)
        shape = np.broadcast_shapes(hand_pos.shape[:-1], yaw.shape, pitch.shape, np.shape(grip),
                                    roll.shape)
        values = np.empty(shape + (7,))
        values[..., :3] = hand_pos - self.base
        values[..., 3:6] = _rotvec(hand_mod.tool_quat(yaw, pitch, roll))
        values[..., 6] = hand_mod.grip_to_ctrl(np.asarray(grip, dtype=float))
        ctrl = np.empty_like(values)
        ctrl[..., self._order] = values
        return ctrl

    def start_qpos(self, model: mujoco.MjModel, position: np.ndarray, yaw: float,
                   pitch: float) -> dict[str, float]:
        q = ik(model, self._qadr, self._dadr, self._tcp, np.asarray(position, dtype=float),
               hand_mod.tool_quat(np.array(yaw), np.array(pitch)))
        start = dict(zip(JOINTS, q.tolist(), strict=True))
        return start | {hand_mod.NAMES.joint_left: hand_mod.FINGER_TRAVEL,
                        hand_mod.NAMES.joint_right: hand_mod.FINGER_TRAVEL}


def _rotvec(quat: np.ndarray) -> np.ndarray:
    """(..., 4) unit quaternions -> (..., 3) rotation vectors (angle in [0, pi])."""
    quat = np.where(quat[..., :1] < 0, -quat, quat)  # the short way round
    vec = quat[..., 1:]
    norm = np.linalg.norm(vec, axis=-1, keepdims=True)
    angle = 2.0 * np.arctan2(norm, quat[..., :1])
    scale = np.where(norm > 1e-12, angle / np.maximum(norm, 1e-12), 2.0)
    return vec * scale


def ik(model: mujoco.MjModel, qadr: np.ndarray, dadr: np.ndarray, site: int, position: np.ndarray,
       quat: np.ndarray, *, iterations: int = 300, damping: float = 0.05) -> np.ndarray:
    """Damped-least-squares IK for the tool site, starting from and biased toward HOME."""
    data = mujoco.MjData(model)
    lo, hi = (np.array(v) for v in zip(*JOINT_LIMITS, strict=True))
    q = np.array(HOME)
    jacp, jacr = np.zeros((3, model.nv)), np.zeros((3, model.nv))
    err_quat, cur_quat = np.zeros(4), np.zeros(4)
    for _ in range(iterations):
        data.qpos[qadr] = q
        mujoco.mj_kinematics(model, data)
        mujoco.mj_comPos(model, data)
        mujoco.mju_mat2Quat(cur_quat, data.site_xmat[site])
        mujoco.mju_negQuat(cur_quat, cur_quat)
        mujoco.mju_mulQuat(err_quat, quat, cur_quat)
        rot_err = np.zeros(3)
        mujoco.mju_quat2Vel(rot_err, err_quat, 1.0)
        err = np.r_[position - data.site_xpos[site], rot_err]
        mujoco.mj_jacSite(model, data, jacp, jacr, site)
        jac = np.vstack([jacp[:, dadr], jacr[:, dadr]])
        step = jac.T @ np.linalg.solve(jac @ jac.T + damping**2 * np.eye(6), err)
        null = np.eye(7) - np.linalg.pinv(jac) @ jac
        step += null @ (0.1 * (np.array(HOME) - q))
        q = np.clip(q + step, lo + 1e-3, hi - 1e-3)
        if np.linalg.norm(err) < 1e-6:
            break
    return q
