"""Python literal text for the plan: calls and tuples laid out on one line when they fit.

Used by `lower` to render the objects a generated module builds (`RT.Primitive(...)` and the like),
so that layout is decided in Python and the template only interpolates lines.
"""

from __future__ import annotations

import json
from dataclasses import dataclass

WIDTH = 100          # the project's line length
INDENT = "    "


@dataclass(frozen=True, slots=True)
class Raw:
    """Python text used as it is."""

    text: str


@dataclass(frozen=True, slots=True)
class Call:
    function: str
    args: tuple[Node | str, ...] = ()
    kwargs: tuple[tuple[str, Node | str], ...] = ()


@dataclass(frozen=True, slots=True)
class Tuple:
    items: tuple[Node | str, ...]


Node = Raw | Call | Tuple


def literal(value: str) -> str:
    """A Python string literal in double quotes.

    >>> literal('say "hi"')
    '"say \\\\"hi\\\\""'
    """
    return json.dumps(value, ensure_ascii=False)


def render_assignment(name: str, value: Node) -> tuple[str, ...]:
    """`name = value` as lines."""
    lines = _render(value, indent=0, column=len(name) + 3)
    return (f"{name} = {lines[0]}", *lines[1:])


def _flat(node: Node | str) -> str:
    match node:
        case str():
            return node
        case Raw(text=text):
            return text
        case Call(function=function, args=args, kwargs=kwargs):
            parts = [_flat(a) for a in args] + [f"{k}={_flat(v)}" for k, v in kwargs]
            return f"{function}({', '.join(parts)})"
        case Tuple(items=items):
            if len(items) == 1:
                return f"({_flat(items[0])},)"
            return f"({', '.join(_flat(i) for i in items)})"


def _render(node: Node | str, *, indent: int, column: int) -> list[str]:
    """Lines of `node`, whose first character is at `column` and whose continuation lines start
    at `indent` (both absolute); the first line is returned without leading spaces."""
    flat = _flat(node)
    if column + len(flat) <= WIDTH or isinstance(node, str | Raw):
        return [flat]
    if isinstance(node, Call):
        parts: list[tuple[str, Node | str]] = [("", a) for a in node.args]
        parts += [(f"{k}=", v) for k, v in node.kwargs]
        opener = f"{node.function}("
    else:
        parts = [("", i) for i in node.items]
        opener = "("
    inner_indent = indent + len(INDENT)
    lines = [opener]
    for prefix, part in parts:
        inner = _render(part, indent=inner_indent, column=inner_indent + len(prefix))
        lines.append(f"{' ' * inner_indent}{prefix}{inner[0]}")
        lines += inner[1:]
        lines[-1] += ","
    lines.append(" " * indent + ")")
    return lines
