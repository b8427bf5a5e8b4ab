"""Properties of the checker on generated programs (hypothesis): whatever the numbers (huge,
tiny, infinite, with any unit), the nesting (past the depth limits) and the budgets (any value of
any optimize or motion setting, any number of keypoints), checking returns diagnostics and never
raises; every diagnostic has a known code and a place in the file; and a program that checks
clean never has a budget above its maximum (rapid_dsl/language/limits.py).

Examples are derandomized so CI is repeatable; set RAPIDC_HYPOTHESIS_RANDOM=1 to explore.
"""

from __future__ import annotations

import os
from datetime import timedelta

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rapid_dsl.frontend.driver import check_text
from rapid_dsl.language import limits
from rapid_dsl.language.codes import CODES

from .test_checker import STUBS

PROPERTY = settings(max_examples=int(os.environ.get("RAPIDC_EXAMPLES", "150")),
                    deadline=timedelta(seconds=5), database=None,
                    derandomize=not os.environ.get("RAPIDC_HYPOTHESIS_RANDOM"),
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])

UNITS = ["", "", "cm", "mm", "m", "deg", "rad", "s", "ms", "kg", "N", "bogus"]
DIGITS = st.one_of(
    st.integers(0, 10**6).map(str),
    st.integers(10**6, 10**400).map(str),
    st.sampled_from(["0", "1", "2", "16", "17", "64", "100", "101", "1024", "1025", "2147483647",
                     "2147483648", "1e308", "1.7976931348623157e308", "1e309", "1e400",
                     "1e-400", "4.9e-324", "0.5", ".5", "7.", "10.0", "1e3", "1E+2", "9" * 400]),
    st.floats(0, 1e300, allow_nan=False, allow_infinity=False).map(repr))
NUMBERS = st.builds(lambda digits, unit: digits + unit, DIGITS, st.sampled_from(UNITS))
NAMES = st.sampled_from(["target", "hand", "up", "pi", "gap", "k0", "nowhere", "start"])
ATOMS = st.one_of(NUMBERS, NAMES, st.sampled_from([
    "distance(hand, target)", "pos(target)", "height(target)", "tilt(target)", "norm(up)",
    "start(height(target))", "[1cm, 2cm, 3cm]", "[1, 2]", "min(1cm, 2deg)", "sqrt(4cm^2)"]))


