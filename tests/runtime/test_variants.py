"""Scene variants: seeded, bounded, resting on their supports, clear of each other, and valid
scene files for both robots; ranges files report problems at their lines."""

from __future__ import annotations

import math
from pathlib import Path

import mujoco
import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rapid_dsl.runtime.scenes.scene import SceneError, load_scene, parse_scene, to_yaml
from rapid_dsl.runtime.scenes.schema import RESTITUTION_RANGE
from rapid_dsl.runtime.scenes.world import build_world
from rapid_dsl.runtime.variants.geometry import Solid, supports
from rapid_dsl.runtime.variants.ranges import (
    DistractorRanges,
    Ranges,
    parse_ranges,
)
from rapid_dsl.runtime.variants.sampler import (
    VariantError,
    VariantRanges,
    VariantSampler,
    sample_variant,
    sample_variants,
)

SCENE = "examples/scenes/push_box.yaml"
EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"

# A table with a platform on it, a wall, a box with a block on top, a can, a ball and a mesh prism.
STACKED = """\
robot: {robot}
floor_height: -0.75
gripper_start: {{position: [0.30, 0.0, 0.25]}}
objects:
  - {{name: table, kind: surface, shape: box, size: [1.0, 1.2, 0.75],
     pose: {{position: [0.55, 0.0, -0.375]}}}}
  - {{name: platform, kind: surface, shape: box, size: [0.2, 0.2, 0.04],
     pose: {{position: [0.8, 0.35, 0.02]}}}}
  - {{name: wall, kind: fixture, shape: box, size: [0.04, 0.4, 0.1],
     pose: {{position: [0.9, -0.1, 0.05]}}}}
  - {{name: box, kind: object, shape: box, size: [0.16, 0.12, 0.04],
     pose: {{position: [0.55, -0.15, 0.02], yaw: 0.3}}, mass: 0.3}}
  - {{name: block, kind: object, shape: box, size: [0.05, 0.05, 0.05],
     pose: {{position: [0.55, -0.15, 0.065]}}, mass: 0.1}}
  - {{name: can, kind: object, shape: cylinder, size: [0.06, 0.1],
     pose: {{position: [0.45, 0.2, 0.05]}}, mass: 0.2, restitution: 0.2}}
  - {{name: ball, kind: object, shape: sphere, size: 0.04,
     pose: {{position: [0.7, 0.1, 0.02]}}, mass: 0.05}}
  - {{name: prism, kind: object, shape: mesh, mesh: prism.obj, size: [0.06, 0.06, 0.08],
     pose: {{position: [0.8, 0.35, 0.08]}}, mass: 0.15}}
"""


def write_prism(path: Path) -> Path:
    """A hexagonal prism standing on a flat face (a mesh that rests like a box does)."""
    angles = np.arange(6) * math.pi / 3
    ring = [(math.cos(a), math.sin(a)) for a in angles]
    vertices = [(x, y, z) for z in (0.0, 1.0) for x, y in ring]
    faces = [(1, 2 + i, 3 + i) for i in range(4)] + [(7, 9 + i, 8 + i) for i in range(4)]
    for i in range(6):
        j = (i + 1) % 6
        faces += [(1 + i, 1 + j, 7 + j), (1 + i, 7 + j, 7 + i)]
    lines = [f"v {x} {y} {z}" for x, y, z in vertices] + [f"f {a} {b} {c}" for a, b, c in faces]
    path.write_text("\n".join(lines) + "\n")
    return path


def stacked(tmp_path: Path, robot: str = "floating_gripper"):
    write_prism(tmp_path / "prism.obj")
    path = tmp_path / f"stacked_{robot}.yaml"
    path.write_text(STACKED.format(robot=robot))
    return load_scene(path)


SHAPES = Ranges(default=VariantRanges(shapes=("box", "cylinder")),
                distractors=DistractorRanges(count=(1, 3)))


def movement_after_settle(scene, steps: int = 200) -> dict[str, float]:
    """How far each movable object moves in `steps` physics steps from the scene's start state,
    the robot holding its start posture."""
    world = build_world(scene)
    data = world.make_data()
    names = [obj.name for obj in scene.objects if obj.kind == "object"]
    start = {name: data.body(name).xpos.copy() for name in names}
    mujoco.mj_step(world.model, data, nstep=steps)
    return {name: float(np.linalg.norm(data.body(name).xpos - start[name])) for name in names}


