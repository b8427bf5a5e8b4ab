"""Segmenting a track into interaction phases: when each object moves, how, and grip events.

The rules and thresholds are `Thresholds` (docs/demos.md lists them with their reasons):

1. Poses are smoothed (moving average over +-`smoothing` s); speeds are measured over
   +-`rate_window` s of the smoothed poses.
2. An object *moves* from a frame where its speed exceeds `speed_on` or its rotation rate
   `turn_on`, for as they stay above `speed_off` / `turn_off` (hysteresis: noise around
   one threshold does not chatter). A rest shorter than `shortest_pause` does not end a motion.
3. A motion whose net effect is below `least_displacement` and `least_rotation` is jitter.
4. Within a motion, each frame is *turning* (rotation rate above `turning`), *vertical* (moving
   more up or down than sideways) or *sliding*; a stretch of one mode shorter than
   `shortest_mode`, or whose own effect is below `least_split_displacement` (vertical,
   sliding) or `least_split_rotation` (turning), joins its longer neighbour. Each remaining
   stretch is a phase: a push straight into a flip without a pause is two phases.
5. Grip events: the finger opening closing or opening faster than `grip_rate`, by at least
   `least_grip_change`. A closing that ends with the hand on an object (`held`) is a grasp; an
   opening that starts with one held is a release. A motion of that object during the event or
   within `shortest_mode` s after it that moves it less than the split thresholds is the grip
   settling, part of the grasp or release.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from rapid_dsl.runtime.demonstrations import signals as sig

Mode = Literal["turning", "vertical", "sliding"]


@dataclass(frozen=True, slots=True, kw_only=True)
class Thresholds:
    """Every threshold of the analysis, SI units (m, rad, s)."""

    smoothing: float = 0.1                 # s, half window of the pose moving average
    rate_window: float = 0.1               # s, half window speeds are measured over
    speed_on: float = 0.02                 # m/s: a motion starts above this ...
    speed_off: float = 0.01                # ... and lasts while above this
    turn_on: float = math.radians(15)      # rad/s, the same for rotation rates
    turn_off: float = math.radians(8)
    shortest_pause: float = 0.2            # s: a shorter rest does not end a motion
    least_displacement: float = 0.01       # m ... a motion below both is jitter
    least_rotation: float = math.radians(5)
    turning: float = math.radians(20)      # rad/s: a frame turning faster is `turning`
    shortest_mode: float = 0.4             # s: a shorter stretch of one mode joins a neighbour
    least_split_displacement: float = 0.02   # m, ... and so does one that moves less
    least_split_rotation: float = math.radians(15)
    rest_window: float = 0.3               # s of rest averaged for the pose before and after
    near: float = 0.03                     # m: the hand this close to an object's box touches it
    grasp_reach: float = 0.01              # m: ... this close, with the grip closed on it, holds
    least_grip: float = 0.003              # m: a closed grip opened wider holds something
    grip_closed: float = 0.005             # m below the track's widest opening: not open
    grip_rate: float = 0.02                # m/s: the fingers close or open faster than this
    least_grip_change: float = 0.01        # m
    approach_window: float = 0.5           # s before a grasp whose hand motion is its approach
    snap: float = math.radians(15)         # a direction this close to a world axis is that axis
    least_turn: float = math.radians(20)   # a phase tipping more flips or topples ...
    least_pivot: float = math.radians(30)  # ... turning more about the vertical pivots
    tilted: float = math.radians(30)       # an axis further from vertical tips (flip, topple)
    fixture_reach: float = 0.03            # m: a tipping object this close to a fixture flips
    support_reach: float = 0.02            # m: an object's bottom this close to a top rests on it

    def units(self) -> dict[str, str]:
        rates = {"speed_on", "speed_off", "grip_rate"}
        turns = {"turn_on", "turn_off", "turning"}
        angles = {"least_rotation", "least_split_rotation", "snap", "least_turn", "least_pivot",
                  "tilted"}
        times = {"smoothing", "rate_window", "shortest_pause", "shortest_mode", "rest_window",
                 "approach_window"}
        return {name: "m/s" if name in rates else "rad/s" if name in turns else
                "rad" if name in angles else "s" if name in times else "m"
                for name in self.__dataclass_fields__}


THRESHOLDS = Thresholds()


@dataclass(frozen=True, slots=True)
class Motion:
    """Frames [start, end) of one object's motion in one mode; `rest_before`/`rest_after` tell
    whether the object rests on that side (then its pose there is averaged over the rest)."""

    obj: str
    start: int
    end: int
    mode: Mode
    rest_before: bool
    rest_after: bool


@dataclass(frozen=True, slots=True)
class Signals:
    """One object's poses along the track, raw and smoothed, with its rates."""

    positions: np.ndarray      # (T, 3) as recorded
    quats: np.ndarray          # (T, 4), signs made continuous
    smooth_positions: np.ndarray
    smooth_quats: np.ndarray
    speed: np.ndarray          # (T,) m/s
    velocity: np.ndarray       # (T, 3)
    turn_rate: np.ndarray      # (T,) rad/s
    moving: np.ndarray         # (T,) bool after hysteresis and gap filling


