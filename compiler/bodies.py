"""Function bodies of a generated module: their lines, scope and what they read.

`Body` collects the lines of one generated function; each line of code carries the notes of the
constants lowered for it (their source forms, `# 15deg`). The helpers render the `return`
statements that end the generated functions.
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Protocol

from rapid_dsl.compiler.constants import number, source_form
from rapid_dsl.compiler.expressions import Expressions, Scope, Uses
from rapid_dsl.compiler.pretty import Raw, literal
from rapid_dsl.compiler.sources import SourceFiles
from rapid_dsl.frontend import ir
from rapid_dsl.language.diagnostics import Span
from rapid_dsl.language.units import Dim


class ModuleNames(Protocol):
    """What a body needs from the module being lowered."""

    global_names: set[str]
    function_names: dict[str, str]
    definitions: dict[str, ir.Function]
    files: SourceFiles


@dataclass(frozen=True, slots=True)
class Part:
    """Lowered text for a line written later: the temporaries it reads, and its note."""

    text: str
    temps: tuple[str, ...] = ()
    note: str = ""


class Body:
    """Lines of one function body plus what they read."""

    def __init__(self, module: ModuleNames, locals_: Iterable[tuple[str, str]], *,
                 features: Mapping[str, ir.Expr] | None = None) -> None:
        self.scope = Scope(module.global_names)
        for kind, name in locals_:
            self.scope.bind(kind, name)
        self.uses = Uses()
        self.lines: list[str] = []
        self.defined: set[tuple[str, str]] = set()
        self.x = Expressions(self.scope, self.uses, module.function_names,
                              module.definitions, features=features)
        self.files = module.files

    def marker(self, span: Span) -> None:
        self.lines.append(self.files.marker(span))

    def line(self, text: str) -> None:
        """A line of code, after the temporaries it reads, with the notes of its constants."""
        temps, note = self.x.take()
        self.lines += [*temps, text + note]

    def part(self, text: str) -> Part:
        """`text` (just lowered) with what it needs, for `returned_dict` or `returned_tuple`."""
        return Part(text, *self.x.take())

    def assign(self, kind: str, name: str, text: str, span: Span) -> str:
        self.marker(span)
        ident = self.scope[(kind, name)]
        self.line(f"{ident} = {text}")
        self.defined.add((kind, name))
        return ident

    def prologue(self, order: Iterable[tuple[str, str]]) -> list[str]:
        """Unpacking lines for what the body used: `target = C.roles["target"]`, ..."""
        lines = []
        if self.uses.frames or self.uses.start:
            lines.append("F = C.frames")
        if self.uses.start:
            lines.append("F0 = F.first()")
        for kind, name in order:
            if (kind, name) in self.uses.refs and (kind, name) not in self.defined:
                lines.append(f"{self.scope[(kind, name)]} = {_SOURCES[kind]}[{literal(name)}]")
        return lines


_SOURCES = {"role": "C.roles", "param": "C.params", "feature": "C.features", "let": "C.lets"}


def returned_dict(items: list[tuple[str, Part]]) -> list[str]:
    """`return {"key": value, ...}` from (key, value), after the values' temporaries."""
    if not items:
        return ["return {}"]
    temps = [t for _, part in items for t in part.temps]
    return [*temps, "return {", *(f"    {literal(k)}: {p.text},{p.note}" for k, p in items), "}"]


def returned_tuple(items: list[tuple[str, Part]]) -> list[str]:
    """`return (` clause, clause, `)` from (marker, clause): each under its marker, as are the
    temporaries a clause reads (before the `return`)."""
    lines = []
    for marker_line, part in items:
        if part.temps:
            lines += [marker_line, *part.temps]
    lines.append("return (")
    for marker_line, part in items:
        lines += [f"    {marker_line}", f"    {part.text},{part.note}"]
    return lines + [")"]


def names(items: Iterable[tuple[str, str]]) -> list[tuple[str, Part]]:
    """(key, name) pairs as `returned_dict` items: names need no temporaries or notes."""
    return [(key, Part(name)) for key, name in items]


def quantity(value: float, dim: Dim) -> Raw:
    """A number the plan states directly (a range, a spread), noted in its source form."""
    return Raw(number(value), source_form(value, dim))
