"""Properties: no input crashes `rapidc`, and `fmt` keeps the program.

- random text, mutated valid programs, deep brackets, megabyte strings and comments, and random
  bytes: `rapid_dsl.cli.main` returns 0, 1 or 2 (3 would be an internal error) within a deadline;
- printing: `parse(format(m)) == m` for generated expressions, types and whole modules;
  `format_source` is idempotent, keeps comments and the AST of every program that parses.

Examples are derandomized so CI is repeatable; set RAPIDC_HYPOTHESIS_RANDOM=1 to explore.
"""

from __future__ import annotations

import atexit
import contextlib
import io
import os
import re
import shutil
import tempfile
from datetime import timedelta
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rapid_dsl.cli import main
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.formatter import format_expr, format_module, format_source, format_type
from rapid_dsl.frontend.parser import parse_expression, parse_module, parse_type

ROOT = Path(__file__).resolve().parents[2]
CORPUS = sorted([*ROOT.glob("stdlib_primitives/*.rapid"), *ROOT.glob("examples/*.rapid"),
                 *ROOT.glob("tests/data/language/*.rapid"), *ROOT.glob("tests/data/fmt/*.rapid")])
SOURCES = [p.read_text(encoding="utf-8") for p in CORPUS]
TOKEN = re.compile(r'\s+|#[^\n]*|"(?:\\.|[^"\\\n])*"|\w+|.', re.DOTALL)
VOCABULARY = sorted({t for s in SOURCES for t in TOKEN.findall(s) if not t.isspace()})
WORK = Path(tempfile.mkdtemp(prefix="rapidc-properties-"))
atexit.register(shutil.rmtree, WORK, ignore_errors=True)


def _settings(examples: int, seconds: float) -> settings:
    return settings(max_examples=examples, deadline=timedelta(seconds=seconds), database=None,
                    derandomize=not os.environ.get("RAPIDC_HYPOTHESIS_RANDOM"),
                    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])


def rapidc(*argv: str) -> int:
    """Exit status of `rapidc ARGV`, output swallowed."""
    with contextlib.redirect_stdout(io.StringIO()), contextlib.redirect_stderr(io.StringIO()):
        return main(list(argv))


def run_on(content: str | bytes, suffix: str = ".rapid") -> list[int]:
    """`rapidc check` and `rapidc fmt` on a file holding `content`."""
    path = WORK / f"input{suffix}"
    if isinstance(content, bytes):
        path.write_bytes(content)
    else:
        path.write_text(content, encoding="utf-8", newline="")
    return [rapidc("check", "--quiet", str(path)), rapidc("fmt", str(path))]


def assert_formats_faithfully(text: str) -> None:
    module, _ = parse_module(text, "p.rapid")
    if module is None:
        return
    formatted, _ = format_source(text, "p.rapid")
    assert formatted is not None
    assert parse_module(formatted, "p.rapid")[0] == module
    assert format_source(formatted, "p.rapid")[0] == formatted
    printed = format_module(module)
    assert parse_module(printed, "p.rapid")[0] == module
    assert format_module(parse_module(printed, "p.rapid")[0]) == printed


# ------------------------------------------------------------------------------ never crash

GRAMMAR_CHARS = "abcxyz_019 .,;:=+-*/^<>!()[]{}\"#\\\n\tAZ"


@pytest.mark.slow
@_settings(150, 2)
@given(st.text(alphabet=st.sampled_from(GRAMMAR_CHARS), max_size=300) | st.text(max_size=200))
def test_random_text(text):
    assert set(run_on(text)) <= {0, 1, 2}
    assert set(run_on(text, ".rapid.yaml")) <= {0, 1, 2}


@st.composite
def mutated_programs(draw):
    tokens = TOKEN.findall(draw(st.sampled_from(SOURCES)))
    for _ in range(draw(st.integers(1, 3))):
        i = draw(st.integers(0, len(tokens) - 1))
        kind = draw(st.sampled_from(["delete", "duplicate", "swap", "insert"]))
        if kind == "delete":
            del tokens[i]
        elif kind == "duplicate":
            tokens.insert(i, tokens[i])
        elif kind == "swap":
            j = draw(st.integers(0, len(tokens) - 1))
            tokens[i], tokens[j] = tokens[j], tokens[i]
        else:
            tokens.insert(i, draw(st.sampled_from(VOCABULARY)))
    return "".join(tokens)


