"""A scene file's YAML, read within bounds, with the line and column of every key and value.

Scene files (and the files read like them) are untrusted. ruamel.yaml's pure-Python reader does
the parsing; this module bounds what reading may cost before anything is built from the text:
- at most MAX_TOKENS tokens are scanned: the reader spends ~25 us per token, so a 10 MiB file of
  `1, 1, 1, ...` would otherwise take minutes;
- the composer stops at MAX_DEPTH levels of nesting (5,000 `[` in a label would exhaust the stack);
- aliases are expanded into at most MAX_VALUES values in all (a "billion laughs" file is a few
  lines), and an alias inside its own anchor is refused (it would nest forever);
- duplicate keys, keys that are not scalars, and tags other than YAML's core ones are errors.

`read_yaml` returns ruamel's round-trip containers (`CommentedMap`, `CommentedSeq`, with `.lc`
positions) holding plain scalars (str, int, float, bool, None), so callers locate a problem as they
would after `YAML(typ="rt").load`. Nothing in the text makes it raise anything but `YamlProblem`,
and no message quotes more of the text than `excerpt` allows.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

MAX_DEPTH = 20          # a scene nests 6 levels (objects[0].pose.position[2])
MAX_TOKENS = 50_000     # a scene of 64 objects has ~3,000 tokens; reading 50,000 takes ~1 s
MAX_VALUES = 20_000     # after aliases expand
MAX_INT_DIGITS = 4000   # Python refuses to convert longer decimal integers

_CORE = "tag:yaml.org,2002:"
_TRUE, _FALSE = {"true", "yes", "on", "y"}, {"false", "no", "off", "n"}
_TEXT_TAGS = ("str", "timestamp")   # kept as the text written


@dataclass(frozen=True, slots=True)
class YamlProblem(Exception):
    line: int       # 1-based
    column: int     # 1-based
    message: str

    def __str__(self) -> str:
        return f"{self.line}:{self.column}: {self.message}"


def excerpt(text: object, limit: int = 40) -> str:
    """`text` as a short one-line excerpt safe to print: non-printable characters escaped, the
    rest cut at `limit` characters (with the full length said)."""
    value = str(text)
    shown = value[:limit]
    escaped = "".join(c if c.isprintable() else repr(c)[1:-1] for c in shown)
    return escaped if len(value) <= limit else f"{escaped}... ({len(value)} characters)"


def read_yaml(text: str) -> Any:
    """The single YAML document in `text` as round-trip containers of plain scalars (None for an
    empty document). Raises YamlProblem."""
    from ruamel.yaml import YAML
    from ruamel.yaml.composer import MaxDepthExceededError
    from ruamel.yaml.error import YAMLError
    from ruamel.yaml.scanner import Scanner

    yaml = YAML(typ="safe", pure=True)
    yaml.Scanner = counting_scanner(Scanner, MAX_TOKENS)
    yaml.max_depth = MAX_DEPTH
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")   # ruamel warns about reused anchors, quoting them
            root = yaml.compose(text)
    except TooManyTokens as limit:
        raise YamlProblem(limit.line, limit.column,
                          f"the YAML has more than {MAX_TOKENS} tokens") from None
    except MaxDepthExceededError as exc:
        line, column = _mark(exc, text)
        raise YamlProblem(line, column, f"the YAML nests deeper than {MAX_DEPTH} levels") from None
    except YAMLError as exc:
        line, column = _mark(exc, text)
        raise YamlProblem(line, column, f"YAML syntax: {_syntax_message(exc)}") from None
    except RecursionError:
        raise YamlProblem(1, 1, f"the YAML nests deeper than {MAX_DEPTH} levels") from None
    except Exception as exc:  # noqa: BLE001 - any reader failure on odd input is a problem
        raise YamlProblem(1, 1, f"cannot read the YAML ({type(exc).__name__})") from None
    if root is None:
        return None
    return _Builder().build(root, 1)


class TooManyTokens(Exception):
    """Raised by a `counting_scanner` at the token past its limit (1-based line and column)."""

    def __init__(self, line: int, column: int) -> None:
        self.line, self.column = line, column


def counting_scanner(base: type, limit: int) -> type:
    """A ruamel.yaml Scanner class (`base`: the one the YAML object would use) that raises
    TooManyTokens after `limit` tokens, so reading costs at most `limit` tokens' time."""

    class CountingScanner(base):  # type: ignore[misc, valid-type]
        fetched = 0

        def fetch_more_tokens(self) -> Any:   # every call fetches at least one token
            self.fetched += 1
            if self.fetched > limit:
                mark = self.reader.get_mark()
                raise TooManyTokens(mark.line + 1, mark.column + 1)
            return super().fetch_more_tokens()

    return CountingScanner


def _mark(exc: Exception, text: str) -> tuple[int, int]:
    mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
    if mark is not None:
        return mark.line + 1, mark.column + 1
    position = getattr(exc, "position", None)   # a ReaderError (bad character) has only this
    if isinstance(position, int) and 0 <= position <= len(text):
        return text.count("\n", 0, position) + 1, position - (text.rfind("\n", 0, position) + 1) + 1
    return 1, 1


