"""Source snippets and unit suggestions for messages."""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable
from functools import lru_cache
from itertools import islice

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.modules import did_you_mean
from rapid_dsl.language.diagnostics import Span
from rapid_dsl.language.units import ANGLE, FORCE, LENGTH, MASS, TIME, Dim


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


def listing(names: Iterable[str], limit: int = 12) -> str:
    """`a`, `b`, `c` for a message; a long list ends in `...`, so a message stays short however
    many names a declaration has."""
    shown = [f"`{name}`" for name in islice(names, limit + 1)]
    return ", ".join(shown[:limit]) + (", ..." if len(shown) > limit else "")


class Hints:
    """Help lines that search the names of a scope (`did you mean ...?`, `names here: ...`),
    for a bounded number of diagnostics per file: each costs the size of the scope, so thousands
    of unknown names in a scope of thousands would otherwise take quadratic time. Past the budget
    a diagnostic gets `fallback` instead."""

    def __init__(self, budget: int = 100) -> None:
        self.left = budget

    def __call__(self, make: Callable[[], str | None], fallback: str | None = None) -> str | None:
        if self.left <= 0:
            return fallback
        self.left -= 1
        return make()


def suggest(name: str, candidates: Iterable[str]) -> str:
    """`did you mean `x`? ` (with the space) or nothing."""
    hint = did_you_mean(name, candidates)
    return hint + " " if hint else ""
