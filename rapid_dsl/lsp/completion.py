"""Completion: what may be written at the cursor, chosen from the text before it on its line and the
declaration around it. Builtins come from the registry, stdlib names from the standard-library
folder, roles, params, resolved features, lets and keypoints from the declaration, primitives
and functions from the document's top level (its own and `use`d), keywords from the grammar.

While the user types, the text often does not parse: the model is then the newest one whose text
did, so names may come from a few keystrokes ago.
"""

from __future__ import annotations

import re

from lsprotocol import types

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.check.signatures import TYPE_NAMES
from rapid_dsl.frontend.formatter import format_type
from rapid_dsl.frontend.highlight import KEYWORDS
from rapid_dsl.frontend.modules import Stdlib
from rapid_dsl.frontend.types import Quantity
from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.language.units import UNITS, si_unit
from rapid_dsl.lsp import describe
from rapid_dsl.lsp.model import Model
from rapid_dsl.lsp.names import declaration_at, scope_at

Kind = types.CompletionItemKind
_STDLIB = re.compile(r"\buse\s*:?\s*[\"']?stdlib\s*\.\s*(\{[\w\s,]*)?\w*$")
_PHASE_PRIMITIVE = re.compile(r"\bphase\s+\w+\s*:\s*\w*$")
_YAML_PRIMITIVE = re.compile(r"^\s+(-\s+)?primitive\s*:\s*[\"']?\w*$")
_ROLE_MAP = re.compile(r"\bphase\s+\w+\s*:\s*(\w+)\s*\(([^()]*)$")
_COMPONENT = re.compile(r"[A-Za-z_)\]]\s*\.\s*\w*$")
_NUMBER = re.compile(r"(?<![\w.])(\d+\.?\d*|\.\d+)([eE][-+]?\d+)?[A-Za-z_]*$")
_TYPE_WORD = re.compile(r"[A-Z]\w*$")
_AFTER_COLON = re.compile(r"\b[a-z_]\w*\s*:\s*$")
_LINE_START = re.compile(r"^\s*\w*$")
_EXPRESSION_KEYWORDS = ("if", "then", "else", "and", "or", "not")
_KINDS = {"role": "role", "param": "param", "feature": "resolved feature", "let": "let",
          "keypoint": "keypoint", "local": "parameter", "solve_var": "solve variable"}


def complete(model: Model | None, before: str, line: int, col: int, *, yaml: bool
             ) -> list[types.CompletionItem]:
    """Items for the project's (line, column), `before` being its line's text up to there."""
    if _STDLIB.search(before):
        return [_item(n, Kind.Module, "standard-library primitive") for n in Stdlib().names()]
    if _COMPONENT.search(before) and not _NUMBER.search(before):
        return [_item(c, Kind.Field, "vector component") for c in ("x", "y", "z")]
    if _NUMBER.search(before):
        return [_item(u, Kind.Unit, f"{describe.type_text(_quantity(u))}, "
                      f"{factor:g} {si_unit(dim)}") for u, (dim, factor) in UNITS.items()]
    if _TYPE_WORD.search(before) or not yaml and _AFTER_COLON.search(before) \
            and not _PHASE_PRIMITIVE.search(before):
        return [_item(t, Kind.Class, "type") for t in TYPE_NAMES]
    if _PHASE_PRIMITIVE.search(before) or yaml and _YAML_PRIMITIVE.search(before):
        return _primitives(model)
    module = model.module if model is not None else None
    decl = declaration_at(module, line, col) if module is not None else None
    role_map = _ROLE_MAP.search(before) if not yaml else None
    if role_map is not None and model is not None:
        return _role_map(model, decl, role_map.group(1), role_map.group(2), line, col)
    if model is not None and isinstance(decl, ast.Strategy) and _LINE_START.search(before):
        phase = _phase_block(decl, line)
        if phase is not None:
            return _params(model, phase.primitive.name)
    items = _locals(decl, line, col) + _functions(model) + _builtins()
    words = _EXPRESSION_KEYWORDS if yaml or not _LINE_START.search(before) else KEYWORDS
    return items + [_item(k, Kind.Keyword, "keyword", sort="3") for k in words]


def _item(label: str, kind: types.CompletionItemKind, detail: str, *, sort: str = "1",
          insert: str | None = None, doc: str | None = None) -> types.CompletionItem:
    return types.CompletionItem(
        label, kind=kind, detail=detail, sort_text=f"{sort}{label}", insert_text=insert,
        documentation=types.MarkupContent(types.MarkupKind.Markdown, doc) if doc else None)


def _quantity(unit: str) -> Quantity:
    return Quantity(UNITS[unit][0])


def _builtins() -> list[types.CompletionItem]:
    return [_item(b.name, Kind.Constant if b.kind == "constant" else Kind.Function, b.signature,
                  sort="2", doc=describe.builtin(b)) for b in BUILTINS.values()]


def _functions(model: Model | None) -> list[types.CompletionItem]:
    if model is None or model.graph is None:
        return []
    out = []
    for name, entry in model.graph.scope(model.graph.root).items():
        if isinstance(entry.decl, (ast.DefDecl, ast.RelationDecl)):
            kind = "relation" if isinstance(entry.decl, ast.RelationDecl) else "def"
            out.append(_item(name, Kind.Function, kind, doc=describe.declaration(entry.decl)))
    return out


def _primitives(model: Model | None) -> list[types.CompletionItem]:
    if model is None or model.graph is None:
        return []
    return [_item(name, Kind.Class, "primitive", doc=describe.declaration(entry.decl))
            for name, entry in model.graph.scope(model.graph.root).items()
            if isinstance(entry.decl, ast.Primitive)]


def _locals(decl: ast.Decl | None, line: int, col: int) -> list[types.CompletionItem]:
    if decl is None:
        return []
    out = []
    for name, o in scope_at(decl, line, col).items():
        detail = _KINDS[o.role] + (f": {format_type(o.type)}" if o.type is not None else "")
        out.append(_item(name, Kind.Variable, detail, sort="0"))
    return out


def _role_map(model: Model, decl: ast.Decl | None, primitive: str, inside: str, line: int,
              col: int) -> list[types.CompletionItem]:
    """In `phase p: prim(...`: the primitive's roles, or after `=` the strategy's."""
    segment = inside.rsplit(",", 1)[-1]
    if "=" in segment:
        if decl is None:
            return []
        return [i for i in _locals(decl, line, col) if i.detail and i.detail.startswith("role")]
    entry = model.entry(primitive)
    if entry is None or not isinstance(entry.decl, ast.Primitive):
        return []
    return [_item(r.name.name, Kind.Field, f"role of {primitive}: {format_type(r.type)}",
                  sort="0", insert=f"{r.name.name}=") for r in describe.roles(entry.decl)]


def _phase_block(strategy: ast.Strategy, line: int) -> ast.Phase | None:
    """The phase whose argument block holds `line` (below the phase's own first line)."""
    for block in strategy.blocks:
        if isinstance(block, ast.Phase) and block.span.line < line <= block.span.end_line:
            return block
    return None


def _params(model: Model, primitive: str) -> list[types.CompletionItem]:
    entry = model.entry(primitive)
    if entry is None or not isinstance(entry.decl, ast.Primitive):
        return []
    return [_item(p.name.name, Kind.Field, f"param of {primitive}: {describe.param(p)}",
                  sort="0", insert=f"{p.name.name} = ") for p in describe.params(entry.decl)]