def _syntax_message(exc: Exception) -> str:
    problem = getattr(exc, "problem", None)
    context = getattr(exc, "context", None)
    if problem is None:   # a ReaderError: which character, not where (that is the position)
        character = getattr(exc, "character", None)
        return "a character YAML does not allow" + (
            f" (U+{ord(character):04X})" if isinstance(character, str) and len(character) == 1
            else "")
    message = f"{context}: {problem}" if context else str(problem)
    return excerpt(message, 120)


class _Builder:
    """Composed nodes -> containers with positions, counting values and nesting."""

    def __init__(self) -> None:
        self.values = 0

    def build(self, node: Any, depth: int) -> Any:
        from ruamel.yaml.comments import CommentedMap, CommentedSeq

        self.values += 1
        line, column = node.start_mark.line + 1, node.start_mark.column + 1
        if self.values > MAX_VALUES:
            raise YamlProblem(line, column, f"the YAML has more than {MAX_VALUES} values "
                                            "(aliases expand)")
        if depth > MAX_DEPTH:
            raise YamlProblem(line, column, f"the YAML nests deeper than {MAX_DEPTH} levels "
                                            "(or an alias refers to its own anchor)")
        if node.id == "scalar":
            return _scalar(node, line, column)
        tag = str(node.tag)
        if node.id == "sequence":
            if tag != _CORE + "seq":
                raise YamlProblem(line, column, f"YAML tag `{_short(tag)}` is not allowed here")
            seq = CommentedSeq()
            seq.lc.line, seq.lc.col = line - 1, column - 1
            for index, item in enumerate(node.value):
                seq.append(self.build(item, depth + 1))
                seq.lc.add_idx_line_col(index, [item.start_mark.line, item.start_mark.column])
            return seq
        if tag != _CORE + "map":
            raise YamlProblem(line, column, f"YAML tag `{_short(tag)}` is not allowed here")
        mapping = CommentedMap()
        mapping.lc.line, mapping.lc.col = line - 1, column - 1
        merged: list[Any] = []
        for key_node, value_node in node.value:
            if key_node.id == "scalar" and str(key_node.tag) == _CORE + "merge":
                merged.append(value_node)   # `<<: *defaults`: keys written here win
                continue
            key = self._key(key_node)
            if key in mapping:
                raise YamlProblem(key_node.start_mark.line + 1, key_node.start_mark.column + 1,
                                  f"`{excerpt(key)}` appears twice in this mapping")
            self._put(mapping, key, key_node, value_node, depth)
        for source in merged:
            for other in source.value if source.id == "sequence" else [source]:
                if other.id != "mapping":
                    raise YamlProblem(other.start_mark.line + 1, other.start_mark.column + 1,
                                      "`<<` merges only mappings")
                for key_node, value_node in other.value:
                    key = self._key(key_node)
                    if key not in mapping:
                        self._put(mapping, key, key_node, value_node, depth)
        return mapping

    def _key(self, node: Any) -> str:
        if node.id != "scalar":
            raise YamlProblem(node.start_mark.line + 1, node.start_mark.column + 1,
                              "a key must be a plain word, not a list or mapping")
        self.values += 1
        return str(node.value)

    def _put(self, mapping: Any, key: str, key_node: Any, value_node: Any, depth: int) -> None:
        mapping[key] = self.build(value_node, depth + 1)
        mapping.lc.add_kv_line_col(key, [key_node.start_mark.line, key_node.start_mark.column,
                                         value_node.start_mark.line,
                                         value_node.start_mark.column])


def _scalar(node: Any, line: int, column: int) -> Any:
    tag, text = str(node.tag), str(node.value)
    kind = tag[len(_CORE):] if tag.startswith(_CORE) else ""
    if kind == "null":
        return None
    if kind == "bool":
        if text.lower() in _TRUE | _FALSE:
            return text.lower() in _TRUE
        raise YamlProblem(line, column, f"`{excerpt(text)}` is not true or false")
    if kind == "int":
        return _integer(text, line, column)
    if kind == "float":
        return _float(text, line, column)
    if kind in _TEXT_TAGS:
        return text
    raise YamlProblem(line, column, f"YAML tag `{_short(tag)}` is not allowed here")


def _short(tag: str) -> str:
    return excerpt("!!" + tag[len(_CORE):] if tag.startswith(_CORE) else tag)


def _integer(text: str, line: int, column: int) -> int:
    digits = text.replace("_", "").strip()
    sign = -1 if digits.startswith("-") else 1
    digits = digits.lstrip("+-")
    bases = {"0x": 16, "0o": 8, "0b": 2}
    try:
        base = bases.get(digits[:2].lower(), 10)
        if base != 10:
            digits = digits[2:]
        elif len(digits) > MAX_INT_DIGITS:
            raise YamlProblem(line, column, f"an integer of {len(digits)} digits is too long")
        return sign * int(digits, base)
    except ValueError:
        raise YamlProblem(line, column, f"`{excerpt(text)}` is not an integer") from None


def _float(text: str, line: int, column: int) -> float:
    plain = text.replace("_", "").strip()
    special = plain.lower().lstrip("+-")
    if special in (".inf", ".nan"):
        value = math.inf if special == ".inf" else math.nan
        return -value if plain.startswith("-") else value
    try:
        return float(plain)
    except ValueError:
        raise YamlProblem(line, column, f"`{excerpt(text)}` is not a number") from None
