"""Scene files: valid loads, and every kind of bad file names the right line and field."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
from mesh_files import write_obj

from rapid_dsl.runtime.scenes.scene import (
    SceneError,
    dump_scene,
    load_scene,
    parse_scene,
    to_yaml,
)

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"

GOOD = """\
robot: franka
objects:
  - name: table
    kind: surface
    shape: box
    size: [1.0, 1.2, 0.75]
    pose: {position: [0.55, 0, -0.375]}
  - name: box
    kind: object
    label: cereal box
    shape: box
    size: [20cm, 14cm, 3cm]
    pose: {position: [0.55, 0.0, 1.5cm], yaw: 30deg}
    mass: 300g
    friction: 0.8
    rgba: [0.8, 0.2, 0.2, 1.0]
  - name: can
    kind: object
    shape: cylinder
    size: [6cm, 12cm]
    pose: {position: [0.4, 0.2, 0.06]}
    mass: 0.2
  - name: ball
    kind: object
    shape: sphere
    size: 4cm
    pose: {position: [0.4, -0.2, 0.02]}
    mass: 0.05kg
    restitution: 0.5
"""


def errors(text: str, tmp_path: Path | None = None) -> list[tuple[int, str, str]]:
    """(line, field, message) of every problem in a scene text."""
    with pytest.raises(SceneError) as caught:
        parse_scene(text, "scene.yaml", base_dir=tmp_path or ".")
    for problem in caught.value.problems:
        assert problem.file == "scene.yaml"
        assert str(problem).startswith(f"scene.yaml:{problem.line}:{problem.column}: error: ")
    return [(p.line, p.field, p.message) for p in caught.value.problems]


def test_valid_scene_is_normalised_to_si():
    scene = parse_scene(GOOD)
    box = scene.object("box")
    assert box.extents == pytest.approx((0.20, 0.14, 0.03))
    assert box.pose.yaw == pytest.approx(math.radians(30))
    assert box.mass == pytest.approx(0.3)
    assert scene.object("can").extents == pytest.approx((0.06, 0.06, 0.12))
    assert scene.object("ball").extents == pytest.approx((0.04, 0.04, 0.04))
    assert scene.object("table").label == "table"          # defaults to the name
    assert scene.object("table").mass is None
    assert scene.robot_base == (0.0, 0.0, 0.0)


def test_example_scenes_load():
    for path in sorted(EXAMPLES.glob("*.yaml")):
        scene = load_scene(path)
        assert any(obj.kind == "object" for obj in scene.objects), path


def test_yaml_round_trip(tmp_path: Path):
    scene = parse_scene(GOOD)
    again = parse_scene(to_yaml(scene))
    assert again.model_dump() == scene.model_dump()
    dump_scene(scene, tmp_path / "copy.yaml")
    assert load_scene(tmp_path / "copy.yaml").model_dump() == scene.model_dump()


def test_with_object_revalidates():
    scene = parse_scene(GOOD)
    heavier = scene.with_object("box", mass="1kg", pose={"position": (0.5, 0.0, 0.015)})
    assert heavier.object("box").mass == 1.0
    assert heavier.object("box").pose.yaw == 0.0
    assert scene.object("box").mass == pytest.approx(0.3)   # the original is untouched
    with pytest.raises(ValueError):
        scene.with_object("box", mass=-1.0)
    with pytest.raises(KeyError):
        scene.with_object("nothing", mass=1.0)


@pytest.mark.parametrize(
    ("old", "new", "line", "field", "message"),
    [
        ("    mass: 300g\n", "    mass: 300cm\n", 14, "objects[1].mass",
         "is a Length, expected a Mass"),
        ("yaw: 30deg", "yaw: 30cm", 13, "objects[1].pose.yaw", "expected an Angle"),
        ("[0.55, 0.0, 1.5cm]", "[0.55, .nan, 1.5cm]", 13, "objects[1].pose.position",
         "not a finite number"),
        ("[0.55, 0.0, 1.5cm]", "[0.55, .inf, 1.5cm]", 13, "objects[1].pose.position",
         "not a finite number"),
        ("    friction: 0.8\n", "    friction: 0.8\n    colour: red\n", 16, "objects[1].colour",
         "unknown field"),
        ("    kind: object\n    label: cereal", "    kind: thing\n    label: cereal", 9,
         "objects[1].kind", "'object', 'fixture' or 'surface'"),
        ("size: [20cm, 14cm, 3cm]", "size: [20cm, 14cm]", 12, "objects[1].size", "a box needs"),
        ("size: [6cm, 12cm]", "size: [6cm, 5cm, 12cm]", 20, "objects[2].size", "must be equal"),
        ("    mass: 0.2\n", "", 17, "objects[2]", "an object needs a `mass`"),
        ("name: ball", "name: box", 23, "objects[3].name", "duplicate object name `box`"),
        ("name: ball", "name: gripper", 23, "objects[3].name", "reserved"),
        ("robot: franka", "robot: ur5", 1, "robot", "'franka' or 'floating_gripper'"),
        ("rgba: [0.8, 0.2, 0.2, 1.0]", "rgba: [0.8, 0.2, 2, 1.0]", 16, "objects[1].rgba", "[0, 1]"),
        ("restitution: 0.5", "restitution: 1.5", 29, "objects[3].restitution",
         "must lie in [0, 0.8]"),
        ("    pose: {position: [0.55, 0, -0.375]}\n",
         "    pose: {position: [0.55, 0, -0.375]}\n    mass: 3kg\n", 8, "objects[0].mass",
         "static"),
    ],
)
def test_bad_field_names_its_line(old, new, line, field, message):
    assert old in GOOD
    problems = errors(GOOD.replace(old, new, 1))
    assert any(p_line == line and p_field == field and message in p_message
               for p_line, p_field, p_message in problems), problems


def test_missing_required_field_points_at_its_mapping():
    problems = errors(GOOD.replace("    pose: {position: [0.4, 0.2, 0.06]}\n", ""))
    assert (17, "objects[2].pose", "required field is missing") in problems


def test_yaml_syntax_error_has_a_line():
    problems = errors(GOOD.replace("size: [6cm, 12cm]", "size: [6cm, 12cm"))
    assert len(problems) == 1 and problems[0][2].startswith("YAML syntax")
    assert problems[0][0] >= 20


def test_not_a_mapping_and_unreadable_file(tmp_path: Path):
    assert errors("- just\n- a list\n")[0][0] == 1
    with pytest.raises(SceneError, match="cannot read scene file"):
        load_scene(tmp_path / "absent.yaml")
    binary = tmp_path / "binary.yaml"
    binary.write_bytes(b"robot: \xd7\xff\x00")
    with pytest.raises(SceneError,
                       match="binary.yaml:1:1: error: cannot read scene file: not UTF-8 text"):
        load_scene(binary)


def test_all_problems_are_reported_at_once():
    text = GOOD.replace("yaw: 30deg", "yaw: 30cm").replace("size: 4cm", "size: 4kg")
    assert {line for line, _, _ in errors(text)} >= {13, 26}


MESH_SCENE = """\
robot: floating_gripper
objects:
  - name: mug
    kind: object
    shape: mesh
    mesh: {mesh}
    pose: {{position: [0.5, 0, 0.05]}}
    mass: 0.3kg
"""


def test_mesh_object_takes_its_extents_from_the_file(tmp_path: Path):
    write_obj(tmp_path / "mug.obj")
    (tmp_path / "scene.yaml").write_text(MESH_SCENE.format(mesh="mug.obj"))
    mug = load_scene(tmp_path / "scene.yaml").object("mug")
    assert mug.extents == pytest.approx((0.08, 0.06, 0.1))
    assert Path(mug.mesh).is_absolute()


def test_missing_mesh_names_the_mesh_line(tmp_path: Path):
    problems = errors(MESH_SCENE.format(mesh="nowhere.obj"), tmp_path)
    assert problems == [(6, "objects[0].mesh", "cannot read the mesh file: no such file")]


def test_corrupt_mesh_names_the_mesh_line(tmp_path: Path):
    (tmp_path / "bad.obj").write_text("v 0 0 0\nv 1 0 0\nf 1 2 3\nthis is not a mesh\n")
    problems = errors(MESH_SCENE.format(mesh="bad.obj"), tmp_path)
    assert len(problems) == 1 and problems[0][:2] == (6, "objects[0].mesh")
