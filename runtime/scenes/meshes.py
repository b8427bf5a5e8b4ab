"""Mesh files for scene objects: read once, keep the convex hull for collision and inertia.

A mesh object's frame is the centre of its hull's axis-aligned bounding box (in the file's own
axes), so `pose.position` means the same thing for every shape: the centre of the object's
extents. The file's origin is ignored. No mujoco import here: scene validation uses this module.

Mesh files are untrusted input like scenes: they are read with `files.read_bytes` (regular files
of at most 10 MiB), parsed by trimesh from memory (so an .obj cannot make it open its `mtllib` or
textures), and only their vertices are used: the hull is computed here with scipy's qhull, after
checking that the points span 3-D, because trimesh's own hull repairs flat input with the optional
networkx. Every problem is a MeshLoadError whose message quotes nothing of the file.
"""

from __future__ import annotations

import hashlib
import io
import logging
import os
import warnings
from collections import OrderedDict
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from rapid_dsl.language.files import FileProblem, read_bytes

MESH_SUFFIXES = (".obj", ".stl", ".ply")
MAX_VERTICES = 1_000_000      # in the file (a 10 MiB file holds at most ~900,000)
MAX_HULL_VERTICES = 1_000     # more are thinned to this many (`_thinned`): MuJoCo's compile
                              # time and model size grow with them (1 s and 9 MB at 19,000)
MAX_COORDINATE = 1e6          # |coordinate| in the file's units
MIN_FILL = 1e-3               # hull volume / bounding-box volume: below it, a needle or a sheet
_FLAT = 1e-9                  # smallest / largest spread of the points: below it, they are flat
_CACHE_SIZE = 64


class MeshLoadError(ValueError):
    """The mesh file is missing, unreadable or degenerate; the message says which, not where."""


@dataclass(frozen=True, slots=True)
class MeshHull:
    vertices: np.ndarray   # (V, 3) hull vertices centred on the bounding-box centre (file units)
    faces: np.ndarray      # (F, 3) int triangles of the hull, counter-clockwise seen from outside
    extents: np.ndarray    # (3,) full bounding-box size along the file's axes

    def scaled(self, extents: np.ndarray) -> np.ndarray:
        """Hull vertices stretched per axis to the given full extents."""
        return self.vertices * (np.asarray(extents, dtype=float) / self.extents)


_hulls: OrderedDict[bytes, MeshHull] = OrderedDict()


def load_hull(path: str | os.PathLike[str]) -> MeshHull:
    """The convex hull of a .obj/.stl/.ply mesh file; MeshLoadError says what is wrong."""
    suffix = Path(path).suffix.lower()
    if suffix not in MESH_SUFFIXES:
        raise MeshLoadError(f"a mesh file is {', '.join(MESH_SUFFIXES[:-1])} or "
                            f"{MESH_SUFFIXES[-1]}")
    try:
        data = read_bytes(path)
    except FileProblem as problem:
        raise MeshLoadError(f"cannot read the mesh file: {problem}") from None
    # keyed by content, so a file changed between two reads is never served stale
    key = hashlib.sha256(data).digest() + suffix.encode()
    hull = _hulls.get(key)
    if hull is None:
        hull = _hull(_vertices(data, suffix))
        _hulls[key] = hull
        if len(_hulls) > _CACHE_SIZE:
            _hulls.popitem(last=False)
    _hulls.move_to_end(key)
    return hull


def _vertices(data: bytes, suffix: str) -> np.ndarray:
    import trimesh  # heavy import, only when a scene has meshes

    logging.getLogger("trimesh").addHandler(logging.NullHandler())  # never logs to stderr
    try:
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore")
            loaded = trimesh.load(io.BytesIO(data), file_type=suffix[1:], force="mesh",
                                  process=False)
            vertices = np.asarray(getattr(loaded, "vertices", np.empty((0, 3))), dtype=float)
    except Exception as error:  # trimesh raises many kinds for malformed files
        raise MeshLoadError(f"not a readable {suffix} mesh ({type(error).__name__})") from None
    if vertices.ndim != 2 or vertices.shape[1] != 3 or len(vertices) < 4:
        raise MeshLoadError("the mesh has fewer than 4 vertices")
    if len(vertices) > MAX_VERTICES:
        raise MeshLoadError(f"the mesh has {len(vertices)} vertices, more than the limit of "
                            f"{MAX_VERTICES}")
    if not np.isfinite(vertices).all():
        raise MeshLoadError("the mesh has vertices that are not finite numbers (NaN or inf)")
    if np.abs(vertices).max() > MAX_COORDINATE:
        raise MeshLoadError(f"the mesh has coordinates beyond {MAX_COORDINATE:g} (file units)")
    return vertices


def _hull(points: np.ndarray) -> MeshHull:
    from scipy.spatial import ConvexHull, QhullError

    centred = points - points.mean(axis=0)
    spread = np.linalg.svd(centred, compute_uv=False)
    if spread[2] <= _FLAT * spread[0]:
        raise MeshLoadError("the mesh is flat: all its vertices lie in one plane (or on a line)")
    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        raise MeshLoadError("the mesh has no 3-D convex hull (its vertices are degenerate)") \
            from None
    if len(hull.vertices) > MAX_HULL_VERTICES:
        points = _thinned(points[hull.vertices])
        hull = ConvexHull(points)
    vertices = points[hull.vertices]
    lo, hi = vertices.min(axis=0), vertices.max(axis=0)
    extents = hi - lo
    fill = hull.volume / float(np.prod(extents))
    if fill < MIN_FILL:
        raise MeshLoadError(f"the mesh is too thin: its hull fills {fill:.2g} of its bounding "
                            f"box (at least {MIN_FILL:g})")
    index = np.empty(len(points), dtype=np.int64)
    index[hull.vertices] = np.arange(len(hull.vertices))
    faces = index[hull.simplices]
    # qhull's facet normals point outward; wind every triangle to agree with its own
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    return MeshHull(vertices - (lo + hi) / 2, faces.astype(np.int32), extents)


def _thinned(vertices: np.ndarray) -> np.ndarray:
    """At most MAX_HULL_VERTICES of a hull's vertices: the outermost one along each of as many
    directions spread evenly over the sphere (a Fibonacci lattice), the six axis directions among
    them so that the bounding box stays the same. Their hull lies inside the original and touches
    it in every one of those directions."""
    count = MAX_HULL_VERTICES - 6
    k = np.arange(count) + 0.5
    polar = np.arccos(1 - 2 * k / count)
    turn = np.pi * (1 + 5**0.5) * k
    directions = np.vstack([np.eye(3), -np.eye(3), np.column_stack([
        np.cos(turn) * np.sin(polar), np.sin(turn) * np.sin(polar), np.cos(polar)])])
    # 64 directions at a time: all of them at once would be a (V, 1000) matrix, 150 MB at 19,000
    outermost = [np.argmax(block @ vertices.T, axis=1) for block in np.split(
        directions, range(64, len(directions), 64))]
    return vertices[np.unique(np.concatenate(outermost))]
