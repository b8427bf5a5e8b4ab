"""Keypoints + sampled offsets -> hand targets for a whole CEM population, in numpy.

The decision vector z of a primitive holds one position offset per keypoint (std `spread`), then a
yaw offset for each keypoint that states a yaw, a pitch offset for each that states a pitch and a
roll offset for each that states a roll (std `spread_angle`). The hand goes from its current pose
through the keypoints in order: `duration` is shared among the segments in proportion to their
length (so the hand moves at a steady pace), each segment eased in and out; where a keypoint
changes the gripper command the hand waits `grip_dwell` there, and after the last keypoint it
holds still for `settle` so the objects come to rest before success is judged. Targets are
computed at the control rate; `simulate.hold` expands them to physics steps.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rapid_dsl.runtime.program import Keypoint
from rapid_dsl.runtime.robots import HandPose

ANGLE_LENGTH = 0.1      # m of path per rad of turning, so pure turns get time too
MIN_SEGMENT = 0.01      # m added to every segment, so repeated keypoints still take time
MAX_TURN = 2 * math.pi / 3   # rad: largest |yaw + roll| a roll is taken at (_carry_rolls)
_EPS = 1e-9


@dataclass(frozen=True, slots=True, kw_only=True)
class Timing:
    dt: float                   # physics timestep [s]
    control_steps: int = 10     # physics steps per control tick
    settle: float = 0.5         # hold after the last keypoint [s]
    grip_dwell: float = 0.4     # wait where the gripper command changes [s]

    @property
    def control_dt(self) -> float:
        return self.dt * self.control_steps


@dataclass(frozen=True, slots=True)
class KeypointSet:
    """Keypoints of one primitive run, evaluated in its start state (the CEM mean)."""

    names: tuple[str, ...]
    position: np.ndarray        # (K, 3) [m]
    yaw: np.ndarray             # (K,) [rad], NaN where the keypoint keeps the previous yaw
    pitch: np.ndarray           # (K,) [rad], NaN likewise
    grip: np.ndarray            # (K,) 0..1, NaN where the keypoint keeps the previous command
    roll: np.ndarray            # (K,) [rad], NaN where the keypoint keeps the previous roll

    @staticmethod
    def from_keypoints(keypoints: tuple[Keypoint, ...]) -> KeypointSet:
        def scalar(value: object) -> float:
            if value is None:
                return math.nan
            return float(np.asarray(value, dtype=float).reshape(-1)[0])

        position = np.stack([np.asarray(k.position, dtype=float).reshape(-1, 3)[0]
                             for k in keypoints])
        return KeypointSet(
            names=tuple(k.name for k in keypoints),
            position=position,
            yaw=np.array([scalar(k.yaw) for k in keypoints]),
            pitch=np.array([scalar(k.pitch) for k in keypoints]),
            grip=np.array([math.nan if k.grip is None else float(k.grip) for k in keypoints]),
            roll=np.array([scalar(k.roll) for k in keypoints]),
        )

    def decision_std(self, spread: float, spread_angle: float) -> np.ndarray:
        """(D,) initial CEM standard deviation; the mean is zero offsets."""
        n_angles = int(sum(np.isfinite(a).sum() for a in (self.yaw, self.pitch, self.roll)))
        return np.concatenate([np.full(self.position.size, spread),
                               np.full(n_angles, spread_angle)])

    def apply(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Offsets z (N, D) -> positions (N, K, 3), yaw, pitch and roll (N, K) (NaN kept)."""
        n, k = z.shape[0], len(self.names)
        position = self.position + z[:, : 3 * k].reshape(n, k, 3)
        angles = [np.broadcast_to(a, (n, k)).copy() for a in (self.yaw, self.pitch, self.roll)]
        column = 3 * k
        for values in angles:
            given = np.flatnonzero(np.isfinite(values[0]))
            values[:, given] += z[:, column: column + len(given)]
            column += len(given)
        return position, angles[0], angles[1], angles[2]