def signals(t: np.ndarray, positions: np.ndarray, quats: np.ndarray,
            limits: Thresholds) -> Signals:
    quats = sig.continuous(quats)
    smooth_p = sig.smooth(t, positions, limits.smoothing)
    smooth_q = sig.smooth_quats(t, quats, limits.smoothing)
    speed = sig.speed(t, smooth_p, limits.rate_window)
    turn = sig.angular_speed(t, smooth_q, limits.rate_window)
    moving = sig.hysteresis((speed > limits.speed_on) | (turn > limits.turn_on),
                            (speed > limits.speed_off) | (turn > limits.turn_off))
    moving = sig.fill_gaps(t, moving, limits.shortest_pause)
    return Signals(positions, quats, smooth_p, smooth_q, speed,
                   sig.velocity(t, smooth_p, limits.rate_window), turn, moving)


def pose_at(t: np.ndarray, s: Signals, frame: int, *, rest: bool, after: bool,
            limits: Thresholds) -> tuple[np.ndarray, np.ndarray]:
    """The object's pose at a phase boundary: averaged over up to `rest_window` s of the rest on
    that side (`after`: the frames from `frame` on, else those before it), or the smoothed pose
    there when it does not rest; the raw first or last frame at the track's ends."""
    count = len(t)
    if rest:
        if after:
            span = range(frame, int(np.searchsorted(t, t[frame] + limits.rest_window, "right")))
        else:
            span = range(int(np.searchsorted(t, t[frame - 1] - limits.rest_window, "left")),
                         frame)
        picked = [j for j in span if not s.moving[j]]
        if picked:
            return s.positions[picked].mean(axis=0), sig.mean_quat(s.quats[picked])
    if frame <= 0 or frame >= count:
        end = 0 if frame <= 0 else count - 1
        return s.positions[end], s.quats[end]
    return s.smooth_positions[frame], s.smooth_quats[frame]


def motions(name: str, t: np.ndarray, s: Signals, limits: Thresholds) -> list[Motion]:
    """The object's motions, split by mode; jitter dropped."""
    found: list[Motion] = []
    for start, end in sig.runs(s.moving):
        before = pose_at(t, s, start, rest=start > 0, after=False, limits=limits)
        after = pose_at(t, s, end, rest=end < len(t), after=True, limits=limits)
        angle, _ = sig.rotation_between(before[1], after[1])
        if (np.linalg.norm(after[0] - before[0]) < limits.least_displacement
                and angle < limits.least_rotation):
            continue
        pieces = _modes(t, s, start, end, limits)
        for k, (mode, a, b) in enumerate(pieces):
            found.append(Motion(name, a, b, mode, rest_before=k == 0 and start > 0,
                                rest_after=k == len(pieces) - 1 and end < len(t)))
    return found