def bottom(scene, name: str) -> float:
    return Solid.of(scene.object(name)).bottom


def top(scene, name: str) -> float:
    return Solid.of(scene.object(name)).top


# --- determinism and ranges -----------------------------------------------------------------

def test_variants_are_reproducible_and_differ_by_index():
    scene = load_scene(SCENE)
    first = sample_variants(scene, 3, seed=7)
    again = sample_variants(scene, 3, seed=7)
    assert [v.scene for v in first] == [v.scene for v in again]
    assert first[0].scene != first[1].scene
    assert sample_variants(scene, 1, seed=8)[0].scene != first[0].scene
    # variant i depends on (seed, i) only, not on how many come before it
    assert sample_variant(scene, 7, 2).scene == first[2].scene


def test_only_objects_move_and_stay_within_the_ranges():
    scene = load_scene(SCENE)
    ranges = VariantRanges(position=0.01, yaw=math.radians(5), size=0.1, mass=0.2, friction=0.2)
    base = scene.object("box")
    for variant in sample_variants(scene, 10, seed=3, ranges=ranges):
        assert variant.scene.object("table") == scene.object("table")
        box = variant.scene.object("box")
        assert abs(box.pose.position[0] - base.pose.position[0]) <= 0.01
        assert abs(box.pose.yaw - base.pose.yaw) <= math.radians(5) + 1e-9
        for new, old in zip(box.extents, base.extents, strict=True):
            assert 0.9 * old - 1e-9 <= new <= 1.1 * old + 1e-9
        # The box still rests on the table top (z = 0): its bottom did not move.
        assert box.pose.position[2] - box.extents[2] / 2 == pytest.approx(0.0, abs=1e-9)
        assert 0.8 * base.mass <= box.mass <= 1.2 * base.mass
        assert variant.describe()["objects"][0]["name"] == "box"


def test_one_range_does_not_shift_the_draws_of_another():
    scene = load_scene(SCENE)
    plain = sample_variant(scene, 5, 0).scene.object("box")
    heavier = sample_variant(scene, 5, 0, VariantRanges(mass=0.6, colour=0.0)).scene.object("box")
    assert heavier.pose == plain.pose and heavier.extents == plain.extents
    assert heavier.mass != plain.mass and heavier.rgba != plain.rgba


@pytest.fixture(scope="module")
def stacked_scene(tmp_path_factory: pytest.TempPathFactory):
    return stacked(tmp_path_factory.mktemp("stacked"))


@settings(max_examples=40, deadline=None)
@given(seed=st.integers(0, 2**32 - 1), index=st.integers(0, 1000))
def test_every_quantity_stays_within_its_range(stacked_scene, seed: int, index: int):
    scene = stacked_scene
    ranges = VariantRanges(position=0.015, yaw=0.2, size=0.1, mass=0.25, friction=0.2,
                           restitution=0.1, colour=0.15)
    variant = sample_variant(scene, seed, index, ranges)
    tol = 1e-9
    for change in variant.changes:
        old, new = scene.object(change.name), variant.scene.object(change.name)
        assert abs(change.dx) <= 0.015 and abs(change.dy) <= 0.015
        assert abs(new.pose.yaw - old.pose.yaw) <= 0.2 + tol
        assert all(0.9 - tol <= s <= 1.1 + tol for s in change.size_scale)
        for a, b in zip(new.extents, old.extents, strict=True):
            assert 0.9 * b - tol <= a <= 1.1 * b + tol
        assert new.shape == old.shape
        assert old.mass * 0.75 - tol <= new.mass <= old.mass * 1.25 + tol
        assert old.friction * 0.8 - tol <= new.friction <= old.friction * 1.2 + tol
        assert max(0.0, old.restitution - 0.1) - tol <= new.restitution \
            <= min(RESTITUTION_RANGE[1], old.restitution + 0.1) + tol
        for c_new, c_old in zip(new.rgba, old.rgba, strict=True):
            assert max(0.0, c_old - 0.15) - tol <= c_new <= min(1.0, c_old + 0.15) + tol
        if change.name != "block":   # the block rides on the box: its offset adds the box's
            assert new.pose.position[0] - old.pose.position[0] == pytest.approx(change.dx,
                                                                                abs=tol)
    # fixtures and surfaces never change; the block still sits on the box
    for name in ("table", "platform", "wall"):
        assert variant.scene.object(name) == scene.object(name)
    assert bottom(variant.scene, "block") == pytest.approx(top(variant.scene, "box"), abs=1e-8)


