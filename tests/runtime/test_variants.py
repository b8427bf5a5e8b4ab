"""Scene variants: seeded, bounded, and only movable objects change."""

import math

import pytest

from rapid_dsl.runtime.scene import load_scene
from rapid_dsl.runtime.variants import VariantRanges, sample_variants

SCENE = "examples/scenes/push_box.yaml"


def test_variants_are_reproducible_and_differ_by_index():
    scene = load_scene(SCENE)
    first = sample_variants(scene, 3, seed=7)
    again = sample_variants(scene, 3, seed=7)
    assert [v.scene for v in first] == [v.scene for v in again]
    assert first[0].scene != first[1].scene
    assert sample_variants(scene, 1, seed=8)[0].scene != first[0].scene


def test_only_objects_move_and_stay_within_the_ranges():
    scene = load_scene(SCENE)
    ranges = VariantRanges(position=0.01, yaw=math.radians(5), size=0.1, mass=0.2, friction=0.2)
    base = scene.object("box")
    for variant in sample_variants(scene, 10, seed=3, ranges=ranges):
        assert variant.scene.object("table") == scene.object("table")
        box = variant.scene.object("box")
        assert abs(box.pose.position[0] - base.pose.position[0]) <= 0.01
        assert abs(box.pose.yaw - base.pose.yaw) <= math.radians(5) + 1e-12
        for new, old in zip(box.extents, base.extents, strict=True):
            assert 0.9 * old - 1e-12 <= new <= 1.1 * old + 1e-12
        # The box still rests on the table top (z = 0): its bottom did not move.
        assert box.pose.position[2] - box.extents[2] / 2 == pytest.approx(0.0, abs=1e-12)
        assert 0.8 * base.mass <= box.mass <= 1.2 * base.mass
        assert variant.describe()["objects"][0]["name"] == "box"
