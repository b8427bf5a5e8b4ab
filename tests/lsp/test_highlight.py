"""Highlighting: the Pygments lexer reads every example and standard-library file without an error
token, and the TextMate grammar for editors is valid JSON, made from the same rules, with a scope
for each class of word the lexer tells apart."""

from __future__ import annotations

import json
import re
from importlib import resources
from pathlib import Path

import pytest
from pygments.lexers import get_lexer_by_name, get_lexer_for_filename
from pygments.token import Comment, Error, Keyword, Number, String

from rapid_dsl.frontend.highlight import (
    KEYWORDS,
    RULES,
    RapidLexer,
    textmate_grammar,
    textmate_json,
)
from rapid_dsl.language.units import UNITS

ROOT = Path(__file__).resolve().parents[2]
GRAMMAR = ROOT / "editors" / "rapid.tmLanguage.json"
PROGRAMS = sorted([*ROOT.joinpath("examples").glob("*.rapid"),
                   *(Path(str(f)) for f in resources.files("rapid_dsl.stdlib_primitives").iterdir()
                     if f.name.endswith(".rapid"))])


def test_there_are_programs_to_read() -> None:
    assert len(PROGRAMS) >= 14


@pytest.mark.parametrize("path", PROGRAMS, ids=lambda p: p.name)
def test_the_lexer_reads_every_example_and_stdlib_file(path: Path) -> None:
    text = path.read_text(encoding="utf-8")
    tokens = list(RapidLexer(stripnl=False).get_tokens(text))
    assert [value for kind, value in tokens if kind in Error] == []
    assert "".join(value for _, value in tokens) == text + ("" if text.endswith("\n") else "\n")
    kinds = {kind for kind, _ in tokens}
    assert Keyword.Declaration in kinds and Number.Float in kinds


def test_what_the_lexer_tells_apart() -> None:
    text = 'use stdlib.push  # a comment\nlet gap = 2.5cm + 1e-3m * up\ngoal "text"\n'
    tokens = [(kind, value) for kind, value in RapidLexer().get_tokens(text)
              if value.strip()]
    assert (Keyword.Declaration, "use") in tokens
    assert (Comment.Single, "# a comment") in tokens
    assert (Keyword, "let") in tokens and (Keyword, "goal") in tokens
    assert (Number.Float, "2.5") in tokens and (Keyword.Pseudo, "cm") in tokens
    assert (Number.Float, "1e-3") in tokens and (Keyword.Pseudo, "m") in tokens
    assert (String.Double, '"text"') in tokens


@pytest.mark.slow
def test_the_lexer_is_registered_with_pygments() -> None:
    """The `pygments.lexers` entry point (pyproject.toml): docs' ```rapid blocks find it."""
    assert isinstance(get_lexer_by_name("rapid"), RapidLexer)
    assert isinstance(get_lexer_for_filename("flip.rapid"), RapidLexer)


def test_the_textmate_grammar_is_made_from_the_rules() -> None:
    """editors/rapid.tmLanguage.json is `python -m rapid_dsl.frontend.highlight`'s output."""
    text = GRAMMAR.read_text(encoding="utf-8")
    assert json.loads(text) == textmate_grammar()
    assert text == textmate_json(), "run: python -m rapid_dsl.frontend.highlight > " \
        "editors/rapid.tmLanguage.json"


def _scopes(grammar: dict[str, object]) -> dict[str, str]:
    """scope -> the pattern that gives it."""
    out: dict[str, str] = {}
    for pattern in grammar["patterns"]:  # type: ignore[attr-defined]
        if "name" in pattern:
            out[pattern["name"]] = pattern["match"]
        for capture in pattern.get("captures", {}).values():
            out.setdefault(capture["name"], pattern["match"])
    return out


def test_the_grammar_has_a_scope_for_each_class_of_word() -> None:
    grammar = json.loads(GRAMMAR.read_text(encoding="utf-8"))
    assert grammar["scopeName"] == "source.rapid" and grammar["fileTypes"] == ["rapid"]
    scopes = _scopes(grammar)
    for scope in ("comment.line.number-sign.rapid", "string.quoted.double.rapid",
                  "constant.numeric.rapid", "keyword.other.unit.rapid", "keyword.other.rapid",
                  "storage.type.rapid", "keyword.operator.word.rapid"):
        assert scope in scopes
    keyword_patterns = [scopes[s] for s in ("keyword.other.rapid", "storage.type.rapid",
                                             "keyword.operator.word.rapid")]
    for keyword in KEYWORDS:     # every keyword of the grammar, whole
        assert any(re.fullmatch(p, keyword) for p in keyword_patterns), keyword
    unit = re.compile(scopes["keyword.other.unit.rapid"])
    for name in UNITS:
        match = unit.fullmatch(f"12{name}")
        assert match is not None and match.group(2) == name
    assert re.fullmatch(scopes["comment.line.number-sign.rapid"], "# note")
    assert re.fullmatch(scopes["string.quoted.double.rapid"], r'"say \"hi\""')


@pytest.mark.parametrize("path", PROGRAMS[:4], ids=lambda p: p.name)
def test_grammar_and_lexer_agree_on_programs(path: Path) -> None:
    """Each keyword, unit, number, string and comment token of the lexer is a whole match of
    the TextMate pattern that gives that class its scope."""
    scopes = _scopes(json.loads(GRAMMAR.read_text(encoding="utf-8")))
    scope_of = {kind: scope for rule in RULES for kind, scope in rule.kinds if scope}
    for kind, value in RapidLexer().get_tokens(path.read_text(encoding="utf-8")):
        if kind in (Keyword, Keyword.Declaration, Comment.Single, String.Double):
            assert re.fullmatch(scopes[scope_of[kind]], value), (kind, value)