@pytest.mark.slow
@settings(max_examples=25, deadline=None)
@given(seed=st.integers(0, 2**32 - 1),
       position=st.floats(0, 0.5), yaw=st.floats(0, math.pi), size=st.floats(0, 0.9),
       mass=st.floats(0, 0.9), shapes=st.lists(st.sampled_from(["box", "cylinder", "mesh"]),
                                               unique=True),
       distractors=st.tuples(st.integers(0, 4), st.integers(0, 4)).map(sorted))
def test_any_ranges_give_a_valid_scene_file_or_say_why(stacked_scene, seed, position, yaw, size,
                                                       mass, shapes, distractors):
    prism = Path(stacked_scene.object("prism").mesh)
    ranges = Ranges(default=VariantRanges(position=position, yaw=yaw, size=size, mass=mass,
                                          shapes=tuple(shapes)),
                    meshes=(str(prism),), distractors=DistractorRanges(count=tuple(distractors)))
    try:
        variant = sample_variant(stacked_scene, seed, 0, ranges)
    except VariantError as error:
        assert "narrow the ranges" in str(error)
        return
    loaded = parse_scene(to_yaml(variant.scene, relative_to=prism.parent), "v.yaml",
                         base_dir=prism.parent)
    assert len(loaded.objects) == len(stacked_scene.objects) + len(variant.distractors)


# --- supports, settling and interpenetration ------------------------------------------------

def test_supports_are_found_in_the_base_scene(stacked_scene):
    assert supports(stacked_scene) == {"box": "table", "block": "box", "can": "table",
                                       "ball": "table", "prism": "platform"}


@pytest.mark.parametrize("robot", ["floating_gripper", "franka"])
def test_shape_changes_and_distractors_rest_on_their_supports(robot: str, tmp_path: Path):
    """Box, cylinder and mesh shapes and distractors, for both robots: every variant is a valid
    scene file that builds, and nothing falls or jumps (< 5 mm in 200 steps)."""
    scene = stacked(tmp_path, robot)
    ranges = Ranges(default=VariantRanges(shapes=("box", "cylinder", "mesh")),
                    meshes=(str(tmp_path / "prism.obj"),),
                    distractors=DistractorRanges(count=(1, 3)))
    shapes = set()
    for variant in sample_variants(scene, 6, seed=4, ranges=ranges):
        shapes |= {variant.scene.object(c.name).shape for c in variant.changes}
        text = to_yaml(variant.scene, relative_to=tmp_path)
        loaded = parse_scene(text, "variant.yaml", base_dir=tmp_path)
        assert [o.name for o in loaded.objects] == [o.name for o in variant.scene.objects]
        moved = movement_after_settle(loaded)
        assert max(moved.values()) < 0.005, (variant.describe(), moved)
        assert bottom(loaded, "block") == pytest.approx(top(loaded, "box"), abs=1e-8)
        assert variant.distractors
    assert shapes >= {"box", "cylinder", "mesh"}


@pytest.mark.parametrize("name", sorted(p.name for p in EXAMPLES.glob("*.yaml")))
def test_example_scene_variants_settle(name: str):
    scene = load_scene(EXAMPLES / name)
    for variant in sample_variants(scene, 3, seed=1, ranges=SHAPES):
        moved = movement_after_settle(variant.scene)
        assert max(moved.values()) < 0.005, (variant.describe(), moved)


def test_distractors_keep_clear_of_everything_but_their_support(stacked_scene):
    clearance = 0.02
    ranges = Ranges(distractors=DistractorRanges(count=(3, 3), clearance=clearance))
    for variant in sample_variants(stacked_scene, 5, seed=9, ranges=ranges):
        assert [d.name for d in variant.distractors] == [f"distractor_{k}" for k in range(3)]
        world = build_world(variant.scene)
        data = world.make_data()
        model = world.model
        for d in variant.distractors:
            geom = model.geom(d.name).id
            assert bottom(variant.scene, d.name) == pytest.approx(top(variant.scene, d.support),
                                                                  abs=1e-8)
            for other in range(model.ngeom):
                body = model.body(int(model.geom_bodyid[other])).name
                if other == geom or body == d.support or not model.geom_conaffinity[other]:
                    continue
                distance = mujoco.mj_geomDistance(model, data, geom, other, 1.0, None)
                assert distance >= clearance - 1e-6, (d.name, body, distance)


