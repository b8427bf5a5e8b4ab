"""Checking time is linear in the program: each shape below was quadratic once (1,000 keypoints
took 0.75 s, 5,000 took 15 s). Four times the program must take well under 16 times as long;
CPU time, best of two, so a busy machine does not decide.
"""

from __future__ import annotations

import gc
import time
from collections.abc import Callable

import pytest

from rapid_dsl.frontend.driver import check_text
from rapid_dsl.frontend.parser import forget_parsed

from .test_checker import STUBS

HEAD = ('primitive p {\n  goal "g"\n  roles { target: Object, hand: Manipulator }\n'
        "  success { touching(hand, target) }\n  cost final = distance(hand, target) / 1cm\n")
KEYPOINT = "  motion { keypoint reach = pos(target) }\n}\n"


def strategy(body: str) -> str:
    return ('strategy s {\n  goal "g"\n  roles { box: Object, hand: Manipulator }\n'
            + body + "}\n")


def keypoints(n: int) -> str:
    return HEAD + "  motion {\n" + "".join(
        f"    keypoint k{i} = k{i - 1} + 1mm * up\n" if i else "    keypoint k0 = pos(target)\n"
        for i in range(n)) + "  }\n}\n"


def features(n: int) -> str:
    entries = "".join(f"    f{i} = f{i - 1} + 1mm\n" if i else "    f0 = height(target)\n"
                      for i in range(n))
    return HEAD.replace("touching(hand, target)", f"f{n - 1} > 1cm") + \
        f"  resolve {{\n{entries}  }}\n" + KEYPOINT


def cost_terms(n: int) -> str:
    """Lint asks of each cost term whether it reads the scene, through the features it reads:
    it walked the whole chain of features again for every term."""
    entries = "".join(f"    f{i} = f{i - 1} + 1mm\n" if i else "    f0 = 1cm\n" for i in range(n))
    cost = " + ".join([f"f{n - 1} / 1cm"] * (n * 3 // 10))    # within the depth limit of 400
    return HEAD.replace("distance(hand, target) / 1cm", cost) + \
        f"  resolve {{\n{entries}  }}\n" + KEYPOINT


def params(n: int) -> str:
    return HEAD + "  params {\n" + "".join(
        f"    q{i}: Length in [0cm, {i + 1}cm] = 0cm\n" for i in range(n)) + "  }\n" + KEYPOINT


def lets(n: int) -> str:
    return HEAD + KEYPOINT + strategy("".join(
        f"  let l{i} = l{i - 1} + 1cm\n" if i else "  let l0 = 1cm\n" for i in range(n))
        + "  phase a: p(target=box, hand=hand)\n")


def def_chain(n: int) -> str:
    return "def d0(a: Body) -> Length = height(a)\n" + "".join(
        f"def d{i}(a: Body) -> Length = d{i - 1}(a) + 1cm\n" for i in range(1, n))


def recursive_ring(n: int) -> str:
    return "".join(f"def d{i}(a: Body) -> Length = d{(i + 1) % n}(a)\n" for i in range(n))


def syntax_errors(n: int) -> str:
    return "".join(f"relation r{i}(a: Body b: Body) = distance(a, b) < {i}cm\n"
                   for i in range(n))


def unknown_names(n: int) -> str:
    return HEAD.replace("  success", "  resolve {\n" + "".join(
        f"    f{i} = distance(hand, target) + g{i}\n" for i in range(n)) + "  }\n  success") \
        + KEYPOINT


def phases_and_requirements(n: int) -> str:
    requires = "".join(f"    distance(target, hand) < {i + 1}cm\n" for i in range(n))
    return HEAD.replace("  success", f"  requires {{\n{requires}  }}\n  success") + KEYPOINT + \
        strategy("".join(f"  phase a{i}: p(target=box, hand=hand)\n" for i in range(n)))


def constant_sums(n: int) -> str:
    terms = " + ".join(["1cm"] * (n * 3 // 10))   # within the depth limit of 400
    return "".join(f"def s{i}() -> Length = {terms}\n" for i in range(10))


def missing_arguments(n: int) -> str:
    params_ = ", ".join(f"a{i}: Length" for i in range(n))
    return f"def big({params_}) -> Length = a0\n" + "".join(
        f"def c{i}() -> Length = big(1cm)\n" for i in range(n))


SHAPES: dict[str, Callable[[int], str]] = {
    "keypoints": keypoints, "features": features, "cost_terms": cost_terms, "params": params,
    "lets": lets,
    "def_chain": def_chain, "recursive_ring": recursive_ring, "syntax_errors": syntax_errors,
    "unknown_names": unknown_names, "phases_and_requirements": phases_and_requirements,
    "constant_sums": constant_sums, "missing_arguments": missing_arguments}


def cpu_seconds(text: str) -> float:
    best = float("inf")
    for _ in range(2):
        forget_parsed()
        start = time.process_time()
        check_text(text, "shape.rapid", stdlib=STUBS, lint=True)
        best = min(best, time.process_time() - start)
    return best


@pytest.mark.slow
@pytest.mark.parametrize("shape", SHAPES)
def test_four_times_the_program_takes_about_four_times_as_long(shape: str) -> None:
    make = SHAPES[shape]
    check_text(make(10), "warm.rapid", stdlib=STUBS, lint=True)
    small, large = cpu_seconds(make(250)), cpu_seconds(make(1000))
    assert large < 8 * max(small, 0.005), (shape, small, large)


def test_checking_leaves_the_cycle_collector_as_it_found_it() -> None:
    """Checking pauses the collector (its passes over the growing heap were quadratic)."""
    text = keypoints(3)
    assert gc.isenabled()
    check_text(text, "a.rapid", stdlib=STUBS)
    assert gc.isenabled()
    gc.disable()
    try:
        check_text(text, "a.rapid", stdlib=STUBS)
        assert not gc.isenabled()
    finally:
        gc.enable()