@pytest.mark.slow
@_settings(150, 3)
@given(mutated_programs())
def test_mutated_programs(text):
    codes = run_on(text)
    assert codes[0] in {0, 1} and codes[1] in {0, 1}
    assert_formats_faithfully(text)


@_settings(20, 5)
@given(st.integers(1000, 10_000), st.sampled_from(["()", "[]", "{}"]), st.booleans())
def test_deep_brackets(depth, pair, balanced):
    opening, closing = pair
    body = opening * depth + "1" + (closing * depth if balanced else "")
    assert set(run_on(f"def f() -> Real = {body}\n")) <= {1}
    assert set(run_on(f"- def: f\n  returns: Real\n  body: {body}\n", ".rapid.yaml")) <= {1}
    assert set(run_on(opening * depth, ".rapid.yaml")) <= {1}


@pytest.mark.slow
@_settings(8, 20)
@given(st.sampled_from(["comment", "goal", "name", "number", "unterminated", "yaml"]))
def test_megabyte_inputs(kind):
    big = "x" * 1_000_000
    program = {
        "comment": f"# {big}\nrelation r(a: Body) = settled(a)  # {big}\n",
        "goal": f'primitive p {{\n  goal "{big}"\n}}\n',
        "name": f"relation {big}(a: Body) = settled(a)\n",
        "number": f"def f() -> Real = {'9' * 1_000_000}\n",
        "unterminated": f'primitive p {{\n  goal "{big}\n}}\n',
        "yaml": f"- relation: r\n  params: {{a: Body}}\n  body: settled(a) # {big}\n",
    }[kind]
    suffix = ".rapid.yaml" if kind == "yaml" else ".rapid"
    assert set(run_on(program, suffix)) <= {0, 1}


@_settings(100, 2)
@given(st.binary(max_size=400))
def test_random_bytes(data):
    assert set(run_on(data)) <= {0, 1, 2}
    assert set(run_on(data, ".rapid.yml")) <= {0, 1, 2}


# ------------------------------------------------------------------------------- round trip

NAMES = ["a", "b", "gap", "x_1", "target", "_tmp"]
NUMBERS = ["0", "1", "2.5", "3cm", "90deg", "1e-3", ".5", "10mm", "2s", "0.5N", "7.", "1E+2kg"]


def _number(text: str) -> ast.Number:
    node, diagnostics = parse_expression(text, "x")
    assert isinstance(node, ast.Number) and not diagnostics
    return node


names = st.sampled_from(NAMES).map(ast.Name)
leaves = names | st.sampled_from(NUMBERS).map(_number)


def _compound(children):
    binary = st.builds(ast.Binary, st.sampled_from(["+", "-", "*", "/", "^"]), children, children)
    args = st.lists(st.builds(ast.Arg, st.none() | names, children), max_size=3)
    return st.one_of(
        st.builds(ast.Unary, st.sampled_from(["-", "not"]), children),
        binary, binary,
        st.builds(ast.Compare, st.sampled_from(["<", "<=", ">", ">=", "==", "!="]), children,
                  children),
        st.builds(ast.Logic, st.sampled_from(["and", "or"]), children, children),
        st.builds(ast.IfExpr, children, children, children),
        st.builds(ast.Call, st.sampled_from(["f", "distance", "abs"]).map(ast.Name),
                  args.map(tuple)),
        st.builds(ast.Component, children, st.sampled_from("xyz").map(ast.Name)),
        st.lists(children, max_size=3).map(lambda items: ast.Vector(tuple(items))),
    )


expressions = st.recursive(leaves, _compound, max_leaves=25)