def _modes(t: np.ndarray, s: Signals, start: int, end: int,
           limits: Thresholds) -> list[tuple[Mode, int, int]]:
    """[(mode, a, b)] covering [start, end): per-frame modes, weak stretches merged away."""
    labels: list[Mode | None] = []
    for i in range(start, end):
        v = s.velocity[i]
        if s.turn_rate[i] > limits.turning:
            labels.append("turning")
        elif s.speed[i] <= limits.speed_off:
            labels.append(None)            # too slow to say: takes its neighbours' mode
        elif abs(v[2]) > np.hypot(v[0], v[1]):
            labels.append("vertical")
        else:
            labels.append("sliding")
    known = [label for label in labels if label is not None]
    if not known:
        return [("turning" if s.turn_rate[start:end].max() > limits.turn_on else "sliding",
                 start, end)]
    filled: list[Mode] = []
    last: Mode = known[0]
    for label in labels:
        last = label if label is not None else last
        filled.append(last)
    pieces: list[_Piece] = []
    for offset, label in enumerate(filled):
        if pieces and pieces[-1].mode == label:
            pieces[-1].end = start + offset + 1
        else:
            pieces.append(_Piece(label, start + offset, start + offset + 1))
    while len(pieces) > 1:
        weak = [k for k, piece in enumerate(pieces) if _weak(t, s, piece, limits)]
        if not weak:
            break
        k = min(weak, key=lambda j: pieces[j].duration(t))
        into = max((j for j in (k - 1, k + 1) if 0 <= j < len(pieces)),
                   key=lambda j: pieces[j].duration(t))
        pieces[into].start = min(pieces[into].start, pieces[k].start)
        pieces[into].end = max(pieces[into].end, pieces[k].end)
        del pieces[k]
        merged: list[_Piece] = []
        for piece in pieces:
            if merged and merged[-1].mode == piece.mode:
                merged[-1].end = piece.end
            else:
                merged.append(piece)
        pieces = merged
    return [(piece.mode, piece.start, piece.end) for piece in pieces]


@dataclass(slots=True)
class _Piece:
    mode: Mode
    start: int
    end: int       # exclusive

    def duration(self, t: np.ndarray) -> float:
        return float(t[self.end - 1] - t[self.start])


def _weak(t: np.ndarray, s: Signals, piece: _Piece, limits: Thresholds) -> bool:
    """A stretch too short, or moving too little in its own mode, to be a phase of its own."""
    if piece.duration(t) < limits.shortest_mode:
        return True
    a, b = piece.start, piece.end - 1
    if piece.mode == "turning":
        angle, _ = sig.rotation_between(s.smooth_quats[a], s.smooth_quats[b])
        return angle < limits.least_split_rotation
    moved = np.linalg.norm(s.smooth_positions[b] - s.smooth_positions[a])
    return bool(moved < limits.least_split_displacement)


@dataclass(frozen=True, slots=True)
class GripEvent:
    kind: Literal["closing", "opening"]
    start: int
    end: int       # exclusive


def grip_events(t: np.ndarray, opening: np.ndarray, limits: Thresholds) -> list[GripEvent]:
    """Stretches where the fingers close or open faster than `grip_rate` by `least_grip_change`."""
    smooth = sig.smooth(t, opening[:, None], limits.smoothing)
    rate = sig.velocity(t, smooth, limits.rate_window)[:, 0]
    events = []
    directions: tuple[tuple[Literal["closing", "opening"], float], ...] = (("closing", -1.0),
                                                                           ("opening", 1.0))
    for kind, sign in directions:
        active = sig.hysteresis(sign * rate > limits.grip_rate,
                                sign * rate > limits.grip_rate / 2)
        for a, b in sig.runs(active):
            before = opening[max(a - 1, 0)]
            after = opening[min(b, len(t) - 1)]
            if sign * (after - before) >= limits.least_grip_change:
                events.append(GripEvent(kind, a, b))
    return sorted(events, key=lambda e: e.start)
