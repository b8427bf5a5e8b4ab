"""Scene files are untrusted: every limit is a scene error at its line and field, never a crash.

Bounded YAML (aliases, nesting, tokens, tags, huge numbers), bounded files (FIFOs, huge files),
physical bounds, names the built model already uses (for both robots) and the robot's reach.
"""

from __future__ import annotations

import os
import subprocess
import sys
import time
import typing
from pathlib import Path

import pytest

from rapid_dsl.language import safe_yaml
from rapid_dsl.runtime.robots import ROBOT_NAMES
from rapid_dsl.runtime.scenes import schema as scene_schema
from rapid_dsl.runtime.scenes.scene import SceneError, load_scene, parse_scene
from rapid_dsl.runtime.scenes.world import build_world, reserved_names

EXAMPLES = Path(__file__).resolve().parents[2] / "examples" / "scenes"
FLIP = (EXAMPLES / "flip_box.yaml").read_text()   # floating gripper: table, wall, box


def problems(text: str, **kwargs) -> list[tuple[int, str, str]]:
    """(line, field, message) of every problem in a scene text; each is short and printable."""
    with pytest.raises(SceneError) as caught:
        parse_scene(text, "scene.yaml", **kwargs)
    for problem in caught.value.problems:
        shown = str(problem)
        assert shown.startswith(f"scene.yaml:{problem.line}:{problem.column}: error: ")
        assert problem.line >= 1 and problem.column >= 1
        assert len(shown) < 400 and shown.isprintable(), shown
    return [(p.line, p.field, p.message) for p in caught.value.problems]


def line_of(text: str, needle: str) -> int:
    """The 1-based number of the first line of `text` that holds `needle`."""
    return next(n for n, line in enumerate(text.splitlines(), 1) if needle in line)


def one(text: str, at: str, field: str, message: str) -> None:
    """The scene has a problem on the line holding `at`, at `field`, saying `message`."""
    found = problems(text)
    line = line_of(text, at)
    assert any(p_line == line and p_field == field and message in p_message
               for p_line, p_field, p_message in found), found


# --- bounded YAML --------------------------------------------------------------------------

def test_an_alias_bomb_stops_at_the_value_limit():
    bomb = "a: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
        f"{chr(98 + i)}: &{chr(98 + i)} [{', '.join(['*' + chr(97 + i)] * 9)}]\n"
        for i in range(9))   # 9**10 values once expanded
    started = time.perf_counter()
    found = problems(bomb + FLIP)
    assert time.perf_counter() - started < 5
    assert found[0][2] == f"the YAML has more than {safe_yaml.MAX_VALUES} values (aliases expand)"


def test_an_alias_inside_its_own_anchor_is_refused():
    assert "an alias refers to its own anchor" in problems("a: &x [1, *x]\n" + FLIP)[0][2]


def test_deep_brackets_in_a_label_stop_at_the_depth_limit():
    text = FLIP.replace("label: flat box", "label: " + "[" * 5000 + "]" * 5000)
    assert problems(text) == [(line_of(text, "label: ["), "",
                               f"the YAML nests deeper than {safe_yaml.MAX_DEPTH} levels")]


def test_deep_block_nesting_stops_at_the_depth_limit():
    assert "nests deeper than" in problems("- " * 3000 + "x\n")[0][2]


@pytest.mark.slow
def test_a_file_of_many_tokens_stops_at_the_token_limit():
    text = FLIP + "extra: [" + "1, " * 300_000 + "1]\n"
    started = time.perf_counter()
    found = problems(text)
    assert time.perf_counter() - started < 5
    assert found[0][2] == f"the YAML has more than {safe_yaml.MAX_TOKENS} tokens"


@pytest.mark.parametrize(("new", "at", "message"), [
    ("mass: !!python/object:os.system ls", "mass", "YAML tag `!!python/object:os.system` is not"),
    ("mass: !kilo 3", "mass", "YAML tag `!kilo` is not allowed"),
    ("mass: !!set {a}", "mass", "YAML tag `!!set` is not allowed"),
    ("mass: 0.3kg\n    mass: 0.4kg", "0.4kg", "`mass` appears twice in this mapping"),
    ("mass: " + "9" * 5000, "mass", "an integer of 5000 digits is too long"),
    ("[mass]: 0.3kg", "[mass]", "a key must be a plain word"),
    ("mass: *nowhere", "mass", "YAML syntax: found undefined alias"),
])
def test_yaml_that_a_scene_cannot_hold(new, at, message):
    text = FLIP.replace("mass: 0.3kg", new)
    assert [(line, message in p_message) for line, _, p_message in problems(text)] == \
        [(line_of(text, at), True)]


