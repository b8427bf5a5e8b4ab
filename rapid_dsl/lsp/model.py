"""The typed model of a document: its syntax tree, the resolved `use` graph and the checker's IR,
which hover, go to definition and completion read.

It is what `driver.check_text` keeps of a document, errors and all: the syntax tree, the module
graph and the IR the checker built. It is made once per version of a document and only when a
feature asks; parsing is cached (parser.py).
"""

from __future__ import annotations

import os
from collections.abc import Iterator, Sequence
from dataclasses import dataclass

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.driver import deep_recursion, parse_source
from rapid_dsl.frontend.modules import Entry, ModuleGraph, SourceFile
from rapid_dsl.frontend.tree import walk


@dataclass(eq=False)
class Model:
    path: str                       # the document as the checker names it
    text: str                       # as the checker reads it (`syntax.source_text`)
    module: ast.Module | None       # None when the text does not parse
    graph: ModuleGraph | None       # None only when the program nests too deeply to read
    program: ir.Program | None      # what the checker built, errors and all

    def entry(self, name: str) -> Entry | None:
        """The top-level declaration `name` visible in the document (its own or `use`d)."""
        if self.graph is None:
            return None
        return self.graph.scope(self.graph.root).get(name)

    def file(self, path: str) -> SourceFile | None:
        if self.graph is None:
            return None
        return next((f for f in self.graph.files if f.path == path), None)

    def expressions(self) -> Iterator[ir.Expr]:
        """Every typed expression node of the document's own declarations."""
        program = self.program
        if program is None:
            return
        roots: list[ir.Expr | ir.Solve] = []
        for function in program.functions:
            if function.span.path == self.path:
                roots.append(function.body)
        for primitive in program.primitives:
            if primitive.path == self.path:
                roots.extend(primitive_expressions(primitive))
        for strategy in program.strategies:
            if strategy.path == self.path:
                roots.extend(strategy_expressions(strategy))
        for root in roots:
            for node in walk(root):
                if not isinstance(node, ir.Solve) and node.span.path == self.path:
                    yield node  # type: ignore[misc]


def primitive_expressions(p: ir.Primitive) -> list[ir.Expr | ir.Solve]:
    out: list[ir.Expr | ir.Solve] = [c.expr for c in (*p.requires, *p.success, *p.filter)]
    out += [param.default for param in p.params if param.default is not None]
    out += [f.expr for f in p.features]
    out += [e for e in (p.cost_final, p.cost_progress) if e is not None]
    out += [e for k in p.keypoints for e in k.children()]   # its point and stated angles
    return out


def strategy_expressions(s: ir.Strategy) -> list[ir.Expr | ir.Solve]:
    out: list[ir.Expr | ir.Solve] = [c.expr for c in (*s.requires, *s.success, *s.filter)]
    out += [let.expr for let in s.lets]
    out += [arg.value for phase in s.phases for arg in phase.args]
    return out


def parses(text: str, path: str) -> bool:
    """Does the text parse? (For `.rapid` text just checked, the parser's cache answers.)"""
    try:
        with deep_recursion():
            return parse_source(text, path)[0] is not None
    except RecursionError:
        return False


def build(text: str, path: str, allowed_dirs: Sequence[str | os.PathLike[str]] = ()) -> Model:
    """The model of `text`, named `path` (the editor's text: BOM and CR line ends are fine)."""
    from rapid_dsl.frontend.driver import check_text

    text = ast.source_text(text)
    result = check_text(text, path, allowed_dirs=allowed_dirs)
    return Model(path, text, result.module, result.graph, result.checked)
