"""Geometry of the numpy builtins on synthetic frames with known answers."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
from frames_factory import Body, make_frames, quat_about, quat_mul, quat_yaw, tabletop

from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.runtime import builtins as B
from rapid_dsl.runtime.builtins import IMPLEMENTATIONS
from rapid_dsl.runtime.frames import is_subkind

DOCS = Path(__file__).resolve().parents[2] / "docs" / "builtins.md"


def _rot(q: np.ndarray) -> np.ndarray:
    frames = make_frames([Body("x", "Object", (1, 1, 1), (0, 0, 0), q)])
    return B._rot(frames, 0)[0, 0]


# --- registry coverage -----------------------------------------------------------------------

def test_implementations_cover_exactly_the_registry():
    assert set(IMPLEMENTATIONS) == set(BUILTINS)
    for name, builtin in BUILTINS.items():
        assert callable(IMPLEMENTATIONS[name]) == (builtin.kind != "constant"), name


def test_docs_list_every_registry_signature_once():
    documented = re.findall(r"^- `([^`]+)` — ", DOCS.read_text(), flags=re.MULTILINE)
    assert sorted(documented) == sorted(b.signature for b in BUILTINS.values())


def _args_for(builtin, frames, rng):
    """Plausible arguments for any registry entry, from its parameter types."""
    batch, steps = frames.batch, frames.steps
    args = []
    for param in builtin.params:
        kinds = [e.index for e in frames.entities.entities if is_subkind(e.kind, param.type)]
        if kinds:
            args.append(kinds[-1])
        elif param.type.startswith("Vec") or param.type in ("Point", "Direction"):
            args.append(rng.normal(size=(batch, steps, 3)))
        else:
            args.append(rng.uniform(0.1, 1.0, size=(batch, steps)))
    return args


def test_every_builtin_returns_batch_by_time_shapes():
    rng = np.random.default_rng(0)
    batch, steps = 3, 5
    bodies = tabletop(
        box=Body("box", "Object", (0.2, 0.14, 0.03),
                 rng.normal(scale=0.05, size=(batch, steps, 3)) + [0.5, 0.0, 0.015]),
        wall=Body("wall", "Fixture", (0.02, 0.4, 0.3), (0.8, 0.0, 0.15), quat_yaw(0.2)),
    )
    frames = make_frames(bodies, batch=batch, steps=steps)
    for name, builtin in BUILTINS.items():
        if builtin.kind == "constant":
            continue
        out = np.asarray(IMPLEMENTATIONS[name](frames, *_args_for(builtin, frames, rng)))
        vector = builtin.returns.startswith("Vec") or builtin.returns in ("Point", "Direction")
        expected = (batch, steps, 3) if vector else (batch, steps)
        assert out.shape == expected, name
        if builtin.kind == "relation":
            assert out.dtype == bool, name
        else:
            assert np.all(np.isfinite(out)), name


# --- distance, direction, heights ------------------------------------------------------------

def _pair(pos_b, quat_b=(1, 0, 0, 0), ext_a=(0.2, 0.1, 0.1), ext_b=(0.1, 0.1, 0.1)):
    return make_frames([Body("a", "Object", ext_a, (0, 0, 0)),
                        Body("b", "Object", ext_b, pos_b, quat_b)])


@pytest.mark.parametrize("gap", [0.0, 0.01, 0.15, 0.4])
def test_distance_between_aligned_boxes_is_the_gap(gap):
    frames = _pair((0.1 + 0.05 + gap, 0.0, 0.0))
    assert B.distance(frames, 0, 1)[0, 0] == pytest.approx(gap, abs=1e-12)
    assert B.distance(frames, 1, 0)[0, 0] == pytest.approx(gap, abs=1e-12)


def test_distance_uses_the_rotated_extent():
    # b is 0.2 long but yawed 90 deg, so only 0.05 of it reaches toward a.
    frames = _pair((0.25, 0.0, 0.0), quat_yaw(math.pi / 2), ext_b=(0.2, 0.1, 0.1))
    assert B.distance(frames, 0, 1)[0, 0] == pytest.approx(0.1)


def test_distance_is_exact_beside_a_tall_wall_at_another_height():
    frames = make_frames([Body("box", "Object", (0.2, 0.14, 0.03), (0.5, 0.1, 0.015)),
                          Body("wall", "Fixture", (0.02, 0.4, 0.3), (0.8, 0.0, 0.15))])
    assert B.distance(frames, 0, 1)[0, 0] == pytest.approx(0.8 - 0.01 - 0.5 - 0.1)


def test_distance_is_zero_when_overlapping_and_when_touching():
    assert B.distance(_pair((0.1, 0.02, 0.0)), 0, 1)[0, 0] == 0.0
    assert B.distance(_pair((0.15, 0.0, 0.1)), 0, 1)[0, 0] == pytest.approx(0.0, abs=1e-12)


def _true_gap(pos, rot, half, iterations=400):
    """Euclidean distance between oriented boxes by alternating projections (exact in the limit)."""
    def project(point, k):
        local = np.einsum("nji,nj->ni", rot[k], point - pos[k])
        return pos[k] + np.einsum("nij,nj->ni", rot[k], np.clip(local, -half[k], half[k]))
    x = pos[0].copy()
    for _ in range(iterations):
        y = project(x, 1)
        x = project(y, 0)
    return np.linalg.norm(x - project(x, 1), axis=-1)


def test_distance_never_exceeds_the_true_gap_of_rotated_boxes():
    rng = np.random.default_rng(1)
    n = 200
    quats = np.stack([quat_about(rng.normal(size=3), rng.uniform(0, math.pi))
                      for _ in range(2 * n)]).reshape(2, n, 4)
    half = rng.uniform(0.025, 0.15, size=(2, n, 3))
    pos = np.stack([np.zeros((n, 3)), rng.normal(scale=0.3, size=(n, 3))])
    rot = np.array([[_rot(q) for q in quats[k]] for k in range(2)])
    true = _true_gap(pos, rot, half)
    ours = np.empty(n)
    for i in range(n):  # extents are per entity, so one frame per random pair
        pair = make_frames([Body("a", "Object", 2 * half[0, i], pos[0, i], quats[0, i]),
                            Body("b", "Object", 2 * half[1, i], pos[1, i], quats[1, i])])
        ours[i] = B.distance(pair, 0, 1)[0, 0]
    assert np.all(ours >= 0.0) and np.all(ours <= true + 1e-6)
    separated = true > 0.01
    assert separated.sum() > n // 2
    # A lower bound, but a useful one: on random poses it is rarely far below the true gap.
    assert np.median(ours[separated] / true[separated]) > 0.8


def test_direction_is_horizontal_unit_or_zero():
    frames = _pair((0.3, 0.4, 1.0))
    np.testing.assert_allclose(B.direction(frames, 0, 1)[0, 0], [0.6, 0.8, 0.0])
    np.testing.assert_allclose(B.direction(frames, 1, 0)[0, 0], [-0.6, -0.8, 0.0])
    np.testing.assert_array_equal(B.direction(_pair((0.0, 0.0, 0.5)), 0, 1)[0, 0], [0, 0, 0])


def test_bottom_and_top_follow_tilt():
    box = Body("box", "Object", (0.2, 0.14, 0.03), (0, 0, 0.5), quat_about([1, 0, 0], math.pi / 2))
    frames = make_frames([box])
    assert B.height(frames, 0)[0, 0] == pytest.approx(0.5)
    assert B.bottom(frames, 0)[0, 0] == pytest.approx(0.5 - 0.07)
    assert B.top(frames, 0)[0, 0] == pytest.approx(0.5 + 0.07)
    np.testing.assert_allclose(B.extents(frames, 0)[0, 0], [0.2, 0.14, 0.03])


# --- orientation -----------------------------------------------------------------------------

@pytest.mark.parametrize("angle", [0.0, 0.7, -2.5, math.pi])
def test_yaw_reads_the_heading(angle):
    frames = make_frames([Body("b", "Object", (1, 1, 1), (0, 0, 0), quat_yaw(angle)),
                          Body("c", "Object", (1, 1, 1), (0, 0, 0), 1.7 * quat_yaw(angle))])
    assert B.yaw(frames, 0)[0, 0] == pytest.approx(angle)
    assert B.yaw(frames, 1)[0, 0] == pytest.approx(angle)  # quaternion scale does not matter
    assert B.tilt(frames, 0)[0, 0] == pytest.approx(0.0, abs=1e-7)


@pytest.mark.parametrize("angle", [0.3, 1.2, math.pi])
def test_tilt_is_angle_from_up_whatever_the_yaw(angle):
    q = quat_mul(quat_about([1, 1, 0], angle), quat_yaw(0.8))
    frames = make_frames([Body("b", "Object", (1, 1, 1), (0, 0, 0), q)])
    assert B.tilt(frames, 0)[0, 0] == pytest.approx(angle)
    assert bool(B.upright(frames, 0)[0, 0]) is False


_YAW_03 = quat_yaw(0.3)


def _turning_box(angles: np.ndarray, axis, start=_YAW_03) -> Body:
    """A box whose orientation at time t is `angles[..., t]` about world `axis` after `start`."""
    q = quat_mul(np.stack([quat_about(axis, a) for a in angles.ravel()]).reshape(
        angles.shape + (4,)), start)
    return Body("box", "Object", (0.2, 0.14, 0.03), (0.5, 0.0, 0.015), q)


def test_rotation_since_start_about_an_axis_is_signed_and_batched():
    angles = np.array([[0.0, 0.5, 1.0, 2.0], [0.0, -0.4, -1.5, 3.0]])  # B=2, T=4
    frames = make_frames([_turning_box(angles, [0, 1, 0])], batch=2, steps=4)
    np.testing.assert_allclose(B.rotation(frames, 0, [0, 1, 0]), angles, atol=1e-12)
    np.testing.assert_allclose(B.rotation(frames, 0, [0, -2, 0]), -angles, atol=1e-12)
    np.testing.assert_allclose(B.rotation(frames, 0, B.UP), 0.0, atol=1e-12)
    # A T=1 view of the terminal state still measures from the start.
    np.testing.assert_allclose(B.rotation(frames.last(), 0, [0, 1, 0])[:, 0], angles[:, -1])


def test_rotation_wraps_to_minus_pi_pi():
    angles = np.array([[0.0, 3 * math.pi / 2]])
    frames = make_frames([_turning_box(angles, [1, 0, 0])], steps=2)
    assert B.rotation(frames, 0, [1, 0, 0])[0, 1] == pytest.approx(-math.pi / 2)


def test_edge_axis_sign_tips_the_top_toward_the_fixture():
    table = Body("table", "Surface", (1, 1, 0.04), (0.5, 0, -0.02))
    wall = Body("wall", "Fixture", (0.02, 0.4, 0.3), (0.5 + 0.3 * math.cos(1.0),
                                                      0.3 * math.sin(1.0), 0.15), quat_yaw(1.0))
    box = Body("box", "Object", (0.2, 0.14, 0.03), (0.5, 0.0, 0.015))
    frames = make_frames([table, wall, box])
    axis = B.edge_axis(frames, 2, 1, 0)[0, 0]
    np.testing.assert_allclose(axis, [-math.sin(1.0), math.cos(1.0), 0.0], atol=1e-12)
    # Tip the box by +0.4 rad about that axis: its top moves toward the wall.
    turned = make_frames([table, wall, _turning_box(np.array([[0.0, 0.4]]), axis,
                                                    start=(1, 0, 0, 0))], steps=2)
    assert B.rotation(turned, 2, axis)[0, 1] == pytest.approx(0.4)
    top_before, top_after = (_rot(turned.quat[0, t, 2]) @ [0, 0, 0.015] for t in (0, 1))
    toward = B.direction(frames, 2, 1)[0, 0]
    assert np.dot(top_after - top_before, toward) > 0.005


def test_edge_axis_runs_along_the_fixtures_face_for_a_box_off_its_middle():
    """The axis is square to the wall's normal, not to the oblique line between the centres."""
    frames = _box_and_wall(box_pos=(0.5, 0.15, 0.015))
    assert abs(B.direction(frames, 2, 3)[0, 0, 1]) > 0.4       # the centres' line is oblique
    np.testing.assert_allclose(B.edge_axis(frames, 2, 3, 0)[0, 0], [0.0, 1.0, 0.0], atol=1e-12)
    turned = _box_and_wall(box_pos=(0.5, 0.15, 0.015), wall_yaw=0.3)
    np.testing.assert_allclose(B.edge_axis(turned, 2, 3, 0)[0, 0],
                               [-math.sin(0.3), math.cos(0.3), 0.0], atol=1e-12)


