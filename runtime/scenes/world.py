"""Scene -> MuJoCo model: ground, lights, entities, robot, and the sensors Frames are decoded from.

Entities, in order: the scene's objects (file order), then `gripper` (Manipulator), then `floor`
(Surface). Every quantity a `Frames` holds comes out of `sensordata`, so native batched rollouts
give everything costs need:
- framepos / framequat / framelinvel / frameangvel of a site at each entity's centre;
- one MuJoCo `contact` sensor (data = number of contacts found) per entity pair that can touch
  (pairs of two static entities cannot, and are always False);
- per entity, a contact sensor with each finger, with the deepest contact's normal (Frames
  `fingers`, `finger_normals`; the builtin `holding` decides from them what is a grasp);
- the two finger joint positions (their sum is the opening);
- the clock, which tells a diverged rollout (MuJoCo resets it) from a good one.

Physics: timestep 2 ms, implicitfast, pyramidal cones, Newton. Restitution e is approximated by the
contact's damping ratio zeta = -ln(e) / sqrt(pi^2 + ln(e)^2) (the restitution of a damped spring
contact), with MuJoCo's default time constant 0.02 s. An object's friction applies to its contacts
with static geometry (objects have contact priority); the robot's pads (higher priority) use their
own; between two objects the larger one wins.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from functools import lru_cache
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from rapid_dsl.language.limits import WORKSPACE
from rapid_dsl.runtime.frames import Entity, EntityTable
from rapid_dsl.runtime.robots import ROBOT_NAMES, Robot, make_robot
from rapid_dsl.runtime.robots import hand as hand_mod
from rapid_dsl.runtime.scenes.meshes import load_hull

if TYPE_CHECKING:   # a scene's validation builds robots here: only its types are needed
    from rapid_dsl.runtime.scenes.schema import Scene, SceneObject

TIMESTEP = 0.002
FLOOR_EXTENT = WORKSPACE         # half-size of the floor plane [m]: it spans every valid position
CONTACT_TIMECONST = 0.02         # s, MuJoCo's default contact stiffness time constant
KIND_NAMES = {"object": "Object", "fixture": "Fixture", "surface": "Surface"}
DEFAULT_START_OFFSET = np.array([0.40, 0.0, 0.25])  # hand start relative to the robot base [m]
START_TOLERANCE = 0.005                             # the start posture must put the hand this close


@dataclass(frozen=True)
class SensorLayout:
    """Where each Frames quantity sits in `sensordata` (all index arrays into its last axis)."""

    pos: np.ndarray          # (E, 3)
    quat: np.ndarray         # (E, 4)
    linvel: np.ndarray       # (E, 3)
    angvel: np.ndarray       # (E, 3)
    pairs: np.ndarray        # (P, 2) entity index pairs with a contact sensor
    contact: np.ndarray      # (P,)
    grasp_entities: np.ndarray  # (G,) entities with finger contact sensors
    grasp_left: np.ndarray   # (G,) number of left-finger contacts
    grasp_right: np.ndarray  # (G,)
    grasp_left_normal: np.ndarray   # (G, 3) normal of the deepest left-finger contact
    grasp_right_normal: np.ndarray  # (G, 3)
    fingers: np.ndarray      # (2,) finger joint positions
    clock: int


@dataclass
class World:
    scene: Scene
    spec: mujoco.MjSpec
    model: mujoco.MjModel
    robot: Robot
    entities: EntityTable
    sensors: SensorLayout
    start_qpos: np.ndarray            # (nq,) scene poses + robot start posture
    start_ctrl: np.ndarray            # (nu,) ctrl holding the start posture

    def make_data(self) -> mujoco.MjData:
        """A new MjData in the start state (forward-evaluated)."""
        data = mujoco.MjData(self.model)
        self.reset(data)
        return data

    def reset(self, data: mujoco.MjData) -> None:
        """Put `data` in the start state: scene poses, robot start posture, holding ctrl."""
        mujoco.mj_resetData(self.model, data)
        data.qpos[:] = self.start_qpos
        data.ctrl[:] = self.start_ctrl
        mujoco.mj_forward(self.model, data)

    @property
    def dt(self) -> float:
        return float(self.model.opt.timestep)


def build_world(scene: Scene) -> World:
    """Compile the scene (robot included) into a MuJoCo model with its entity table and sensors.

    A validated scene always builds: names, sizes, masses and the start pose were checked against
    what this function needs (scene_schema.py, `reserved_names`, `start_problem`).
    """
    base = np.asarray(scene.robot_base, dtype=float)
    robot = make_robot(scene.robot, base)
    spec, entities, layout_names = _assemble(robot, scene.floor_height, scene.objects)
    model = spec.compile()
    robot.bind(model)
    sensors = _layout(model, layout_names)
    position, yaw, pitch = start_pose(scene)
    posture = start_posture(scene.robot, tuple(scene.robot_base), tuple(position), yaw, pitch)
    qpos = model.qpos0.copy()
    for joint, value in posture.joints:
        qpos[model.joint(joint).qposadr[0]] = value
    ctrl = robot.controls(position, np.array(yaw), np.array(pitch), np.array(0.0))
    world = World(scene, spec, model, robot, entities, sensors, qpos, ctrl)
    reached = robot.hand_pose(world.make_data()).position
    if np.linalg.norm(reached - position) > START_TOLERANCE:  # the robot-only model disagrees
        raise ValueError(f"the start posture puts the hand at {np.round(reached, 4).tolist()}, "
                         f"not at {np.round(position, 4).tolist()}")
    return world


def _assemble(robot: Robot, floor_height: float, objects: Sequence[SceneObject]
              ) -> tuple[mujoco.MjSpec, EntityTable, _SensorNames]:
    """The whole model's spec: ground, lights, objects, robot, entity sites and sensors."""
    spec = mujoco.MjSpec()
    spec.modelname = "rapid_scene"
    _options(spec)
    _visuals(spec, floor_height, robot.base)
    for obj in objects:
        _add_object(spec, obj)
    robot.build(spec)
    entities = _entity_table(objects, robot)
    _add_entity_sites(spec, objects, floor_height)
    return spec, entities, _add_sensors(spec, entities)


