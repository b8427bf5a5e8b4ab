"""Numpy implementations of every builtin in the registry, vectorized over rollouts and time.

Calling convention (what compiled programs emit): every function and relation is
`impl(frames, *args)`. An entity argument is an int entity index; a quantity is a float or an array
broadcastable to (B, T); a vector is an array broadcastable to (B, T, 3). Quantities come back as
(B, T) arrays, vectors as (B, T, 3), relations as bool (B, T). Values are SI (m, rad, kg, s).
Constants (`up`, `pi`) are plain values in `IMPLEMENTATIONS`, not callables.

Bodies are seen as oriented boxes: centre `frames.pos`, orientation `frames.quat` (w x y z) and the
entity's full `extents` along its own axes. docs/builtins.md states each builtin's exact meaning.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np

from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.robots.hand import FINGER_BASE, FINGER_LENGTH, TCP_DEPTH

# Relation thresholds (SI). Named here so that docs, tests and tuning refer to the same numbers.
ON_GAP = 0.01                       # on: |bottom(o) - top(s)| at most 1 cm
ON_TOUCH_SLACK = 0.003              # on: with no MuJoCo contact, the gap must be within 3 mm
FACES_RANGE = 0.5                   # faces: distance(f, o) at most 50 cm
SETTLED_SPEED = 0.01                # settled: linear speed below 1 cm/s
SETTLED_SPIN = 0.1                  # settled: angular speed below 0.1 rad/s
UPRIGHT_TILT = math.radians(10.0)   # upright: z axis within 10 deg of world up
UNDISTURBED = 0.01                  # undisturbed: no Object moved more than 1 cm
HOLD_AXIS_COS = math.cos(math.radians(45))     # holding: each finger's contact normal within
                                               # 45 deg of the opening axis (a squeeze)
HOLD_OPPOSED_COS = math.cos(math.radians(30))  # holding: the two normals within 30 deg of opposite
HOLD_DEPTH = 0.005                  # holding: o reaches 5 mm past the fingertips
TIP_OFFSET = FINGER_BASE + FINGER_LENGTH - TCP_DEPTH   # fingertips beyond the tool point [m]
PALM_DEPTH = TCP_DEPTH - FINGER_BASE    # the palm (finger roots) behind the tool point [m]
_EPS = 1e-9                         # lengths below this count as zero (coincident centres)

UP = np.array([0.0, 0.0, 1.0])
_XY = np.array([1.0, 1.0, 0.0])

Quantity = float | np.ndarray
Vector = np.ndarray


# ---------------------------------------------------------------------------------------------
# Helpers for compiled code (not builtins: programs cannot name them).

def vec(x: Quantity, y: Quantity, z: Quantity) -> Vector:
    """A vector (..., 3) from three broadcastable quantities (vector literals `[a, b, c]`)."""
    return np.stack(np.broadcast_arrays(x, y, z), axis=-1).astype(float, copy=False)


def component(v: Vector, i: int) -> np.ndarray:
    """`v.x`, `v.y`, `v.z` for i = 0, 1, 2."""
    return np.asarray(v)[..., i]


def scale(q: Quantity, v: Vector) -> Vector:
    """`q * v`: a quantity (B, T) times a vector (B, T, 3)."""
    return np.asarray(q)[..., None] * v


# ---------------------------------------------------------------------------------------------
# Geometry of oriented boxes.

def _rot(frames: Frames, e: int) -> np.ndarray:
    """(B, T, 3, 3) rotation matrices of entity e; column i is the body's axis i in world."""
    q = frames.quat[:, :, e]
    w, x, y, z = q[..., 0], q[..., 1], q[..., 2], q[..., 3]
    s = 2.0 / (w * w + x * x + y * y + z * z)  # exact for quaternions that are not quite unit
    rot = np.empty(q.shape[:-1] + (3, 3))
    rot[..., 0, 0] = 1 - s * (y * y + z * z)
    rot[..., 0, 1] = s * (x * y - w * z)
    rot[..., 0, 2] = s * (x * z + w * y)
    rot[..., 1, 0] = s * (x * y + w * z)
    rot[..., 1, 1] = 1 - s * (x * x + z * z)
    rot[..., 1, 2] = s * (y * z - w * x)
    rot[..., 2, 0] = s * (x * z - w * y)
    rot[..., 2, 1] = s * (y * z + w * x)
    rot[..., 2, 2] = 1 - s * (x * x + y * y)
    return rot


