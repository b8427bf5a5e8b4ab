"""The hand's roll in motions: the decision vector, carried and half-turned rolls, the start pose's
equivalent reading, and the tool frame's inverse (numpy only, no simulation)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from rapid_dsl.runtime.motion import KeypointSet, Timing, hand_targets, start_angles
from rapid_dsl.runtime.program import Keypoint
from rapid_dsl.runtime.robots import HandPose
from rapid_dsl.runtime.robots.hand import ROLL_TILT, tool_quat, yaw_pitch_roll_of

TIMING = Timing(dt=0.002)
HOME = HandPose(np.array([0.4, 0.0, 0.2]), 0.0, 0.0, 0.08)
DEG = math.pi / 180


def keypoints(*options: dict) -> KeypointSet:
    return KeypointSet.from_keypoints(tuple(
        Keypoint(f"k{i}", np.array([0.5, 0.0, 0.1 + 0.05 * i]), **o)
        for i, o in enumerate(options)))


def final(plan: KeypointSet, z: np.ndarray, start: HandPose = HOME) -> np.ndarray:
    """(N, 3) yaw, pitch, roll at the last control tick."""
    _, yaw, pitch, roll, _ = hand_targets(plan, np.atleast_2d(z), start, 0.0, duration=1.0,
                                          timing=TIMING)
    return np.stack([yaw[:, -1], pitch[:, -1], roll[:, -1]], axis=1)


def matrix(yaw: float, pitch: float, roll: float) -> np.ndarray:
    out = np.zeros(9)
    mujoco.mju_quat2Mat(out, tool_quat(np.array(yaw), np.array(pitch), np.array(roll)))
    return out


def test_the_decision_vector_has_an_offset_per_stated_yaw_pitch_and_roll():
    plan = keypoints({"yaw": 0.1, "roll": 0.3}, {"pitch": 0.2}, {"roll": -0.4}, {})
    std = plan.decision_std(0.02, 0.1)
    assert std.shape == (4 * 3 + 4,)
    np.testing.assert_allclose(std[12:], 0.1)        # spread_angle for every stated angle
    z = np.zeros((2, std.size))
    z[1, 12:] = [0.01, 0.02, 0.03, 0.04]            # yaw k0, pitch k1, roll k0, roll k2
    _, yaw, pitch, roll = plan.apply(z)
    np.testing.assert_allclose(yaw[1], [0.11, np.nan, np.nan, np.nan])
    np.testing.assert_allclose(pitch[1], [np.nan, 0.22, np.nan, np.nan])
    np.testing.assert_allclose(roll[1], [0.33, np.nan, -0.36, np.nan])
    np.testing.assert_allclose(roll[0], [0.3, np.nan, -0.4, np.nan])


def test_a_roll_carries_over_and_an_offset_moves_it():
    plan = keypoints({"pitch": 90 * DEG, "roll": 60 * DEG}, {})
    z = np.zeros((2, plan.decision_std(0.02, 0.1).size))
    z[1, -1] = 5 * DEG                               # the roll offset
    np.testing.assert_allclose(final(plan, z), [[0, 90 * DEG, 60 * DEG],
                                                [0, 90 * DEG, 65 * DEG]], atol=1e-12)


def test_an_unstated_roll_keeps_the_start_pose_roll():
    start = HandPose(HOME.position, 0.3, 80 * DEG, 0.08, 40 * DEG)
    plan = keypoints({"yaw": 0.5})
    np.testing.assert_allclose(final(plan, np.zeros(4), start), [[0.5, 80 * DEG, 40 * DEG]])


def test_a_roll_is_turned_by_half_a_turn_where_yaw_plus_roll_nears_pi():
    # the hand looks the same turned by pi about its approach axis; yaw 90 + pitch 90 + roll 90
    # is a rotation by exactly pi from the home frame (where the Franka's target wraps), yaw 90 +
    # pitch 90 - roll 90 one by pi/2
    cases = {(90, 90): -90, (90, -90): -90, (-90, -90): 90, (45, 90): -90, (-135, -90): 90,
             (180, 90): 90, (-135, 90): 90, (0, 90): 90, (30, 60): 60}
    for (yaw, roll), expected in cases.items():
        plan = keypoints({"yaw": yaw * DEG, "pitch": 90 * DEG, "roll": roll * DEG})
        assert final(plan, np.zeros(6))[0, 2] == pytest.approx(expected * DEG), (yaw, roll)
    # the half turn goes toward the previous roll
    start = HandPose(HOME.position, 90 * DEG, 90 * DEG, 0.08, -80 * DEG)
    plan = keypoints({"roll": 90 * DEG})
    assert final(plan, np.zeros(4), start)[0, 2] == pytest.approx(-90 * DEG)


def test_yaw_is_symmetric_by_pi_only_while_the_hand_is_unpitched():
    # at pitch 0 a yaw of pi is a half turn about the approach axis, whatever the roll
    unpitched = keypoints({"yaw": 170 * DEG, "roll": 10 * DEG})
    assert final(unpitched, np.zeros(5))[0, 0] == pytest.approx(-10 * DEG)
    pitched = keypoints({"yaw": 170 * DEG, "pitch": 30 * DEG})
    assert final(pitched, np.zeros(5))[0, 0] == pytest.approx(170 * DEG)


def test_the_start_is_read_the_way_nearer_the_stated_angles():
    # (y, p, r) and (y + pi, -p, r + pi) are the same orientation
    start = HandPose(HOME.position, 180 * DEG, -90 * DEG, 0.08, -90 * DEG)
    plan = keypoints({"pitch": 90 * DEG, "roll": -90 * DEG})
    assert start_angles(start, plan) == pytest.approx((0.0, 90 * DEG, 90 * DEG))
    # (roll -90 is roll 90 turned by pi: the hand looks the same)
    # ... so a motion that keeps the pose does not swing the hand through a half turn
    _, yaw, pitch, roll, _ = hand_targets(plan, np.zeros((1, 5)), start, 0.0, duration=1.0,
                                          timing=TIMING)
    assert np.ptp(pitch) == pytest.approx(0.0) and np.ptp(yaw) == pytest.approx(0.0)
    assert start_angles(start, keypoints({})) == (start.yaw, start.pitch, start.roll)


@pytest.mark.parametrize("angles", [(0.3, 0.0, 0.0), (1.0, 0.4, 0.0), (-2.0, -0.5, 0.0),
                                    (0.5, 90 * DEG, 90 * DEG), (90 * DEG, 60 * DEG, -45 * DEG),
                                    (-2.5, 1.2, -1.4), (3.0, -0.7, 0.6)])
def test_the_inverse_of_the_tool_frame_returns_all_three(angles):
    yaw, pitch, roll = yaw_pitch_roll_of(matrix(*angles))
    assert (yaw, pitch, roll) == pytest.approx(angles, abs=1e-9)


def test_the_inverse_picks_the_reading_with_the_smaller_roll():
    # (y + pi, -p, r + pi) is the same frame; the reading keeps |roll| <= pi/2
    yaw, pitch, roll = yaw_pitch_roll_of(matrix(0.2, 0.7, 2.5))
    assert (yaw, pitch, roll) == pytest.approx((0.2 - math.pi, -0.7, 2.5 - math.pi))


def test_a_nearly_vertical_hand_reads_no_roll():
    # at a tilt of a few degrees the split between yaw and roll is noise: the turn is yaw
    for tilt in (0.0, 1e-7, 0.5 * ROLL_TILT, ROLL_TILT):
        yaw, pitch, roll = yaw_pitch_roll_of(matrix(0.4, tilt, 0.9))
        assert roll == pytest.approx(0.0, abs=1e-9)
        assert yaw == pytest.approx(1.3, abs=tilt + 1e-9)
    assert yaw_pitch_roll_of(matrix(0.4, 3 * ROLL_TILT, 0.9))[2] == pytest.approx(0.9)
