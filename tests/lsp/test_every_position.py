"""Hover, go to definition and completion at every token of the examples, the standard library and
the YAML programs of the tests, in process: none of them raises, a hover on a name of an
expression says something, and every definition is a declaration's name in a file that exists."""

from __future__ import annotations

import os
from importlib import resources
from pathlib import Path

import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from rapid_dsl.frontend.syntax import source_text
from rapid_dsl.lsp.completion import complete
from rapid_dsl.lsp.definition import definition
from rapid_dsl.lsp.hover import hover
from rapid_dsl.lsp.model import Model, build
from rapid_dsl.lsp.names import excerpt, occurrences

ROOT = Path(__file__).resolve().parents[2]
STDLIB = Path(str(resources.files("rapid_dsl.stdlib_primitives")))
FILES = sorted([*ROOT.joinpath("examples").glob("*.rapid"), *STDLIB.glob("*.rapid"),
                *ROOT.joinpath("tests", "data", "yaml").glob("*.rapid.yaml")])


def _text_of(path: str) -> str:
    if path.startswith("<stdlib>/"):
        path = str(STDLIB / path.removeprefix("<stdlib>/"))
    return source_text(Path(path).read_text(encoding="utf-8"))


@pytest.mark.slow
@pytest.mark.parametrize("path", FILES, ids=lambda p: p.name)
def test_every_name(path: Path) -> None:
    text = source_text(path.read_text(encoding="utf-8"))
    model = build(text, str(path))
    assert model.module is not None and model.program is not None
    lines = text.split("\n")
    for decl in model.module.decls:
        for o in occurrences(decl):
            span = o.name.span
            line, col = span.line, span.col
            if o.role == "stdlib" and path.name.endswith(".yaml"):   # the whole `use:` value
                col += excerpt(text, span).index(o.name.name)
            else:
                assert excerpt(text, span) == o.name.name     # exact, in YAML too
            found = hover(model, line, col)
            if o.role in ("value", "call", "primitive", "stdlib", "role", "param", "feature"):
                assert found is not None, (o.role, o.name.name, span.line)
            target = definition(model, line, col)
            if target is not None:
                source = text if target.path == str(path) else _text_of(target.path)
                assert excerpt(source, target.span) in (o.name.name, ""), (o, target)
            before = lines[line - 1][:col - 1]
            assert isinstance(complete(model, before, line, col,
                                       yaml=str(path).endswith(".yaml")), list)


_models: dict[Path, Model] = {}


@settings(max_examples=60, deadline=None)
@given(st.sampled_from(FILES), st.integers(0, 10_000), st.integers(-2, 200))
def test_any_position(path: Path, line_seed: int, col: int) -> None:
    """Positions anywhere, past the ends of lines and files included."""
    text = source_text(path.read_text(encoding="utf-8"))
    model = _models.setdefault(path, build(text, str(path)))
    lines = text.split("\n")
    line = line_seed % (len(lines) + 2)
    hover(model, line, col)
    definition(model, line, col)
    before = lines[line - 1][:max(col - 1, 0)] if 1 <= line <= len(lines) else ""
    complete(model, before, line, col, yaml=os.fspath(path).endswith(".yaml"))

