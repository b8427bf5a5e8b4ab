"""Mesh files for scene objects: load once with trimesh, keep the convex hull for collision.

A mesh object's frame is the centre of its hull's axis-aligned bounding box (in the file's own
axes), so `pose.position` means the same thing for every shape: the centre of the object's
extents. The file's origin is ignored. No mujoco import here: scene validation uses this module.
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache
from pathlib import Path

import numpy as np


class MeshLoadError(ValueError):
    """The mesh file is missing, unreadable or degenerate."""


@dataclass(frozen=True, slots=True)
class MeshHull:
    vertices: np.ndarray   # (V, 3) hull vertices centred on the bounding-box centre (file units)
    faces: np.ndarray      # (F, 3) int triangles of the hull
    extents: np.ndarray    # (3,) full bounding-box size along the file's axes

    def scaled(self, extents: np.ndarray) -> np.ndarray:
        """Hull vertices stretched per axis to the given full extents."""
        return self.vertices * (np.asarray(extents, dtype=float) / self.extents)


def load_hull(path: str | Path) -> MeshHull:
    """The convex hull of a .obj/.stl/.ply mesh file; MeshLoadError says what is wrong."""
    resolved = Path(path).expanduser().resolve()
    if not resolved.is_file():
        raise MeshLoadError(f"mesh file `{path}` does not exist")
    stat = resolved.stat()
    return _load_hull(str(resolved), stat.st_mtime_ns, stat.st_size)


@lru_cache(maxsize=64)
def _load_hull(path: str, _mtime: int, _size: int) -> MeshHull:
    import trimesh  # heavy import, only when a scene has meshes

    try:
        loaded = trimesh.load(path, force="mesh", process=True)
    except Exception as error:  # trimesh raises many kinds for malformed files
        raise MeshLoadError(f"cannot read mesh `{path}`: {error}") from error
    vertices = np.asarray(getattr(loaded, "vertices", np.empty((0, 3))), dtype=float)
    if vertices.ndim != 2 or len(vertices) < 4 or not np.isfinite(vertices).all():
        raise MeshLoadError(f"mesh `{path}` has no usable vertices")
    try:
        hull = trimesh.convex.convex_hull(vertices)
    except Exception as error:  # qhull fails on flat or degenerate point sets
        raise MeshLoadError(f"mesh `{path}` has no 3-D convex hull: {error}") from error
    lo, hi = hull.bounds
    extents = hi - lo
    if np.any(extents <= 1e-6) or hull.volume <= 0:
        raise MeshLoadError(f"mesh `{path}` is flat (extents {extents.round(6).tolist()})")
    centred = np.asarray(hull.vertices, dtype=float) - (lo + hi) / 2
    return MeshHull(centred, np.asarray(hull.faces, dtype=np.int32), extents)
