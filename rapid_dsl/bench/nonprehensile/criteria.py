"""Criteria the tasks share, measured on the final state (never the strategy's own clauses)."""

from __future__ import annotations

import numpy as np

from rapid_dsl.bench.nonprehensile.spec import FinalState, Measure

LIFT_CLEARANCE = 0.03       # m: a grasped object's lowest point above its support


def lowest_point(state: FinalState, name: str) -> float:
    """The object's lowest point, world z [m], exact for its shape (a mesh by its hull)."""
    return state.solid(name).bottom


def grasped_above(state: FinalState, name: str, support: str,
                  clearance: float = LIFT_CLEARANCE) -> Measure:
    """Lowest point at least `clearance` above the support's top, with both fingers on it."""
    gap = lowest_point(state, name) - state.top(support)
    fingers = state.fingers_touch(name)
    ok = bool(gap >= clearance and fingers)
    return Measure(ok, gap, f"lowest point {gap * 100:.1f} cm above {support} "
                            f"(needs {clearance * 100:g}); "
                            f"{'both fingers touch' if fingers else 'fingers do not both touch'}")


def inside_box(state: FinalState, name: str, centre: np.ndarray, half: np.ndarray,
               yaw: float = 0.0) -> bool:
    """The object's centre lies inside the box volume (centre, half extents, yaw about z)."""
    c, s = np.cos(yaw), np.sin(yaw)
    offset = state.pos(name) - np.asarray(centre, dtype=float)
    local = np.array([c * offset[0] + s * offset[1], -s * offset[0] + c * offset[1], offset[2]])
    return bool(np.all(np.abs(local) <= np.asarray(half, dtype=float)))
