"""Parsing is linear and the depth limits stop it at once. A sum of 40,000 terms took 8 s to check
and a run of 40,000 `-` 4 s (each reduction copied the chain read so far), and the run was refused
as E0107 with no place; now the parser refuses an expression deeper than MAX_DEPTH (E0409) as soon
as it reads past the limit, where the expression starts, and whether it refuses one is exactly
whether the expression nests deeper than that.
"""

from __future__ import annotations

import random
import time
from unittest import mock

import pytest
from hypothesis import event, given, settings
from hypothesis import strategies as st

from rapid_dsl.bench.check import SHAPES, cpu_ms
from rapid_dsl.frontend import parser
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.driver import check_text
from rapid_dsl.frontend.parser import MAX_DEPTH, parse_expression

REFUSED = [name for name, (_, _, expected) in SHAPES.items() if expected]
CLEAN = [name for name, (_, _, expected) in SHAPES.items() if not expected]


def assert_scales_linearly(shape: str, terms: int) -> None:
    _, make, expected = SHAPES[shape]
    cpu_ms(make(100), 1)    # warm: imports, tables
    (small, codes), (large, codes_4n) = cpu_ms(make(terms), 3), cpu_ms(make(4 * terms), 3)
    assert codes == codes_4n == ([expected] if expected else []), (codes, codes_4n)
    # quadratic work would take about 16 times as long; the floor keeps timer noise out
    assert large < 6 * max(small, 10.0), (shape, small, large)


@pytest.mark.slow
@pytest.mark.parametrize("shape", REFUSED)
def test_four_times_the_chain_takes_at_most_about_four_times_as_long(shape: str) -> None:
    assert_scales_linearly(shape, 10_000)


@pytest.mark.slow
@pytest.mark.parametrize("shape", CLEAN)
def test_four_times_the_expressions_within_the_limit_take_about_four_times_as_long(
        shape: str) -> None:
    assert_scales_linearly(shape, 2_000)


def strategy(expression: str) -> str:
    return f'strategy s {{\n  goal "g"\n  let x = {expression}\n}}\n'


@pytest.mark.parametrize(("expression", "code", "col"), ids=[
    "minus", "not", "sum", "components", "brackets", "minus-brackets"], argvalues=[
    ("- " * 40_000 + "1", "E0409", 11),
    ("not " * 40_000 + "1 < 2", "E0409", 11),
    ("+".join(["1"] * 80_000), "E0409", 11),
    ("x" + ".x" * 40_000, "E0409", 11),
    ("(" * 100_000 + "1" + ")" * 100_000, "E0107", 110),    # the strategy's `{` is one
    ("-(" * 100_000 + "1" + ")" * 100_000, "E0107", 210),
])
def test_a_deep_run_is_refused_at_once_where_it_starts(expression: str, code: str,
                                                       col: int) -> None:
    start = time.perf_counter()
    result = check_text(strategy(expression), "deep.rapid")
    assert time.perf_counter() - start < 2.0
    [diagnostic] = result.diagnostics
    assert (diagnostic.code, diagnostic.span.line, diagnostic.span.col) == (code, 3, col)


def test_the_parser_reads_no_further_than_the_depth_limit() -> None:
    # what follows the deep sum is never read: no E0102 for the `@`, nothing of the rest
    text = "def f() -> Real = " + " + ".join(["1"] * (MAX_DEPTH + 1)) + " @ $\n"
    [diagnostic] = check_text(text, "stop.rapid").diagnostics
    assert diagnostic.code == "E0409" and diagnostic.span.col == 19
    assert diagnostic.message == f"an expression nests deeper than {MAX_DEPTH} levels"


