"""No input crashes the front end: mutated programs, deep nesting and huge input all give
diagnostics (or a clean result), never an exception, and quickly.
"""

from __future__ import annotations

import time
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rapid_dsl.frontend.driver import check_text

DATA = Path(__file__).parent.parent / "data"
STUBS = DATA / "stub_stdlib"
SEEDS = [p.read_text() for p in sorted((DATA / "language").glob("*.rapid"))] + \
    [p.read_text() for p in sorted(STUBS.glob("*.rapid"))] + \
    [p.read_text() for p in sorted((DATA / "diagnostics").glob("E0[2-5]*.rapid"))]
TOKENS = ["target", "hand", "box", "up", "pi", "start", "x", "z", "1cm", "90deg", "2", "0",
          "1e400", "-", "+", "*", "/", "^", "<", "==", "and", "not", "if", "then", "else", "(",
          ")", "[", "]", "{", "}", ",", ";", "\n", "=", ".", ":", "Object", "Length", "Vec",
          "Point", "solve", "phase", "let", "keypoint", "roles", "params", "success", "motion",
          "cost final =", "use stdlib.push", 'use "x.rapid"', "distance(", "norm(", "min(",
          "rotation(target, about=", "in [", "] =", "relation r(a: Body) =", "def d() -> Real ="]


def assert_total(text: str, path: str = "fuzz.rapid") -> None:
    result = check_text(text, path, stdlib=STUBS, lint=True)
    lines = text.count("\n") + 2
    for d in result.diagnostics:
        assert d.code and d.message
        if d.span.path == path:
            assert 1 <= d.span.line <= lines, d
    assert (result.program is None) == any(d.is_error for d in result.diagnostics)


@st.composite
def mutated(draw: st.DrawFn) -> str:
    text = draw(st.sampled_from(SEEDS))
    for _ in range(draw(st.integers(1, 4))):
        i = draw(st.integers(0, len(text)))
        j = draw(st.integers(i, min(len(text), i + 40)))
        action = draw(st.sampled_from(["delete", "insert", "replace", "duplicate"]))
        if action == "delete":
            text = text[:i] + text[j:]
        elif action == "duplicate":
            text = text[:j] + text[i:j] + text[j:]
        else:
            token = draw(st.sampled_from(TOKENS))
            text = text[:i] + f" {token} " + (text[j:] if action == "replace" else text[i:])
    return text


@pytest.mark.slow
@settings(max_examples=300, deadline=2000, suppress_health_check=[HealthCheck.too_slow])
@given(mutated())
def test_mutated_programs_never_raise(text: str) -> None:
    assert_total(text)


@settings(max_examples=100, deadline=2000)
@given(st.text(max_size=300))
def test_arbitrary_text_never_raises(text: str) -> None:
    assert_total(text)


@pytest.mark.slow
def test_deep_and_huge_input() -> None:
    start = time.perf_counter()
    body = 'primitive p {{\n  goal "g"\n  roles {{ t: Object, h: Manipulator }}\n' \
           "  success {{ {} }}\n  cost final = 1\n  motion {{ keypoint k = pos(t) }}\n}}\n"
    for clause in ["-" * 5000 + "1 > 0", "not " * 5000 + "touching(t, h)",
                   " + ".join(["1"] * 20000) + " > 0", "[" * 5000 + "]" * 5000,
                   "f(" * 3000 + ")" * 3000, "pos(t)" + ".x" * 3000 + " > 0cm",
                   "1 < 2 < 3", "x" * 1_000_000]:
        assert_total(body.format(clause))
    assert_total('primitive p { goal "' + "g" * 1_000_000 + '" }\n')
    assert_total("\n" * 200_000)
    assert_total("use stdlib." + ".".join(["a"] * 1000) + "\n")
    assert time.perf_counter() - start < 30


def test_yaml_input_never_raises() -> None:
    for text in ["", "[", "- primitive: p\n  success: [\"" + "(" * 500 + "\"]\n",
                 "- primitive: p\n  goal: g\n  roles: {t: Object}\n  success: ['1 <']\n",
                 "a: &a [*a, *a]\n"]:
        assert_total(text, "fuzz.yaml")
