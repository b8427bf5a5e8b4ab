"""The checker's diagnostics as LSP diagnostics of one document: range, severity, code, message
with the label and help, and related locations.

A diagnostic in a file the document `use`s (directly or through other files) is shown at the
document's `use` that brings that file in, its message saying where it is, with the exact place as
related information (editors make it a link): the editor shows each document's own diagnostics,
and the used file may not be open.
"""

from __future__ import annotations

import os
from collections.abc import Callable

from lsprotocol import types

from rapid_dsl.frontend import syntax as ast
from rapid_dsl.frontend.driver import CheckResult, parse_source
from rapid_dsl.frontend.modules import STDLIB_PREFIX
from rapid_dsl.language.diagnostics import Diagnostic, Severity, Span
from rapid_dsl.lsp.positions import Text

SOURCE = "rapidc"
_SEVERITY = {Severity.ERROR: types.DiagnosticSeverity.Error,
             Severity.WARNING: types.DiagnosticSeverity.Warning,
             Severity.NOTE: types.DiagnosticSeverity.Information}


def to_lsp(result: CheckResult, path: str, lines: Text,
           uri_of: Callable[[str], str | None]) -> list[types.Diagnostic]:
    """The diagnostics of checking the document named `path` whose editor text is `lines`."""
    anchors: dict[str, Span] | None = None
    out = []
    for d in result.diagnostics:
        message = _message(d)
        if d.span.path == path:
            where = lines.range(d.span)
        else:
            if anchors is None:
                anchors = _use_anchors(result, path)
            anchor = anchors.get(d.span.path)
            where = lines.range(anchor) if anchor is not None else \
                types.Range(types.Position(0, 0), types.Position(0, 0))
            message = f"{_shown(d.span.path, path)}:{d.span.line}:{d.span.col}: {message}"
        related = [(text, span) for text, span in d.related]
        if d.span.path != path:
            related.insert(0, ("here", d.span))
        out.append(types.Diagnostic(
            where, message, severity=_SEVERITY[d.severity], code=d.code, source=SOURCE,
            related_information=[info for info in (_related(result, path, lines, uri_of, t, s)
                                                   for t, s in related) if info is not None]
            or None))
    return out


def not_checked(message: str) -> list[types.Diagnostic]:
    """The one diagnostic of a document that is not checked, at its start."""
    start = types.Position(0, 0)
    return [types.Diagnostic(types.Range(start, start), message,
                             severity=types.DiagnosticSeverity.Error, source=SOURCE)]


def _message(d: Diagnostic) -> str:
    parts = [d.message]
    if d.label:
        parts.append(d.label)
    if d.help:
        parts.append(f"help: {d.help}")
    return "\n".join(parts)


def _related(result: CheckResult, path: str, lines: Text, uri_of: Callable[[str], str | None],
             text: str, span: Span) -> types.DiagnosticRelatedInformation | None:
    uri = uri_of(span.path)
    if uri is None:
        return None
    if span.path == path:
        where = lines.range(span)
    else:
        source = result.sources.get(span.path)
        if source is None:
            return None
        where = Text(source, lines.encoding).range(span)
    return types.DiagnosticRelatedInformation(types.Location(uri, where), text)


def _shown(target: str, path: str) -> str:
    if os.path.isabs(target):
        return os.path.relpath(target, os.path.dirname(path))
    return target


def _use_anchors(result: CheckResult, root: str) -> dict[str, Span]:
    """Each file the check read -> the span of the root's `use` that brought it in (first found,
    breadth first). Parsing is cached, so this repeats no work for `.rapid` files."""
    anchors: dict[str, Span] = {}
    queue: list[tuple[str, Span | None]] = [(root, None)]
    for path, anchor in queue:
        text = result.sources.get(path)
        if text is None:
            continue
        module, _ = parse_source(text, path)
        for decl in module.decls if module is not None else ():
            if not isinstance(decl, ast.Use):
                continue
            for target in _targets(path, decl):
                if target != root and target not in anchors:
                    anchors[target] = anchor or decl.span
                    queue.append((target, anchors[target]))
    return anchors


def _targets(path: str, use: ast.Use) -> list[str]:
    """The names the module loader gives the files a `use` reads (modules.py, `shown`)."""
    if use.file is not None:
        if "\0" in use.file:
            return []
        return [os.path.normpath(os.path.join(os.path.dirname(path), use.file))]
    if use.module == ("stdlib",):
        return [f"{STDLIB_PREFIX}/{name.name}.rapid" for name in use.names]
    return []