# --- contact point and faces -----------------------------------------------------------------

def _box_and_wall(box_yaw=0.0, box_pos=(0.5, 0.0, 0.015), wall_yaw=0.0, wall_pos=(0.8, 0, 0.15)):
    return make_frames(tabletop(
        box=Body("box", "Object", (0.2, 0.14, 0.03), box_pos, quat_yaw(box_yaw)),
        wall=Body("wall", "Fixture", (0.02, 0.4, 0.3), wall_pos, quat_yaw(wall_yaw)),
    ), contacts=[("box", "table")])


def test_contact_point_is_on_the_far_side_at_centre_height():
    np.testing.assert_allclose(B.contact_point(_box_and_wall(), 2, 3)[0, 0], [0.4, 0.0, 0.015])
    # Yawed 90 deg, the box is only 0.14 deep toward the wall.
    rotated = _box_and_wall(box_yaw=math.pi / 2)
    np.testing.assert_allclose(B.contact_point(rotated, 2, 3)[0, 0], [0.43, 0.0, 0.015])


def test_half_extent_and_heading_follow_the_box_orientation():
    flat = _box_and_wall()
    assert B.half_extent(flat, 2, [1.0, 0.0, 0.0])[0, 0] == pytest.approx(0.10)
    assert B.half_extent(flat, 2, [0.0, -2.0, 0.0])[0, 0] == pytest.approx(0.07)  # normalized
    rotated = _box_and_wall(box_yaw=math.pi / 2)
    assert B.half_extent(rotated, 2, [1.0, 0.0, 0.0])[0, 0] == pytest.approx(0.07)
    np.testing.assert_allclose(B.heading(rotated, 2)[0, 0], [0.0, 1.0, 0.0], atol=1e-12)
    np.testing.assert_allclose(B.heading(flat, 2)[0, 0], [1.0, 0.0, 0.0], atol=1e-12)


