"""narrow_side and palm_depth: the grasp's world-frame geometry, on synthetic frames."""

from __future__ import annotations

import math

import numpy as np
import pytest
from frames_factory import Body, make_frames, quat_about, quat_mul, quat_yaw, tabletop

from rapid_dsl.runtime import builtins as B


def _box(quat: np.ndarray, extents=(0.2, 0.14, 0.03), batch: int = 1):
    return make_frames(tabletop(box=Body("box", "Object", extents, (0.5, 0.0, 0.1), quat)),
                       batch=batch)


def _across(frames) -> np.ndarray:
    return B.narrow_side(frames, 2)[0, 0]


def _width(frames) -> float:
    return 2 * float(B.half_extent(frames, 2, B.narrow_side(frames, 2))[0, 0])


@pytest.mark.parametrize("angle", [0.0, 0.4, -1.2, math.pi / 2, 2.8])
def test_a_flat_box_is_grasped_across_its_short_side(angle):
    frames = _box(quat_yaw(angle))
    short_axis = np.array([-math.sin(angle), math.cos(angle), 0.0])
    assert abs(_across(frames) @ short_axis) == pytest.approx(1.0)
    assert _width(frames) == pytest.approx(0.14)


@pytest.mark.parametrize("angle", [0.0, 0.7, -2.0])
def test_a_flat_box_stood_on_its_edge_is_grasped_across_its_thickness(angle):
    # Turned 90 deg about its x axis, then yawed: its z axis (3 cm) is horizontal, its y vertical.
    frames = _box(quat_mul(quat_yaw(angle), quat_about([1, 0, 0], math.pi / 2)))
    thickness_axis = np.array([math.sin(angle), -math.cos(angle), 0.0])
    assert abs(_across(frames) @ thickness_axis) == pytest.approx(1.0)
    assert _width(frames) == pytest.approx(0.03)
    # Its own x/y extents (20 x 14 cm) would say it cannot be grasped at all.
    assert min(B.extents(frames, 2)[0, 0][:2]) > 0.08


def test_a_tilted_box_is_never_narrower_than_the_answer_in_any_horizontal_direction():
    rng = np.random.default_rng(3)
    for _ in range(20):
        quat = rng.normal(size=4)
        frames = _box(quat / np.linalg.norm(quat))
        best = _width(frames)
        for theta in np.linspace(0, math.pi, 181):
            d = np.array([math.cos(theta), math.sin(theta), 0.0])
            assert 2 * float(B.half_extent(frames, 2, d)[0, 0]) >= best - 1e-9
        assert _across(frames)[2] == 0.0
        assert np.linalg.norm(_across(frames)) == pytest.approx(1.0)


def test_narrow_side_is_batched_and_palm_depth_is_the_hand_geometry():
    quats = np.stack([quat_yaw(0.0), quat_yaw(math.pi / 2)])[:, None, :]   # (B=2, T=1, 4)
    frames = _box(quats, batch=2)
    np.testing.assert_allclose(np.abs(B.narrow_side(frames, 2)[:, 0]), [[0, 1, 0], [1, 0, 0]],
                               atol=1e-12)
    depth = B.palm_depth(frames, 3)
    assert depth.shape == frames.opening.shape
    assert depth[0, 0] == pytest.approx(0.045)