def test_merge_keys_and_anchors_still_work():
    text = FLIP.replace("objects:\n", "defaults: &static {kind: fixture, shape: box}\nobjects:\n") \
        .replace("    kind: fixture\n    label: wall\n    shape: box\n", "    <<: *static\n")
    assert "defaults" in problems(text)[0][1]          # an unknown top-level key, nothing else
    text = text.replace("defaults: &static {kind: fixture, shape: box}\n", "") \
        .replace("    <<: *static\n", "    <<: {kind: fixture, shape: box, label: wall}\n")
    assert parse_scene(text).object("wall").kind == "fixture"


def test_a_huge_integer_anywhere_a_number_goes():
    big = "9" * 401
    for old, new, field in [
        ("mass: 0.3kg", f"mass: {big}", "objects[2].mass"),
        ("[0.30, 0.0, 0.10]", f"[0.30, {big}, 0.10]", "gripper_start.position"),
        ("[4cm, 40cm, 10cm]", f"[4cm, {big}, 10cm]", "objects[1].size"),
        ("friction: 0.8", f"friction: {big}", "objects[1].friction"),
        ("[0.2, 0.45, 0.85, 1.0]", f"[0.2, {big}, 0.85, 1.0]", "objects[2].rgba"),
        ("floor_height: -0.75m", f"floor_height: -{big}", "floor_height"),
        ("position: [0.72, 0.0, 5cm]}", f"position: [0.72, 0.0, 5cm], yaw: {big}}}",
         "objects[1].pose.yaw"),
    ]:
        assert old in FLIP
        one(FLIP.replace(old, new), big, field, "is too large")


# --- bounded files -------------------------------------------------------------------------

@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_is_refused_without_blocking(tmp_path: Path):
    fifo = tmp_path / "scene.yaml"
    os.mkfifo(fifo)
    with pytest.raises(SceneError, match=r"scene.yaml:1:1: error: cannot read scene file: not a "
                                         r"regular file"):
        load_scene(fifo)


def test_a_huge_file_is_refused_unread_and_unquoted(tmp_path: Path):
    big = tmp_path / "big.yaml"
    with big.open("wb") as f:
        f.write(b"robot: " + b"x" * 100)
        f.truncate(1 << 30)   # sparse: 1 GiB without writing it
    with pytest.raises(SceneError) as caught:
        load_scene(big)
    assert "larger than the input limit of 10 MiB" in str(caught.value)
    assert "xxx" not in str(caught.value)


def test_unknown_keys_are_quoted_short_and_escaped():
    key = "colour\u202e" + "x" * 500
    found = problems(FLIP.replace("    friction: 0.6\n  - name: wall",
                                  f"    {key}: red\n  - name: wall"))
    (line, field, message), = found
    assert (line, message) == (line_of(FLIP, "friction: 0.6"), "unknown field")
    assert field.startswith("objects[0].`colour\\u202exxx") and "(507 characters)" in field


# --- physical bounds ------------------------------------------------------------------------