@pytest.mark.parametrize(("fits", "too_deep"), ids=["sum", "minus", "power", "calls"], argvalues=[
    (" + ".join(["1"] * MAX_DEPTH), " + ".join(["1"] * (MAX_DEPTH + 1))),
    ("- " * (MAX_DEPTH - 1) + "1", "- " * MAX_DEPTH + "1"),
    ("2" + "^2" * (MAX_DEPTH - 1), "2" + "^2" * MAX_DEPTH),
    ("f(" * 99 + " + ".join(["1"] * (MAX_DEPTH - 99)) + ")" * 99,
     "f(" * 99 + " + ".join(["1"] * (MAX_DEPTH - 98)) + ")" * 99),
])
def test_the_limit_is_exactly_max_depth_levels(fits: str, too_deep: str) -> None:
    assert parse_expression(fits, "p.rapid")[0] is not None
    node, diagnostics = parse_expression(too_deep, "p.rapid")
    assert node is None and [d.code for d in diagnostics] == ["E0409"]


def depth(node: ast.Expr) -> int:
    """Levels of an expression, as the checker recurses through them."""
    deepest, stack = 0, [(node, 1)]
    while stack:
        e, level = stack.pop()
        deepest = max(deepest, level)
        match e:
            case ast.Unary(operand=a) | ast.Component(target=a):
                children: tuple[ast.Expr, ...] = (a,)
            case ast.Binary(left=a, right=b) | ast.Compare(left=a, right=b) | \
                    ast.Logic(left=a, right=b):
                children = (a, b)
            case ast.IfExpr(cond=a, then=b, orelse=c):
                children = (a, b, c)
            case ast.Call(args=args):
                children = tuple(arg.value for arg in args)
            case ast.Vector(items=items):
                children = items
            case _:
                children = ()
        stack.extend((child, level + 1) for child in children)
    return deepest


OPERATORS = ["+", "-", "*", "/", "^", "<", "==", "and", "or"]


def chain(rnd: random.Random, level: int = 0) -> str:
    """A chain of a few operators, at times with a run of prefixes, whose operands are at times
    calls, vectors, components, brackets or `if`s of shorter chains: near LIMIT levels deep."""
    ops = rnd.sample(OPERATORS, rnd.randint(1, 3))
    parts = []
    for i in range(rnd.randint(1, 45) if level == 0 else rnd.randint(1, 5)):
        if i:
            parts.append(rnd.choice(ops))
        if rnd.random() < 0.05:
            parts.append(rnd.choice(["- ", "not "]) * rnd.randint(1, 20))
        parts.append(operand(rnd, level))
    return " ".join(parts)


def operand(rnd: random.Random, level: int) -> str:
    if level >= 3 or rnd.random() < 0.85:
        return rnd.choice(["x", "1"])
    kind = rnd.choice(["call", "vector", "paren", "component", "if"])
    a, b, c = (chain(rnd, level + 1) for _ in range(3))
    return {"call": f"f({a}, {b})", "vector": f"[{a}, x, {b}]", "paren": f"({a})",
            "component": f"({a}).x" + ".y" * rnd.randint(0, 3),
            "if": f"(if {a} then {b} else {c})"}[kind]


LIMIT = 40     # MAX_DEPTH in the property test below: the same rules, smaller programs


@settings(max_examples=100, deadline=None, derandomize=True)
@given(st.integers(0, 2**32))
def test_an_expression_is_refused_exactly_when_it_nests_deeper_than_the_limit(seed: int) -> None:
    text = chain(random.Random(seed))   # a seed, not hypothesis's randoms: 10 times as fast
    with mock.patch.object(parser, "MAX_DEPTH", 10**9):
        reference, _ = parse_expression(text, "p.rapid")
    assert reference is not None
    with mock.patch.object(parser, "MAX_DEPTH", LIMIT):
        node, diagnostics = parse_expression(text, "p.rapid")
    event("refused" if depth(reference) > LIMIT else "accepted")
    if depth(reference) <= LIMIT:
        assert node == reference
    else:
        assert node is None and [d.code for d in diagnostics] == ["E0409"]