def test_a_grown_object_never_interpenetrates_its_neighbour(tmp_path: Path):
    """Two boxes 1 cm apart growing by up to 30 %: the draws that would overlap are redrawn."""
    path = tmp_path / "tight.yaml"
    path.write_text(STACKED.split("  - {{name: platform")[0].format(robot="floating_gripper")
                    + """\
  - {name: a, kind: object, shape: box, size: [0.1, 0.1, 0.05], pose: {position: [0.5, 0, 0.025]},
     mass: 0.2}
  - {name: b, kind: object, shape: box, size: [0.1, 0.1, 0.05], pose: {position: [0.61, 0, 0.025]},
     mass: 0.2}
""")
    scene = load_scene(path)
    variants = sample_variants(scene, 10, seed=0, ranges=VariantRanges(size=0.3, position=0.0,
                                                                       yaw=0.0))
    assert any(v.attempts > 1 for v in variants)
    for variant in variants:
        a, b = variant.scene.object("a"), variant.scene.object("b")
        gap = (b.pose.position[0] - b.extents[0] / 2) - (a.pose.position[0] + a.extents[0] / 2)
        assert gap >= -1e-4


def test_an_interpenetration_of_the_base_scene_is_not_held_against_its_variants(tmp_path: Path):
    path = tmp_path / "sunk.yaml"
    path.write_text(STACKED.split("  - {{name: platform")[0].format(robot="floating_gripper")
                    + "  - {name: box, kind: object, shape: box, size: [0.1, 0.1, 0.05],\n"
                      "     pose: {position: [0.5, 0, 0.015]}, mass: 0.2}\n")
    variant = sample_variant(load_scene(path), 0, 0)
    assert variant.attempts == 1


# --- no room ---------------------------------------------------------------------------------

def test_a_scene_without_objects_or_distractors_has_no_variants(tmp_path: Path):
    scene = parse_scene(STACKED.split("  - {{name: box")[0].format(robot="franka"))
    with pytest.raises(VariantError, match="no objects"):
        VariantSampler(scene)
    assert VariantSampler(scene, Ranges(distractors=DistractorRanges(count=(1, 1)))) \
        .sample(0, 0).distractors


def test_distractors_need_a_surface():
    scene = parse_scene("robot: franka\nobjects:\n  - {name: box, kind: object, shape: box, "
                        "size: [0.1, 0.1, 0.1], pose: {position: [0.5, 0, 0.05]}, mass: 0.2}\n")
    with pytest.raises(VariantError, match="no level surface"):
        VariantSampler(scene, Ranges(distractors=DistractorRanges(count=(0, 1))))


@pytest.mark.slow
def test_ranges_that_leave_no_room_say_why(stacked_scene):
    crowded = Ranges(distractors=DistractorRanges(count=(20, 20), size=(0.3, 0.5)))
    with pytest.raises(VariantError, match=r"every one of 50 draws was rejected, most often "
                                           r"\(\d+x\) because there is no room for 20 "
                                           r"distractors.*narrow the ranges"):
        sample_variant(stacked_scene, 0, 0, crowded)


# --- ranges files ----------------------------------------------------------------------------

def ranges_errors(text: str, scene=None, base_dir: Path | str = ".") -> list[tuple[int, str, str]]:
    with pytest.raises(SceneError) as caught:
        parse_ranges(text, "ranges.yaml", base_dir=base_dir, scene=scene)
    for problem in caught.value.problems:
        assert str(problem).startswith(f"ranges.yaml:{problem.line}:{problem.column}: error: ")
    return [(p.line, p.field, p.message) for p in caught.value.problems]


def test_an_empty_ranges_file_means_the_defaults():
    assert parse_ranges("") == Ranges()
    assert parse_ranges("# nothing\n") == Ranges()


