"""The one traversal (`rapid_dsl.frontend.tree`) reaches every node of every syntax and IR tree.

Checked against a reflective walk that knows nothing of `Node.children`: it follows every
dataclass field and every tuple, however nested, so a field the traversal missed (or a child kind
it does not know) shows up as a node the two disagree on.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterator
from pathlib import Path

import pytest

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.driver import check_file
from rapid_dsl.frontend.parser import parse_module
from rapid_dsl.frontend.tree import Node, find_all, walk

ROOT = Path(__file__).resolve().parents[2]
PROGRAMS = sorted([*(ROOT / "stdlib_primitives").glob("*.rapid"),
                   *(ROOT / "examples").glob("*.rapid"),
                   *(ROOT / "tests" / "data" / "language").glob("*.rapid")])
STUBS = ROOT / "tests" / "data" / "stub_stdlib"


def _reflect(value: object) -> Iterator[Node]:
    if isinstance(value, Node):
        yield value
        for f in dataclasses.fields(value):  # type: ignore[arg-type]
            yield from _reflect(getattr(value, f.name))
    elif isinstance(value, tuple):
        for item in value:
            yield from _reflect(item)


def parse(text: str, path: str) -> ast.Module:
    module, diagnostics = parse_module(text, path)
    assert module is not None, diagnostics
    return module


def _ids(nodes: Iterator[Node]) -> list[int]:
    return sorted(id(n) for n in nodes)


@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: p.name)
def test_walk_reaches_every_syntax_and_ir_node(path: Path) -> None:
    module = parse(path.read_text(), str(path))
    assert _ids(walk(module)) == _ids(_reflect(module))
    result = check_file(str(path), stdlib=STUBS if "tests" in path.parts else None, lint=False)
    assert result.program is not None
    for decl in (*result.program.primitives, *result.program.strategies,
                 *result.program.functions):
        assert _ids(walk(decl)) == _ids(_reflect(decl))


def test_walk_is_preorder_left_to_right_and_prunes() -> None:
    module = parse("def f(x: Length) -> Length = x + start(-x) * 2\n", "t.rapid")
    body = module.decls[0].body  # type: ignore[union-attr]
    names = [type(n).__name__ for n in walk(body)]
    assert names == ["Binary", "Name", "Binary", "Call", "Name", "Arg", "Unary", "Name", "Number"]
    pruned = [type(n).__name__ for n in walk(body, into=lambda n: not isinstance(n, ast.Call))]
    assert pruned == ["Binary", "Name", "Binary", "Call", "Number"]
    assert [n.name for n in find_all(body, ast.Name)] == ["x", "start", "x"]


def test_deep_trees_do_not_recurse() -> None:
    expr: ir.Expr = ir.Ref("local", "x", None)  # type: ignore[arg-type]
    for _ in range(50_000):
        expr = ir.Unary("-", expr, None)  # type: ignore[arg-type]
    assert sum(1 for _ in walk(expr)) == 50_001