def _half(frames: Frames, e: int) -> np.ndarray:
    """(3,) half extents of entity e."""
    return 0.5 * np.asarray(frames.entities.entities[e].extents, dtype=float)


def _local(rot: np.ndarray, v: Vector) -> Vector:
    """World vector(s) v (..., 3) expressed in the body frame given by rot (..., 3, 3)."""
    v = np.asarray(v)
    # Written out: a batched (3,) x (3, 3) product is much slower through sum() or matmul.
    return (v[..., 0, None] * rot[..., 0, :] + v[..., 1, None] * rot[..., 1, :]
            + v[..., 2, None] * rot[..., 2, :])


def _support(rot: np.ndarray, half: np.ndarray, n: Vector) -> np.ndarray:
    """Half-width of the box (rot, half) along unit direction(s) n: max over the box of x . n."""
    return np.abs(_local(rot, n)) @ half


def _vertical_half(frames: Frames, e: int) -> np.ndarray:
    """(B, T) half-height of entity e's box in world z."""
    return np.abs(_rot(frames, e)[..., 2, :]) @ _half(frames, e)


def _face_axis(frames: Frames, f: int, point: Vector) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Which of f's side faces (+-x or +-y) looks toward `point`.

    The face is the one the ray from f's centre to the point leaves through, measured in units of
    f's half extents, so a thin wall's broad face wins even for points far along the wall.
    Returns (uses_x (B, T) bool, local coordinates (B, T, 3), rotation (B, T, 3, 3)).
    """
    rot = _rot(frames, f)
    local = _local(rot, np.asarray(point) - frames.pos[:, :, f])
    half = np.maximum(_half(frames, f), _EPS)
    uses_x = np.abs(local[..., 0]) / half[0] >= np.abs(local[..., 1]) / half[1]
    return uses_x, local, rot


def _over_footprint(frames: Frames, f: int, point: Vector) -> np.ndarray:
    """(B, T) bool: point lies within f's box along f's own x and y axes."""
    local = _local(_rot(frames, f), np.asarray(point) - frames.pos[:, :, f])
    half = _half(frames, f)
    return (np.abs(local[..., 0]) <= half[0]) & (np.abs(local[..., 1]) <= half[1])


# ---------------------------------------------------------------------------------------------
# Geometry of scene entities.

def pos(frames: Frames, b: int) -> Vector:
    return frames.pos[:, :, b]


def extents(frames: Frames, b: int) -> Vector:
    shape = frames.pos.shape[:2] + (3,)
    return np.broadcast_to(2.0 * _half(frames, b), shape)


def distance(frames: Frames, a: int, b: int) -> np.ndarray:
    """Largest separation of the two boxes' projections over candidate axes.

    Candidates are the centre line and the three axes of each box. Every projection gap is a lower
    bound of the true gap, and it is exact whenever a face of either box separates them (the usual
    case: box beside a wall, box above a table), where the centre line alone underestimates.
    """
    rot_a, rot_b = _rot(frames, a), _rot(frames, b)
    half_a, half_b = _half(frames, a), _half(frames, b)
    c = frames.pos[:, :, b] - frames.pos[:, :, a]
    c_a, c_b = _local(rot_a, c), _local(rot_b, c)           # centre offset in each box's frame
    # cosines[..., i, j] = |a_i . b_j| between the boxes' axes.
    cosines = np.abs(np.swapaxes(rot_a, -1, -2) @ rot_b)
    gaps_a = np.abs(c_a) - half_a - cosines @ half_b                   # along a's axes
    gaps_b = np.abs(c_b) - half_b - half_a @ cosines                   # along b's axes
    length = np.sqrt((c * c).sum(axis=-1))
    inv = np.where(length > _EPS, 1.0 / np.maximum(length, _EPS), 0.0)
    gap_c = length - (np.abs(c_a) @ half_a + np.abs(c_b) @ half_b) * inv  # along the centre line
    return np.maximum.reduce([gaps_a[..., 0], gaps_a[..., 1], gaps_a[..., 2], gaps_b[..., 0],
                              gaps_b[..., 1], gaps_b[..., 2], gap_c, np.zeros_like(gap_c)])


def direction(frames: Frames, a: int, b: int) -> Vector:
    flat = (frames.pos[:, :, b] - frames.pos[:, :, a]) * _XY
    length = np.linalg.norm(flat, axis=-1, keepdims=True)
    return np.where(length > _EPS, flat / np.maximum(length, _EPS), 0.0)


def height(frames: Frames, b: int) -> np.ndarray:
    return frames.pos[:, :, b, 2]


def bottom(frames: Frames, b: int) -> np.ndarray:
    return frames.pos[:, :, b, 2] - _vertical_half(frames, b)


def top(frames: Frames, b: int) -> np.ndarray:
    return frames.pos[:, :, b, 2] + _vertical_half(frames, b)


def yaw(frames: Frames, b: int) -> np.ndarray:
    rot = _rot(frames, b)
    angle = np.arctan2(rot[..., 1, 0], rot[..., 0, 0])
    return np.where(angle <= -math.pi, angle + 2 * math.pi, angle)


def tilt(frames: Frames, b: int) -> np.ndarray:
    return np.arccos(np.clip(_rot(frames, b)[..., 2, 2], -1.0, 1.0))


def speed(frames: Frames, b: int) -> np.ndarray:
    return np.linalg.norm(frames.linvel[:, :, b], axis=-1)


def spin(frames: Frames, b: int) -> np.ndarray:
    return np.linalg.norm(frames.angvel[:, :, b], axis=-1)


def rotation(frames: Frames, b: int, about: Vector) -> np.ndarray:
    """Twist of the world-frame rotation since the start about `about`, right-handed, (-pi, pi]."""
    q = frames.quat[:, :, b]
    q0 = frames.first().quat[:, :, b]
    w, v = q[..., 0], q[..., 1:]
    w0, v0 = q0[..., 0], q0[..., 1:]
    # q_rel = q * conj(q0): the rotation applied in world coordinates since the start.
    rel_w = w * w0 + (v * v0).sum(axis=-1)
    rel_v = w0[..., None] * v - w[..., None] * v0 - cross(frames, v, v0)
    axis = normalize(frames, np.asarray(about, dtype=float))
    angle = 2.0 * np.arctan2((rel_v * axis).sum(axis=-1), rel_w)
    return math.pi - np.mod(math.pi - angle, 2.0 * math.pi)


def contact_point(frames: Frames, o: int, away_from: int) -> Vector:
    toward = direction(frames, o, away_from)
    reach = _support(_rot(frames, o), _half(frames, o), toward)
    return frames.pos[:, :, o] - reach[..., None] * toward


def edge_axis(frames: Frames, o: int, f: int, s: int) -> Vector:
    # up x d, d into f's face (its normal, not the line between the centres, which runs oblique
    # when o stands off f's middle): a positive rotation about it moves o's top toward f (s only
    # names the support).
    return cross(frames, UP, -normal_toward(frames, f, o))


def normal_toward(frames: Frames, f: int, o: int) -> Vector:
    uses_x, local, rot = _face_axis(frames, f, frames.pos[:, :, o])
    coord = np.where(uses_x, local[..., 0], local[..., 1])
    sign = np.where(coord < 0.0, -1.0, 1.0)
    axis = np.where(uses_x[..., None], rot[..., :, 0], rot[..., :, 1])
    return sign[..., None] * axis


def half_extent(frames: Frames, b: int, along: Vector) -> np.ndarray:
    n = normalize(frames, np.asarray(along, dtype=float))
    return _support(_rot(frames, b), _half(frames, b), n)


def heading(frames: Frames, b: int) -> Vector:
    return normalize(frames, horizontal(frames, _rot(frames, b)[..., :, 0]))


def narrow_side(frames: Frames, b: int) -> Vector:
    # The horizontal width along d is sum_i h_i |a_i . d|, concave between the directions where
    # one term vanishes, so its minimum is at a direction perpendicular to one axis's horizontal
    # projection: three candidates, exact for any orientation (flat, standing, on an edge).
    rot, half = _rot(frames, b), _half(frames, b)
    best_dir = np.zeros(rot.shape[:-2] + (3,))
    best_width = np.full(rot.shape[:-2], np.inf)
    for i in range(3):
        across = np.cross(UP, rot[..., :, i] * _XY)
        length = np.linalg.norm(across, axis=-1)
        valid = length > 1e-6              # an axis pointing straight up gives no candidate
        d = across / np.maximum(length, 1e-6)[..., None]
        width = np.where(valid, _support(rot, half, d), np.inf)
        better = width < best_width - 1e-9
        best_dir = np.where(better[..., None], d, best_dir)
        best_width = np.where(better, width, best_width)
    return best_dir


def palm_depth(frames: Frames, m: int) -> np.ndarray:
    return np.full(frames.opening.shape, PALM_DEPTH)


def opening(frames: Frames, m: int) -> np.ndarray:
    return frames.opening


def disturbance(frames: Frames, m: int) -> np.ndarray:
    # every Object, whoever moved it: the hand is the only actor while a primitive runs
    objects = [e.index for e in frames.entities.entities if e.kind == "Object"]
    if not objects:
        return np.zeros(frames.opening.shape)
    moved = frames.pos[:, :, objects] - frames.first().pos[:, :, objects]
    return np.linalg.norm(moved, axis=-1).max(axis=-1)


# ---------------------------------------------------------------------------------------------
# Math, generic in the dimension; vectors use the last axis.

def abs_(frames: Frames, x: Quantity) -> np.ndarray:
    return np.abs(x)


def min_(frames: Frames, a: Quantity, b: Quantity) -> np.ndarray:
    return np.minimum(a, b)


def max_(frames: Frames, a: Quantity, b: Quantity) -> np.ndarray:
    return np.maximum(a, b)


def clamp(frames: Frames, x: Quantity, lo: Quantity, hi: Quantity) -> np.ndarray:
    return np.minimum(np.maximum(x, lo), hi)


def sqrt(frames: Frames, x: Quantity) -> np.ndarray:
    return np.sqrt(x)


def sin(frames: Frames, a: Quantity) -> np.ndarray:
    return np.sin(a)


def cos(frames: Frames, a: Quantity) -> np.ndarray:
    return np.cos(a)


def atan2(frames: Frames, y: Quantity, x: Quantity) -> np.ndarray:
    return np.arctan2(y, x)


def norm(frames: Frames, v: Vector) -> np.ndarray:
    v = np.asarray(v)
    return np.sqrt((v * v).sum(axis=-1))


def dot(frames: Frames, a: Vector, b: Vector) -> np.ndarray:
    return (np.asarray(a) * np.asarray(b)).sum(axis=-1)


def cross(frames: Frames, a: Vector, b: Vector) -> Vector:
    a, b = np.asarray(a), np.asarray(b)
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack(np.broadcast_arrays(a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0),
                    axis=-1)


def normalize(frames: Frames, v: Vector) -> Vector:
    """Unit vector along v; the zero vector stays zero."""
    v = np.asarray(v, dtype=float)
    length = np.sqrt((v * v).sum(axis=-1, keepdims=True))
    return np.where(length > _EPS, v / np.maximum(length, _EPS), 0.0)


def horizontal(frames: Frames, v: Vector) -> Vector:
    return np.asarray(v) * _XY


# ---------------------------------------------------------------------------------------------
# Relations: bool (B, T).

def on(frames: Frames, o: int, s: int) -> np.ndarray:
    gap = np.abs(bottom(frames, o) - top(frames, s))
    touch = frames.contact[:, :, o, s] | (gap <= ON_TOUCH_SLACK)
    return (gap <= ON_GAP) & _over_footprint(frames, s, frames.pos[:, :, o]) & touch


def touching(frames: Frames, a: int, b: int) -> np.ndarray:
    return frames.contact[:, :, a, b]


def faces(frames: Frames, f: int, o: int) -> np.ndarray:
    uses_x, local, _ = _face_axis(frames, f, frames.pos[:, :, o])
    half = _half(frames, f)
    across = np.where(uses_x, np.abs(local[..., 0]) >= half[0], np.abs(local[..., 1]) >= half[1])
    within_span = np.where(uses_x, np.abs(local[..., 1]) <= half[1],
                           np.abs(local[..., 0]) <= half[0])
    # "On the same support": their vertical extents overlap, so o can lean on f.
    level = (bottom(frames, o) < top(frames, f)) & (bottom(frames, f) < top(frames, o))
    near = distance(frames, f, o) <= FACES_RANGE
    return across & within_span & level & near


def reachable(frames: Frames, m: int, b: int) -> np.ndarray:
    table = frames.entities
    offset = frames.pos[:, :, b] - np.asarray(table.robot_base, dtype=float)
    return np.linalg.norm(offset, axis=-1) <= table.robot_reach


def inside(frames: Frames, o: int, f: int) -> np.ndarray:
    return _over_footprint(frames, f, frames.pos[:, :, o])


def settled(frames: Frames, o: int) -> np.ndarray:
    return (speed(frames, o) < SETTLED_SPEED) & (spin(frames, o) < SETTLED_SPIN)


def holding(frames: Frames, m: int, o: int) -> np.ndarray:
    """Both fingers squeeze o from opposite sides, o reaching well between the fingers.

    A push with the front of the fingers (normals along the approach), a pinch above a round
    object's widest part (normals tilted apart) or on a box's top edge (o barely past the
    fingertips) touches with both fingers but does not lift o.
    """
    tool = _rot(frames, m)                               # tool frame: fingers along -z
    opening_axis, approach = tool[..., :, 1], -tool[..., :, 2]
    normals = frames.finger_normals[:, :, o]             # (B, T, 2, 3), finger -> o
    along = np.abs((normals * opening_axis[..., None, :]).sum(-1)) >= HOLD_AXIS_COS
    opposed = (normals[..., 0, :] * normals[..., 1, :]).sum(-1) <= -HOLD_OPPOSED_COS
    # How far o's box reaches past the fingertips toward the hand, within the fingers' length.
    tips = frames.pos[:, :, m] + TIP_OFFSET * approach
    depth = ((tips - frames.pos[:, :, o]) * approach).sum(-1)      # of o's centre
    half = _support(_rot(frames, o), _half(frames, o), approach)
    between = (depth + half >= HOLD_DEPTH) & (depth - half <= FINGER_LENGTH)
    return frames.fingers[:, :, o].all(-1) & along.all(-1) & opposed & between


def upright(frames: Frames, o: int) -> np.ndarray:
    return tilt(frames, o) <= UPRIGHT_TILT


def undisturbed(frames: Frames, m: int) -> np.ndarray:
    return disturbance(frames, m) < UNDISTURBED


# ---------------------------------------------------------------------------------------------

CONSTANTS: dict[str, Any] = {"up": UP, "pi": math.pi}

IMPLEMENTATIONS: dict[str, Callable[..., Any] | Any] = {
    "pos": pos, "extents": extents, "distance": distance, "direction": direction,
    "height": height, "bottom": bottom, "top": top, "yaw": yaw, "tilt": tilt, "speed": speed,
    "spin": spin, "rotation": rotation, "contact_point": contact_point, "edge_axis": edge_axis,
    "normal_toward": normal_toward, "half_extent": half_extent, "heading": heading,
    "narrow_side": narrow_side, "palm_depth": palm_depth, "opening": opening,
    "disturbance": disturbance,
    "abs": abs_, "min": min_, "max": max_, "clamp": clamp, "sqrt": sqrt, "sin": sin, "cos": cos,
    "atan2": atan2, "norm": norm, "dot": dot, "cross": cross, "normalize": normalize,
    "horizontal": horizontal,
    "on": on, "touching": touching, "faces": faces, "reachable": reachable, "inside": inside,
    "settled": settled, "holding": holding, "upright": upright, "undisturbed": undisturbed,
    **CONSTANTS,
}