@lru_cache(maxsize=1)
def reserved_names() -> dict[str, str]:
    """Every name the model uses besides the objects' own, for either robot, with who uses it.

    MuJoCo needs names unique per kind of element and binding needs entity names unique, so an
    object may take none of these (whichever robot the scene has, so a scene can switch robots).
    """
    users: dict[str, list[str]] = {}
    for name in ROBOT_NAMES:
        robot = make_robot(name, np.zeros(3))
        spec, entities, _ = _assemble(robot, 0.0, ())
        for used in {used.decode() for used in spec.compile().names.split(b"\0") if used}:
            users.setdefault(used, []).append(name)
    fixed = {entity.name for entity in entities.entities}   # the same for both robots
    return {used: f"the scene's own `{used}` entity" if used in fixed else
            f"the {' and the '.join(robots)} model{'s use' if len(robots) > 1 else ' uses'} it"
            for used, robots in users.items()}


def start_pose(scene: Scene) -> tuple[np.ndarray, float, float]:
    """Where the hand starts: `gripper_start`, or a default in front of the base."""
    start = scene.gripper_start
    if start is None:
        return np.asarray(scene.robot_base) + DEFAULT_START_OFFSET, 0.0, 0.0
    return np.asarray(start.position, dtype=float), start.yaw, start.pitch


@dataclass(frozen=True)
class StartPosture:
    joints: tuple[tuple[str, float], ...]   # joint name -> value, fingers open
    reached: np.ndarray                     # (3,) where it puts the hand [m]


