"""Hover: the type and dimension of the expression under the cursor, the signature and
documentation of a builtin (from the registry), and what a declared name is.
"""

from __future__ import annotations

import os

from rapid_dsl.frontend import ir
from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.formatter import format_type
from rapid_dsl.frontend.types import Type
from rapid_dsl.language.diagnostics import Span
from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.lsp import describe
from rapid_dsl.lsp.model import Model
from rapid_dsl.lsp.names import Occurrence, contains, excerpt, occurrence_at, scope_at

_KINDS = {"role": "role", "param": "param", "feature": "resolved feature", "let": "let",
          "keypoint": "keypoint", "local": "parameter", "solve_var": "solve variable"}


def hover(model: Model, line: int, col: int) -> tuple[str, Span] | None:
    """Markdown for the position (the project's line and column) and the span it is about."""
    module = model.module
    if module is None:
        return None
    found = occurrence_at(module, model.text, line, col)
    if found is not None:
        content = _name(model, found, line, col)
        if content:
            return content, found.name.span
    node = _innermost(model, line, col)
    if node is None:
        return None
    return f"{describe.quote(excerpt(model.text, node.span))}: {describe.type_text(node.type)}", \
        node.span


def _name(model: Model, o: Occurrence, line: int, col: int) -> str | None:
    name = o.name.name
    match o.role:
        case "call":
            return _call(model, o)
        case "value":
            declared = scope_at(o.owner, line, col).get(name)
            if declared is not None:
                return _declared(model, declared, _type_at(model, o.name.span))
            builtin = BUILTINS.get(name)
            return describe.builtin(builtin) if builtin is not None else None
        case "decl" | "primitive" | "stdlib":
            return _entry(model, name)
        case "phase":
            return f"phase {describe.quote(name)}, which runs {describe.quote(o.context or '')}"
        case "binding_role" | "argument":
            return _member(model, o)
        case "binding_target":
            declared = scope_at(o.owner, line, col).get(name)
            return _declared(model, declared, None) if declared is not None else None
        case "keyword":
            return _keyword(model, o)
    return _declared(model, o, _declared_type(model, o))


def _call(model: Model, o: Occurrence) -> str | None:
    name = o.name.name
    entry = model.entry(name)
    if entry is not None and isinstance(entry.decl, (ast.DefDecl, ast.RelationDecl)):
        text = _entry(model, name)
    elif name in BUILTINS:
        text = describe.builtin(BUILTINS[name])
    elif name == "start":
        text = describe.code("start(e)") + "\n\nThe value of `e` at the running primitive's " \
            "first step."
    else:
        return None
    call = _call_node(model, o.name.span)
    if call is not None and text is not None:
        text += f"\n\nThis call: {describe.type_text(call.type)}"
    return text


def _entry(model: Model, name: str) -> str | None:
    entry = model.entry(name)
    if entry is None:
        return None
    where = None if model.graph is None or entry.file is model.graph.root else entry.file.path
    if where is not None and os.path.isabs(where):
        where = os.path.relpath(where, os.path.dirname(model.path))
    return describe.declaration(entry.decl, where)


def _member(model: Model, o: Occurrence) -> str | None:
    """A role or param of the primitive a phase runs."""
    entry = model.entry(o.context or "")
    if entry is None or not isinstance(entry.decl, ast.Primitive):
        return None
    primitive = entry.decl
    if o.role == "binding_role":
        role = next((r for r in describe.roles(primitive) if r.name.name == o.name.name), None)
        if role is None:
            return None
        return describe.code(f"role {describe.typed_names((role,))}") + \
            f"\n\nrole of {describe.quote(primitive.name.name)}"
    param = next((p for p in describe.params(primitive) if p.name.name == o.name.name), None)
    if param is None:
        return None
    return describe.code(f"param {describe.param(param)}") + \
        f"\n\nparam of {describe.quote(primitive.name.name)}"


def _keyword(model: Model, o: Occurrence) -> str | None:
    callee = o.context or ""
    entry = model.entry(callee)
    if entry is not None and isinstance(entry.decl, (ast.DefDecl, ast.RelationDecl)):
        for p in entry.decl.params:
            if p.name.name == o.name.name:
                return describe.code(describe.typed_names((p,))) + \
                    f"\n\nparameter of {describe.quote(callee)}"
        return None
    builtin = BUILTINS.get(callee)
    if builtin is None:
        return None
    for bp in builtin.params:
        if bp.name == o.name.name:
            return describe.code(f"{bp.name}: {bp.type}") + \
                f"\n\nparameter of {describe.quote(callee)}"
    return None


def _declared(model: Model, o: Occurrence, t: Type | None) -> str:
    kind = _KINDS.get(o.role, o.role)
    written = o.type
    if o.role == "param" and model.module is not None:
        decl = o.owner
        if isinstance(decl, ast.Primitive):
            found = next((p for p in describe.params(decl) if p.name == o.name), None)
            if found is not None:
                return describe.code(f"param {describe.param(found)}") + \
                    (f"\n\n{describe.type_text(t)}" if t is not None else "")
    head = f"{kind} {o.name.name}"
    if written is not None:
        head += f": {format_type(written)}"
    elif t is not None:
        head += f": {t}"
    return describe.code(head) + (f"\n\n{describe.type_text(t)}" if t is not None else "")


def _declared_type(model: Model, o: Occurrence) -> Type | None:
    """The checked type of a declared name: from a reference to it, or its defining expression."""
    program = model.program
    if program is None:
        return None
    owner = o.owner.name.name if not isinstance(o.owner, ast.Use) else ""
    if o.role == "feature":
        for p in program.primitives:
            if p.path == model.path and p.name == owner:
                return next((f.expr.type for f in p.features if f.name == o.name.name), None)
    if o.role == "let":
        for s in program.strategies:
            if s.path == model.path and s.name == owner:
                return next((let.expr.type for let in s.lets if let.name == o.name.name), None)
    if o.role in ("role", "param", "keypoint", "local", "solve_var"):
        return _reference_type(model, o)
    return None


def _reference_type(model: Model, o: Occurrence) -> Type | None:
    """The type the checker gave a reference to the declared name inside its declaration."""
    owner = o.owner.span
    for node in model.expressions():
        if isinstance(node, ir.Ref) and node.name == o.name.name and \
                contains(owner, node.span.line, node.span.col):
            return node.type
    return None


def _type_at(model: Model, span: Span) -> Type | None:
    for node in model.expressions():
        if isinstance(node, ir.Ref) and (node.span.line, node.span.col) == (span.line, span.col):
            return node.type
    return None


def _call_node(model: Model, name: Span) -> ir.Expr | None:
    for node in model.expressions():
        if isinstance(node, (ir.BuiltinCall, ir.UserCall, ir.Start)) and \
                (node.span.line, node.span.col) == (name.line, name.col):
            return node
    return None


def _innermost(model: Model, line: int, col: int) -> ir.Expr | None:
    """The smallest typed expression around the position: the latest start, then earliest end."""
    best: ir.Expr | None = None
    for node in model.expressions():
        s = node.span
        if not (s.line, s.col) <= (line, col) < (s.end_line, s.end_col):
            continue
        if best is None or (s.line, s.col) > (best.span.line, best.span.col) or \
                (s.line, s.col) == (best.span.line, best.span.col) and \
                (s.end_line, s.end_col) < (best.span.end_line, best.span.end_col):
            best = node
    return best
