"""Demonstration analysis: a track's interaction phases and the effect of each (docs/demos.md).

`analyze_track(path_or_data)` reads a track (runtime/demonstrations/track.py), segments it into
phases (runtime/demonstrations/segments.py: when each object moves and how, grip events) and
measures each phase's effect on the object it moved: displacement (vector and length), rotation
(angle and world axis), lift height, what else moved, the surface it rested on and the fixture
nearest to it. Each phase is matched to the standard primitive whose effect it shows, with that
effect as the primitive's argument (a push's displacement, a flip's angle, a lift's rise ...): the
arguments a strategy built from the demonstration starts from (the paper's InferEffect). Pure
numpy: no MuJoCo.
"""

from __future__ import annotations

import math
import os
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from rapid_dsl.runtime.demonstrations import signals as sig
from rapid_dsl.runtime.demonstrations.segments import (
    THRESHOLDS,
    GripEvent,
    Motion,
    Signals,
    Thresholds,
    grip_events,
    motions,
    pose_at,
    signals,
)
from rapid_dsl.runtime.demonstrations.track import EntityInfo, Track, load_track, validate_track

FORMAT = "rapidc-demo/1"
# The phase kinds that are a standard primitive's effect (the others, `release` and `other`,
# have none), with each one's effect param and its unit.
ARGUMENTS: dict[str, tuple[str, str]] = {
    "push": ("displacement", "m"), "press_move": ("displacement", "m"),
    "flip": ("angle", "rad"), "pivot": ("angle", "rad"), "topple": ("toward", ""),
    "grasp": ("approach", ""), "lift": ("rise", "m"), "move": ("displacement", "m"),
}
EFFECT_UNITS = {"displacement": "m", "distance": "m", "horizontal_distance": "m",
                "rotation_angle": "rad", "rotation_axis": "", "lift_height": "m",
                "peak_lift_height": "m"}
UP = np.array([0.0, 0.0, 1.0])
PRESSING_MARGIN = 0.005    # m: the fingertips this far below an object's top press on it
APPROACH_SPEED = 0.02      # m/s: the hand's last motion faster than this is a grasp's approach


def analyze_track(source: str | os.PathLike[str] | Mapping[str, Any] | Track, *,
                  thresholds: Thresholds = THRESHOLDS) -> dict[str, Any]:
    """The analysis of a track file, of parsed track JSON, or of a Track, as a JSON-ready dict
    (docs/demos.md). Raises TrackError (runtime/demonstrations/track.py) for a track that is not
    valid."""
    if isinstance(source, Track):
        track, name = source, "<track>"
    elif isinstance(source, Mapping):
        track, name = validate_track(source), "<track>"
    else:
        track, name = load_track(source), os.fspath(source)
    return Analysis(track, thresholds).to_json(name)


# --- one phase ---------------------------------------------------------------------------------

Pose = tuple[np.ndarray, np.ndarray]      # position (3,), quaternion w x y z (4,)


@dataclass(slots=True)
class Phase:
    kind: str
    motion: str                 # sliding | turning | vertical | closing | opening
    obj: str
    start: int                  # frames [start, end)
    end: int
    before: Pose
    after: Pose
    hand_near: float = 0.0      # fraction of its frames with the hand touching the object
    held: float = 0.0           # ... with the object in the closed grip
    support: str | None = None
    fixture: str | None = None
    also_moved: list[dict[str, Any]] = field(default_factory=list)
    arguments: dict[str, Any] = field(default_factory=dict)

    def effect(self) -> dict[str, Any]:
        (p0, q0), (p1, q1) = self.before, self.after
        moved = p1 - p0
        angle, axis = sig.rotation_between(q0, q1)
        return {"displacement": _vector(moved), "distance": float(np.linalg.norm(moved)),
                "horizontal_distance": float(np.hypot(moved[0], moved[1])),
                "rotation_angle": angle,
                "rotation_axis": _vector(axis) if angle >= math.radians(0.5) else None,
                "lift_height": float(moved[2])}