@lru_cache(maxsize=256)
def start_posture(robot_name: str, base: tuple[float, ...], position: tuple[float, ...],
                  yaw: float, pitch: float) -> StartPosture:
    """The robot's start posture for a hand pose, found on a model of the robot alone (its
    kinematics do not depend on the scene), so validation and `build_world` agree exactly."""
    robot = make_robot(robot_name, np.asarray(base, dtype=float))
    spec = mujoco.MjSpec()
    _options(spec)
    robot.build(spec)
    model = spec.compile()
    robot.bind(model)
    joints = robot.start_qpos(model, np.asarray(position), yaw, pitch)
    data = mujoco.MjData(model)
    for joint, value in joints.items():
        data.qpos[model.joint(joint).qposadr[0]] = value
    mujoco.mj_kinematics(model, data)
    reached = data.site(hand_mod.NAMES.tcp_site).xpos.copy()
    return StartPosture(tuple(joints.items()), reached)


def start_problem(scene: Scene) -> tuple[tuple[str, ...], str] | None:
    """Why the robot cannot start with its hand where the scene says, at which field; or None.

    The start must lie within the robot's reach of `robot_base` (the radius `reachable` uses:
    franka 0.855 m, floating_gripper 1 m), and the franka's IK must put the hand within
    START_TOLERANCE of it.
    """
    position, yaw, pitch = start_pose(scene)
    where = ("gripper_start", "position") if scene.gripper_start else ("robot_base",)
    base = np.asarray(scene.robot_base, dtype=float)
    reach = make_robot(scene.robot, base).reach
    distance = float(np.linalg.norm(position - base))
    shown = np.round(position, 3).tolist()
    if distance > reach:
        return where, (f"the hand start {shown} is {distance:.3f} m from robot_base, beyond the "
                       f"{scene.robot}'s reach of {reach:g} m")
    posture = start_posture(scene.robot, tuple(scene.robot_base), tuple(position), yaw, pitch)
    miss = float(np.linalg.norm(posture.reached - position))
    if miss > START_TOLERANCE:
        return where, (f"the {scene.robot} cannot put its hand at {shown} (with this yaw and "
                       f"pitch): its closest posture puts it at "
                       f"{np.round(posture.reached, 3).tolist()}, {miss * 100:.1f} cm away")
    return None


def _options(spec: mujoco.MjSpec) -> None:
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    # island discovery costs ~6 % per step in these few-body scenes and changes no result
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
    spec.compiler.autolimits = True
    spec.compiler.degree = False  # every angle in this package is in radians


def _visuals(spec: mujoco.MjSpec, floor_height: float, base: np.ndarray) -> None:
    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, width=300, height=300,
                     rgb1=[0.30, 0.33, 0.36], rgb2=[0.25, 0.28, 0.31])
    spec.add_material(name="floor", textures=["", "grid"], texrepeat=[8, 8])
    spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[FLOOR_EXTENT, FLOOR_EXTENT, 0.05],
        pos=[0, 0, floor_height], material="floor", friction=[0.8, 0.005, 0.0001],
        contype=hand_mod.SCENE_CONTYPE, conaffinity=hand_mod.SCENE_CONTYPE | hand_mod.ROBOT_CONTYPE)
    spec.worldbody.add_light(name="key", pos=base + [0.6, -0.6, 2.5], dir=[-0.2, 0.2, -1],
                             diffuse=[0.7, 0.7, 0.7], castshadow=True)
    spec.worldbody.add_light(name="fill", pos=base + [0.6, 0.8, 2.0], dir=[0, -0.3, -1],
                             diffuse=[0.3, 0.3, 0.3], castshadow=False)
    spec.visual.global_.offwidth = 1280
    spec.visual.global_.offheight = 720


def _quat(yaw: float, pitch: float, roll: float) -> np.ndarray:
    """R = Rz(yaw) Ry(pitch) Rx(roll) as a w x y z quaternion."""
    quat = np.zeros(4)
    mujoco.mju_euler2Quat(quat, np.array([yaw, pitch, roll]), "zyx")  # intrinsic z, y', x''
    return quat


def _solref(restitution: float) -> list[float]:
    if restitution <= 0:
        return [CONTACT_TIMECONST, 1.0]
    log_e = math.log(restitution)
    return [CONTACT_TIMECONST, -log_e / math.sqrt(math.pi**2 + log_e**2)]


