"""Synthetic tracks with known effects, for the demonstration analysis tests.

`synthetic(steps)` plays a list of steps on one box resting on a table: pauses, slides, lifts
(the hand holding the box), grasps (the grip closing on it) and rotations about any axis through
any point, each eased in and out (smoothstep), with the hand beside or on the box, then adds
Gaussian noise to every recorded position and orientation. Each step's true effect is what it
was told to do.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

EXTENTS = (0.12, 0.05, 0.04)       # m, the box
START = (0.5, 0.0, 0.02)           # m, resting on the table top at z = 0
OPEN, SHUT = 0.08, 0.0             # m, the finger opening, wide open and closed as a paddle


@dataclass(frozen=True)
class Step:
    kind: str                      # pause | slide | lift | grasp | turn
    duration: float
    move: tuple[float, float, float] = (0.0, 0.0, 0.0)   # m, slide and lift
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)   # turn
    angle: float = 0.0                                   # rad, turn
    about: tuple[float, float, float] | None = None      # m from the box centre; None: centre


def pause(duration: float) -> Step:
    return Step("pause", duration)


def slide(dx: float, dy: float, dz: float = 0.0, duration: float = 1.5) -> Step:
    return Step("slide", duration, move=(dx, dy, dz))


def lift(height: float, duration: float = 1.5) -> Step:
    return Step("lift", duration, move=(0.0, 0.0, height))


def grasp(duration: float = 0.6) -> Step:
    return Step("grasp", duration)


def turn(axis: tuple[float, float, float], degrees: float, duration: float = 1.5,
         about: tuple[float, float, float] | None = None) -> Step:
    norm = math.sqrt(sum(a * a for a in axis))
    return Step("turn", duration, axis=tuple(a / norm for a in axis),  # type: ignore[arg-type]
                angle=math.radians(degrees), about=about)


@dataclass
class _State:
    position: np.ndarray
    quat: np.ndarray
    opening: float = OPEN
    holding: bool = False
    frames: list[dict[str, Any]] = field(default_factory=list)


def synthetic(steps: list[Step], *, rate: float = 25.0, noise: float = 0.0,
              angle_noise: float = 0.0, seed: int = 0) -> dict[str, Any]:
    """The track of `steps` at `rate` Hz, with `noise` m and `angle_noise` rad of noise."""
    rng = np.random.default_rng(seed)
    state = _State(np.array(START, dtype=float), np.array([1.0, 0.0, 0.0, 0.0]))
    t = 0.0
    samples: list[tuple[float, np.ndarray, np.ndarray, np.ndarray, float]] = []
    for step in steps:
        count = max(1, round(step.duration * rate))
        begin_p, begin_q, begin_open = state.position.copy(), state.quat.copy(), state.opening
        for k in range(1, count + 1):
            u = k / count
            ease = u * u * (3 - 2 * u)
            position, quat, opening = begin_p, begin_q, begin_open
            if step.kind in ("slide", "lift"):
                position = begin_p + ease * np.array(step.move)
            elif step.kind == "turn":
                spin = axis_angle(np.array(step.axis), ease * step.angle)
                quat = multiply(spin, begin_q)
                if step.about is not None:
                    pivot = begin_p + np.array(step.about)
                    position = pivot + rotate(spin, begin_p - pivot)
            elif step.kind == "grasp":
                opening = OPEN + ease * (EXTENTS[1] - OPEN)   # the fingers stop at the box
            state.position, state.quat, state.opening = position, quat, opening
            if step.kind in ("grasp", "lift"):
                state.holding = True
            hand = _hand(state, step)
            samples.append((t + k / rate, position.copy(), quat.copy(), hand, state.opening))
        t += count / rate
    first = (0.0, np.array(START, dtype=float), np.array([1.0, 0.0, 0.0, 0.0]),
             _hand(_State(np.array(START), np.array([1.0, 0, 0, 0])), steps[0]), OPEN)
    frames = []
    for time, position, quat, hand, opening in [first, *samples]:
        noisy_q = multiply(axis_angle(_unit(rng.normal(size=3)),
                                      abs(rng.normal(scale=angle_noise))), quat)
        frames.append({
            "t": round(time, 6),
            "objects": {"box": {"position": _list(position + rng.normal(scale=noise, size=3)),
                                "quat": _list(noisy_q)}},
            "hand": {"position": _list(hand + rng.normal(scale=noise, size=3)),
                     "quat": [1.0, 0.0, 0.0, 0.0], "opening": round(opening, 6)}})
    return {
        "format": "rapidc-track/1",
        "source": {"recorder": "tests/runtime/demo_tracks.py"},
        "hand": "gripper",
        "entities": [
            {"name": "table", "kind": "Surface", "shape": "box", "extents": [1.0, 1.0, 0.1],
             "pose": {"position": [0.5, 0.0, -0.05], "quat": [1.0, 0.0, 0.0, 0.0]}},
            {"name": "box", "kind": "Object", "shape": "box", "extents": list(EXTENTS)},
            {"name": "gripper", "kind": "Manipulator", "shape": "gripper",
             "extents": [0.02, 0.1, 0.02]},
        ],
        "frames": frames,
    }


def _hand(state: _State, step: Step) -> np.ndarray:
    """Holding: at the box centre. Pushing or turning: against the side the box moves away
    from (a paddle, closed). Pausing: 10 cm above the box."""
    if state.holding or step.kind == "grasp":
        return state.position.copy()
    if step.kind == "slide":
        heading = np.array(step.move) / max(np.linalg.norm(step.move), 1e-9)
        return state.position - (EXTENTS[0] / 2 + 0.005) * heading
    if step.kind == "turn":
        return state.position + np.array([0.0, 0.0, EXTENTS[2] / 2 + 0.005])
    return state.position + np.array([0.0, 0.0, 0.1])


def axis_angle(axis: np.ndarray, angle: float) -> np.ndarray:
    return np.concatenate([[math.cos(angle / 2)], math.sin(angle / 2) * np.asarray(axis)])


def multiply(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w1, x1, y1, z1 = a
    w2, x2, y2, z2 = b
    return np.array([w1 * w2 - x1 * x2 - y1 * y2 - z1 * z2, w1 * x2 + x1 * w2 + y1 * z2 - z1 * y2,
                     w1 * y2 - x1 * z2 + y1 * w2 + z1 * x2, w1 * z2 + x1 * y2 - y1 * x2 + z1 * w2])


def rotate(q: np.ndarray, v: np.ndarray) -> np.ndarray:
    return multiply(multiply(q, np.concatenate([[0.0], v])), q * [1, -1, -1, -1])[1:]


def angle_between(a: list[float] | np.ndarray, b: list[float] | np.ndarray) -> float:
    """Angle [rad] between two directions."""
    a, b = np.asarray(a, dtype=float), np.asarray(b, dtype=float)
    cos = np.dot(a, b) / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.arccos(np.clip(cos, -1.0, 1.0)))


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v)


def _list(v: np.ndarray) -> list[float]:
    return [round(float(x), 7) for x in v]
