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
from dataclasses import dataclass, field

import mujoco
import numpy as np

from rapid_dsl.runtime.frames import Entity, EntityTable
from rapid_dsl.runtime.meshes import load_hull
from rapid_dsl.runtime.robots import Robot, make_robot
from rapid_dsl.runtime.robots import hand as hand_mod
from rapid_dsl.runtime.scene import Scene, SceneObject

TIMESTEP = 0.002
FLOOR_EXTENT = 10.0              # half-size of the floor plane [m]
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

    Raises ValueError when the robot cannot put its hand at `gripper_start`.
    """
    base = np.asarray(scene.robot_base, dtype=float)
    robot = make_robot(scene.robot, base)
    spec = mujoco.MjSpec()
    spec.modelname = "rapid_scene"
    _options(spec)
    _visuals(spec, scene)
    for obj in scene.objects:
        _add_object(spec, obj)
    robot.build(spec)
    entities = _entity_table(scene, robot)
    _add_entity_sites(spec, scene)
    layout_names = _add_sensors(spec, entities)
    model = spec.compile()
    robot.bind(model)
    sensors = _layout(model, layout_names)
    start = scene.gripper_start
    position = np.asarray(start.position) if start else base + DEFAULT_START_OFFSET
    yaw, pitch = (start.yaw, start.pitch) if start else (0.0, 0.0)
    qpos = model.qpos0.copy()
    for joint, value in robot.start_qpos(model, position, yaw, pitch).items():
        qpos[model.joint(joint).qposadr[0]] = value
    ctrl = robot.controls(position, np.array(yaw), np.array(pitch), np.array(0.0))
    world = World(scene, spec, model, robot, entities, sensors, qpos, ctrl)
    reached = robot.hand_pose(world.make_data()).position
    if np.linalg.norm(reached - position) > START_TOLERANCE:
        where = f"{scene.source}: " if scene.source else ""
        raise ValueError(f"{where}gripper_start {np.round(position, 3).tolist()} is out of the "
                         f"{robot.name}'s reach (the closest posture puts the hand at "
                         f"{np.round(reached, 3).tolist()})")
    return world


def _options(spec: mujoco.MjSpec) -> None:
    spec.option.timestep = TIMESTEP
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
    spec.option.cone = mujoco.mjtCone.mjCONE_PYRAMIDAL
    spec.option.solver = mujoco.mjtSolver.mjSOL_NEWTON
    # island discovery costs ~6 % per step in these few-body scenes and changes no result
    spec.option.disableflags |= mujoco.mjtDisableBit.mjDSBL_ISLAND
    spec.compiler.autolimits = True
    spec.compiler.degree = False  # every angle in this package is in radians


def _visuals(spec: mujoco.MjSpec, scene: Scene) -> None:
    spec.add_texture(name="grid", type=mujoco.mjtTexture.mjTEXTURE_2D,
                     builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER, width=300, height=300,
                     rgb1=[0.30, 0.33, 0.36], rgb2=[0.25, 0.28, 0.31])
    spec.add_material(name="floor", textures=["", "grid"], texrepeat=[8, 8])
    spec.worldbody.add_geom(
        name="floor", type=mujoco.mjtGeom.mjGEOM_PLANE, size=[FLOOR_EXTENT, FLOOR_EXTENT, 0.05],
        pos=[0, 0, scene.floor_height], material="floor", friction=[0.8, 0.005, 0.0001],
        contype=hand_mod.SCENE_CONTYPE, conaffinity=hand_mod.SCENE_CONTYPE | hand_mod.ROBOT_CONTYPE)
    base = np.asarray(scene.robot_base)
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


def _entity_table(scene: Scene, robot: Robot) -> EntityTable:
    entities = [
        Entity(i, obj.name, KIND_NAMES[obj.kind], obj.label, obj.shape,  # type: ignore[arg-type]
               np.asarray(obj.extents, dtype=float))
        for i, obj in enumerate(scene.objects)
    ]
    n = len(entities)
    entities.append(Entity(n, "gripper", "Manipulator", "gripper", "gripper",
                           hand_mod.GRIPPER_EXTENTS.copy()))
    entities.append(Entity(n + 1, "floor", "Surface", "floor", "plane",
                           np.array([2 * FLOOR_EXTENT, 2 * FLOOR_EXTENT, 0.0])))
    return EntityTable(tuple(entities), np.asarray(scene.robot_base, dtype=float), robot.reach)


def _add_entity_sites(spec: mujoco.MjSpec, scene: Scene) -> None:
    for obj in scene.objects:
        spec.body(obj.name).add_site(name=obj.name, size=[0.005] * 3, group=4)
    spec.worldbody.add_site(name="floor", pos=[0, 0, scene.floor_height], size=[0.005] * 3,
                            group=4)


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