def _compound(inner: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
    return st.one_of(
        st.builds(lambda a, op, b: f"{a} {op} {b}", inner,
                  st.sampled_from(["+", "-", "*", "/", "<", ">=", "==", "and", "or"]), inner),
        st.builds(lambda a, n: f"{a}^{n}", inner, st.sampled_from(["2", "-1", "1000", "0.5"])),
        inner.map(lambda a: f"-{a}"), inner.map(lambda a: f"not {a}"),
        inner.map(lambda a: f"({a})"), inner.map(lambda a: f"{a}.z"),
        st.builds(lambda c, a, b: f"if {c} then {a} else {b}", inner, inner, inner),
        st.builds(lambda f, a: f"{f}({a})", st.sampled_from(["abs", "norm", "height", "d"]),
                  inner))


SHALLOW = st.recursive(ATOMS, _compound, max_leaves=8)


@st.composite
def expressions(draw: st.DrawFn) -> str:
    """Mostly shallow; sometimes nested past the parser's bracket limit (100) or the checker's
    depth limit (400)."""
    e = draw(SHALLOW)
    shape = draw(st.sampled_from(["flat"] * 6 + ["parens", "minus", "sum", "power"]))
    depth = draw(st.integers(1, 450))
    if shape == "parens":
        return "(" * min(depth, 130) + e + ")" * min(depth, 130)
    if shape == "minus":
        return "-" * depth + e
    if shape == "sum":
        return " + ".join([e] * depth)
    if shape == "power":
        return "^".join([e] * min(depth, 60))
    return e


def optimize_block(draw: st.DrawFn) -> str:
    keys = st.sampled_from(["samples", "elites", "iterations", "seed", "sample"])
    budget = st.one_of(DIGITS, st.builds(lambda d: "-" + d, DIGITS), expressions())
    items = draw(st.lists(st.builds(lambda k, v: f"{k} {v}", keys, budget), max_size=5))
    return "  optimize { " + "; ".join(items) + " }\n"


def motion_block(draw: st.DrawFn) -> str:
    count = draw(st.sampled_from([0, 1, 2, 5, limits.MAX_KEYPOINTS, limits.MAX_KEYPOINTS + 1,
                                  limits.MAX_KEYPOINTS + 7]))
    lines = [f"    keypoint k{i} = pos(target) + {i}cm * up" + draw(st.sampled_from(
        ["", " gripper open", " gripper closed", " yaw 10deg"])) for i in range(count)]
    if count and draw(st.booleans()):
        lines[-1] = f"    keypoint k{count - 1} = {draw(expressions())}"
    for key in draw(st.lists(st.sampled_from(["duration", "spread", "spread_angle"]),
                             max_size=3)):
        lines.append(f"    {key} {draw(st.one_of(NUMBERS, expressions()))}")
    return "  motion {\n" + "\n".join(lines) + "\n  }\n"


@st.composite
def programs(draw: st.DrawFn) -> str:
    blocks = ['  goal "g"\n', "  roles { target: Object, hand: Manipulator }\n"]
    if draw(st.booleans()):
        blocks.append("  params { gap: Length in [" + draw(expressions()) + ", "
                      + draw(NUMBERS) + "] = " + draw(NUMBERS) + " }\n")
    if draw(st.booleans()):
        blocks.append("  resolve { d = " + draw(expressions()) + " }\n")
    blocks.append("  success { " + draw(expressions()) + " }\n")
    blocks.append("  cost final = " + draw(expressions()) + "\n")
    if draw(st.booleans()):
        blocks.append("  cost progress weight " + draw(NUMBERS) + " = " + draw(expressions())
                      + "\n")
    blocks.append(motion_block(draw))
    if draw(st.booleans()):
        blocks.append(optimize_block(draw))
    blocks = draw(st.permutations(blocks))
    text = "def d(x: Length) -> Length = x\n" if draw(st.booleans()) else ""
    text += "primitive p {\n" + "".join(blocks) + "}\n"
    if draw(st.booleans()):
        text += ("strategy s {\n  goal \"g\"\n  roles { box: Object, hand: Manipulator }\n"
                 f"  let m = {draw(expressions())}\n"
                 f"  phase one: p(target=box, hand=hand) {{ gap = {draw(expressions())} }}\n"
                 f"  success {{ {draw(expressions())} }}\n}}\n")
    return text


@pytest.mark.slow
@PROPERTY
@given(programs())
def test_checking_any_program_gives_diagnostics_and_never_raises(text: str) -> None:
    result = check_text(text, "gen.rapid", stdlib=STUBS, lint=True)
    last_line = text.count("\n") + 1
    for d in result.diagnostics:
        assert d.code in CODES, d
        assert d.message
        assert d.span.path == "gen.rapid", d
        assert 1 <= d.span.line <= last_line and d.span.col >= 1, d
    assert (result.program is None) == any(d.is_error for d in result.diagnostics)
    if result.program is None:
        return
    for primitive in result.program.primitives:
        settings_ = primitive.optimize
        assert 1 <= settings_.samples <= limits.MAX_SAMPLES
        assert 1 <= settings_.elites <= min(settings_.samples, limits.MAX_ELITES)
        assert 1 <= settings_.iterations <= limits.MAX_ITERATIONS
        assert settings_.seed is None or 0 <= settings_.seed <= limits.MAX_SEED
        assert 0 < primitive.duration <= limits.MAX_DURATION
        assert 1 <= len(primitive.keypoints) <= limits.MAX_KEYPOINTS


@pytest.mark.slow
@PROPERTY
@given(st.lists(st.sampled_from(["keypoints", "lets", "features", "phases", "unknown"]),
                min_size=1, max_size=3), st.integers(1, 300))
def test_long_declarations_check_without_error(kinds: list[str], n: int) -> None:
    """Many definitions in one declaration: each kind checks (or fails) at its own size."""
    motion = "".join(f"    keypoint k{i} = pos(target) + {i}mm * up\n"
                     for i in range(n if "keypoints" in kinds else 1))
    features = "".join(f"    f{i} = distance(hand, target) + {i}mm\n"
                       for i in range(n if "features" in kinds else 1))
    unknown = " + ".join(f"u{i}" for i in range(min(n, 300))) if "unknown" in kinds else "1cm"
    lets = "".join(f"  let l{i} = {i}cm\n" for i in range(n if "lets" in kinds else 1))
    phases = "".join(f"  phase a{i}: p(target=box, hand=hand)\n"
                     for i in range(n if "phases" in kinds else 1))
    text = ('primitive p {\n  goal "g"\n  roles { target: Object, hand: Manipulator }\n'
            f"  resolve {{\n{features}  }}\n  success {{ f0 < {unknown} }}\n"
            "  cost final = distance(hand, target) / 1cm\n"
            f"  motion {{\n{motion}  }}\n}}\n"
            'strategy s {\n  goal "g"\n  roles { box: Object, hand: Manipulator }\n'
            f"{lets}{phases}}}\n")
    result = check_text(text, "long.rapid", stdlib=STUBS, lint=True)
    codes = {d.code for d in result.diagnostics if d.is_error}
    expected = set()
    if "keypoints" in kinds and n > limits.MAX_KEYPOINTS:
        expected.add("E0412")
    if "unknown" in kinds:
        expected.add("E0201")
    assert codes == expected, sorted(codes)


INTEGERS = st.one_of(st.integers(-3, 2 * limits.MAX_SAMPLES).map(str),
                     st.sampled_from(["0", "1", "8", "100", "101", "1024", "1025", "2147483647",
                                      "2147483648", "1e3", "1e300", "1e400", "2.5", "9" * 400]))


@st.composite
def budgets(draw: st.DrawFn) -> tuple[str, dict[str, str], tuple[str, str] | None, int]:
    """A clean primitive whose budgets alone vary: (text, optimize settings, duration, count)."""
    chosen = draw(st.dictionaries(st.sampled_from(["samples", "elites", "iterations", "seed"]),
                                  INTEGERS, max_size=4))
    duration = draw(st.none() | st.tuples(st.one_of(DIGITS, st.sampled_from(
        ["10", "10.0", "10.001", "9.999", "10000", "10001", "0"])), st.sampled_from(["s", "ms"])))
    count = draw(st.integers(1, limits.MAX_KEYPOINTS + 3))
    keypoints = "".join(f"    keypoint k{i} = pos(target) + {i}mm * up\n" for i in range(count))
    settings_ = f"    duration {duration[0]}{duration[1]}\n" if duration else ""
    optimize = "; ".join(f"{k} {v}" for k, v in chosen.items())
    text = ('primitive p {\n  goal "g"\n  roles { target: Object, hand: Manipulator }\n'
            "  success { touching(hand, target) }\n"
            "  cost final = distance(hand, target) / 1cm\n"
            f"  motion {{\n{keypoints}{settings_}  }}\n"
            + (f"  optimize {{ {optimize} }}\n" if chosen else "") + "}\n")
    return text, chosen, duration, count


def _allowed(key: str, text: str) -> bool:
    value = float(text)
    if value != value or value in (float("inf"), float("-inf")) or not value.is_integer():
        return False
    least, most = (0, limits.MAX_SEED) if key == "seed" else (1, {
        "samples": limits.MAX_SAMPLES, "elites": limits.MAX_ELITES,
        "iterations": limits.MAX_ITERATIONS}[key])
    return least <= value <= most


@pytest.mark.slow
@PROPERTY
@given(budgets())
def test_a_program_checks_clean_exactly_when_its_budgets_are_within_the_maxima(
        case: tuple[str, dict[str, str], tuple[str, str] | None, int]) -> None:
    text, chosen, duration, count = case
    result = check_text(text, "budget.rapid", stdlib=STUBS)
    allowed = all(_allowed(k, v) for k, v in chosen.items()) and count <= limits.MAX_KEYPOINTS
    if duration is not None:
        seconds = float(duration[0]) * (0.001 if duration[1] == "ms" else 1.0)
        allowed = allowed and 0 < seconds <= limits.MAX_DURATION
    samples = int(float(chosen["samples"])) if "samples" in chosen and \
        _allowed("samples", chosen["samples"]) else 64
    if "elites" in chosen and _allowed("elites", chosen["elites"]):
        allowed = allowed and float(chosen["elites"]) <= samples
    assert (result.program is not None) == allowed, [d.message for d in result.diagnostics]
    if result.program is not None:
        p = result.program.primitive("p")
        assert p.optimize.samples == samples and len(p.keypoints) == count
        for key in ("elites", "iterations", "seed"):
            if key in chosen:
                assert getattr(p.optimize, key) == int(float(chosen[key]))
