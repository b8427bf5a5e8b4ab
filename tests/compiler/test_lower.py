"""Generated code computes what the program says: evaluated on synthetic frames, no MuJoCo."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from rapid_dsl.compiler import compile_program, lower
from rapid_dsl.compiler.lower import python_identifier
from rapid_dsl.frontend.driver import check_file, check_text
from rapid_dsl.runtime.frames import Entity, EntityTable, Frames
from rapid_dsl.runtime.loader import load
from rapid_dsl.runtime.program import Context, truth

DATA = Path(__file__).resolve().parents[1] / "data" / "compiled"
EXTENTS = {"box": (0.2, 0.1, 0.04), "table": (1.0, 1.0, 0.1), "wall": (0.05, 0.8, 0.2),
           "gripper": (0.02, 0.1, 0.02)}
KINDS = {"box": "Object", "table": "Surface", "wall": "Fixture", "gripper": "Manipulator"}


def frames(positions: dict[str, list[list[float]]]) -> Frames:
    """B=1 frames; each entity's position per time point, identity orientation, at rest."""
    names = list(positions)
    steps = len(positions[names[0]])
    pos = np.stack([np.asarray(positions[n], dtype=float) for n in names], axis=1)[None]
    quat = np.zeros((1, steps, len(names), 4))
    quat[..., 0] = 1.0
    entities = tuple(Entity(i, n, KINDS[n], n, "box", np.asarray(EXTENTS[n]))
                     for i, n in enumerate(names))
    table = EntityTable(entities, np.zeros(3), 1.0)
    contact = np.zeros((1, steps, len(names), len(names)), dtype=bool)
    return Frames(time=np.arange(steps) * 0.1, pos=pos, quat=quat, linvel=np.zeros_like(pos),
                  angvel=np.zeros_like(pos), contact=contact,
                  fingers=np.zeros((1, steps, len(names), 2), dtype=bool),
                  finger_normals=np.zeros((1, steps, len(names), 2, 3)),
                  opening=np.zeros((1, steps)), entities=table)


def compiled(text: str):
    result = check_text(text, "t.rapid")
    assert result.program is not None, [d.message for d in result.diagnostics]
    return load(compile_program(result.program).source, "t").program, result.program


def test_python_identifier():
    assert python_identifier("lambda") == "lambda_"
    assert python_identifier("match") == "match_"
    assert python_identifier("gap") == "gap"


ARITHMETIC = """
def a(b: Body) -> Length = height(b) - (height(b) - 1cm) * 2
def c(b: Body) -> Real = -(height(b) / 1cm) ^ 2 + 3 / (2 - height(b) / 1cm)
def d(b: Body) -> Length = (pos(b) - 2 * (pos(b) - [1cm, 0cm, 0cm])).x / 2
def e(b: Body) -> Length =
    if height(b) > 5cm and not (height(b) > 1m) then height(b) else -height(b)
def f(b: Body) -> Length = norm(-(pos(b) / 2))
primitive p {
  goal "g"
  roles { b: Object, h: Manipulator }
  success { a(b) < 1m; c(b) < 1; d(b) < 1m; e(b) < 1m; f(b) < 1m }
  cost final = 0
  motion { keypoint k = pos(b) }
}
"""


def test_operator_precedence_and_vector_arithmetic():
    program, _ = compiled(ARITHMETIC)
    checks = program.primitive("p").success
    f = frames({"box": [[0.3, 0.2, 0.07]], "gripper": [[0, 0, 0.5]]})
    values = checks.evaluate(Context(f, {"b": 0, "h": 1}))
    h = 0.07
    expected = [h - (h - 0.01) * 2, -((h / 0.01) ** 2) + 3 / (2 - h / 0.01),
                (0.3 - 2 * (0.3 - 0.01)) / 2, h, 0.5 * math.sqrt(0.3**2 + 0.2**2 + h**2)]
    np.testing.assert_allclose([float(np.asarray(v.lhs).ravel()[0]) for v in values], expected)


