"""One RGB-D frame with object masks -> the support, and per object a box or a convex mesh.

The pipeline (docs/reconstruction.md):
1. back-project every pixel that has a depth to world points (rgbd.back_project);
2. per mask, drop outliers: statistical (mean distance to the 16 nearest neighbours beyond
   3 standard deviations) and by radius (clusters chained within 3 point spacings; the largest
   stays, with any other a quarter of its size or more);
3. find level planes among the pixels outside every mask by RANSAC (within 10 deg of world z,
   6 mm): the support is the highest one under any object, the floor the lowest one at least
   5 cm below it; the world is levelled so that the support's measured normal is exactly z;
4. the support becomes a static Surface box: its top the plane, its outline the smallest
   rectangle around the plane's visible part, down to the floor (or 0.75 m when none is seen);
5. per object (lowest first), its support is the highest of the support, the floor and the
   objects under it that lies below its lowest point; a camera sees only its front, so the
   object is completed down to its support: its footprint is the smallest rectangle around its
   points seen from above (each side leaving out 0.3 % of them), its yaw
   that rectangle's, its top the 99.7th percentile of its heights. It is a box when the box
   explains the points: the camera saw through at most 2 % of a grid inside that box (a
   cylinder's corners are empty), and once each seen face is moved onto the median of the points
   nearest it, 90 % of the points lie within 3 mm (or 3 % of its smallest side, or 3 standard
   deviations of the depth noise measured on the support) of its surface. Otherwise it is the
   convex hull of its points and their footprint on the support, a mesh.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from rapid_dsl.language.limits import WORKSPACE
from rapid_dsl.runtime.reconstruction.geometry import (
    Hull,
    Plane,
    Rect,
    box_distance,
    convex_hull,
    horizontal_planes,
    level_rotation,
    main_clusters,
    min_area_rect,
    refine_box,
    spacing,
    statistical_inliers,
    subsample,
    trimmed_rect,
)
from rapid_dsl.runtime.reconstruction.rgbd import Frame, RgbdError, back_project, problem
from rapid_dsl.runtime.scenes.schema import MASS_RANGE, SIZE_RANGE

MAX_WORK_PIXELS = 1_310_720      # 1280 x 1024; larger frames are reconstructed strided
MAX_BACKGROUND_POINTS = 60_000   # RANSAC sample of the pixels outside the masks
MAX_OBJECT_POINTS = 20_000       # per object
MAX_HULL_POINTS = 4_000          # points a mesh's hull is computed from
PLANE_THRESHOLD = 0.006          # m: a point this close to a plane is on it
MAX_TILT = math.radians(10)      # a support is within this of level
MIN_PLANE_FRACTION = 0.02        # a plane holds at least this share of the sampled pixels
MIN_PLANE_POINTS = 200
SUPPORT_TOLERANCE = 0.01         # m: a support lies at most this far above an object's bottom
FLOOR_GAP = 0.05                 # m: a floor lies at least this far below the support
TABLE_HEIGHT = 0.75              # m: how far the support reaches down when no floor is seen
BAND = 0.003                     # m: points this close above a support belong to it
MIN_POINTS = 20                  # an object needs this many points once outliers are gone
BOX_FREE = 0.02                  # at most this share of a box's inside may be seen through
FREE_TOLERANCE = 0.005           # m: a depth this far beyond a point sees through it
BOX_SURFACE = 0.90               # share of points near the box's surface, for a box
BOX_TOLERANCE = 0.003            # m, or BOX_TOLERANCE_SHARE of the smallest side if larger
BOX_TOLERANCE_SHARE = 0.03
TRIM = 0.003                     # share of an object's points left out beyond each side
NOISE_TOLERANCE = 3.0            # sigmas of depth noise a point may lie off a box's surface
DENSITY = 400.0                  # kg/m^3 for masses labels.json does not give
SUPPORT_NAME = "table"


@dataclass(frozen=True)
class SupportFit:
    name: str
    height: float           # z of the plane after levelling [m]
    tilt: float             # how far the measured plane was from level [rad]
    rect: Rect              # outline of its visible part (clamped to the size limit)
    thickness: float        # down to the floor [m]
    floor_height: float
    floor_seen: bool
    inliers: int            # pixels on the plane
    noise: float            # depth noise along the camera's rays, measured on it [m]


@dataclass(frozen=True)
class ObjectFit:
    name: str
    kind: str
    label: str
    shape: str              # box | mesh
    position: np.ndarray    # (3,) centre of the extents, world [m]
    yaw: float              # about the support normal (world z) [rad]
    extents: np.ndarray     # (3,) full size along the object's axes [m]
    mass: float | None
    friction: float | None
    rgba: tuple[float, float, float, float]
    rests_on: str           # the support's name, `floor` or another object's
    points: int             # points the fit used
    outliers: int           # points removed as outliers
    free: float             # share of the box's inside the camera saw through
    surface: float          # share of points near the box's surface
    hull: Hull | None       # for a mesh: vertices in the object's frame


class _View:
    """The camera as it saw the levelled world: which levelled points it saw through."""

    def __init__(self, frame: Frame, pivot: np.ndarray, rotation: np.ndarray):
        from scipy import ndimage

        self.frame, self.pivot, self.rotation = frame, pivot, rotation   # world -> levelled
        # a 3 x 3 median: one stray depth does not make a box's inside look empty; no
        # measurement counts as near (it sees through nothing)
        self.depth = ndimage.median_filter(np.nan_to_num(frame.depth, nan=0.0), size=3)

    def seen_through(self, points: np.ndarray, tolerance: float) -> np.ndarray:
        """Bool per levelled point: the camera measured a depth more than `tolerance` beyond it
        (so it is empty space), where it projects into the image."""
        world = (points - self.pivot) @ self.rotation + self.pivot
        pose = self.frame.camera_to_world
        camera = (world - pose[:3, 3]) @ pose[:3, :3]
        k = self.frame.intrinsics
        z = camera[:, 2]
        ahead = z > 1e-6
        u = np.full(len(points), -1.0)
        v = np.full(len(points), -1.0)
        u[ahead] = np.rint(camera[ahead, 0] / z[ahead] * k.fx + k.cx)
        v[ahead] = np.rint(camera[ahead, 1] / z[ahead] * k.fy + k.cy)
        inside = ahead & (u >= 0) & (u < k.width) & (v >= 0) & (v < k.height)
        beyond = np.zeros(len(points), dtype=bool)
        measured = self.depth[v[inside].astype(int), u[inside].astype(int)]
        beyond[inside] = measured > z[inside] + tolerance
        return beyond


@dataclass(frozen=True)
class Reconstruction:
    support: SupportFit
    objects: tuple[ObjectFit, ...]
    notes: tuple[str, ...]  # what was adjusted: the scene format's limits, a strided frame


def reconstruct(frame: Frame) -> Reconstruction:
    """The support and every masked object of a frame; RgbdError for a frame that does not
    give one (a mask without depth, no level plane under the objects, an object too large)."""
    notes: list[str] = []
    step = math.ceil(math.sqrt(frame.depth.size / MAX_WORK_PIXELS))
    if step > 1:   # time and memory grow with the pixels; the object points are sampled anyway
        frame = frame.strided(step)
        notes.append(f"the frame was reconstructed from one pixel in {step} in each "
                     f"direction (at most {MAX_WORK_PIXELS:,} pixels)")
    clouds = {name: _object_points(frame, name) for name in frame.masks}
    centre = np.vstack([points for points, _ in clouds.values()]).mean(axis=0)
    background = ~np.logical_or.reduce(list(frame.masks.values()))
    rows, cols = np.nonzero(np.isfinite(frame.depth) & background)
    ground = back_project(frame, background)
    sample = subsample(ground, MAX_BACKGROUND_POINTS)
    planes = horizontal_planes(sample, threshold=PLANE_THRESHOLD, max_tilt=MAX_TILT,
                               min_points=max(MIN_PLANE_POINTS,
                                              int(MIN_PLANE_FRACTION * len(sample))))
    bottoms = [_bottom(points) for points, _ in clouds.values()]
    support = _support_plane(frame, planes, centre, max(bottoms), len(sample))
    # level the world: the support's normal becomes z, about the point under the objects
    pivot = np.array([centre[0], centre[1], support.height_at(centre[:2])])
    rotation = level_rotation(support.normal)

    def level(points: np.ndarray) -> np.ndarray:
        return np.asarray((points - pivot) @ rotation.T + pivot)

    height = float(pivot[2])
    on_plane = np.abs(support.distance(ground)) < PLANE_THRESHOLD
    floors = [plane for plane in planes
              if plane.height_at(centre[:2]) < height - FLOOR_GAP]
    floor = min(floors, key=lambda p: p.height_at(centre[:2])) if floors else None
    floor_height = height - TABLE_HEIGHT
    if floor is not None:
        floor_height = float(np.median(level(ground[np.abs(floor.distance(ground))
                                                    < PLANE_THRESHOLD])[:, 2]))
    noise = _noise(frame, support, ground[on_plane])
    levelled = {name: (level(points), removed) for name, (points, removed) in clouds.items()}
    on_support = [points for points, _ in levelled.values()
                  if _bottom(points) >= height - SUPPORT_TOLERANCE]    # not those on the floor
    standing = np.vstack(on_support or [points for points, _ in levelled.values()])
    table = _support_fit(frame, level(ground[on_plane]), rows[on_plane], cols[on_plane],
                         standing, height, floor_height, floor is not None, support.tilt, noise,
                         notes)
    objects = _objects(_View(frame, pivot, rotation), levelled, table, notes)
    return Reconstruction(table, objects, tuple(notes))


def _bottom(points: np.ndarray) -> float:
    """An object's lowest height, ignoring the lowest 2 % of its points."""
    return float(np.percentile(points[:, 2], 2))


