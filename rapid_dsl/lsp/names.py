"""Where names are in a syntax tree and what each one is: the occurrence under the cursor, and the
names a declaration defines, for hover, go to definition and completion.

Positions here are the project's: 1-based lines and columns in code points (positions.py converts
them). A name's span contains a position from its first character to just after its last, so a
cursor at the end of a word is on it.
"""

from __future__ import annotations

import re
from collections.abc import Iterator
from dataclasses import dataclass, replace
from typing import Literal

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.tree import walk
from rapid_dsl.language.diagnostics import Span

# What a name occurrence is. Declarations: `decl` (top-level), `role`, `param`, `feature`, `let`,
# `keypoint`, `local` (a def's or relation's parameter), `solve_var`, `phase`. References: `value`
# (a name in an expression), `call`, `keyword` (an argument name; `context` is the callee),
# `primitive` (a phase's), `binding_role` and `argument` (a phase's role map key and argument
# name; `context` is the primitive), `binding_target` (a strategy role in a role map), `stdlib`
# (a name in `use stdlib.NAME`).
Role = Literal["decl", "role", "param", "feature", "let", "keypoint", "local", "solve_var", "phase",
               "value", "call", "keyword", "primitive", "binding_role", "argument",
               "binding_target", "stdlib"]
DECLARING = frozenset({"role", "param", "feature", "let", "keypoint", "local", "solve_var"})


@dataclass(frozen=True, slots=True)
class Occurrence:
    name: ast.Name
    role: Role
    owner: ast.Decl                         # the top-level declaration it is in
    context: str | None = None              # the callee of a keyword, a phase's primitive
    solve: ast.Solve | None = None          # the `solve` a solve variable belongs to
    type: ast.TypeExpr | None = None        # the written type of a declared name


def contains(span: Span, line: int, col: int) -> bool:
    return (span.line, span.col) <= (line, col) <= (span.end_line, span.end_col)


def declaration_at(module: ast.Module, line: int, col: int) -> ast.Decl | None:
    """The top-level declaration around the position: the last one to start before it (a YAML
    item's span ends where the next one starts), or one whose lines hold it."""
    found = lines = None
    for decl in module.decls:
        if contains(decl.span, line, col):
            found = decl
        if decl.span.line <= line <= decl.span.end_line:   # past the end of one of its lines
            lines = decl
    return found or lines


def occurrence_at(module: ast.Module, text: str, line: int, col: int) -> Occurrence | None:
    """The name at the position in `text` (the module's source, as the checker reads it)."""
    decl = declaration_at(module, line, col)
    if decl is None:
        return None
    for o in occurrences(decl):
        if o.role == "stdlib":
            o = _narrowed(o, text)
        if contains(o.name.span, line, col):
            return o
    return None


def _narrowed(o: Occurrence, text: str) -> Occurrence:
    """The names of a YAML `use: stdlib.{push, flip}` all have the span of the whole value:
    each gets the span of its own word in it."""
    span = o.name.span
    written = excerpt(text, span)
    if written == o.name.name or span.line != span.end_line:
        return o
    match = re.search(rf"(?<!\w){re.escape(o.name.name)}\b(?!\s*\.)", written)
    if match is None:
        return o
    col = span.col + match.start()
    narrow = Span(span.path, span.start + match.start(), span.start + match.end(), span.line,
                  col, span.line, col + len(o.name.name))
    return replace(o, name=ast.Name(o.name.name, narrow))


def excerpt(text: str, span: Span) -> str:
    """The text of a span, by lines and columns (YAML spans have no reliable offsets)."""
    lines = text.split("\n")
    if not 1 <= span.line <= len(lines):
        return ""
    if span.end_line == span.line:
        return lines[span.line - 1][span.col - 1:span.end_col - 1]
    parts = [lines[span.line - 1][span.col - 1:]]
    parts += lines[span.line:span.end_line - 1]
    if span.end_line <= len(lines):
        parts.append(lines[span.end_line - 1][:span.end_col - 1])
    return "\n".join(parts)


def scope_at(decl: ast.Decl, line: int, col: int) -> dict[str, Occurrence]:
    """The names `decl` declares for its expressions (a solve variable only inside its solve)."""
    names: dict[str, Occurrence] = {}
    for o in occurrences(decl):
        if o.role in DECLARING and (o.solve is None or contains(o.solve.span, line, col)):
            names.setdefault(o.name.name, o)
    return names


