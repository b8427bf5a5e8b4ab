"""The Franka's Cartesian controller: tracking error, and recovery after a collision.

Three measurements on the arm alone over a table (docs/physics.md, "Franka: limits and posture"):
- standard motion: the tool point on a 10 cm circle at 0.5 Hz around (0.50, 0, 0.15) m with the
  yaw swinging +-0.6 rad; RMS and largest position error, RMS orientation error, after 0.5 s;
- static poses: from the start, a 0.5 s ramp to each pose of a grid and 1 s of hold; median and
  90th percentile of the errors, and how many poses end more than 1 cm or 5 deg off. `workspace`:
  x 0.35-0.65, y +-0.2, z 0.05/0.20 m, yaw -1.5/0/1.5, pitch 0/0.5 rad (108 poses); `wide` adds
  yaw +-1, +-2 and pitch -0.5, 0.4, 0.8 rad (360 poses);
- recovery: four ways of getting caught on a fixed wall (pulled back with a finger hooked behind
  it, the same at yaw 0.8 rad, pushed over it, dragged sideways along it), then the wall's
  contacts are switched off and the hand is sent to 18 poses; how many end more than 1 cm or 5 deg
  off, and the most seconds a joint then spends on a limit.

Usage: python -m rapid_dsl.bench.franka_tracking [--without-bands] [--posture-stiffness K]
`--without-bands` measures the model with the dead-band springs' stiffness set to 0 (the
controller as it was before them; the tendons themselves exert nothing then);
`--posture-stiffness` sets the plain joint springs to the ready posture (default 0.5 N m/rad).
"""

from __future__ import annotations

import argparse
import itertools
import math
import sys

import mujoco
import numpy as np

from rapid_dsl.runtime.robots import franka
from rapid_dsl.runtime.robots.hand import tool_quat
from rapid_dsl.runtime.scenes.scene import parse_scene
from rapid_dsl.runtime.scenes.world import World, build_world

SCENE = """\
robot: franka
floor_height: -0.75m
gripper_start: {{position: {start}}}
objects:
  - {{name: table, kind: surface, shape: box, size: [1.0m, 1.2m, 0.75m],
     pose: {{position: [0.55, 0.0, {table}]}}}}
{wall}"""
WALL = ("  - {{name: wall, kind: fixture, shape: box, size: [{sx}m, {sy}m, {h}m],\n"
        "     pose: {{position: [{x}, {y}, {z}]}}}}\n")
# name -> hand start, wall (size x, size y, height, x, y), yaw, the hand target's path
CAUGHT = {
    "pulled back": ((0.68, 0.0, 0.06), (0.04, 0.4, 0.12, 0.58, 0.0), 0.0,
                    [(0.35, 0.0, 0.06), (0.35, 0.0, 0.20), (0.35, 0.0, 0.20)]),
    "pulled back, yawed": ((0.68, 0.05, 0.06), (0.04, 0.4, 0.12, 0.58, 0.0), 0.8,
                           [(0.35, 0.0, 0.06), (0.35, 0.0, 0.20), (0.35, 0.0, 0.20)]),
    "pushed over": ((0.42, 0.0, 0.06), (0.04, 0.4, 0.20, 0.55, 0.0), 0.0,
                    [(0.75, 0.0, 0.06), (0.75, 0.0, 0.15), (0.75, 0.0, 0.15)]),
    "dragged sideways": ((0.55, -0.12, 0.06), (0.4, 0.04, 0.12, 0.55, 0.0), 0.0,
                         [(0.55, 0.25, 0.06), (0.55, 0.25, 0.20), (0.55, 0.25, 0.20)]),
}
FINALS = list(itertools.product([(0.45, 0.0, 0.15), (0.55, 0.15, 0.10), (0.40, -0.2, 0.25)],
                                (-1.5, 0.0, 1.5), (0.0, 0.6)))
LOW, HIGH = (np.array(side) for side in zip(*franka.JOINT_LIMITS, strict=True))


def world(start: tuple[float, ...] = (0.40, 0.0, 0.20), wall: tuple[float, ...] | None = None
          ) -> World:
    text = WALL.format(sx=wall[0], sy=wall[1], h=wall[2], x=wall[3], y=wall[4], z=wall[2] / 2) \
        if wall else ""
    # without a wall the table sits 40 cm lower, out of every pose's way
    return build_world(parse_scene(SCENE.format(start=list(start), wall=text,
                                                table=-0.375 if wall else -0.775)))


def drive(w: World, data: mujoco.MjData, start: np.ndarray, end: np.ndarray, steps: int,
          yaw: tuple[float, float] = (0.0, 0.0), pitch: tuple[float, float] = (0.0, 0.0),
          joints: list[np.ndarray] | None = None) -> None:
    """The hand target along a straight line (and yaw, pitch ramps) in `steps` physics steps."""
    qadr = [w.model.joint(j).qposadr[0] for j in franka.JOINTS]
    for k in range(steps):
        s = (k + 1) / steps
        data.ctrl[:] = w.robot.controls(start + s * (end - start),
                                        np.array(yaw[0] + s * (yaw[1] - yaw[0])),
                                        np.array(pitch[0] + s * (pitch[1] - pitch[0])),
                                        np.array(0.0))
        mujoco.mj_step(w.model, data)
        if joints is not None:
            joints.append(data.qpos[qadr].copy())


