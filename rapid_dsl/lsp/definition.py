"""Go to definition: where the name under the cursor is declared, in the document or in a file it
`use`s (the module graph knows which file each top-level name comes from).
"""

from __future__ import annotations

import os
from dataclasses import dataclass

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.language.diagnostics import Span
from rapid_dsl.lsp import describe
from rapid_dsl.lsp.model import Model
from rapid_dsl.lsp.names import DECLARING, occurrence_at, scope_at, use_at

_FILE_START = Span("", 0, 0, 1, 1, 1, 1)


@dataclass(frozen=True, slots=True)
class Target:
    path: str       # the file as the checker names it (the document's own path, or a used file's)
    span: Span


def definition(model: Model, line: int, col: int) -> Target | None:
    """The declaration of what is at the project's (line, column) in the document."""
    module = model.module
    if module is None:
        return None
    use = use_at(module, line, col)
    if use is not None:
        return _used_file(model, use)
    o = occurrence_at(module, model.text, line, col)
    if o is None:
        return None
    name = o.name.name
    if o.role in DECLARING or o.role in ("decl", "phase"):
        return Target(model.path, o.name.span)
    if o.role in ("value", "binding_target"):
        declared = scope_at(o.owner, line, col).get(name)
        return Target(model.path, declared.name.span) if declared is not None else None
    if o.role in ("call", "primitive", "stdlib"):
        entry = model.entry(name)
        return Target(entry.file.path, entry.decl.name.span) if entry is not None else None
    entry = model.entry(o.context or "")
    if entry is None:
        return None
    decl = entry.decl
    members: tuple[ast.Name, ...] = ()
    if o.role == "keyword" and isinstance(decl, (ast.DefDecl, ast.RelationDecl)):
        members = tuple(p.name for p in decl.params)
    elif o.role == "binding_role" and isinstance(decl, ast.Primitive):
        members = tuple(r.name for r in describe.roles(decl))
    elif o.role == "argument" and isinstance(decl, ast.Primitive):
        members = tuple(p.name for p in describe.params(decl))
    found = next((m for m in members if m.name == name), None)
    return Target(entry.file.path, found.span) if found is not None else None


def _used_file(model: Model, use: ast.Use) -> Target | None:
    """The start of the file a `use "path"` reads, if it was read."""
    graph = model.graph
    if graph is None or use.file is None:
        return None
    for entry in graph.scope(graph.root).values():
        if entry.use is use:
            return Target(entry.file.path, _FILE_START)
    # A file that declares nothing brings no entry: find it by the path the loader shows.
    shown = os.path.normpath(os.path.join(os.path.dirname(model.path), use.file))
    file = model.file(shown)
    return Target(file.path, _FILE_START) if file is not None and file is not graph.root \
        else None

