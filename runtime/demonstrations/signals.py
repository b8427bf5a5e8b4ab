"""Signals of a track for the demonstration analysis: smoothing, speeds, rest, rotations, boxes.

Everything works on frames at any (strictly increasing) times: windows are in seconds, found with
`searchsorted`, so a track sampled unevenly (a video's dropped frames) is read the same way.
Quaternions are w x y z; rotations are in the world frame.
"""

from __future__ import annotations

import numpy as np


def windows(t: np.ndarray, half: float, *, neighbours: bool = False
            ) -> tuple[np.ndarray, np.ndarray]:
    """Per frame i, the frames [lo[i], hi[i]) within `half` seconds of t[i]; with `neighbours`,
    at least the frames next to i too (a rate needs two frames, sparse ones included)."""
    lo, hi = np.searchsorted(t, t - half, "left"), np.searchsorted(t, t + half, "right")
    if neighbours:
        index = np.arange(len(t))
        lo, hi = np.minimum(lo, np.maximum(index - 1, 0)), np.maximum(hi, np.minimum(index + 2,
                                                                                     len(t)))
    return lo, hi


def smooth(t: np.ndarray, values: np.ndarray, half: float) -> np.ndarray:
    """Moving average of (T, ...) values over +-half seconds (shorter at the ends)."""
    lo, hi = windows(t, half)
    flat = values.reshape(len(t), -1)
    sums = np.concatenate([np.zeros((1, flat.shape[1])), np.cumsum(flat, axis=0)])
    mean = (sums[hi] - sums[lo]) / (hi - lo)[:, None]
    return mean.reshape(values.shape)


def continuous(quats: np.ndarray) -> np.ndarray:
    """(T, 4) quaternions with signs flipped so neighbours lie in the same hemisphere (q and -q
    are one rotation; averaging needs them on one side)."""
    out = quats / np.linalg.norm(quats, axis=1, keepdims=True)
    for i in range(1, len(out)):
        if np.dot(out[i], out[i - 1]) < 0:
            out[i] = -out[i]
    return out


def smooth_quats(t: np.ndarray, quats: np.ndarray, half: float) -> np.ndarray:
    """Moving average of continuous (T, 4) quaternions, renormalized (fine for small spreads)."""
    mean = smooth(t, quats, half)
    return mean / np.linalg.norm(mean, axis=1, keepdims=True)


def speed(t: np.ndarray, positions: np.ndarray, half: float) -> np.ndarray:
    """(T,) speed [m/s]: the distance between the ends of each +-half window over its time."""
    lo, hi = windows(t, half, neighbours=True)
    last = hi - 1
    span = np.maximum(t[last] - t[lo], 1e-9)
    return np.linalg.norm(positions[last] - positions[lo], axis=1) / span


def velocity(t: np.ndarray, positions: np.ndarray, half: float) -> np.ndarray:
    """(T, k) rate of change of (T, k) values (positions: velocity) over each +-half window."""
    lo, hi = windows(t, half, neighbours=True)
    last = hi - 1
    span = np.maximum(t[last] - t[lo], 1e-9)
    return (positions[last] - positions[lo]) / span[:, None]


def angular_speed(t: np.ndarray, quats: np.ndarray, half: float) -> np.ndarray:
    """(T,) rotation rate [rad/s] over each +-half window."""
    lo, hi = windows(t, half, neighbours=True)
    last = hi - 1
    span = np.maximum(t[last] - t[lo], 1e-9)
    dots = np.abs(np.sum(quats[last] * quats[lo], axis=1)).clip(0.0, 1.0)
    return 2.0 * np.arccos(dots) / span


def hysteresis(on: np.ndarray, stay: np.ndarray) -> np.ndarray:
    """True from a frame where `on` holds while `stay` keeps holding (`on` implies `stay`)."""
    state = np.zeros(len(on), dtype=bool)
    active = False
    for i in range(len(on)):
        active = bool(on[i]) or (active and bool(stay[i]))
        state[i] = active
    return state


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    """[start, end) frame ranges where `mask` is True."""
    edges = np.diff(np.concatenate([[0], mask.astype(np.int8), [0]]))
    return list(zip(np.flatnonzero(edges == 1).tolist(), np.flatnonzero(edges == -1).tolist(),
                    strict=True))


def fill_gaps(t: np.ndarray, mask: np.ndarray, shortest: float) -> np.ndarray:
    """`mask` with False stretches shorter than `shortest` seconds between True ones filled."""
    out = mask.copy()
    spans = runs(mask)
    for (_, end), (start, _) in zip(spans, spans[1:], strict=False):
        if t[start] - t[end - 1] < shortest:
            out[end:start] = True
    return out


# --- rotations -----------------------------------------------------------------------------------

def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Hamilton product a * b of w x y z quaternions."""
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2,
                     w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2,
                     w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def conjugate(q: np.ndarray) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def rotation_between(q0: np.ndarray, q1: np.ndarray) -> tuple[float, np.ndarray]:
    """The world-frame rotation taking orientation q0 to q1, as (angle in [0, pi], unit axis)."""
    r = multiply(q1, conjugate(q0))
    if r[0] < 0:
        r = -r
    sin_half = float(np.linalg.norm(r[1:]))
    angle = 2.0 * float(np.arctan2(sin_half, r[0]))
    axis = r[1:] / sin_half if sin_half > 1e-12 else np.array([0.0, 0.0, 1.0])
    return angle, axis


def mean_quat(quats: np.ndarray) -> np.ndarray:
    """The average of nearby orientations (T, 4), renormalized."""
    aligned = continuous(quats)
    mean = aligned.mean(axis=0)
    return mean / np.linalg.norm(mean)


def matrix(q: np.ndarray) -> np.ndarray:
    """3x3 rotation matrix of a w x y z quaternion."""
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


# --- boxes ---------------------------------------------------------------------------------------

def box_distance(point: np.ndarray, centre: np.ndarray, quat: np.ndarray,
                 extents: np.ndarray) -> float:
    """Distance from a point to an oriented box (0 inside)."""
    local = matrix(quat).T @ (point - centre)
    outside = np.maximum(np.abs(local) - extents / 2.0, 0.0)
    return float(np.linalg.norm(outside))


def corners(centre: np.ndarray, quat: np.ndarray, extents: np.ndarray) -> np.ndarray:
    """(9, 3): the centre and the 8 corners of an oriented box."""
    signs = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    return np.vstack([centre, centre + (signs * extents / 2.0) @ matrix(quat).T])


def boxes_gap(a: tuple[np.ndarray, np.ndarray, np.ndarray],
              b: tuple[np.ndarray, np.ndarray, np.ndarray]) -> float:
    """Approximate gap between two oriented boxes (centre, quat, extents): the smallest distance
    from either's centre and corners to the other (0 when they overlap at one of those)."""
    return min(min(box_distance(p, *b) for p in corners(*a)),
               min(box_distance(p, *a) for p in corners(*b)))


def half_height(quat: np.ndarray, extents: np.ndarray) -> float:
    """Half the world-z extent of an oriented box."""
    return float(np.abs(matrix(quat)[2]) @ extents / 2.0)
