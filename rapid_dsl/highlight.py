"""Highlighting of `.rapid` text: a Pygments lexer (registered as the `pygments.lexers` entry point
`rapid`, so ```` ```rapid ```` blocks highlight in docs) and the language's keywords.

The keywords are read from the grammar (every lowercase literal of rapid_dsl/grammar/rapid.lark),
the builtins from the registry and the units from runtime/units.py, so the lexer follows the
language. editors/rapid.tmLanguage.json gives editors the same classes of words; a test keeps the
two in step.
"""

from __future__ import annotations

import re
from importlib import resources

from pygments.lexer import RegexLexer, bygroups, words
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

from rapid_dsl.runtime.registry import BUILTINS
from rapid_dsl.runtime.units import UNITS


def _grammar_keywords() -> tuple[str, ...]:
    grammar = resources.files("rapid_dsl.grammar").joinpath("rapid.lark").read_text("utf-8")
    grammar = re.sub(r"//[^\n]*", "", grammar)
    return tuple(sorted(set(re.findall(r'"([a-z_]+)"', grammar))))


KEYWORDS = _grammar_keywords()
DECLARATION_KEYWORDS = ("use", "relation", "def", "primitive", "strategy")
WORD_OPERATORS = ("and", "or", "not", "in")
_OTHER_KEYWORDS = tuple(k for k in KEYWORDS if k not in DECLARATION_KEYWORDS + WORD_OPERATORS)
_FUNCTIONS = tuple(b.name for b in BUILTINS.values() if b.kind != "constant")
_CONSTANTS = tuple(b.name for b in BUILTINS.values() if b.kind == "constant")
# A number and the unit written right after it (`3cm`, `1e-3m`, `90deg`), as the grammar's NUMBER.
_NUMBER = r"(\d+(?:\.\d*)?|\.\d+)(?:[eE][-+]?\d+)?"
_UNITS = "|".join(sorted(UNITS, key=len, reverse=True))


class RapidLexer(RegexLexer):
    """The RAPID robot-program language (`.rapid`)."""

    name = "RAPID robot programs"
    aliases = ["rapid"]
    filenames = ["*.rapid"]
    mimetypes = ["text/x-rapid"]

    tokens = {
        "root": [
            (r"[ \t\f]+", Whitespace),
            (r"\r?\n|\r", Whitespace),
            (r"\\(?:\r?\n|\r)", Whitespace),          # a line continued on the next
            (r"#[^\n\r]*", Comment.Single),
            (r'"(?:\\.|[^"\\\n\r])*"', String.Double),
            (_NUMBER + rf"({_UNITS})(?![A-Za-z0-9_])", bygroups(Number.Float, Keyword.Pseudo)),
            (_NUMBER + r"(?![A-Za-z_])", Number.Float),
            (words(DECLARATION_KEYWORDS, suffix=r"\b"), Keyword.Declaration),
            (words(WORD_OPERATORS, suffix=r"\b"), Operator.Word),
            (words(_OTHER_KEYWORDS, suffix=r"\b"), Keyword),
            (words(_CONSTANTS, suffix=r"\b"), Name.Builtin),
            (words(_FUNCTIONS, suffix=r"\b(?=\s*\()"), Name.Builtin),
            (r"[a-z_][A-Za-z0-9_]*(?=\s*\()", Name.Function),
            (r"[a-z_][A-Za-z0-9_]*", Name),
            (r"[A-Z][A-Za-z0-9_]*", Keyword.Type),
            (r"->|<=|>=|==|!=|[-+*/^<>=]", Operator),
            (r"[{}()\[\],;:.]", Punctuation),
        ],
    }