def test_normal_toward_picks_the_face_that_looks_at_the_body():
    frames = _box_and_wall(box_pos=(0.5, 0.15, 0.015))
    np.testing.assert_allclose(B.normal_toward(frames, 3, 2)[0, 0], [-1, 0, 0], atol=1e-12)
    beyond_end = _box_and_wall(box_pos=(0.8, 0.5, 0.015))
    np.testing.assert_allclose(B.normal_toward(beyond_end, 3, 2)[0, 0], [0, 1, 0], atol=1e-12)
    # The same wall yawed 90 deg now spans x; the box in front of it at -y sees its -y face.
    turned = _box_and_wall(box_pos=(0.8, -0.3, 0.015), wall_yaw=math.pi / 2)
    np.testing.assert_allclose(B.normal_toward(turned, 3, 2)[0, 0], [0, -1, 0], atol=1e-12)


def test_faces():
    assert B.faces(_box_and_wall(), 3, 2).all()
    assert not B.faces(_box_and_wall(box_pos=(0.5, 0.3, 0.015)), 3, 2).any()   # beyond the span
    assert not B.faces(_box_and_wall(box_pos=(0.1, 0.0, 0.015)), 3, 2).any()   # > 50 cm away
    assert not B.faces(_box_and_wall(box_pos=(0.5, 0.0, 0.6)), 3, 2).any()     # above the wall