@pytest.mark.parametrize(("old", "new", "at", "field", "message"), [
    ("mass: 0.3kg", "mass: 1e-300", "mass", "objects[2].mass", "must lie in [0.001 kg, 100 kg]"),
    ("mass: 0.3kg", "mass: 0.5g", "mass", "objects[2].mass", "got 0.0005 kg"),
    ("mass: 0.3kg", "mass: 101kg", "mass", "objects[2].mass", "must lie in"),
    ("mass: 0.3kg", "mass: -1", "mass", "objects[2].mass", "must lie in"),
    ("mass: 0.3kg", "mass: 1e400", "mass", "objects[2].mass", "not a finite number"),
    ("mass: 0.3kg", "mass: .nan", "mass", "objects[2].mass", "not a finite number"),
    ("[14cm, 20cm, 3cm]", "[14cm, 20cm, 4mm]", "4mm", "objects[2].size",
     "each must lie in [0.005 m, 2 m]"),
    ("[1.0m, 1.2m, 0.75m]", "[1.0m, 2.1m, 0.75m]", "2.1m", "objects[0].size",
     "[1 m, 2.1 m, 0.75 m]"),
    ("[14cm, 20cm, 3cm]", "[14cm, 20cm, 1e-300]", "1e-300", "objects[2].size",
     "each must lie in"),
    ("friction: 0.6\n    rgba", "friction: 2.5\n    rgba", "2.5", "objects[2].friction",
     "must lie in [0, 2]"),
    ("friction: 0.6\n    rgba", "friction: -0.1\n    rgba", "-0.1", "objects[2].friction",
     "must lie in [0, 2]"),
    ("friction: 0.6\n    rgba", "friction: 0.6\n    restitution: 0.85\n    rgba", "0.85",
     "objects[2].restitution", "must lie in [0, 0.8]"),
    ("[0.2, 0.45, 0.85, 1.0]", "[0.2, 0.45, 0.85, 1.5]", "rgba", "objects[2].rgba",
     "must lie in [0, 1]"),
    ("[0.2, 0.45, 0.85, 1.0]", "[0.2, 0.45, 0.85, 1.0, 1.0]", "rgba", "objects[2].rgba",
     "expected 4 numbers"),
    ("[0.55, 0.0, 1.5cm]", "[10.5, 0.0, 1.5cm]", "10.5", "objects[2].pose.position",
     "must lie in [-10 m, 10 m]"),
    ("floor_height: -0.75m", "floor_height: -11m", "floor", "floor_height",
     "must lie in [-10 m, 10 m]"),
    ("floor_height: -0.75m", "floor_height: -0.75m\nrobot_base: [0, 20, 0]", "robot_base",
     "robot_base", "must lie in [-10 m, 10 m]"),
    ("position: [0.72, 0.0, 5cm]}", "position: [0.72, 0.0, 5cm], yaw: 721deg}", "721deg",
     "objects[1].pose.yaw", "must lie in [-720deg, 720deg]"),
    ("{position: [0.30, 0.0, 0.10]}", "{position: [0.30, 0.0, 0.10], pitch: 1e9}", "1e9",
     "gripper_start.pitch", "must lie in"),
    ("label: flat box", "label: " + "b" * 101, "bbb", "objects[2].label",
     "at most 100 characters"),
    ("label: flat box", 'label: "flat\\u202ebox"', "u202e", "objects[2].label",
     "one line of plain"),
    ("label: flat box", 'label: "two\\nlines"', "lines", "objects[2].label", "one line of plain"),
    ("label: flat box", "label: [a, b]", "[a, b]", "objects[2].label", "valid string"),
    ("name: box", "name: " + "b" * 65, "bbb", "objects[2].name", "at most 64 characters"),
    ("mass: 0.3kg", "mass: " + "1" * 70 + "kg", "mass", "objects[2].mass",
     "... (72 characters)` is not a number"),
    ("mass: 0.3kg", "mass: 3furlong", "mass", "objects[2].mass", "(m, cm, mm, rad, deg, kg"),
    ("mass: 0.3kg", 'mass: "3\\x1fcm"', "mass", "objects[2].mass",
     "`3\\x1fcm` is a Length, expected a Mass"),
])
def test_values_outside_the_bounds(old, new, at, field, message):
    assert old in FLIP
    one(FLIP.replace(old, new, 1), at, field, message)


def test_too_many_objects():
    extra = "".join(f"  - {{name: o{i}, kind: object, shape: sphere, size: 1cm, "
                    f"pose: {{position: [0, 0, 1]}}, mass: 0.1}}\n"
                    for i in range(scene_schema.MAX_OBJECTS))
    limit = scene_schema.MAX_OBJECTS
    assert problems(FLIP + extra) == [(line_of(FLIP, "- name: table"), "objects",
                                       f"a scene holds at most {limit} objects, this one "
                                       f"{limit + 3}")]


def test_the_bounds_themselves_load_and_build():
    """Values at every bound are valid and MuJoCo takes them, for both robots."""
    text = FLIP.replace("mass: 0.3kg", "mass: 1g").replace("[14cm, 20cm, 3cm]", "[5mm, 2m, 5mm]") \
        .replace("friction: 0.6\n    rgba", "friction: 2\n    restitution: 0.8\n    rgba") \
        .replace("[0.72, 0.0, 5cm]", "[10, -10, 10]") \
        .replace("[0.55, 0.0, -0.375]", "[0.55, 0, -9]")
    for robot in ROBOT_NAMES:
        build_world(parse_scene(text.replace("robot: floating_gripper", f"robot: {robot}")))
    build_world(parse_scene(FLIP.replace("mass: 0.3kg", "mass: 100kg")))