def use_at(module: ast.Module, line: int, col: int) -> ast.Use | None:
    """The `use "file"` declaration under the position."""
    for decl in module.decls:
        if isinstance(decl, ast.Use) and decl.file is not None and contains(decl.span, line, col):
            return decl
    return None


def occurrences(decl: ast.Decl) -> Iterator[Occurrence]:
    """Every name of a top-level declaration, in source order within each block."""
    if isinstance(decl, ast.Use):
        for name in decl.names:
            yield Occurrence(name, "stdlib", decl)
        return
    yield Occurrence(decl.name, "decl", decl)
    if isinstance(decl, (ast.RelationDecl, ast.DefDecl)):
        for p in decl.params:
            yield Occurrence(p.name, "local", decl, type=p.type)
        yield from _expression(decl.body, decl)
        return
    for block in decl.blocks:
        yield from _block(block, decl)


def _block(block: ast.PrimitiveBlock | ast.StrategyBlock, owner: ast.Decl) -> Iterator[Occurrence]:
    match block:
        case ast.Roles(roles=roles):
            for r in roles:
                yield Occurrence(r.name, "role", owner, type=r.type)
        case ast.Requires(relations=exprs) | ast.Success(clauses=exprs) | ast.Filter(clauses=exprs):
            for e in exprs:
                yield from _expression(e, owner)
        case ast.Params(params=params):
            for p in params:
                yield Occurrence(p.name, "param", owner, type=p.type)
                for bound in (p.low, p.high, p.default):
                    if bound is not None:
                        yield from _expression(bound, owner)
        case ast.Resolve(features=features):
            for f in features:
                yield Occurrence(f.name, "feature", owner)
                yield from _expression(f.value, owner)
        case ast.CostFinal(expr=e):
            yield from _expression(e, owner)
        case ast.CostProgress(weight=w, expr=e):
            if w is not None:
                yield from _expression(w, owner)
            yield from _expression(e, owner)
        case ast.Motion(items=items):
            for item in items:
                if isinstance(item, ast.Keypoint):
                    yield Occurrence(item.name, "keypoint", owner)
                    for part in item.children():   # the point and each stated option
                        if part is not item.name:
                            yield from _expression(part, owner)  # type: ignore[arg-type]
                else:
                    yield from _expression(item.value, owner)
        case ast.Optimize(settings=settings):
            for s in settings:
                yield from _expression(s.value, owner)
        case ast.Let(name=name, value=e):
            yield Occurrence(name, "let", owner)
            yield from _expression(e, owner)
        case ast.Phase():
            yield from _phase(block, owner)


def _phase(phase: ast.Phase, owner: ast.Decl) -> Iterator[Occurrence]:
    primitive = phase.primitive.name
    yield Occurrence(phase.name, "phase", owner, context=primitive)
    yield Occurrence(phase.primitive, "primitive", owner)
    for binding in phase.role_map:
        yield Occurrence(binding.role, "binding_role", owner, context=primitive)
        yield Occurrence(binding.target, "binding_target", owner)
    for arg in phase.args:
        yield Occurrence(arg.name, "argument", owner, context=primitive)
        value = arg.value
        if isinstance(value, ast.Solve):
            yield Occurrence(value.var, "solve_var", owner, solve=value, type=value.type)
            for e in (value.objective, *value.constraints):
                yield from _expression(e, owner)
        else:
            yield from _expression(value, owner)


def _expression(root: ast.Expr, owner: ast.Decl) -> Iterator[Occurrence]:
    """The names of an expression, left to right. A parent comes before its children in the walk,
    so a call's name, an argument's keyword and a component's field are known as such before
    they are reached."""
    callee: dict[int, str] = {}     # id of an argument -> the function it is passed to
    not_values: set[int] = set()    # ids of names that are not references to values
    for node in walk(root):
        match node:
            case ast.Call(func=func, args=args):
                yield Occurrence(func, "call", owner)
                not_values.add(id(func))
                callee.update((id(arg), func.name) for arg in args)
            case ast.Arg(name=ast.Name() as name):
                yield Occurrence(name, "keyword", owner, context=callee[id(node)])
                not_values.add(id(name))
            case ast.Component(field=name):
                not_values.add(id(name))
            case ast.Name() if id(node) not in not_values:
                yield Occurrence(node, "value", owner)
