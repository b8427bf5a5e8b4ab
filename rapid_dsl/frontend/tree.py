"""One traversal for every tree of the front end: a node's children are its fields.

Syntax nodes (`frontend.syntax`) and IR nodes (`frontend.ir`) derive from `Node`. A child is any
field value that is a `Node`, or a `Node` inside a tuple field, in field order; spans, types,
strings and numbers are not children. So a new node class, or a new field on one, is walked by
everything (checker, lint, compiler, language server) without touching a walker.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator
from dataclasses import fields
from typing import TypeVar


class Node:
    """The base of syntax and IR nodes (frozen, slotted dataclasses)."""

    __slots__ = ()

    def children(self) -> Iterator[Node]:
        for name in _child_fields(type(self)):
            value = getattr(self, name)
            if isinstance(value, Node):
                yield value
            elif isinstance(value, tuple):
                for item in value:
                    if isinstance(item, Node):
                        yield item


_FIELDS: dict[type, tuple[str, ...]] = {}


def _child_fields(cls: type) -> tuple[str, ...]:
    names = _FIELDS.get(cls)
    if names is None:
        names = _FIELDS[cls] = tuple(f.name for f in fields(cls) if f.name != "span")
    return names


N = TypeVar("N", bound=Node)


def walk(root: Node, *, into: Callable[[Node], bool] | None = None) -> Iterator[Node]:
    """Every node under `root`, `root` first, depth first and left to right. Iterative, since
    expressions nest deeply. With `into`, the children of a node for which it is false are
    skipped (the node itself is still yielded)."""
    stack: list[Node] = [root]
    while stack:
        node = stack.pop()
        yield node
        if into is None or into(node):
            stack.extend(reversed(tuple(node.children())))


def find_all(root: Node, kind: type[N]) -> Iterator[N]:
    """The nodes under `root` (itself included) that are instances of `kind`."""
    return (node for node in walk(root) if isinstance(node, kind))