def test_features_use_the_start_state_and_success_holds_on_the_last():
    program = load(compile_program(check_file(str(DATA / "nudge.rapid")).program).source,
                   "nudge").program
    nudge = program.primitive("nudge")
    f = frames({"box": [[0.5, 0.0, 0.02], [0.5, 0.03, 0.02], [0.5, 0.05, 0.02]],
                "table": [[0.5, 0.0, -0.05]] * 3, "gripper": [[0.3, 0.0, 0.2]] * 3})
    roles = {"item": 0, "base": 1, "hand": 2}
    params = nudge.defaults(Context(f.first(), roles))
    features = nudge.features(Context(f, roles, params))
    np.testing.assert_allclose(features["travelled"], [[0.0, 0.03, 0.05]])
    np.testing.assert_array_equal(features["lead"], [[0.0, 1.0, 1.0]])
    last = f.last()
    values = nudge.success.evaluate(Context(last, roles, params, nudge.features(
        Context(last, roles, params))))
    assert [bool(truth(v).all()) for v in values] == [True, True, True, True]
    raised = frames({"box": [[0.5, 0.0, 0.02], [0.5, 0.05, 0.05]],
                     "table": [[0.5, 0.0, -0.05]] * 2, "gripper": [[0.3, 0.0, 0.2]] * 2}).last()
    values = nudge.success.evaluate(Context(raised, roles, params, nudge.features(
        Context(raised, roles, params))))
    assert [bool(truth(v).all()) for v in values] == [True, True, False, False]
    keypoints = nudge.motion.keypoints(Context(f.first(), roles, params,
                                               nudge.features(Context(f.first(), roles, params))))
    assert [k.name for k in keypoints] == ["above", "low", "push", "away"]
    # top(table) + 1.5cm
    np.testing.assert_allclose(np.ravel(keypoints[1].position)[2], 0.0 + 0.015)
    assert keypoints[0].grip == 1.0 and keypoints[3].grip == 0.0
    assert keypoints[2].pitch == pytest.approx(math.radians(5))
    assert keypoints[2].roll is None and keypoints[3].roll == pytest.approx(math.radians(-10))


def test_requirements_are_relations_over_the_roles_they_name():
    program = load(compile_program(check_file(str(DATA / "nudge.rapid")).program).source,
                   "nudge").program
    requirement = program.primitive("nudge").requires[1]
    assert requirement.roles == ("item", "hand")
    f = frames({"box": [[0.5, 0.0, 0.02]], "gripper": [[0.3, 0.0, 0.2]]})
    assert bool(np.all(requirement.test(f, 0, 1)))


def test_solve_argument_is_computed_just_in_time():
    program = load(compile_program(check_file(str(DATA / "align_then_push.rapid")).program)
                   .source, "align").program
    strategy = program.strategy("align_then_push")
    f = frames({"box": [[0.5, 0.0, 0.02]], "table": [[0.5, 0.0, -0.05]],
                "wall": [[0.8, 0.0, 0.1]], "gripper": [[0.3, 0.0, 0.2]]})
    roles = {"box": 0, "table": 1, "wall": 2, "hand": 3}
    lets = strategy.lets(Context(f, roles))
    close = strategy.phases[0].arguments(Context(f, roles, lets=lets))
    gap = 0.8 - 0.025 - (0.5 + 0.1)
    np.testing.assert_allclose(np.ravel(close["displacement"]), [gap - 0.02, 0.0, 0.0], atol=1e-9)
    slide = strategy.phases[1].arguments(Context(f, roles, lets=lets))
    np.testing.assert_allclose(slide["displacement"], [0.0, 0.05, 0.0], atol=1e-5)


def test_lower_is_pure_and_deterministic():
    program = check_file(str(DATA / "align_then_push.rapid")).program
    assert lower(program) == lower(program)
