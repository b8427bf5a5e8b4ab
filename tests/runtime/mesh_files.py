"""Small mesh files written on the fly for scene and world tests."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_obj(path: Path, extents=(0.08, 0.06, 0.1), offset=(1.0, 2.0, 3.0)) -> Path:
    """A box-shaped .obj whose origin is far from its centre."""
    corners = np.array([[x, y, z] for x in (0, 1) for y in (0, 1) for z in (0, 1)], dtype=float)
    vertices = corners * extents + offset
    faces = [(1, 2, 4), (1, 4, 3), (5, 7, 8), (5, 8, 6), (1, 5, 6), (1, 6, 2),
             (3, 4, 8), (3, 8, 7), (1, 3, 7), (1, 7, 5), (2, 6, 8), (2, 8, 4)]
    lines = [f"v {x} {y} {z}" for x, y, z in vertices] + [f"f {a} {b} {c}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path
