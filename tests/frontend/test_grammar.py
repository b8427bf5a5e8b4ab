"""The grammar itself: LALR(1) without conflicts, and operator precedence as documented."""

from importlib import resources

import pytest
from lark import Lark

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.parser import parse_expression


def test_grammar_has_no_conflicts_in_strict_mode():
    grammar = resources.files("rapid_dsl.grammar").joinpath("rapid.lark").read_text("utf-8")
    # strict mode turns shift/reduce conflicts and terminal collisions into errors
    Lark(grammar, parser="lalr", start=["start", "expr_only", "type_only"], strict=True)


def _shape(node: object) -> str:
    match node:
        case ast.Name(name=name):
            return name
        case ast.Number(text=text):
            return text
        case ast.Unary(op=op, operand=operand):
            return f"({op} {_shape(operand)})"
        case (ast.Binary(op=op, left=left, right=right)
              | ast.Compare(op=op, left=left, right=right)
              | ast.Logic(op=op, left=left, right=right)):
            return f"({_shape(left)} {op} {_shape(right)})"
    raise AssertionError(node)


@pytest.mark.parametrize(("text", "shape"), [
    ("a + b * c", "(a + (b * c))"),
    ("a - b - c", "((a - b) - c)"),
    ("a / b * c", "((a / b) * c)"),
    ("-a ^ 2", "(- (a ^ 2))"),
    ("-a * b", "((- a) * b)"),
    ("a ^ b ^ c", "(a ^ (b ^ c))"),
    ("2 ^ -1", "(2 ^ (- 1))"),
    ("not a < b", "(not (a < b))"),
    ("not a and b", "((not a) and b)"),
    ("a or b and c", "(a or (b and c))"),
    ("a + b < c * d", "((a + b) < (c * d))"),
    ("(a + b) * c", "((a + b) * c)"),
])
def test_operator_precedence(text, shape):
    node, diagnostics = parse_expression(text, "x.rapid")
    assert not diagnostics
    assert _shape(node) == shape


def test_comparisons_do_not_chain():
    _, diagnostics = parse_expression("a < b < c", "x.rapid")
    assert [d.code for d in diagnostics] == ["E0101"]
    assert diagnostics[0].span.col == 7


def test_spans_of_operator_chains_cover_parentheses_but_operands_keep_their_own():
    node, _ = parse_expression("(a + b) * c", "x.rapid")
    assert (node.span.col, node.span.end_col) == (1, 12)
    assert (node.left.span.col, node.left.span.end_col) == (2, 7)