# --- relations -------------------------------------------------------------------------------

def test_on_needs_height_footprint_and_touch():
    assert B.on(_box_and_wall(), 2, 0).all()
    assert not B.on(_box_and_wall(box_pos=(0.5, 0.0, 0.035)), 2, 0).any()    # 2 cm above
    assert not B.on(_box_and_wall(box_pos=(1.05, 0.0, 0.015)), 2, 0).any()   # centre off the table
    hovering = make_frames(tabletop(box=Body("box", "Object", (0.2, 0.14, 0.03),
                                             (0.5, 0.0, 0.022))))
    assert not B.on(hovering, 2, 0).any()                                     # 7 mm, no contact
    resting = make_frames(tabletop(box=Body("box", "Object", (0.2, 0.14, 0.03),
                                            (0.5, 0.0, 0.0135))))
    assert B.on(resting, 2, 0).all()                                          # 1.5 mm sunk in


def test_touching_holding_inside_reachable():
    frames = make_frames(tabletop(box=Body("box", "Object", (0.1, 0.1, 0.1), (0.5, 0, 0.05)),
                                  far=Body("far", "Object", (0.1, 0.1, 0.1), (2.0, 0, 0.05))),
                         contacts=[("gripper", "box")], grasped=["box"])
    assert B.touching(frames, 1, 2).all() and B.touching(frames, 2, 1).all()
    assert not B.touching(frames, 1, 3).any()
    assert B.inside(frames, 2, 0).all() and not B.inside(frames, 3, 0).any()
    assert B.reachable(frames, 1, 2).all() and not B.reachable(frames, 1, 3).any()
    assert B.opening(frames, 1)[0, 0] == pytest.approx(0.08)


def _hand_on_box(tool_height: float, normals=((0, 1, 0), (0, -1, 0)), touch=(True, True)):
    """A 6 cm tall box on the table and the hand's tool point `tool_height` above its centre,
    with given finger contact normals (finger -> box)."""
    frames = make_frames(tabletop(box=Body("box", "Object", (0.04, 0.04, 0.06), (0.5, 0, 0.03))))
    gripper = frames.entities.index("gripper")
    frames.pos[:, :, gripper] = (0.5, 0.0, 0.03 + tool_height)
    frames.fingers[:, :, 2] = touch
    frames.finger_normals[:, :, 2] = normals
    return frames