def _add_object(spec: mujoco.MjSpec, obj: SceneObject) -> None:
    pose = obj.pose
    body = spec.worldbody.add_body(name=obj.name, pos=pose.position,
                                   quat=_quat(pose.yaw, pose.pitch, pose.roll))
    if not obj.is_static:
        body.add_freejoint(name=obj.name)
    extents = np.asarray(obj.extents)
    geom = dict(
        name=obj.name, rgba=list(obj.rgba or ()), friction=[obj.friction, 0.005, 0.0001],
        solref=_solref(obj.restitution), contype=hand_mod.SCENE_CONTYPE,
        conaffinity=hand_mod.SCENE_CONTYPE | hand_mod.ROBOT_CONTYPE,
        priority=0 if obj.is_static else 1,
    )
    if obj.mass is not None:
        geom["mass"] = obj.mass
    if obj.shape == "box":
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_BOX, size=extents / 2, **geom)
    elif obj.shape == "cylinder":
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_CYLINDER, size=[extents[0] / 2, extents[2] / 2],
                      **geom)
    elif obj.shape == "sphere":
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[extents[0] / 2], **geom)
    else:
        assert obj.mesh is not None
        hull = load_hull(obj.mesh)
        spec.add_mesh(name=obj.name, uservert=hull.scaled(extents).ravel().tolist(),
                      userface=hull.faces.ravel().tolist())
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_MESH, meshname=obj.name, **geom)


def _entity_table(objects: Sequence[SceneObject], robot: Robot) -> EntityTable:
    entities = [
        Entity(i, obj.name, KIND_NAMES[obj.kind], obj.label, obj.shape,  # type: ignore[arg-type]
               np.asarray(obj.extents, dtype=float))
        for i, obj in enumerate(objects)
    ]
    n = len(entities)
    entities.append(Entity(n, "gripper", "Manipulator", "gripper", "gripper",
                           hand_mod.GRIPPER_EXTENTS.copy()))
    entities.append(Entity(n + 1, "floor", "Surface", "floor", "plane",
                           np.array([2 * FLOOR_EXTENT, 2 * FLOOR_EXTENT, 0.0])))
    return EntityTable(tuple(entities), robot.base.copy(), robot.reach)


def _add_entity_sites(spec: mujoco.MjSpec, objects: Sequence[SceneObject],
                      floor_height: float) -> None:
    for obj in objects:
        spec.body(obj.name).add_site(name=obj.name, size=[0.005] * 3, group=4)
    spec.worldbody.add_site(name="floor", pos=[0, 0, floor_height], size=[0.005] * 3, group=4)


def _contact_side(entity: Entity) -> tuple[mujoco.mjtObj, str]:
    """How a contact sensor names an entity: the hand's subtree, the world body, or a body."""
    if entity.kind == "Manipulator":
        return mujoco.mjtObj.mjOBJ_XBODY, hand_mod.NAMES.hand  # XBODY = the body's subtree
    if entity.name == "floor":
        return mujoco.mjtObj.mjOBJ_BODY, "world"
    return mujoco.mjtObj.mjOBJ_BODY, entity.name


def _is_static(entity: Entity) -> bool:
    return entity.kind in ("Fixture", "Surface")


@dataclass
class _SensorNames:
    """Sensor names per Frames quantity, in the order they were added."""

    frames: dict[str, list[str]] = field(default_factory=dict)   # pos/quat/linvel/angvel
    pairs: list[tuple[int, int, str]] = field(default_factory=list)
    grasp: list[tuple[int, str, str]] = field(default_factory=list)
    fingers: list[str] = field(default_factory=list)


FRAME_SENSORS = {"pos": (mujoco.mjtSensor.mjSENS_FRAMEPOS, 3),
                 "quat": (mujoco.mjtSensor.mjSENS_FRAMEQUAT, 4),
                 "linvel": (mujoco.mjtSensor.mjSENS_FRAMELINVEL, 3),
                 "angvel": (mujoco.mjtSensor.mjSENS_FRAMEANGVEL, 3)}