# --- names the model already uses ------------------------------------------------------------

@pytest.mark.parametrize("robot", ROBOT_NAMES)
def test_an_object_can_take_no_name_the_built_model_uses(robot: str):
    text = FLIP.replace("robot: floating_gripper", f"robot: {robot}")
    model = build_world(parse_scene(text)).model
    own = {"table", "wall", "box"}
    used = {name.decode() for name in model.names.split(b"\0") if name} - own
    assert {"world", "gripper", "floor", "hand"} <= used
    assert ({"carriage"} if robot == "floating_gripper" else
            {f"link{i}" for i in range(8)} | {"cartesian_ref"}) <= used
    line = line_of(text, "name: wall")
    for name in sorted(used):
        found = problems(text.replace("name: wall", f"name: '{name}'"))
        assert [(line, field) for line, field, _ in found] == [(line, "objects[1].name")], name


def test_the_schema_knows_the_robots_the_builders_know():
    robot = scene_schema.Scene.model_fields["robot"].annotation
    assert set(typing.get_args(robot)) == set(ROBOT_NAMES)


def test_reserved_names_say_who_uses_them():
    one(FLIP.replace("name: wall", "name: link3"), "name: link3", "objects[1].name",
        "`link3` is reserved: the franka model uses it")
    one(FLIP.replace("name: wall", "name: world"), "name: world", "objects[1].name",
        "the floating_gripper and the franka models use it")
    one(FLIP.replace("name: wall", "name: gripper"), "name: gripper", "objects[1].name",
        "`gripper` is reserved: the scene's own `gripper` entity")
    assert set(reserved_names()) >= {"carriage", "cartesian_ref", "link0", "link7", "floor"}


# --- reach -------------------------------------------------------------------------------------

FRANKA = (EXAMPLES / "push_box_franka.yaml").read_text()


@pytest.mark.parametrize(("old", "new", "message"), [
    ("[0.30, 0.0, 0.10]", "[1.5, 0.0, 0.10]",
     "the hand start [1.5, 0.0, 0.1] is 1.503 m from robot_base, beyond the franka's reach of "
     "0.855 m"),
    ("[0.30, 0.0, 0.10]", "[0.0, 0.0, 0.05]", "the franka cannot put its hand at [0.0, 0.0, 0.05]"),
    ("floor_height: -0.75m", "floor_height: -0.75m\nrobot_base: [3, 0, 0]",
     "is 2.702 m from robot_base"),
])
def test_a_start_out_of_the_frankas_reach(old, new, message):
    assert old in FRANKA
    found = problems(FRANKA.replace(old, new))
    assert len(found) == 1 and found[0][1] == "gripper_start.position" and message in found[0][2]


def test_the_floating_gripper_has_its_own_workspace():
    text = FLIP.replace("[0.30, 0.0, 0.10]", "[1.2, 0.0, 0.10]")
    assert "beyond the floating_gripper's reach of 1 m" in problems(text)[0][2]
    # without gripper_start the hand starts in front of the base, always within reach
    build_world(parse_scene(FLIP.replace("gripper_start: {position: [0.30, 0.0, 0.10]}\n", "")
                            .replace("robot: floating_gripper", "robot: franka")))


def test_a_reachable_start_builds_where_validation_said(tmp_path: Path):
    text = FRANKA.replace("[0.30, 0.0, 0.10]", "[0.5, 0.3, 0.3]")
    world = build_world(parse_scene(text))
    hand = world.robot.hand_pose(world.make_data()).position
    assert hand == pytest.approx([0.5, 0.3, 0.3], abs=5e-3)


def test_scene_validation_imports_no_front_end():
    """The runtime reads scenes with the vocabulary's bounded YAML, not the compiler's."""
    code = ("import sys; from rapid_dsl.runtime.scenes.scene import load_scene; "
            f"load_scene({str(EXAMPLES / 'flip_box.yaml')!r}); "
            "print(sorted(m for m in sys.modules if m.startswith('rapid_dsl.')"
            " and not m.startswith(('rapid_dsl.runtime', 'rapid_dsl.language'))))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"