def hand_targets(
    keypoints: KeypointSet,
    z: np.ndarray,
    start: HandPose,
    start_grip: float,
    *,
    duration: float,
    timing: Timing,
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Hand targets at every control tick for each sample of z (N, D).

    Returns position (N, M, 3) [m], yaw, pitch, roll (N, M) [rad] and grip (N, M) (0..1).
    """
    position, yaw, pitch, roll = keypoints.apply(np.atleast_2d(z))
    n, k = position.shape[:2]
    # Waypoint 0 is the current hand pose; unspecified angles and grips carry over.
    points = np.concatenate([np.broadcast_to(start.position, (n, 1, 3)), position], axis=1)
    start_yaw, start_pitch, start_roll = start_angles(start, keypoints)
    # A parallel gripper looks the same turned by pi about its approach axis. While the hand stays
    # unpitched that axis is vertical, so a yaw of pi is such a turn (at any roll); once pitched,
    # yaw turns the approach axis itself and only whole turns are equivalent.
    symmetric = not np.isfinite(keypoints.pitch).any() and abs(start_pitch) < 1e-3
    yaws = _carry_angles(start_yaw, yaw, math.pi if symmetric else 2 * math.pi)
    pitches = _carry_angles(start_pitch, pitch, None)
    rolls = _carry_rolls(start_roll, roll, yaws)
    grips = np.empty(k + 1)
    grips[0] = start_grip
    for i in range(k):
        grips[i + 1] = grips[i] if math.isnan(keypoints.grip[i]) else keypoints.grip[i]

    length = np.linalg.norm(np.diff(points, axis=1), axis=-1)
    turning = sum(np.abs(np.diff(a, axis=1)) for a in (yaws, pitches, rolls))
    weight = length + ANGLE_LENGTH * turning + MIN_SEGMENT
    segment = duration * weight / weight.sum(axis=1, keepdims=True)        # (N, K)

    # Knots: the start, each arrival, and the end of each dwell where the grip changes.
    angles = (yaws, pitches, rolls)
    times, values, knot_grip = [np.zeros(n)], [_pose(points, angles, 0)], [grips[0]]
    clock = np.zeros(n)
    for i in range(1, k + 1):
        clock = clock + segment[:, i - 1]
        times.append(clock)
        values.append(_pose(points, angles, i))
        knot_grip.append(grips[i])
        if grips[i] != grips[i - 1]:
            clock = clock + timing.grip_dwell
            times.append(clock)
            values.append(values[-1])
            knot_grip.append(grips[i])
    knot_t = np.stack(times, axis=1)                    # (N, J)
    knot_v = np.stack(values, axis=1)                   # (N, J, 6)
    total = duration + timing.grip_dwell * (len(times) - 1 - k) + timing.settle
    ticks = np.arange(math.ceil(total / timing.control_dt - 1e-9)) * timing.control_dt   # (M,)

    passed = (knot_t[:, None, :] <= ticks[None, :, None] + _EPS).sum(axis=-1) - 1       # (N, M)
    lo = np.clip(passed, 0, knot_t.shape[1] - 2)
    t_a = np.take_along_axis(knot_t, lo, axis=1)
    t_b = np.take_along_axis(knot_t, lo + 1, axis=1)
    alpha = np.clip((ticks - t_a) / np.maximum(t_b - t_a, _EPS), 0.0, 1.0)
    alpha = alpha * alpha * (3.0 - 2.0 * alpha)          # ease in and out of every segment
    v_a = np.take_along_axis(knot_v, lo[..., None], axis=1)
    v_b = np.take_along_axis(knot_v, lo[..., None] + 1, axis=1)
    pose = v_a + alpha[..., None] * (v_b - v_a)
    grip = np.asarray(knot_grip)[np.clip(passed, 0, len(knot_grip) - 1)]
    return pose[..., :3], pose[..., 3], pose[..., 4], pose[..., 5], grip


def start_angles(start: HandPose, keypoints: KeypointSet) -> tuple[float, float, float]:
    """The start pose's (yaw, pitch, roll), as read or as its equivalent (yaw + pi, -pitch,
    roll + pi): whichever is nearer the first angle each keypoint states, so that the hand does
    not swing through a half turn to reach an orientation it already has."""
    read = (start.yaw, start.pitch, start.roll)
    if abs(start.pitch) < 1e-3:      # unpitched, the other reading is only yaw and roll + pi
        return read
    other = (math.remainder(start.yaw + math.pi, 2 * math.pi), -start.pitch,
             math.remainder(start.roll + math.pi, 2 * math.pi))
    targets = [_first_finite(a) for a in (keypoints.yaw, keypoints.pitch, keypoints.roll)]

    def distance(angles: tuple[float, float, float]) -> float:
        periods = (2 * math.pi, 2 * math.pi, math.pi)     # a roll is taken modulo pi
        return sum(abs((t - a + p / 2) % p - p / 2)
                   for a, t, p in zip(angles, targets, periods, strict=True) if not math.isnan(t))
    return other if distance(other) < distance(read) - 1e-6 else read


def _first_finite(values: np.ndarray) -> float:
    given = values[np.isfinite(values)]
    return float(given[0]) if given.size else math.nan


def _pose(points: np.ndarray, angles: tuple[np.ndarray, ...], i: int) -> np.ndarray:
    return np.concatenate([points[:, i], *(a[:, i, None] for a in angles)], axis=1)


def _carry_rolls(start: float, given: np.ndarray, yaws: np.ndarray) -> np.ndarray:
    """(N, K+1) rolls: start, then each keypoint's (or the previous one where NaN), the short way
    round.

    The parallel gripper looks the same turned by pi about its approach axis. Where yaw + roll
    would be more than MAX_TURN from 0 (mod 2 pi) the roll is taken that half turn round (toward
    the previous roll): the tool frame's rotation angle from the fingers-down home is
    2 acos(|cos(pitch / 2) cos((yaw + roll) / 2)|), so this keeps it below ~140 deg, away from pi,
    where the Franka's rotation-vector target wraps (docs/physics.md). Elsewhere the roll is kept
    as stated: which of the two the arm reaches better depends on its wrist, not on the frame.
    """
    n, k = given.shape
    out = np.empty((n, k + 1))
    out[:, 0] = start
    for i in range(k):
        previous = out[:, i]
        value = previous + (given[:, i] - previous + math.pi) % (2 * math.pi) - math.pi
        total = (yaws[:, i + 1] + value + math.pi) % (2 * math.pi) - math.pi
        turned = value - math.pi * np.where(value >= previous, 1.0, -1.0)
        value = np.where(np.abs(total) > MAX_TURN, turned, value)
        out[:, i + 1] = np.where(np.isnan(value), previous, value)
    return out


def _carry_angles(start: float, given: np.ndarray, period: float | None) -> np.ndarray:
    """(N, K+1) angles: start, then each keypoint's (or the previous one where NaN).

    With a period, each angle is moved by whole periods to be nearest to the previous one, so the
    hand never turns the long way round.
    """
    n, k = given.shape
    out = np.empty((n, k + 1))
    out[:, 0] = start
    for i in range(k):
        value = given[:, i]
        previous = out[:, i]
        if period is not None:
            value = previous + (value - previous + period / 2) % period - period / 2
        out[:, i + 1] = np.where(np.isnan(value), previous, value)
    return out
