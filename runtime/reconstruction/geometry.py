"""Point-cloud geometry for reconstruction: outlier removal, RANSAC planes, oriented rectangles
and boxes, convex hulls. Plain numpy and scipy; every random choice comes from a seeded generator,
so the same frame always gives the same scene.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

UP = np.array([0.0, 0.0, 1.0])
SCORED = 10_000     # points a RANSAC hypothesis is scored on


def subsample(points: np.ndarray, limit: int, seed: int = 0) -> np.ndarray:
    """At most `limit` of the points, drawn without replacement (all of them if fewer)."""
    if len(points) <= limit:
        return points
    pick = np.random.default_rng(seed).choice(len(points), size=limit, replace=False)
    return points[np.sort(pick)]


def statistical_inliers(points: np.ndarray, neighbours: int = 16,
                        std_ratio: float = 3.0) -> np.ndarray:
    """Bool mask of the points whose mean distance to their nearest neighbours is at most the
    mean of those distances plus `std_ratio` standard deviations (flying pixels, speckle)."""
    from scipy.spatial import cKDTree

    if len(points) <= neighbours:
        return np.ones(len(points), dtype=bool)
    distances, _ = cKDTree(points).query(points, k=neighbours + 1)
    spread = distances[:, 1:].mean(axis=1)
    return np.asarray(spread <= spread.mean() + std_ratio * spread.std())


def main_clusters(points: np.ndarray, radius: float, keep: float = 0.25,
                  neighbours: int = 8) -> np.ndarray:
    """Bool mask of the points in the largest cluster of points chained within `radius`, and in
    any other cluster at least `keep` times its size (a part of the object cut off by an
    occluder stays; background seen through a mask's edge goes). Each point is linked to its
    `neighbours` nearest within `radius` only, so dense points cost no more than sparse ones."""
    from scipy.sparse import coo_matrix
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if len(points) < 2:
        return np.ones(len(points), dtype=bool)
    k = min(neighbours + 1, len(points))
    distances, nearest = cKDTree(points).query(points, k=k, distance_upper_bound=radius)
    linked = np.isfinite(distances[:, 1:])
    rows = np.repeat(np.arange(len(points)), k - 1)[linked.ravel()]
    graph = coo_matrix((np.ones(len(rows)), (rows, nearest[:, 1:][linked])),
                       shape=(len(points), len(points)))
    _, labels = connected_components(graph, directed=False)
    sizes = np.bincount(labels)
    kept = np.asarray(sizes[labels] >= keep * sizes.max())
    # A clump whose nearest neighbours all lie inside it is still chained to what is kept when
    # one of its points lies within `radius` of a kept point.
    while not kept.all():
        distance, _ = cKDTree(points[kept]).query(points[~kept], distance_upper_bound=radius)
        joined = np.unique(labels[~kept][np.isfinite(distance)])
        if len(joined) == 0:
            break
        kept |= np.isin(labels, joined)
    return kept


def spacing(points: np.ndarray) -> float:
    """The median distance from a point to its nearest neighbour."""
    from scipy.spatial import cKDTree

    if len(points) < 2:
        return 0.0
    distances, _ = cKDTree(points).query(points, k=2)
    return float(np.median(distances[:, 1]))


@dataclass(frozen=True, slots=True)
class Plane:
    """The plane n . p = offset, n a unit normal pointing up (n . z > 0)."""

    normal: np.ndarray
    offset: float
    inliers: int

    def distance(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points @ self.normal - self.offset)

    def height_at(self, xy: np.ndarray) -> float:
        """The plane's z above the world point (x, y)."""
        n = self.normal
        return float((self.offset - n[0] * xy[0] - n[1] * xy[1]) / n[2])

    @property
    def tilt(self) -> float:
        """Angle between the normal and world z [rad]."""
        return math.acos(min(1.0, float(self.normal @ UP)))


def ransac_plane(points: np.ndarray, *, threshold: float, max_tilt: float, iterations: int = 400,
                 seed: int = 0) -> Plane | None:
    """The plane through the most points (within `threshold`) among planes tilted at most
    `max_tilt` [rad] from horizontal, refined by least squares on its inliers; None if fewer
    than 3 points or no sampled plane is that level."""
    if len(points) < 3:
        return None
    rng = np.random.default_rng(seed)
    triples = points[rng.integers(0, len(points), size=(iterations, 3))]
    normals = np.cross(triples[:, 1] - triples[:, 0], triples[:, 2] - triples[:, 0])
    lengths = np.linalg.norm(normals, axis=1)
    good = lengths > 1e-12
    normals = normals[good] / lengths[good, None]
    normals *= np.where(normals[:, 2] < 0, -1.0, 1.0)[:, None]
    level = normals[:, 2] >= math.cos(max_tilt)
    normals, anchors = normals[level], triples[good][level][:, 0]
    if not len(normals):
        return None
    offsets = np.einsum("ij,ij->i", normals, anchors)
    # hypotheses are scored on a random share of the points, the best one refined on all
    scored = points[rng.choice(len(points), size=min(len(points), SCORED), replace=False)]
    counts = np.concatenate([
        (np.abs(scored @ normals[i:i + 32].T - offsets[i:i + 32]) < threshold).sum(axis=0)
        for i in range(0, len(normals), 32)])
    best = int(np.argmax(counts))
    plane = Plane(normals[best], float(offsets[best]), 0)
    plane = Plane(plane.normal, plane.offset, int((np.abs(plane.distance(points)) < threshold)
                                                  .sum()))
    for _ in range(3):   # least squares on the inliers, then the inliers of that plane
        near = points[np.abs(plane.distance(points)) < threshold]
        if len(near) < 3:
            break
        centre = near.mean(axis=0)
        normal = np.linalg.svd(near - centre, full_matrices=False)[2][2]
        normal = normal if normal[2] > 0 else -normal
        if normal[2] < math.cos(max_tilt):
            break
        plane = Plane(normal, float(normal @ centre), len(near))
    return plane


def horizontal_planes(points: np.ndarray, *, threshold: float, max_tilt: float,
                      min_points: int, limit: int = 4, seed: int = 0) -> list[Plane]:
    """Up to `limit` level planes found one after another by RANSAC, each with at least
    `min_points` inliers, the inliers of each removed before the next is sought."""
    planes: list[Plane] = []
    rest = points
    for index in range(limit):
        plane = ransac_plane(rest, threshold=threshold, max_tilt=max_tilt, seed=seed + index)
        if plane is None or plane.inliers < min_points:
            break
        planes.append(plane)
        rest = rest[np.abs(plane.distance(rest)) >= 2 * threshold]
    return planes


def level_rotation(normal: np.ndarray) -> np.ndarray:
    """The smallest rotation taking the unit vector `normal` to world z."""
    axis = np.cross(normal, UP)
    sine, cosine = float(np.linalg.norm(axis)), float(normal @ UP)
    if sine < 1e-12:
        return np.eye(3)
    k = axis / sine
    cross = np.array([[0, -k[2], k[1]], [k[2], 0, -k[0]], [-k[1], k[0], 0]])
    return np.asarray(np.eye(3) + sine * cross + (1 - cosine) * cross @ cross)


@dataclass(frozen=True, slots=True)
class Rect:
    """An oriented rectangle in the xy plane: centre, full extents along its own axes, yaw."""

    centre: np.ndarray   # (2,)
    extents: np.ndarray  # (2,)
    yaw: float           # rad, in [-pi/4, pi/4)

    def local(self, xy: np.ndarray) -> np.ndarray:
        """Points in the rectangle's own axes, relative to its centre."""
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        d = xy - self.centre
        return np.stack([c * d[:, 0] + s * d[:, 1], -s * d[:, 0] + c * d[:, 1]], axis=1)

    def contains(self, xy: np.ndarray, margin: float = 0.0) -> bool:
        return bool((np.abs(self.local(np.atleast_2d(xy))) <= self.extents / 2 + margin).all())


def min_area_rect(xy: np.ndarray) -> Rect | None:
    """The smallest-area rectangle around 2-D points (one side lies along a hull edge); None if
    the points span no area."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = xy[ConvexHull(xy).vertices]
    except (QhullError, ValueError):
        return None
    edges = np.diff(np.vstack([hull, hull[:1]]), axis=0)
    angles = np.unique(np.mod(np.arctan2(edges[:, 1], edges[:, 0]), math.pi / 2))
    best: tuple[float, Rect] | None = None
    for angle in angles:
        c, s = math.cos(angle), math.sin(angle)
        local = hull @ np.array([[c, -s], [s, c]])   # rows: (x c + y s, -x s + y c)
        lo, hi = local.min(axis=0), local.max(axis=0)
        area = float(np.prod(hi - lo))
        if best is None or area < best[0] - 1e-15:
            mid = (lo + hi) / 2
            centre = np.array([c * mid[0] - s * mid[1], s * mid[0] + c * mid[1]])
            extents, yaw = hi - lo, float(angle)
            if yaw >= math.pi / 4:   # the same rectangle turned a quarter back
                yaw, extents = yaw - math.pi / 2, extents[::-1]
            best = (area, Rect(centre, np.array(extents, dtype=float), yaw))
    return best[1] if best else None


def trimmed_rect(xy: np.ndarray, trim: float) -> Rect | None:
    """The smallest-area rectangle's orientation, with sides that leave out a share `trim` of
    the points beyond each of them (noise and stray points do not widen it); None if the points
    span no area."""
    rect = min_area_rect(xy)
    if rect is None:
        return None
    # stray points turn the smallest rectangle: find it again without what the trim cuts off
    lo, hi = np.percentile(rect.local(xy), [100 * trim, 100 * (1 - trim)], axis=0)
    local = rect.local(xy)
    rect = min_area_rect(xy[((local >= lo) & (local <= hi)).all(axis=1)]) or rect
    lo, hi = np.percentile(rect.local(xy), [100 * trim, 100 * (1 - trim)], axis=0)
    mid = (lo + hi) / 2
    c, s = math.cos(rect.yaw), math.sin(rect.yaw)
    centre = rect.centre + np.array([c * mid[0] - s * mid[1], s * mid[0] + c * mid[1]])
    return Rect(centre, np.asarray(hi - lo, dtype=float), rect.yaw)


def refine_box(points: np.ndarray, rect: Rect, bottom: float, top: float, *,
               min_share: float = 0.05, rounds: int = 2) -> tuple[Rect, float]:
    """Each seen face of the upright box moved to the median of the points nearest to it (so
    noise does not push it out); a face with fewer than `min_share` of the points (an unseen
    side) stays where it is. The bottom stays on the support."""
    for _ in range(rounds):
        local = rect.local(points[:, :2])
        half = rect.extents / 2
        lo, hi = -half.copy(), half.copy()
        gaps = np.column_stack([np.abs(local[:, 0] - hi[0]), np.abs(local[:, 0] - lo[0]),
                                np.abs(local[:, 1] - hi[1]), np.abs(local[:, 1] - lo[1]),
                                np.abs(points[:, 2] - top)])
        nearest = gaps.argmin(axis=1)
        enough = max(10, int(min_share * len(points)))
        for face, (axis, side) in enumerate(((0, hi), (0, lo), (1, hi), (1, lo))):
            near = nearest == face
            if near.sum() >= enough:
                side[axis] = float(np.median(local[near, axis]))
        if (nearest == 4).sum() >= enough:
            top = max(float(np.median(points[nearest == 4, 2])), bottom + 1e-3)
        if (hi - lo <= 1e-3).any():
            break
        mid = (lo + hi) / 2
        c, s = math.cos(rect.yaw), math.sin(rect.yaw)
        rect = Rect(rect.centre + np.array([c * mid[0] - s * mid[1], s * mid[0] + c * mid[1]]),
                    hi - lo, rect.yaw)
    return rect, top


def box_distance(points: np.ndarray, rect: Rect, bottom: float, top: float) -> np.ndarray:
    """Unsigned distance of each point to the surface of the upright box over `rect` from z =
    `bottom` to `top`."""
    local = np.column_stack([rect.local(points[:, :2]), points[:, 2] - (bottom + top) / 2])
    half = np.append(rect.extents / 2, (top - bottom) / 2)
    excess = np.abs(local) - half
    outside = np.linalg.norm(np.maximum(excess, 0.0), axis=1)
    return np.asarray(np.where(excess.max(axis=1) > 0, outside, -excess.max(axis=1)))


@dataclass(frozen=True, slots=True)
class Hull:
    vertices: np.ndarray   # (V, 3)
    faces: np.ndarray      # (F, 3) int, counter-clockwise seen from outside
    volume: float


def convex_hull(points: np.ndarray) -> Hull | None:
    """The 3-D convex hull with outward-wound faces; None if the points span no volume."""
    from scipy.spatial import ConvexHull, QhullError

    try:
        hull = ConvexHull(points)
    except (QhullError, ValueError):
        return None
    index = np.full(len(points), -1, dtype=np.int64)
    index[hull.vertices] = np.arange(len(hull.vertices))
    vertices = points[hull.vertices]
    faces = index[hull.simplices]
    a, b, c = (vertices[faces[:, k]] for k in range(3))
    inward = np.einsum("ij,ij->i", np.cross(b - a, c - a), hull.equations[:, :3]) < 0
    faces[inward] = faces[inward][:, ::-1]
    return Hull(vertices, faces, float(hull.volume))