def test_holding_needs_opposed_squeezing_contacts_with_the_object_between_the_fingers():
    assert B.holding(_hand_on_box(0.0), 1, 2).all()                        # a real grasp
    assert not B.holding(_hand_on_box(0.0, touch=(True, False)), 1, 2).any()  # one finger
    # a pinch above a round part's widest point: normals tilted 20 deg down, 40 deg apart
    tilted = ((0, math.cos(0.35), -math.sin(0.35)), (0, -math.cos(0.35), -math.sin(0.35)))
    assert not B.holding(_hand_on_box(0.0, normals=tilted), 1, 2).any()
    # the front of the fingers pushing down on the top: normals along the approach
    assert not B.holding(_hand_on_box(0.0, normals=((0, 0, -1), (0, 0, -1))), 1, 2).any()
    # the fingertips over the top edge: the box reaches 3 mm between the fingers, not 5 mm
    assert not B.holding(_hand_on_box(0.037), 1, 2).any()
    assert B.holding(_hand_on_box(0.034), 1, 2).all()
    assert B.HOLD_DEPTH == pytest.approx(0.005)


def test_settled_and_upright_thresholds():
    def state(linvel, angvel, tilt_angle=0.0):
        return make_frames([Body("b", "Object", (0.1, 0.1, 0.1), (0, 0, 0.05),
                                 quat_about([1, 0, 0], tilt_angle), linvel=linvel,
                                 angvel=angvel)])
    assert B.settled(state((0.005, 0, 0), (0, 0, 0.05)), 0).all()
    assert not B.settled(state((0.02, 0, 0), (0, 0, 0)), 0).any()
    assert not B.settled(state((0, 0, 0), (0.2, 0, 0)), 0).any()
    assert B.speed(state((0.3, 0.4, 0), (0, 0, 0)), 0)[0, 0] == pytest.approx(0.5)
    assert B.upright(state((0, 0, 0), (0, 0, 0), math.radians(9)), 0).all()
    assert not B.upright(state((0, 0, 0), (0, 0, 0), math.radians(11)), 0).any()


# --- math and helpers ------------------------------------------------------------------------

def test_vector_math_broadcasts_over_the_last_axis():
    rng = np.random.default_rng(2)
    frames = make_frames([Body("b", "Object", (1, 1, 1), (0, 0, 0))])
    a, b = rng.normal(size=(4, 5, 3)), rng.normal(size=(4, 5, 3))
    np.testing.assert_allclose(B.cross(frames, a, b), np.cross(a, b))
    np.testing.assert_allclose(B.cross(frames, B.UP, b), np.cross(B.UP, b))
    np.testing.assert_allclose(B.dot(frames, a, b), np.einsum("...i,...i", a, b))
    np.testing.assert_allclose(B.norm(frames, a), np.linalg.norm(a, axis=-1))
    unit = B.normalize(frames, a)
    np.testing.assert_allclose(np.linalg.norm(unit, axis=-1), 1.0)
    np.testing.assert_array_equal(B.normalize(frames, np.zeros(3)), np.zeros(3))
    np.testing.assert_array_equal(B.horizontal(frames, a)[..., 2], 0.0)
    np.testing.assert_array_equal(B.horizontal(frames, a)[..., :2], a[..., :2])


def test_scalar_math_and_helpers():
    frames = make_frames([Body("b", "Object", (1, 1, 1), (0, 0, 0))])
    x = np.array([[-2.0, 0.5, 3.0]])
    np.testing.assert_array_equal(IMPLEMENTATIONS["clamp"](frames, x, -1.0, 1.0), [[-1, 0.5, 1]])
    np.testing.assert_array_equal(IMPLEMENTATIONS["abs"](frames, x), [[2, 0.5, 3]])
    np.testing.assert_array_equal(IMPLEMENTATIONS["min"](frames, x, 1.0), [[-2, 0.5, 1]])
    np.testing.assert_array_equal(IMPLEMENTATIONS["max"](frames, x, 1.0), [[1, 1, 3]])
    assert IMPLEMENTATIONS["atan2"](frames, 1.0, -1.0) == pytest.approx(3 * math.pi / 4)
    assert IMPLEMENTATIONS["sqrt"](frames, 0.04) == pytest.approx(0.2)
    v = B.vec(x, 0.0, 1.0)
    assert v.shape == (1, 3, 3)
    np.testing.assert_array_equal(B.component(v, 0), x)
    np.testing.assert_array_equal(B.scale(x, B.UP)[..., 2], x)