def _noise(frame: Frame, plane: Plane, points: np.ndarray) -> float:
    """The depth noise along the camera's rays [m], from the support's points: a robust
    deviation (the plane's band also holds the tops of its sides) of their distances to the
    plane, divided by how squarely each ray meets it."""
    rays = points - frame.camera_to_world[:3, 3]
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    squareness = np.maximum(np.abs(rays @ plane.normal), 0.1)
    return 1.4826 * float(np.median(np.abs(plane.distance(points)) / squareness))


def _object_points(frame: Frame, name: str) -> tuple[np.ndarray, int]:
    """An object's world points without outliers, and how many were removed."""
    where = frame.mask_file(name)
    mask = frame.masks[name]
    points = back_project(frame, mask)
    if not mask.any():   # a mask of a few pixels, lost to striding a large frame
        raise problem(where, f"the mask is too small for this frame's {frame.shape[1]}x"
                             f"{frame.shape[0]} pixels once strided")
    if not len(points):
        raise problem(where, f"none of the mask's {int(mask.sum())} pixels has a depth "
                             "measurement")
    points = subsample(points, MAX_OBJECT_POINTS)
    kept = points[statistical_inliers(points)]
    kept = kept[main_clusters(kept, max(0.005, 3 * spacing(kept)))]
    if len(kept) < MIN_POINTS:
        raise problem(where, f"too few depth points: {len(kept)} of the mask's pixels remain "
                             f"once outliers are removed, at least {MIN_POINTS} are needed")
    return kept, len(points) - len(kept)