def test_ranges_file_units_overrides_and_distractors(stacked_scene, tmp_path: Path):
    write_prism(tmp_path / "prism.obj")
    ranges = parse_ranges("""\
position: 1cm
yaw: 10deg
shapes: [box, cylinder]
meshes: [prism.obj]
distractors: 2
distractor: {size: [2cm, 4cm], mass: [20g, 50g], clearance: 1cm}
objects:
  box: {position: 3cm, shapes: [mesh]}
  can: {mass: 0}
""", base_dir=tmp_path, scene=stacked_scene)
    assert ranges.default.position == pytest.approx(0.01)
    assert ranges.default.yaw == pytest.approx(math.radians(10))
    assert ranges.default.size == VariantRanges().size
    box, can = ranges.for_object("box"), ranges.for_object("can")
    assert (box.position, box.shapes, box.yaw) == (pytest.approx(0.03), ("mesh",),
                                                   pytest.approx(math.radians(10)))
    assert (can.mass, can.position, can.shapes) == (0.0, pytest.approx(0.01), ("box", "cylinder"))
    assert ranges.meshes == (str((tmp_path / "prism.obj").resolve()),)
    assert ranges.distractors.count == (2, 2)
    assert ranges.distractors.mass == pytest.approx((0.02, 0.05))
    variant = sample_variant(stacked_scene, 1, 0, ranges)
    assert variant.scene.object("box").shape == "mesh"
    assert len(variant.distractors) == 2


def test_bad_ranges_name_their_line_and_field():
    assert ranges_errors("""\
position: 2cm
yaw: 2cm
size: 1.5
colour: -0.1
shapes: [box, pyramid]
distractors: [3, 1]
distractor: {size: [1mm, 3cm], shapes: []}
speed: 3
""") == [
        (2, "yaw", "`2cm` is a Length, expected an Angle"),
        (3, "size", "Input should be less than or equal to 0.9"),
        (4, "colour", "Input should be greater than or equal to 0"),
        (5, "shapes[1]", "Input should be 'box', 'cylinder' or 'mesh'"),
        (6, "distractors", "expected `[min, max]` with min <= max"),
        (7, "distractor.size", "distractor sizes must lie in [1cm, 50cm]"),
        (7, "distractor.shapes", "Value should have at least 1 item after validation, not 0"),
        (8, "speed", "unknown field"),
    ]


def test_a_yaw_range_is_at_most_a_half_turn():
    assert ranges_errors("yaw: 400deg\n") == [(1, "yaw", "must lie in [0deg, 180deg], got 400deg")]
    assert parse_ranges("yaw: 180deg\n").default.yaw == pytest.approx(math.pi)


def test_ranges_counts_are_counts():
    assert ranges_errors("distractors: true\n") == [
        (1, "distractors", "expected a count, or `[min, max]` counts")]
    assert ranges_errors("distractors: [0, 50]\n") == [
        (1, "distractors[1]", "Input should be less than or equal to 20")]


def test_ranges_yaml_problems_are_scene_errors():
    assert ranges_errors("position: [1, 2\n")[0][1:] == ("", "YAML syntax: while parsing a flow "
                                                             "sequence: expected ',' or ']', but "
                                                             "got '<stream end>'")
    assert ranges_errors("- 1\n- 2\n") == [
        (1, "", "a ranges file is a mapping of ranges (see docs/variants.md)")]


def test_a_ranges_file_is_read_within_the_scene_files_bounds():
    """A "billion laughs" file stops at the YAML reader's value limit, at once."""
    lines = ["l0: &l0 [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]"]
    lines += [f"l{i}: &l{i} [" + ", ".join([f"*l{i - 1}"] * 10) + "]" for i in range(1, 9)]
    problems = ranges_errors("\n".join(lines) + "\n")
    assert len(problems) == 1 and "values" in problems[0][2]


def test_ranges_are_checked_against_the_scene(stacked_scene):
    assert ranges_errors("""\
shapes: [mesh]
objects:
  wall: {position: 0}
  cupboard: {yaw: 0}
""", scene=stacked_scene) == [
        (3, "objects.wall", "`wall` is a fixture; only objects (kind `object`) vary"),
        (4, "objects.cupboard", "the scene has no object `cupboard` (its movable objects: box, "
                                "block, can, ball, prism)"),
        (1, "shapes", "shape `mesh` for the box `box` needs `meshes:` (the hulls to use)"),
    ]


def test_ranges_meshes_stay_inside_the_ranges_folder(tmp_path: Path):
    inner = tmp_path / "inner"
    inner.mkdir()
    write_prism(tmp_path / "outside.obj")
    problems = ranges_errors("meshes: [../outside.obj, missing.obj]\n", base_dir=inner)
    assert problems[0] == (1, "meshes[0]", "mesh `../outside.obj` lies outside the ranges "
                                           "file's folder")
    assert problems[1][:2] == (1, "meshes[1]")   # the mesh loader's own message follows
    allowed = parse_ranges("meshes: [../outside.obj]\n", base_dir=inner, allowed_dirs=[tmp_path])
    assert allowed.meshes == (str((tmp_path / "outside.obj").resolve()),)