class Analysis:
    """The phases of one track (see the module doc); `to_json` is the result tools read."""

    def __init__(self, track: Track, limits: Thresholds = THRESHOLDS) -> None:
        self.track, self.limits = track, limits
        frames = track.frames
        self.t = np.array([f.t for f in frames])
        self.hand = np.array([f.hand.position for f in frames])
        self.opening = np.array([f.hand.opening for f in frames])
        self.widest = float(self.opening.max())
        self.entities: dict[str, EntityInfo] = {e.name: e for e in track.entities}
        self.signals: dict[str, Signals] = {
            o.name: signals(self.t, np.array([f.objects[o.name].position for f in frames]),
                            np.array([f.objects[o.name].quat for f in frames]), limits)
            for o in track.objects()}
        self._measured: dict[Motion, tuple[Pose, Pose]] = {}
        found = [m for name, s in self.signals.items() for m in motions(name, self.t, s, limits)]
        grips = [p for e in grip_events(self.t, self.opening, limits)
                 if (p := self._grip_phase(e)) is not None]
        found = [m for m in found if not any(self._settling(m, g) for g in grips)]
        self.phases = [self._motion_phase(group) for group in _groups(found, self._score)]
        self.phases = sorted(self.phases + grips, key=lambda p: (p.start, p.end))

    # --- motion phases ---------------------------------------------------------------------

    def _poses(self, m: Motion) -> tuple[Pose, Pose]:
        if m not in self._measured:
            s = self.signals[m.obj]
            self._measured[m] = (
                pose_at(self.t, s, m.start, rest=m.rest_before, after=False, limits=self.limits),
                pose_at(self.t, s, m.end, rest=m.rest_after, after=True, limits=self.limits))
        return self._measured[m]

    def _settling(self, m: Motion, grip: Phase) -> bool:
        """A small motion of a grasped or released object while the grip closes or opens, or
        just after (docs/demos.md): part of the grip phase."""
        limits = self.limits
        until = self.t[min(grip.end, len(self.t) - 1)] + limits.shortest_mode
        if m.obj != grip.obj or m.end <= grip.start or (m.start >= grip.end
                                                         and self.t[m.start] > until):
            return False
        (p0, q0), (p1, q1) = self._poses(m)
        return bool(np.linalg.norm(p1 - p0) < limits.least_split_displacement
                    and sig.rotation_between(q0, q1)[0] < limits.least_split_rotation)

    def _score(self, m: Motion) -> float:
        """How much a motion moved its object: 1 per cm and per 3 deg."""
        (p0, q0), (p1, q1) = self._poses(m)
        return float(np.linalg.norm(p1 - p0)) / 0.01 + sig.rotation_between(q0, q1)[0] / \
            math.radians(3)

    def _motion_phase(self, group: list[Motion]) -> Phase:
        main = max(group, key=self._score)
        before, after = self._poses(main)
        phase = Phase("other", main.mode, main.obj, main.start, main.end, before, after)
        for other in group:
            if other is not main:
                (p0, q0), (p1, q1) = self._poses(other)
                phase.also_moved.append({
                    "object": other.obj, "distance": float(np.linalg.norm(p1 - p0)),
                    "rotation_angle": sig.rotation_between(q0, q1)[0]})
        frames = range(main.start, main.end)
        phase.hand_near = _fraction(self._near(main.obj, i) for i in frames)
        phase.held = _fraction(self._held(main.obj, i) for i in frames)
        phase.support = self._support(main.obj, before)
        phase.fixture = self._fixture(main.obj, after)
        self._classify(phase, pressing=_fraction(self._pressing(main.obj, i) for i in frames))
        return phase

    def _classify(self, phase: Phase, *, pressing: float) -> None:
        """The phase's kind and its primitive's argument (docs/demos.md, "Phase kinds")."""
        limits = self.limits
        (p0, q0), (p1, q1) = phase.before, phase.after
        moved = p1 - p0
        across = float(np.hypot(moved[0], moved[1]))
        rise = float(moved[2])
        angle, axis = sig.rotation_between(q0, q1)
        value: float | list[float]
        vertical = abs(axis[2]) >= math.cos(limits.tilted)
        if angle >= (limits.least_pivot if vertical else limits.least_turn):
            if vertical:
                phase.kind, value = "pivot", angle * math.copysign(1.0, axis[2])
            elif phase.fixture is not None:
                phase.kind, value = "flip", angle
            else:
                toward = np.array([moved[0], moved[1], 0.0])
                if across < limits.least_displacement:   # fell in place: where its top went
                    toward = np.cross(axis, UP)          # not 0: the axis is tilted
                phase.kind, value = "topple", _vector(toward / np.linalg.norm(toward))
        elif rise >= max(limits.least_split_displacement / 2, across):
            phase.kind, value = "lift", rise
        elif phase.held >= 0.5:
            phase.kind, value = "move", _vector(moved)
        elif across >= limits.least_displacement:
            phase.kind = "press_move" if pressing >= 0.5 else "push"
            value = _vector(np.array([moved[0], moved[1], 0.0]))
        else:
            return
        phase.arguments = {ARGUMENTS[phase.kind][0]: value}

    # --- grip phases -----------------------------------------------------------------------

    def _grip_phase(self, event: GripEvent) -> Phase | None:
        """A closing that ends holding an object is a grasp of it; an opening that starts
        holding one, its release. Other grip changes (a paddle for a push) are no phase."""
        last = len(self.t) - 1
        at = min(event.end, last) if event.kind == "closing" else max(event.start - 1, 0)
        held = [name for name in self.signals if self._held(name, at)]
        if not held:
            return None
        name = min(held, key=lambda n: self._distance(n, at))
        s = self.signals[name]
        before = (s.smooth_positions[event.start], s.smooth_quats[event.start])
        end = min(event.end, last)
        after = (s.smooth_positions[end], s.smooth_quats[end])
        if event.kind == "opening":
            return Phase("release", "opening", name, event.start, event.end, before, after,
                         held=1.0)
        phase = Phase("grasp", "closing", name, event.start, event.end, before, after,
                      hand_near=1.0, held=1.0, support=self._support(name, before))
        phase.arguments = {"approach": self._approach(event.start)}
        return phase

    def _approach(self, start: int) -> list[float]:
        """The direction of the hand's last motion before `start` (default straight down)."""
        speed = sig.speed(self.t, sig.smooth(self.t, self.hand, self.limits.smoothing),
                          self.limits.rate_window)
        moving = np.flatnonzero(speed[:start] > APPROACH_SPEED)
        if moving.size:
            end = int(moving[-1])
            first = int(np.searchsorted(self.t, self.t[end] - self.limits.approach_window))
            step = self.hand[end] - self.hand[first]
            if np.linalg.norm(step) >= self.limits.least_split_displacement / 2:
                return _vector(_snapped(step / np.linalg.norm(step), self.limits.snap))
        return [0.0, 0.0, -1.0]

    # --- relations -------------------------------------------------------------------------

    def _box(self, name: str, i: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s = self.signals[name]
        return s.positions[i], s.quats[i], np.array(self.entities[name].extents)

    def _distance(self, name: str, i: int) -> float:
        return sig.box_distance(self.hand[i], *self._box(name, i))

    def _near(self, name: str, i: int) -> bool:
        return self._distance(name, i) <= self.limits.near

    def _held(self, name: str, i: int) -> bool:
        limits = self.limits
        return (self._distance(name, i) <= limits.grasp_reach
                and limits.least_grip <= self.opening[i] <= self.widest - limits.grip_closed)

    def _pressing(self, name: str, i: int) -> bool:
        """The hand on top of the object: touching it, above its top less a margin, over its
        footprint (in the object's own frame)."""
        centre, quat, extents = self._box(name, i)
        top = centre[2] + sig.half_height(quat, extents)
        local = sig.matrix(quat).T @ (self.hand[i] - centre)
        return (self._near(name, i) and self.hand[i][2] >= top - PRESSING_MARGIN
                and bool(np.all(np.abs(local[:2]) <= extents[:2] / 2)))

    def _support(self, name: str, pose: Pose) -> str | None:
        """The surface whose top is nearest the object's bottom under it (within
        `support_reach`), in the pose given."""
        position, quat = pose
        bottom = position[2] - sig.half_height(quat, np.array(self.entities[name].extents))
        best: tuple[float, str] | None = None
        for surface in self.entities.values():
            if surface.kind != "Surface" or surface.pose is None:
                continue
            centre, squat = np.array(surface.pose.position), np.array(surface.pose.quat)
            extents = np.array(surface.extents)
            local = sig.matrix(squat).T @ (position - centre)
            under = surface.shape == "plane" or bool(np.all(np.abs(local[:2]) <= extents[:2] / 2))
            gap = abs(bottom - (centre[2] + sig.half_height(squat, extents)))
            if under and gap <= self.limits.support_reach and (best is None or gap < best[0]):
                best = (gap, surface.name)
        return best[1] if best else None

    def _fixture(self, name: str, pose: Pose) -> str | None:
        """The fixture nearest the object (within `fixture_reach`) in the pose given."""
        box = (pose[0], pose[1], np.array(self.entities[name].extents))
        gaps = [(sig.boxes_gap(box, (np.array(f.pose.position), np.array(f.pose.quat),
                                     np.array(f.extents))), f.name)
                for f in self.entities.values() if f.kind == "Fixture" and f.pose is not None]
        near = [g for g in gaps if g[0] <= self.limits.fixture_reach]
        return min(near)[1] if near else None

    # --- the result ------------------------------------------------------------------------

    def to_json(self, name: str) -> dict[str, Any]:
        t = self.t
        phases = []
        for index, phase in enumerate(self.phases, start=1):
            effect = phase.effect()
            s = self.signals[phase.obj]
            effect["peak_lift_height"] = float(
                s.smooth_positions[phase.start:max(phase.end, phase.start + 1), 2].max()
                - phase.before[0][2])
            param = ARGUMENTS.get(phase.kind)
            phases.append({
                "index": index, "kind": phase.kind,
                "primitive": phase.kind if param else None, "motion": phase.motion,
                "object": phase.obj, "start": float(t[phase.start]),
                "end": float(t[min(phase.end, len(t)) - 1]),
                "effect": effect, "before": _pose(phase.before), "after": _pose(phase.after),
                "support": phase.support, "fixture": phase.fixture,
                "hand": {"near": phase.hand_near, "held": phase.held},
                "also_moved": phase.also_moved,
                "arguments": phase.arguments,
                "argument_units": {param[0]: param[1]} if param and phase.arguments else {},
                "argument_text": {k: literal(v, param[1]) for k, v in phase.arguments.items()}
                if param else {},
            })
        return {
            "format": FORMAT, "track": name, "hand": self.track.hand,
            "frames": len(t), "duration": float(t[-1] - t[0]),
            "objects": {o: {"moved": any(p.obj == o for p in self.phases
                                         if p.kind not in ("grasp", "release")),
                            "start": _pose((s.positions[0], s.quats[0])),
                            "end": _pose((s.positions[-1], s.quats[-1]))}
                        for o, s in self.signals.items()},
            "phases": phases,
            "units": {"start": "s", "end": "s", **EFFECT_UNITS},
            "thresholds": {k: getattr(self.limits, k) for k in self.limits.__dataclass_fields__},
            "threshold_units": self.limits.units(),
        }


def _groups(found: list[Motion], score: Any) -> list[list[Motion]]:
    """Motions of different objects that overlap in time form one phase (the one that moved its
    object most is the phase's; the others moved along)."""
    groups: list[list[Motion]] = []
    end = -1
    for m in sorted(found, key=lambda m: (m.start, -score(m))):
        if groups and m.start < end and all(g.obj != m.obj for g in groups[-1]):
            groups[-1].append(m)
            end = max(end, m.end)
        else:
            groups.append([m])
            end = m.end
    return groups


def _snapped(direction: np.ndarray, snap: float) -> np.ndarray:
    """A unit direction within `snap` of a world axis (either way) becomes that axis."""
    axis = int(np.argmax(np.abs(direction)))
    if abs(direction[axis]) >= math.cos(snap):
        out = np.zeros(3)
        out[axis] = math.copysign(1.0, direction[axis])
        return out
    return direction


def _fraction(values: Any) -> float:
    flags = [bool(v) for v in values]
    return sum(flags) / len(flags) if flags else 0.0


def _vector(v: np.ndarray) -> list[float]:
    return [float(x) + 0.0 for x in v]


def _pose(pose: Pose) -> dict[str, list[float]]:
    return {"position": _vector(pose[0]), "quat": _vector(pose[1])}


# --- language text -----------------------------------------------------------------------------

def literal(value: float | list[float], unit: str) -> str:
    """A value as a constant in the language: `11.2cm`, `88.5deg`, `[11.2cm, -0.1cm, 0cm]`,
    `[0.995, 0.1, 0]` (a direction); to 1 mm, 0.1 deg and 0.001."""
    def one(x: float) -> str:
        if unit == "m":
            return _digits(x * 100.0, 1) + "cm"
        if unit == "rad":
            return _digits(math.degrees(x), 1) + "deg"
        return _digits(x, 3)
    if isinstance(value, list):
        return "[" + ", ".join(one(x) for x in value) + "]"
    return one(value)


def _digits(x: float, places: int) -> str:
    text = f"{x:.{places}f}".rstrip("0").rstrip(".")
    return "0" if text in ("-0", "") else text