def _support_plane(frame: Frame, planes: list[Plane], centre: np.ndarray, bottom: float,
                   sampled: int) -> Plane:
    """The highest level plane under any object: below the highest of their lowest points
    (objects lower down stand on the floor)."""
    where = frame.files.get("depth", "depth")
    if not sampled:
        raise problem(where, "no support plane found: no pixel outside the masks has a depth "
                             "measurement; the support must be visible around the objects")
    if not planes:
        raise problem(where, f"no support plane found: no level plane (within "
                             f"{math.degrees(MAX_TILT):.0f}deg of world z) holds "
                             f"{MIN_PLANE_FRACTION:.0%} of the {sampled} sampled pixels outside "
                             "the masks; the support must be visible around the objects, and "
                             "the extrinsics must be camera-to-world with OpenCV axes")
    under = [p for p in planes if p.height_at(centre[:2]) <= bottom + SUPPORT_TOLERANCE]
    if not under:
        heights = ", ".join(f"{p.height_at(centre[:2]):.3f}" for p in planes)
        raise problem(where, f"no support plane under the objects: the level planes found "
                             f"(z = {heights} m) lie above every object's lowest point (the "
                             f"highest at z = {bottom:.3f} m)")
    return max(under, key=lambda p: p.height_at(centre[:2]))


