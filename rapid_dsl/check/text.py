"""Source snippets and unit suggestions for messages."""

from __future__ import annotations

import math
from functools import lru_cache

from rapid_dsl import syntax as ast
from rapid_dsl.diagnostics import Span
from rapid_dsl.runtime.units import ANGLE, FORCE, LENGTH, MASS, TIME, Dim


@lru_cache(maxsize=8)
def _lines(text: str) -> list[str]:
    return text.split("\n")


def snippet(text: str, span: Span) -> str:
    """The source text under `span`, found by line and column (right for YAML-embedded code too)."""
    lines = _lines(text)
    if not 1 <= span.line <= len(lines) or span.end_line < span.line:
        return ""
    if span.line == span.end_line:
        return lines[span.line - 1][span.col - 1: span.end_col - 1]
    parts = [lines[span.line - 1][span.col - 1:]]
    parts += lines[span.line: span.end_line - 1]
    if span.end_line <= len(lines):
        parts.append(lines[span.end_line - 1][: span.end_col - 1])
    return "\n".join(parts)


def short(text: str, span: Span, limit: int = 30) -> str | None:
    """A one-line snippet short enough to quote in a message, else None."""
    s = snippet(text, span).strip()
    return s if s and "\n" not in s and len(s) <= limit else None


def bare_number(node: ast.Expr) -> ast.Number | None:
    """`2` or `-2` written without a unit."""
    if isinstance(node, ast.Unary) and node.op == "-":
        inner = bare_number(node.operand)
        return inner
    if isinstance(node, ast.Number) and node.unit is None:
        return node
    return None


def _fmt(x: float) -> str:
    return f"{x:.6g}"


def with_unit(node: ast.Expr, dim: Dim) -> str | None:
    """How to write the bare number `node` as a quantity of `dim`: `2` -> `2cm`, `0.05` -> `5cm`.

    A number below 1 compared with a length was most likely meant in metres, a larger one in
    centimetres; angles up to 2*pi likely radians, larger ones degrees.
    """
    number = bare_number(node)
    if number is None:
        return None
    sign = "-" if isinstance(node, ast.Unary) else ""
    v = number.value
    if dim == LENGTH:
        if 0 < v < 1:
            return sign + (_fmt(v * 100) + "cm" if v >= 0.01 else _fmt(v * 1000) + "mm")
        return f"{sign}{number.text}cm"
    if dim == ANGLE:
        return f"{sign}{number.text}" + ("rad" if v <= 2 * math.pi else "deg")
    for unit_dim, unit in ((TIME, "s"), (MASS, "kg"), (FORCE, "N")):
        if dim == unit_dim:
            return f"{sign}{number.text}{unit}"
    return None
