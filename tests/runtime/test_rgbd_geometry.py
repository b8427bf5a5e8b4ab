"""Point-cloud geometry of reconstruction, as properties: rectangles, planes, levelling, box
surfaces and outlier removal on random inputs with known answers."""

from __future__ import annotations

import math
import time

import numpy as np
from hypothesis import example, given, settings
from hypothesis import strategies as st

from rapid_dsl.runtime.reconstruction.geometry import (
    Rect,
    box_distance,
    convex_hull,
    horizontal_planes,
    level_rotation,
    main_clusters,
    min_area_rect,
    ransac_plane,
    refine_box,
    statistical_inliers,
    trimmed_rect,
)

SETTINGS = settings(max_examples=40, deadline=None)
yaws = st.floats(-math.pi, math.pi)
sides = st.floats(0.02, 1.0)
seeds = st.integers(0, 2**32 - 1)


def rectangle_points(centre, extents, yaw, count, rng, *, edge_only=False):
    local = rng.uniform(-0.5, 0.5, (count, 2)) * extents
    if edge_only:   # points on the outline only
        side = rng.integers(0, 2, count)
        local[np.arange(count), side] = np.sign(local[np.arange(count), side]) * \
            np.asarray(extents)[side] / 2
    c, s = math.cos(yaw), math.sin(yaw)
    return local @ np.array([[c, s], [-s, c]]) + centre


def same_rectangle(rect: Rect, extents, yaw, tolerance):
    """Equal up to quarter turns: a rectangle turned by 90 deg has its sides swapped."""
    quarters = round((rect.yaw - yaw) / (math.pi / 2))
    assert abs(rect.yaw - yaw - quarters * math.pi / 2) < 1e-6 + tolerance
    expected = np.array(extents)[[1, 0]] if quarters % 2 else np.array(extents)
    assert np.allclose(rect.extents, expected, atol=tolerance)
    assert -math.pi / 4 - 1e-9 <= rect.yaw < math.pi / 4 + 1e-9


@SETTINGS
@given(sides, sides, yaws, seeds)
def test_the_smallest_rectangle_of_a_rectangles_outline_is_that_rectangle(a, b, yaw, seed):
    rng = np.random.default_rng(seed)
    edge = rectangle_points((0.5, -0.2), (a, b), yaw, 400, rng, edge_only=True)
    local = np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]) * (a, b)
    c, s = math.cos(yaw), math.sin(yaw)
    corners = local @ np.array([[c, s], [-s, c]]) + (0.5, -0.2)
    rect = min_area_rect(np.vstack([edge, corners]))
    assert rect is not None
    same_rectangle(rect, (a, b), yaw, 1e-6)
    assert np.allclose(rect.centre, (0.5, -0.2), atol=1e-6)
    assert rect.contains(np.array([0.5, -0.2])) and not rect.contains(np.array([5.0, 5.0]))


@SETTINGS
@given(sides, sides, yaws, seeds)
def test_a_trimmed_rectangle_ignores_stray_points(a, b, yaw, seed):
    rng = np.random.default_rng(seed)
    inside = rectangle_points((0.0, 0.0), (a, b), yaw, 4000, rng)
    stray = rng.uniform(-3, 3, (4, 2))      # 0.1 %: less than the trimmed share per side
    rect = trimmed_rect(np.vstack([inside, stray]), 0.003)
    assert rect is not None
    assert (rect.extents <= np.hypot(a, b) + 1e-9).all()   # never reaches out to the strays
    assert (np.sort(rect.extents) >= 0.95 * np.sort([a, b]) - 0.002).all()


def test_degenerate_points_have_no_rectangle_or_hull():
    line = np.column_stack([np.linspace(0, 1, 10), np.linspace(0, 2, 10)])
    assert min_area_rect(line) is None and trimmed_rect(line, 0.01) is None
    assert convex_hull(np.column_stack([line, np.zeros(10)])) is None


@SETTINGS
@given(st.floats(-1, 1), st.floats(-0.1, 0.1), st.floats(-0.1, 0.1), seeds)   # tilt <= 8 deg
def test_ransac_finds_a_level_plane_among_outliers(height, tx, ty, seed):
    rng = np.random.default_rng(seed)
    normal = np.array([tx, ty, 1.0]) / np.linalg.norm([tx, ty, 1.0])
    xy = rng.uniform(-1, 1, (3000, 2))
    z = height - (normal[0] * xy[:, 0] + normal[1] * xy[:, 1]) / normal[2]
    plane_points = np.column_stack([xy, z + rng.normal(0, 0.001, 3000)])
    clutter = rng.uniform(-1, 1, (2000, 3)) + [0, 0, height]
    plane = ransac_plane(np.vstack([plane_points, clutter]), threshold=0.005,
                         max_tilt=math.radians(10), seed=seed % 1000)
    assert plane is not None
    assert np.degrees(np.arccos(min(1.0, plane.normal @ normal))) < 0.5
    assert abs(plane.height_at(np.zeros(2)) - height) < 0.002
    assert plane.inliers >= 2900