def _support_fit(frame: Frame, points: np.ndarray, rows: np.ndarray, cols: np.ndarray,
                 objects: np.ndarray, height: float, floor_height: float, floor_seen: bool,
                 tilt: float, noise: float, notes: list[str]) -> SupportFit:
    """The support's outline: the smallest rectangle around the plane's largest connected
    pieces in the image (a farther table in the same plane is not this one)."""
    from scipy import ndimage

    image = np.zeros(frame.shape, dtype=bool)
    image[rows, cols] = True
    labels, count = ndimage.label(image, structure=np.ones((3, 3)))
    sizes = np.bincount(labels[rows, cols], minlength=count + 1)
    keep = sizes[labels[rows, cols]] >= 0.25 * sizes[1:].max()
    outline = np.vstack([points[keep][:, :2], objects[:, :2]])  # objects stand on it
    rect = min_area_rect(subsample(outline, 200_000))
    if rect is None:
        raise problem(frame.files.get("depth", "depth"), "the support plane spans no area")
    rect = _clamp_rect(rect, objects[:, :2].mean(axis=0), notes)
    thickness = height - floor_height
    lo, hi = SIZE_RANGE
    if not lo <= thickness <= hi:
        thickness = min(max(thickness, lo), hi)
        notes.append(f"the support reaches {thickness:.3f} m down (the size limit), not to the "
                     f"floor {height - floor_height:.3f} m below it")
    return SupportFit(SUPPORT_NAME, height, tilt, rect, thickness, floor_height, floor_seen,
                      int(len(points)), noise)


def _clamp_rect(rect: Rect, focus: np.ndarray, notes: list[str]) -> Rect:
    """A rectangle within the size limit: a side longer than 2 m is cut to 2 m around the
    objects' centre (kept inside the rectangle)."""
    lo, hi = SIZE_RANGE
    if (rect.extents <= hi).all() and (rect.extents >= lo).all():
        return rect
    local = rect.local(focus[None])[0]
    extents = np.clip(rect.extents, lo, hi)
    room = np.maximum(rect.extents - extents, 0) / 2
    shift = np.clip(local, -room, room)
    c, s = math.cos(rect.yaw), math.sin(rect.yaw)
    centre = rect.centre + np.array([c * shift[0] - s * shift[1], s * shift[0] + c * shift[1]])
    notes.append(f"the support's visible outline ({rect.extents[0]:.2f} x "
                 f"{rect.extents[1]:.2f} m) is cut to the size limits around the objects")
    return Rect(centre, extents, rect.yaw)


def _objects(view: _View, clouds: dict[str, tuple[np.ndarray, int]], table: SupportFit,
             notes: list[str]) -> tuple[ObjectFit, ...]:
    """Fit every object, lowest first, so that one resting on another finds it. An object
    rests on the highest of the support, the floor (if seen) and the objects under it that lies
    below its lowest point."""
    bottoms = {name: _bottom(points) for name, (points, _) in clouds.items()}
    levels = [(table.name, table.height)] + ([("floor", table.floor_height)]
                                             if table.floor_seen else [])
    fitted: dict[str, ObjectFit] = {}
    for name in sorted(clouds, key=lambda n: (bottoms[n], n)):
        points, removed = clouds[name]
        under = [level for level in levels if level[1] <= bottoms[name] + SUPPORT_TOLERANCE]
        if not under:
            raise problem(view.frame.mask_file(name),
                          f"the object lies below the support (its lowest point is at z = "
                          f"{bottoms[name]:.3f} m, the support at {table.height:.3f} m)")
        below = max(under, key=lambda level: level[1])
        middle = points[:, :2].mean(axis=0)
        for other in fitted.values():
            top = float(other.position[2] + other.extents[2] / 2)
            footprint = Rect(other.position[:2], other.extents[:2], other.yaw)
            if top > below[1] and top <= bottoms[name] + SUPPORT_TOLERANCE \
                    and footprint.contains(middle):
                below = other.name, top
        fitted[name] = _fit(view, name, points, removed, below, table.noise, notes)
    return tuple(fitted[name] for name in view.frame.masks)


