"""The server's resources: what an agent reads to write programs.

- `rapid://card`: the language card (rapid_dsl/frontend/card.py, as `rapidc guide` prints it);
- `rapid://language`: the language reference, docs/language.md (in a source checkout);
- `rapid://builtins`: the builtin registry (rapid_dsl/language/registry.py) as JSON;
- `rapid://stdlib/NAME`: each standard primitive's source;
- `rapid://diagnostics`: every diagnostic code and its title (codes.py) as JSON, and
  `rapid://diagnostics.md`, docs/diagnostics.md with an example and a fix for each (a checkout).

Texts are made when read, from the same tables the compiler uses.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from functools import partial
from pathlib import Path


@dataclass(frozen=True, slots=True)
class Entry:
    uri: str
    name: str
    description: str
    mime_type: str
    read: Callable[[], str]


def entries() -> list[Entry]:
    from rapid_dsl.frontend.card import card, stdlib_sources

    found = [
        Entry("rapid://card", "card", "The language card: syntax, kinds, units, builtins, the "
              "standard library and common errors; read it before writing a program",
              "text/markdown", card),
        Entry("rapid://builtins", "builtins", "Every builtin function, relation and constant "
              "with its signature, as JSON", "application/json", _builtins),
        Entry("rapid://diagnostics", "diagnostics", "Every diagnostic code and its title, as "
              "JSON", "application/json", _codes),
    ]
    for name, title in (("language", "The language reference"),
                        ("diagnostics.md", "Every diagnostic code with an example and its fix")):
        page = _docs_page("language.md" if name == "language" else name)
        if page is not None:
            found.append(Entry(f"rapid://{name}", name, title, "text/markdown",
                               partial(page.read_text, encoding="utf-8")))
    for file, text in sorted(stdlib_sources().items()):
        stem = file.removesuffix(".rapid")
        found.append(Entry(f"rapid://stdlib/{stem}", f"stdlib/{stem}",
                           f"The standard primitive `{stem}` (use stdlib.{stem})", "text/plain",
                           partial(str, text)))
    return found


def find(uri: str) -> Entry | None:
    return next((e for e in entries() if e.uri == uri), None)


def _docs_page(name: str) -> Path | None:
    """docs/NAME of the source checkout this package runs from, if it does."""
    import rapid_dsl

    page = Path(rapid_dsl.__file__).resolve().parent.parent / "docs" / name
    try:
        heading = page.read_text(encoding="utf-8").partition("\n")[0]
    except OSError:
        return None
    # a `docs` folder beside an installed package may be another project's
    return page if heading.startswith(("# The RAPID language", "# Diagnostics")) else None


def _builtins() -> str:
    from rapid_dsl.language.registry import BUILTINS

    return json.dumps([{"name": b.name, "kind": b.kind, "signature": b.signature,
                        "params": [{"name": p.name, "type": p.type} for p in b.params],
                        "returns": b.returns, "symbolic": b.symbolic, "doc": b.doc}
                       for b in BUILTINS.values()], indent=1)


def _codes() -> str:
    from rapid_dsl.language.codes import CODES

    return json.dumps([{"code": code, "severity": "warning" if code.startswith("W") else "error",
                        "title": title} for code, title in CODES.items()], indent=1)