def miss(w: World, data: mujoco.MjData, position: np.ndarray, yaw: float,
         pitch: float) -> tuple[float, float]:
    """Position [cm] and orientation [deg] error of the tool point against a pose."""
    site = w.robot._tcp
    quat = np.zeros(4)
    mujoco.mju_mat2Quat(quat, data.site_xmat[site])
    dot = abs(float(quat @ tool_quat(np.array(yaw), np.array(pitch))))
    return (100 * float(np.linalg.norm(data.site_xpos[site] - position)),
            math.degrees(2 * math.acos(min(1.0, dot))))


def standard_motion() -> str:
    w = world()
    data = w.make_data()
    start, centre = w.robot.hand_pose(data).position, np.array([0.50, 0.0, 0.15])
    drive(w, data, start, centre + [0.1, 0.0, 0.0], round(1.0 / w.dt))
    errors = []
    for k in range(round(3.0 / w.dt)):
        angle = math.pi * (k + 1) * w.dt   # 0.5 Hz
        target = centre + 0.1 * np.array([math.cos(angle), math.sin(angle), 0.0])
        yaw = 0.6 * math.sin(angle)
        data.ctrl[:] = w.robot.controls(target, np.array(yaw), np.array(0.0), np.array(0.0))
        mujoco.mj_step(w.model, data)
        if k * w.dt >= 0.5:
            errors.append(miss(w, data, target, yaw, 0.0))
    e = np.array(errors)
    return (f"standard motion: position RMS {np.sqrt((e[:, 0] ** 2).mean()):.2f} cm, largest "
            f"{e[:, 0].max():.2f} cm; orientation RMS {np.sqrt((e[:, 1] ** 2).mean()):.2f} deg")


def static_poses(wide: bool) -> str:
    w = world()
    yaws, pitches = ((-2.0, -1.0, 0.0, 1.0, 2.0), (-0.5, 0.0, 0.4, 0.8)) if wide else \
        ((-1.5, 0.0, 1.5), (0.0, 0.5))
    errors = []
    for x, y, z, yaw, pitch in itertools.product((0.35, 0.5, 0.65), (-0.2, 0.0, 0.2), (0.05, 0.2),
                                                 yaws, pitches):
        data = w.make_data()
        target = np.array([x, y, z])
        drive(w, data, w.robot.hand_pose(data).position, target, 250, (0.0, yaw), (0.0, pitch))
        drive(w, data, target, target, 500, (yaw, yaw), (pitch, pitch))
        errors.append(miss(w, data, target, yaw, pitch))
    e = np.array(errors)
    off = int(((e[:, 0] > 1.0) | (e[:, 1] > 5.0)).sum())
    return (f"static poses, {'wide' if wide else 'workspace'} ({len(e)}): position median "
            f"{np.median(e[:, 0]):.2f} cm, p90 {np.percentile(e[:, 0], 90):.2f} cm; orientation "
            f"median {np.median(e[:, 1]):.2f} deg, p90 {np.percentile(e[:, 1], 90):.2f} deg; "
            f"{off} more than 1 cm or 5 deg off")


def recovery(name: str) -> str:
    start, wall, yaw, path = CAUGHT[name]
    off, on_limit = 0, 0.0
    for final, final_yaw, final_pitch in FINALS:
        w = world(start, wall)
        data, joints = w.make_data(), []
        target = np.array(start)
        drive(w, data, target, target, 250, (0.0, yaw))
        for point in map(np.array, path):
            drive(w, data, target, point, 300, (yaw, yaw))
            target = point
        wall_id = w.model.geom("wall").id
        w.model.geom_contype[wall_id] = w.model.geom_conaffinity[wall_id] = 0
        here, goal = w.robot.hand_pose(data), np.array(final)
        drive(w, data, here.position, goal, 500, (here.yaw, final_yaw),
              (here.pitch, final_pitch), joints)
        drive(w, data, goal, goal, 750, (final_yaw, final_yaw), (final_pitch, final_pitch),
              joints)
        position, angle = miss(w, data, goal, final_yaw, final_pitch)
        off += position > 1.0 or angle > 5.0
        q = np.array(joints)
        near = (np.minimum(q - LOW, HIGH - q) < 0.02).any(axis=1)
        on_limit = max(on_limit, float(near.sum() * w.dt))
    return (f"recovery, {name}: {off}/{len(FINALS)} poses more than 1 cm or 5 deg off; at most "
            f"{on_limit:.2f} s on a joint limit after the wall is cleared")


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--without-bands", action="store_true",
                        help="the dead-band springs' stiffness set to 0 (the controller before)")
    parser.add_argument("--posture-stiffness", type=float, default=franka.NULL_STIFFNESS,
                        metavar="K", help="joint springs to the ready posture [N m/rad]")
    args = parser.parse_args()
    franka.NULL_STIFFNESS = args.posture_stiffness
    if args.without_bands:
        franka.SPRING_BANDS = tuple((low, high, 0.0) for low, high, _ in franka.SPRING_BANDS)
    print(standard_motion(), flush=True)
    for wide in (False, True):
        print(static_poses(wide), flush=True)
    for name in CAUGHT:
        print(recovery(name), flush=True)
    return 0


if __name__ == "__main__":
    sys.exit(main())