def _fit(view: _View, name: str, points: np.ndarray, removed: int, support: tuple[str, float],
         noise: float, notes: list[str]) -> ObjectFit:
    frame = view.frame
    where = frame.mask_file(name)
    base = support[1]
    points = points[points[:, 2] > base + BAND]
    if len(points) < MIN_POINTS:
        raise problem(where, f"the object lies flat on `{support[0]}`: fewer than {MIN_POINTS} "
                             f"of its points are more than {BAND * 1000:.0f} mm above it")
    rect = trimmed_rect(points[:, :2], TRIM)
    if rect is None:
        raise problem(where, "the object's points span no area seen from above")
    top = max(float(np.percentile(points[:, 2], 100 * (1 - TRIM))), base + BAND)
    tolerance = max(BOX_TOLERANCE, BOX_TOLERANCE_SHARE * min(*rect.extents, top - base),
                    NOISE_TOLERANCE * noise)
    # the box around the points must be filled (a cylinder's corners are seen through) ...
    free = float(view.seen_through(_inside(rect, base, top, tolerance),
                                   max(FREE_TOLERANCE, NOISE_TOLERANCE * noise)).mean())
    # ... and its faces, moved onto the points (noisy extremes lie beyond them), near them
    bounds, ceiling = rect, top
    rect, top = refine_box(points, rect, base, top)
    surface = float((box_distance(points, rect, base, top) <= tolerance).mean())
    is_box = free <= BOX_FREE and surface >= BOX_SURFACE
    hull = None
    position = np.array([rect.centre[0], rect.centre[1], (base + top) / 2])
    extents = np.append(rect.extents, top - base)
    if not is_box:   # the stray points the trimmed bounds leave out are left out here too
        local = bounds.local(points[:, :2])
        kept = (np.abs(local) <= bounds.extents / 2 + tolerance).all(axis=1) \
            & (points[:, 2] <= ceiling + tolerance)
        hull, position, extents = _mesh(where, points[kept], bounds, base)
    extents = _sizes(where, name, extents, notes)
    if np.abs(position).max() > WORKSPACE:
        raise problem(where, f"the object is at {np.round(position, 3).tolist()}, outside the "
                             f"scene's workspace of +-{WORKSPACE:g} m (check the extrinsics)")
    info = frame.info.get(name)
    kind = (info.kind if info else None) or "object"
    mass = info.mass if info else None
    if kind == "object" and mass is None:
        volume = hull.volume if hull is not None else float(np.prod(extents))
        mass = float(np.clip(DENSITY * volume, *MASS_RANGE))
    colour = np.median(frame.rgb[frame.masks[name]], axis=0) / 255.0
    return ObjectFit(name, kind, (info.label if info else None) or name.replace("_", " "),
                     "box" if is_box else "mesh", position, rect.yaw, extents,
                     mass if kind == "object" else None, info.friction if info else None,
                     (*(round(float(c), 3) for c in colour), 1.0),  # type: ignore[arg-type]
                     support[0], len(points), removed, free, surface, hull)


def _inside(rect: Rect, bottom: float, top: float, margin: float) -> np.ndarray:
    """A 12 x 12 x 6 grid of levelled points filling the upright box over `rect`, `margin`
    inside its faces."""
    half = np.maximum(np.append(rect.extents / 2, (top - bottom) / 2) - margin, 0.0)
    axes = [np.linspace(-h, h, n) for h, n in zip(half, (12, 12, 6), strict=True)]
    local = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    c, s = math.cos(rect.yaw), math.sin(rect.yaw)
    return np.column_stack([rect.centre[0] + c * local[:, 0] - s * local[:, 1],
                            rect.centre[1] + s * local[:, 0] + c * local[:, 1],
                            (bottom + top) / 2 + local[:, 2]])


def _mesh(where: str, points: np.ndarray, rect: Rect, base: float
          ) -> tuple[Hull, np.ndarray, np.ndarray]:
    """The convex hull of the points and their footprint on the support, in the object's frame
    (axes along the footprint rectangle, origin at the centre of its extents)."""
    seen = subsample(points, MAX_HULL_POINTS // 2)
    footprint = np.column_stack([seen[:, :2], np.full(len(seen), base)])
    cloud = np.vstack([seen, footprint])
    local = np.column_stack([rect.local(cloud[:, :2]), cloud[:, 2]])
    hull = convex_hull(local)
    if hull is None:
        raise problem(where, "the object's points span no volume")
    lo, hi = hull.vertices.min(axis=0), hull.vertices.max(axis=0)
    middle = (lo + hi) / 2
    c, s = math.cos(rect.yaw), math.sin(rect.yaw)
    position = np.array([rect.centre[0] + c * middle[0] - s * middle[1],
                         rect.centre[1] + s * middle[0] + c * middle[1], middle[2]])
    return Hull(hull.vertices - middle, hull.faces, hull.volume), position, hi - lo


def _sizes(where: str, name: str, extents: np.ndarray, notes: list[str]) -> np.ndarray:
    lo, hi = SIZE_RANGE
    if (extents > hi).any():
        raise problem(where, f"the object is {' x '.join(f'{e:.2f}' for e in extents)} m, "
                             f"larger than the scene limit of {hi:g} m per side (is the mask "
                             "right?)")
    if (extents < lo).any():
        notes.append(f"`{name}` is thinner than {lo * 1000:g} mm ("
                     f"{' x '.join(f'{e * 1000:.1f}' for e in extents)} mm): widened to the "
                     "size limit")
        extents = np.maximum(extents, lo)
    return extents


__all__ = ["ObjectFit", "Reconstruction", "RgbdError", "SupportFit", "reconstruct"]