def test_only_level_planes_are_found_and_each_once():
    rng = np.random.default_rng(3)
    wall = np.column_stack([np.zeros(3000), rng.uniform(-1, 1, (3000, 2))])   # x = 0
    table = np.column_stack([rng.uniform(-1, 1, (3000, 2)), np.zeros(3000)])
    floor = np.column_stack([rng.uniform(-2, 2, (2000, 2)), np.full(2000, -0.75)])
    planes = horizontal_planes(np.vstack([wall, table, floor]), threshold=0.005,
                               max_tilt=math.radians(10), min_points=500)
    heights = sorted(p.height_at(np.zeros(2)) for p in planes)
    assert np.allclose(heights, [-0.75, 0.0], atol=1e-4)
    assert ransac_plane(wall, threshold=0.005, max_tilt=math.radians(10)) is None or \
        ransac_plane(wall, threshold=0.005, max_tilt=math.radians(10)).inliers < 100


@SETTINGS
@given(st.floats(-1, 1), st.floats(-1, 1), st.floats(0.05, 1))
def test_levelling_turns_a_normal_onto_z(x, y, z):
    normal = np.array([x, y, z]) / np.linalg.norm([x, y, z])
    rotation = level_rotation(normal)
    assert np.allclose(rotation @ normal, [0, 0, 1], atol=1e-9)
    assert np.allclose(rotation.T @ rotation, np.eye(3), atol=1e-9)
    assert math.isclose(np.linalg.det(rotation), 1.0, abs_tol=1e-9)


@SETTINGS
@given(sides, sides, st.floats(0.01, 0.5), yaws, seeds)
def test_box_surface_points_are_at_distance_zero_and_others_are_not(a, b, h, yaw, seed):
    rng = np.random.default_rng(seed)
    rect = Rect(np.array([0.3, 0.1]), np.array([a, b]), yaw)
    top = rectangle_points(rect.centre, (a, b), yaw, 200, rng)
    on_top = np.column_stack([top, np.full(200, h)])
    assert np.allclose(box_distance(on_top, rect, 0.0, h), 0, atol=1e-9)
    above = on_top + [0, 0, 0.05]
    assert np.allclose(box_distance(above, rect, 0.0, h), 0.05, atol=1e-9)
    centre = np.array([[0.3, 0.1, h / 2]])
    assert math.isclose(box_distance(centre, rect, 0.0, h)[0], min(a / 2, b / 2, h / 2),
                        rel_tol=1e-9)


@SETTINGS
@given(st.floats(0.05, 0.5), st.floats(0.05, 0.5), st.floats(0.02, 0.3), yaws, seeds)
def test_refined_faces_sit_on_noisy_points(a, b, h, yaw, seed):
    """Faces seen with noise move onto the points' medians; the top and two sides are seen."""
    rng = np.random.default_rng(seed)
    noise = 0.002
    top = np.column_stack([rectangle_points((0, 0), (a, b), yaw, 2000, rng), np.full(2000, h)])
    c, s = math.cos(yaw), math.sin(yaw)
    side_x = np.column_stack([np.full(800, a / 2), rng.uniform(-b / 2, b / 2, 800)])
    side_y = np.column_stack([rng.uniform(-a / 2, a / 2, 800), np.full(800, -b / 2)])
    sides_xy = np.vstack([side_x, side_y]) @ np.array([[c, s], [-s, c]])
    sides_points = np.column_stack([sides_xy, rng.uniform(0, h, 1600)])
    points = np.vstack([top, sides_points]) + rng.normal(0, noise, (3600, 3))
    start = Rect(np.zeros(2), np.array([a, b]) + 0.02, yaw)   # too large, as noise makes it
    rect, new_top = refine_box(points, start, 0.0, h + 0.01)
    assert abs(new_top - h) < noise
    low, high = start.local(rect.centre[None])[0] + np.array([[-1], [1]]) * rect.extents / 2
    assert np.allclose([high[0], low[1]], [a / 2, -b / 2], atol=noise)   # the seen sides
    assert np.allclose([low[0], high[1]], [-a / 2 - 0.01, b / 2 + 0.01], atol=1e-9)   # unseen


@SETTINGS
@given(seeds)
@example(250)   # a clump of 10 surface points whose 8 nearest neighbours are all in the clump
def test_outlier_removal_keeps_the_object_and_drops_strays(seed):
    rng = np.random.default_rng(seed)
    surface = np.column_stack([rng.uniform(0, 0.1, (3000, 2)), np.zeros(3000)])
    strays = rng.uniform(-1, 1, (30, 3)) + [0, 0, 2]
    points = np.vstack([surface, strays])
    kept = statistical_inliers(points)
    assert kept[:3000].mean() > 0.98 and not kept[3000:].any()
    clustered = main_clusters(points, 0.01)
    assert clustered[:3000].all() and not clustered[3000:].any()


def test_clustering_dense_points_costs_what_sparse_ones_do():
    """20,000 points within a millimetre (a mask on a far, tiny object, or a bad focal length)
    would be 200 million pairs within the radius: each point links to 8 neighbours only."""
    points = np.random.default_rng(0).normal(0, 1e-4, (20_000, 3))
    started = time.perf_counter()
    assert main_clusters(points, 0.005).all()
    assert time.perf_counter() - started < 10
