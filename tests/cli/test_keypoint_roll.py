"""Keypoint `roll`: parsed, checked as an Angle, formatted, the same from YAML, compiled, linted."""

from __future__ import annotations

import json
import math

from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_file
from rapid_dsl.frontend.formatter import format_module
from rapid_dsl.frontend.parser import parse_module
from rapid_dsl.frontend.yaml import parse_yaml_module
from rapid_dsl.runtime.loader import load
from rapid_dsl.runtime.program import Context
from tests.compiler.test_lower import frames

PRIMITIVE = """\
primitive pinch {
  goal "Squeeze an edge from above and below"
  roles { box: Object, hand: Manipulator }
  success { holding(hand, box) }
  cost final = distance(hand, box) / 1cm
  motion {
    keypoint side = pos(box) + 8cm * up yaw 10deg pitch 90deg roll 90deg gripper open
    keypoint under = pos(box) roll -45deg
    spread 1cm
    spread_angle 5deg
    duration 2s
  }
}
"""

YAML = """\
- primitive: pinch
  goal: Squeeze an edge from above and below
  roles: {box: Object, hand: Manipulator}
  success: ["holding(hand, box)"]
  cost: {final: "distance(hand, box) / 1cm"}
  motion:
    keypoints:
      - {name: side, at: "pos(box) + 8cm * up", yaw: 10deg, pitch: 90deg, roll: 90deg,
         gripper: open}
      - {name: under, at: pos(box), roll: -45deg}
    spread: 1cm
    spread_angle: 5deg
    duration: 2s
"""


def test_roll_is_checked_and_compiled_into_the_keypoints(rapidc, write):
    path = write("pinch.rapid", PRIMITIVE)
    assert rapidc("check", path).code == 0
    result = check_file(str(path))
    assert result.program is not None
    side, under = result.program.primitive("pinch").keypoints
    assert side.roll is not None and under.roll is not None and under.yaw is None
    pinch = load(compile_program(result.program).source, "pinch").program.primitive("pinch")
    f = frames({"box": [[0.5, 0.0, 0.02]], "gripper": [[0.3, 0.0, 0.2]]})
    roles = {"box": 0, "hand": 1}
    assert pinch.defaults is None     # no params
    side, under = pinch.motion.keypoints(Context(f.first(), roles, {},
                                                 pinch.features(Context(f.first(), roles, {}))))
    assert float(side.roll) == math.radians(90) and float(side.pitch) == math.radians(90)
    assert float(under.roll) == math.radians(-45) and under.yaw is None and under.pitch is None


def test_fmt_keeps_roll_and_is_stable(rapidc, write):
    module, diagnostics = parse_module(PRIMITIVE, "p.rapid")
    assert diagnostics == [] and module is not None
    text = format_module(module)
    assert "pitch 90deg roll 90deg gripper open" in text
    assert "keypoint under = pos(box) roll -45deg" in text
    again, _ = parse_module(text, "p.rapid")
    assert again == module
    assert rapidc("fmt", "--check", write("f.rapid", text)).code == 0


def test_yaml_roll_gives_the_same_ast(rapidc, write):
    from_yaml, diagnostics = parse_yaml_module(YAML, "p")
    assert diagnostics == []
    from_rapid, _ = parse_module(PRIMITIVE, "p")
    assert from_yaml == from_rapid
    assert rapidc("check", write("pinch.rapid.yaml", YAML)).code == 0
    printed = rapidc("fmt", write("again.rapid.yaml", YAML))
    assert printed.code == 0 and "pitch 90deg roll 90deg" in printed.out


def test_roll_must_be_an_angle(rapidc, write):
    path = write("bad.rapid", PRIMITIVE.replace("roll -45deg", "roll 3cm"))
    run = rapidc("--format", "json", "check", path)
    assert run.code == 1
    [diagnostic] = json.loads(run.out)
    assert diagnostic["code"] == "E0313"
    assert diagnostic["message"] == "`roll` must be an Angle, got Length"
    assert (diagnostic["line"], diagnostic["column"]) == (8, 36)
    human = rapidc("check", path)
    assert "bad.rapid:8:36: error[E0313]: `roll` must be an Angle, got Length" in human.out


def test_roll_twice_is_an_error(rapidc, write):
    path = write("twice.rapid", PRIMITIVE.replace("roll -45deg", "roll -45deg roll 5deg"))
    run = rapidc("check", path)
    assert run.code == 1 and "error[E0109]: keypoint `under` sets `roll` twice" in run.out


def test_a_param_read_only_by_a_roll_is_used(rapidc, write):
    text = PRIMITIVE.replace("  success", "  params { twist: Angle = 30deg }\n  success")
    unused = rapidc("lint", write("unused.rapid", text)).out
    assert "warning[W0102]: param `twist` is never used" in unused
    used = rapidc("lint", write("used.rapid", text.replace("roll -45deg", "roll twist"))).out
    assert "W0102" not in used and "warning[W0104]" in used   # read, but judged by no cost