type_names = st.sampled_from(["Real", "Length", "Angle", "Time", "Object", "Point"])
types = st.recursive(
    type_names.map(ast.TypeName),
    lambda inner: st.one_of(
        st.builds(ast.TypeApply, st.just("Vec"), inner),
        st.builds(ast.TypeBinary, st.sampled_from(["*", "/"]), inner, inner),
        st.builds(ast.TypePower, inner, st.integers(-3, 3))),
    max_leaves=6)


@pytest.mark.slow
@_settings(400, 2)
@given(expressions)
def test_expressions_print_and_parse_back(e):
    text = format_expr(e)
    assert parse_expression(text, "x") == (e, [])


@_settings(200, 2)
@given(types)
def test_types_print_and_parse_back(t):
    assert parse_type(format_type(t), "x") == (t, [])


def _typed(name: str, type_: ast.TypeExpr) -> ast.TypedName:
    return ast.TypedName(ast.Name(name), type_)


@st.composite
def modules(draw):
    def e() -> ast.Expr:
        return draw(expressions)

    goal = draw(st.text(st.characters(blacklist_characters="\n", blacklist_categories=("Cs",)),
                        max_size=30))
    keypoint = ast.Keypoint(ast.Name("k"), e(), draw(st.none() | expressions),
                            draw(st.none() | expressions), draw(st.sampled_from([None, "open",
                                                                                 "closed"])),
                            roll=draw(st.none() | expressions))
    primitive = ast.Primitive(ast.Name("p"), (
        ast.Goal(goal),
        ast.Roles((_typed("a", draw(types)), _typed("hand", ast.TypeName("Manipulator")))),
        ast.Requires(tuple(draw(st.lists(expressions, max_size=2)))),
        ast.Params((ast.ParamDecl(ast.Name("q"), draw(types), e(), e(), e()),
                    ast.ParamDecl(ast.Name("r"), draw(types)))),
        ast.Resolve((ast.Assign(ast.Name("z"), e()),)),
        ast.Success(tuple(draw(st.lists(expressions, min_size=1, max_size=3)))),
        ast.CostFinal(e()),
        ast.CostProgress(draw(st.none() | expressions), e()),
        ast.Motion((keypoint, ast.MotionSetting(draw(st.sampled_from(
            ["spread", "spread_angle", "duration"])), e()))),
        ast.Optimize((ast.Setting(ast.Name("samples"), e()),)),
        ast.Filter((e(),)),
    ))
    solve = ast.Solve(ast.Name("d"), draw(types), e(), tuple(draw(st.lists(expressions,
                                                                           max_size=2))))
    strategy = ast.Strategy(ast.Name("s"), (
        ast.Goal(goal),
        ast.Let(ast.Name("m"), e()),
        ast.Phase(ast.Name("one"), ast.Name("p"),
                  (ast.RoleBinding(ast.Name("a"), ast.Name("b")),),
                  tuple(draw(st.lists(st.builds(ast.Argument, names, expressions | st.just(solve)),
                                      max_size=2)))),
        ast.Phase(ast.Name("two"), ast.Name("p"), (), ()),
    ))
    declarations = [
        ast.Use(("stdlib",), (ast.Name("push"),)),
        ast.Use(("stdlib",), (ast.Name("push"), ast.Name("flip"))),
        ast.Use(None, (), goal),
        ast.RelationDecl(ast.Name("r"), (_typed("a", draw(types)),), e()),
        ast.DefDecl(ast.Name("f"), (), draw(types), e()),
        primitive, strategy,
    ]
    chosen = draw(st.lists(st.sampled_from(declarations), max_size=5))
    return ast.Module("m.rapid", tuple(chosen))


@pytest.mark.slow
@_settings(60, 3)
@given(modules())
def test_modules_print_and_parse_back(module):
    text = format_module(module)
    parsed, _ = parse_module(text, "m.rapid")
    assert parsed == module
    assert format_module(parsed) == text
    assert format_source(text, "m.rapid")[0] == text


@_settings(60, 3)
@given(st.sampled_from(SOURCES))
def test_corpus_formats_faithfully(text):
    assert_formats_faithfully(text)
