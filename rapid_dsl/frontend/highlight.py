"""Highlighting of `.rapid` text: one table of rules that makes both the Pygments lexer (the
`pygments.lexers` entry point `rapid`, so ```` ```rapid ```` blocks highlight in docs) and the
TextMate grammar that editors read (editors/rapid.tmLanguage.json, written by
`python -m rapid_dsl.frontend.highlight`; a test checks that the file is what this module makes).

The keywords are read from the grammar (every lowercase literal of rapid_dsl/grammar/rapid.lark),
the builtins from the registry and the units from language/units.py, so highlighting follows the
language. The patterns are written in the regular-expression syntax that Python and Oniguruma
(TextMate's) share.
"""

from __future__ import annotations

import json
import re
import sys
from dataclasses import dataclass
from importlib import resources
from typing import Any

from pygments.lexer import RegexLexer, bygroups
from pygments.token import (
    Comment,
    Keyword,
    Name,
    Number,
    Operator,
    Punctuation,
    String,
    Whitespace,
)

from rapid_dsl.language.registry import BUILTINS
from rapid_dsl.language.units import UNITS


def _grammar_keywords() -> tuple[str, ...]:
    grammar = resources.files("rapid_dsl.grammar").joinpath("rapid.lark").read_text("utf-8")
    grammar = re.sub(r"//[^\n]*", "", grammar)
    return tuple(sorted(set(re.findall(r'"([a-z_]+)"', grammar))))


KEYWORDS = _grammar_keywords()
DECLARATION_KEYWORDS = ("use", "relation", "def", "primitive", "strategy")
WORD_OPERATORS = ("and", "or", "not", "in")
OTHER_KEYWORDS = tuple(k for k in KEYWORDS if k not in DECLARATION_KEYWORDS + WORD_OPERATORS)
FUNCTIONS = tuple(b.name for b in BUILTINS.values() if b.kind != "constant")
CONSTANTS = tuple(b.name for b in BUILTINS.values() if b.kind == "constant")


def _words(items: tuple[str, ...], after: str = "") -> str:
    return r"\b(?:" + "|".join(sorted(items, key=len, reverse=True)) + r")\b" + after


# A number, and the unit written right after it (`3cm`, `1e-3m`, `90deg`), as the grammar's NUMBER.
_NUMBER = r"(?<![\w.])((?:\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?)"
_UNIT = "(" + "|".join(sorted(UNITS, key=len, reverse=True)) + ")(?![A-Za-z0-9_])"


@dataclass(frozen=True, slots=True)
class Rule:
    """A pattern and what it is: one (Pygments token, TextMate scope) for the whole match, or one
    per group. A rule without a scope is Pygments' only (TextMate needs no whitespace rules)."""

    pattern: str
    kinds: tuple[tuple[Any, str | None], ...]   # (a pygments.token type, a scope)


RULES = (
    Rule(r"[ \t\f]+|\r\n|\r|\n", ((Whitespace, None),)),
    Rule(r"\\(?=\r?\n|\r|$)", ((Punctuation, "punctuation.separator.continuation.rapid"),)),
    Rule(r"#[^\n\r]*", ((Comment.Single, "comment.line.number-sign.rapid"),)),
    Rule(r'"(?:\\.|[^"\\\n\r])*"', ((String.Double, "string.quoted.double.rapid"),)),
    Rule(_NUMBER + _UNIT, ((Number.Float, "constant.numeric.rapid"),
                           (Keyword.Pseudo, "keyword.other.unit.rapid"))),
    Rule(_NUMBER + r"(?![A-Za-z0-9_])", ((Number.Float, "constant.numeric.rapid"),)),
    Rule(_words(DECLARATION_KEYWORDS), ((Keyword.Declaration, "storage.type.rapid"),)),
    Rule(_words(WORD_OPERATORS), ((Operator.Word, "keyword.operator.word.rapid"),)),
    Rule(_words(OTHER_KEYWORDS), ((Keyword, "keyword.other.rapid"),)),
    Rule(_words(CONSTANTS), ((Name.Builtin, "support.constant.rapid"),)),
    Rule(_words(FUNCTIONS, r"(?=\s*\()"), ((Name.Builtin, "support.function.rapid"),)),
    Rule(r"\b[a-z_][A-Za-z0-9_]*(?=\s*\()", ((Name.Function, "entity.name.function.rapid"),)),
    Rule(r"\b[a-z_][A-Za-z0-9_]*", ((Name, "variable.other.rapid"),)),
    Rule(r"\b[A-Z][A-Za-z0-9_]*", ((Keyword.Type, "entity.name.type.rapid"),)),
    Rule(r"->|<=|>=|==|!=|[-+*/^<>=]", ((Operator, "keyword.operator.rapid"),)),
    Rule(r"[{}()\[\],;:.]", ((Punctuation, "punctuation.rapid"),)),
)


class RapidLexer(RegexLexer):
    """The RAPID robot-program language (`.rapid`)."""

    name = "RAPID robot programs"
    aliases = ["rapid"]
    filenames = ["*.rapid"]
    mimetypes = ["text/x-rapid"]

    tokens = {"root": [
        (rule.pattern, rule.kinds[0][0] if len(rule.kinds) == 1
         else bygroups(*(token for token, _ in rule.kinds)))
        for rule in RULES
    ]}


def textmate_grammar() -> dict[str, Any]:
    """The TextMate grammar of the rules (editors/rapid.tmLanguage.json)."""
    patterns: list[dict[str, Any]] = []
    for rule in RULES:
        scopes = [scope for _, scope in rule.kinds]
        if all(scope is None for scope in scopes):
            continue
        if len(scopes) == 1:
            patterns.append({"name": scopes[0], "match": rule.pattern})
        else:
            patterns.append({"match": rule.pattern, "captures": {
                str(i): {"name": scope} for i, scope in enumerate(scopes, 1) if scope}})
    return {
        "$schema": "https://raw.githubusercontent.com/martinring/tmlanguage/master/"
                   "tmlanguage.json",
        "name": "RAPID",
        "scopeName": "source.rapid",
        "fileTypes": ["rapid"],
        "comment": "Made by `python -m rapid_dsl.frontend.highlight` from "
                   "rapid_dsl/frontend/highlight.py; do not edit by hand.",
        "patterns": patterns,
    }


def textmate_json() -> str:
    return json.dumps(textmate_grammar(), indent=2) + "\n"


if __name__ == "__main__":
    sys.stdout.write(textmate_json())
