"""How deeply a declaration's expressions nest, measured without recursion.

The checker (and the compiler after it) walk expressions recursively; a cap on the depth turns
absurd input (a sum of thousands of terms, `- - - ... x`) into one diagnostic instead of a
RecursionError.
"""

from __future__ import annotations

import dataclasses
from functools import cache

from rapid_dsl import syntax as ast

MAX_DEPTH = 400  # nesting levels of one expression; real programs stay below 20

_EXPR_TYPES = (ast.Name, ast.Number, ast.Vector, ast.Unary, ast.Binary, ast.Compare, ast.Logic,
               ast.IfExpr, ast.Call, ast.Component)


@cache
def _node_fields(kind: type) -> tuple[str, ...]:
    return tuple(f.name for f in dataclasses.fields(kind) if f.name != "span")


def too_deep(root: object) -> ast.Expr | None:
    """The outermost expression under `root` that nests deeper than MAX_DEPTH, if any."""
    stack: list[tuple[object, int, ast.Expr | None]] = [(root, 0, None)]
    while stack:
        node, depth, top = stack.pop()
        if isinstance(node, _EXPR_TYPES):
            top = top or node
            depth += 1
            if depth > MAX_DEPTH:
                return top
        elif not isinstance(node, ast.Arg):
            top, depth = None, 0  # a block or declaration: its expressions start afresh
        for name in _node_fields(type(node)):
            value = getattr(node, name)
            items = value if isinstance(value, tuple) else (value,)
            for item in items:
                if dataclasses.is_dataclass(item) and not isinstance(item, type):
                    stack.append((item, depth, top))
    return None
