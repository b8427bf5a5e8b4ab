"""Why a builtin relation is false for given entities, in numbers (what binding explanations quote).

`evidence(frames, "touching", (box, floor))` -> `"distance 0.31 m"`. Values are read at the first
recorded sample and time point where the relation is false, and follow the relation's definition
in builtins.py (docs/builtins.md), naming the first of its conditions that fails.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable

import numpy as np

from rapid_dsl.runtime import builtins as B
from rapid_dsl.runtime.frames import Frames

_CALL = re.compile(r"\s*(\w+)\s*\(\s*(\w+(?:\s*,\s*\w+)*)\s*\)\s*")
At = tuple[int, int]   # (sample, time point)


def parse_call(text: str) -> tuple[str, tuple[str, ...]] | None:
    """`"touching(box, wall)"` -> `("touching", ("box", "wall"))`; None for any other clause."""
    match = _CALL.fullmatch(text)
    if match is None or match[1] not in _WHY:
        return None
    return match[1], tuple(a.strip() for a in match[2].split(","))


def evidence(frames: Frames, relation: str, indices: tuple[int, ...]) -> str | None:
    """Numbers showing why builtin `relation` is false for entity `indices`; None if it holds or
    is not a builtin relation."""
    why = _WHY.get(relation)
    if why is None or len(indices) != why[0]:
        return None
    holds = np.asarray(B.IMPLEMENTATIONS[relation](frames, *indices), dtype=bool)
    if holds.all():
        return None
    sample, step = np.unravel_index(int(np.argmin(holds)), holds.shape)
    return why[1](frames, (int(sample), int(step)), *indices)


def _m(value: float) -> str:
    return f"{value:.3g} m"


def _name(frames: Frames, e: int) -> str:
    return frames.entities.entities[e].name


def _on(frames: Frames, at: At, o: int, s: int) -> str:
    gap = float(np.abs(B.bottom(frames, o) - B.top(frames, s))[at])
    if not B._over_footprint(frames, s, frames.pos[:, :, o])[at]:
        return f"the centre of {_name(frames, o)} is not over {_name(frames, s)}"
    if gap > B.ON_GAP:
        return (f"the bottom of {_name(frames, o)} is {_m(gap)} from the top of "
                f"{_name(frames, s)}, more than {_m(B.ON_GAP)}")
    return f"no contact, and a gap of {_m(gap)} (more than {_m(B.ON_TOUCH_SLACK)})"


def _touching(frames: Frames, at: At, a: int, b: int) -> str:
    return f"distance {_m(float(B.distance(frames, a, b)[at]))}"


def _faces(frames: Frames, at: At, f: int, o: int) -> str:
    gap = float(B.distance(frames, f, o)[at])
    if gap > B.FACES_RANGE:
        return f"distance {_m(gap)}, more than {_m(B.FACES_RANGE)}"
    level = (B.bottom(frames, o) < B.top(frames, f)) & (B.bottom(frames, f) < B.top(frames, o))
    if not level[at]:
        return (f"not level: {_name(frames, o)} spans z {_span(frames, at, o)}, "
                f"{_name(frames, f)} z {_span(frames, at, f)}")
    return f"{_name(frames, o)} is not in front of a side face of {_name(frames, f)}"


def _span(frames: Frames, at: At, e: int) -> str:
    return f"{float(B.bottom(frames, e)[at]):.3g}..{float(B.top(frames, e)[at]):.3g} m"


def _reachable(frames: Frames, at: At, m: int, b: int) -> str:
    offset = frames.pos[:, :, b] - np.asarray(frames.entities.robot_base, dtype=float)
    far = float(np.linalg.norm(offset, axis=-1)[at])
    return f"{_m(far)} from the robot's base, reach {_m(frames.entities.robot_reach)}"


def _inside(frames: Frames, at: At, o: int, f: int) -> str:
    return f"the centre of {_name(frames, o)} is outside the footprint of {_name(frames, f)}"


def _settled(frames: Frames, at: At, o: int) -> str:
    return (f"speed {float(B.speed(frames, o)[at]):.3g} m/s, spin "
            f"{float(B.spin(frames, o)[at]):.3g} rad/s")


def _holding(frames: Frames, at: At, m: int, o: int) -> str:
    return f"the hand does not hold {_name(frames, o)}"


def _upright(frames: Frames, at: At, o: int) -> str:
    return (f"tilt {math.degrees(float(B.tilt(frames, o)[at])):.3g} deg, more than "
            f"{math.degrees(B.UPRIGHT_TILT):.3g} deg")


def _undisturbed(frames: Frames, at: At, m: int) -> str:
    objects = [e for e in frames.entities.entities if e.kind == "Object"]
    moved = np.linalg.norm(frames.pos[:, :, [e.index for e in objects]]
                           - frames.first().pos[:, :, [e.index for e in objects]], axis=-1)[at]
    farthest = int(np.argmax(moved))
    return (f"{objects[farthest].name} moved {_m(float(moved[farthest]))}, more than "
            f"{_m(B.UNDISTURBED)}")


# relation -> (arity, explanation at a (sample, time point) where it is false)
_WHY: dict[str, tuple[int, Callable[..., str]]] = {
    "on": (2, _on), "touching": (2, _touching), "faces": (2, _faces),
    "reachable": (2, _reachable), "inside": (2, _inside), "settled": (1, _settled),
    "holding": (2, _holding), "upright": (1, _upright), "undisturbed": (1, _undisturbed),
}