# `contact` sensor data fields (bits of mjtConDataField): FOUND = number of matching contacts,
# NORMAL = the deepest one's normal. intprm = (fields, reduce = mindist, num = 1).
FOUND = 1 << int(mujoco.mjtConDataField.mjCONDATA_FOUND)
NORMAL = 1 << int(mujoco.mjtConDataField.mjCONDATA_NORMAL)


def _add_sensors(spec: mujoco.MjSpec, table: EntityTable) -> _SensorNames:
    names = _SensorNames()
    for key, (kind, _) in FRAME_SENSORS.items():
        names.frames[key] = []
        for entity in table.entities:
            site = hand_mod.NAMES.tcp_site if entity.kind == "Manipulator" else entity.name
            spec.add_sensor(name=f"{key}:{entity.name}", type=kind,
                            objtype=mujoco.mjtObj.mjOBJ_SITE, objname=site)
            names.frames[key].append(f"{key}:{entity.name}")
    for a in table.entities:
        for b in table.entities[a.index + 1:]:
            if _is_static(a) and _is_static(b):
                continue  # two static bodies never collide
            name = f"contact:{a.name}:{b.name}"
            _contact_sensor(spec, name, _contact_side(a), _contact_side(b), FOUND)
            names.pairs.append((a.index, b.index, name))
    for entity in table.entities:
        if entity.kind == "Manipulator" or entity.name == "floor":
            continue
        sides = []
        for finger in (hand_mod.NAMES.finger_left, hand_mod.NAMES.finger_right):
            name = f"grasp:{finger}:{entity.name}"
            _contact_sensor(spec, name, (mujoco.mjtObj.mjOBJ_BODY, finger), _contact_side(entity),
                            FOUND | NORMAL)
            sides.append(name)
        names.grasp.append((entity.index, sides[0], sides[1]))
    for joint in (hand_mod.NAMES.joint_left, hand_mod.NAMES.joint_right):
        spec.add_sensor(name=f"finger:{joint}", type=mujoco.mjtSensor.mjSENS_JOINTPOS,
                        objtype=mujoco.mjtObj.mjOBJ_JOINT, objname=joint)
        names.fingers.append(f"finger:{joint}")
    spec.add_sensor(name="clock", type=mujoco.mjtSensor.mjSENS_CLOCK)
    return names


def _contact_sensor(spec: mujoco.MjSpec, name: str, side1: tuple[mujoco.mjtObj, str],
                    side2: tuple[mujoco.mjtObj, str], fields: int) -> None:
    spec.add_sensor(name=name, type=mujoco.mjtSensor.mjSENS_CONTACT, objtype=side1[0],
                    objname=side1[1], reftype=side2[0], refname=side2[1], intprm=[fields, 1, 1])


def _layout(model: mujoco.MjModel, names: _SensorNames) -> SensorLayout:
    def adr(name: str, width: int) -> np.ndarray:
        sensor = model.sensor(name)
        assert sensor.dim[0] == width, (name, sensor.dim)
        return sensor.adr[0] + np.arange(width)

    frames = {key: np.stack([adr(n, FRAME_SENSORS[key][1]) for n in sensor_names])
              for key, sensor_names in names.frames.items()}
    left = np.array([adr(n, 4) for _, n, _ in names.grasp], dtype=int).reshape(-1, 4)
    right = np.array([adr(n, 4) for _, _, n in names.grasp], dtype=int).reshape(-1, 4)
    return SensorLayout(
        pairs=np.array([(a, b) for a, b, _ in names.pairs], dtype=int).reshape(-1, 2),
        contact=np.array([adr(n, 1)[0] for _, _, n in names.pairs], dtype=int),
        grasp_entities=np.array([e for e, _, _ in names.grasp], dtype=int),
        grasp_left=left[:, 0], grasp_right=right[:, 0],
        grasp_left_normal=left[:, 1:], grasp_right_normal=right[:, 1:],
        fingers=np.array([adr(n, 1)[0] for n in names.fingers], dtype=int),
        clock=int(adr("clock", 1)[0]),
        **frames,
    )
