"""YAML read node by node with places (ruamel.yaml's composer), within the limits of the form:
every value keeps its line and column and the text it was written as."""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Any

from rapid_dsl.frontend.yaml.schema import (
    E_YAML_DUPLICATE_KEY,
    E_YAML_LIMIT,
    E_YAML_SHAPE,
    E_YAML_SYNTAX,
    E_YAML_TEXT,
)
from rapid_dsl.language.diagnostics import Diagnostic, Span, error
from rapid_dsl.language.safe_yaml import TooManyTokens, counting_scanner

MAX_DEPTH = 50          # a real program nests about 6 levels
MAX_NODES = 50_000      # stops alias bombs (`&a [*b, *b, ...]` nested)
_SURROGATE = re.compile("[\ud800-\udfff]")
_SURROGATE_PAIR = re.compile("[\ud800-\udbff][\udc00-\udfff]")
MAX_TOKENS = 4 * MAX_NODES   # read before nodes are counted: ~25 us each, so at most ~5 s


def _joined_surrogates(text: str) -> tuple[str, str | None]:
    """`text` with JSON-style escape pairs (`"\\ud83d\\ude00"`) joined into one character, and
    its first lone surrogate, if any is left."""
    if not _SURROGATE.search(text):
        return text, None
    pieces = _SURROGATE_PAIR.sub(
        lambda m: m[0].encode("utf-16-le", "surrogatepass").decode("utf-16-le"), text)
    lone = _SURROGATE.search(pieces)
    return pieces, lone[0] if lone else None


@dataclass(slots=True)
class _Node:
    """A YAML value (text, None, list or mapping) and where it is."""

    value: Any              # str | None | list[_Node] | dict[str, _Node]
    span: Span
    key_span: Span | None = None
    content: tuple[int, int] = (1, 1)   # where a scalar's text starts (after a quote)
    split_risk: bool = False    # a plain scalar in `[...]` or `{...}`: YAML ends it at a comma

    def plain(self) -> Any:
        if isinstance(self.value, list):
            return [item.plain() for item in self.value]
        if isinstance(self.value, dict):
            return {key: item.plain() for key, item in self.value.items()}
        return self.value


def _flow_depth(text: str) -> int:
    """Deepest nesting of `[` and `{` in the text; quotes are ignored, so it may overcount."""
    depth = deepest = 0
    for char in text:
        if char in "[{":
            depth += 1
            deepest = max(deepest, depth)
        elif char in "]}" and depth:
            depth -= 1
    return deepest


class _Limit(Exception):
    def __init__(self, message: str, span: Span) -> None:
        self.message, self.span = message, span


class _Loader:
    def __init__(self, text: str, path: str) -> None:
        self.text, self.path = text, path
        self.lines = text.split("\n")
        self.diagnostics: list[Diagnostic] = []
        self.count = 0

    def load(self) -> _Node | None:
        from ruamel.yaml import YAML
        from ruamel.yaml.error import YAMLError

        if _flow_depth(self.text) > MAX_DEPTH:
            # ruamel's scanner is quadratic in the depth of `[`/`{`: refuse before reading.
            self.diagnostics.append(error(
                E_YAML_LIMIT, f"the YAML nests `[` or `{{` deeper than {MAX_DEPTH} levels",
                Span.point(self.path)))
            return None
        yaml = YAML(typ="rt", pure=True)
        yaml.Scanner = counting_scanner(yaml.Scanner, MAX_TOKENS)
        try:
            root = yaml.compose(self.text)
        except TooManyTokens as limit:
            self.diagnostics.append(error(
                E_YAML_LIMIT, f"the YAML has more than {MAX_TOKENS} tokens",
                Span.point(self.path, limit.line, limit.column),
                help="split the program into files joined with `use`"))
            return None
        except YAMLError as exc:
            self.diagnostics.append(self._yaml_error(exc))
            return None
        except RecursionError:
            self.diagnostics.append(error(E_YAML_LIMIT, "the YAML nests too deeply to read",
                                          Span.point(self.path)))
            return None
        except Exception as exc:  # noqa: BLE001 - any reader failure on odd input is a diagnostic
            self.diagnostics.append(error(E_YAML_SYNTAX, f"cannot read the YAML: {exc}",
                                          Span.point(self.path)))
            return None
        if root is None:
            return None
        try:
            return self.node(root, 0, None)
        except _Limit as limit:
            self.diagnostics.append(error(E_YAML_LIMIT, limit.message, limit.span))
            return None

    def _yaml_error(self, exc: Exception) -> Diagnostic:
        mark = getattr(exc, "problem_mark", None) or getattr(exc, "context_mark", None)
        position = getattr(exc, "position", None)   # a ReaderError (bad character) has only this
        if mark is not None:
            span = Span.point(self.path, mark.line + 1, mark.column + 1, mark.index)
        elif isinstance(position, int) and 0 <= position <= len(self.text):
            line = self.text.count("\n", 0, position) + 1
            col = position - (self.text.rfind("\n", 0, position) + 1) + 1
            span = Span.point(self.path, line, col, position)
        else:
            span = Span.point(self.path)
        problem = (getattr(exc, "problem", None)
                   or (str(exc).strip().splitlines() or ["unreadable input"])[0])
        context = getattr(exc, "context", None)
        message = f"{context}: {problem}" if context else str(problem)
        return error(E_YAML_SYNTAX, f"invalid YAML: {message}", span,
                     help="check indentation, colons and quotes around this place")

    def span(self, node: Any) -> Span:
        start, end = node.start_mark, node.end_mark
        return Span(self.path, start.index, end.index, start.line + 1, start.column + 1,
                    end.line + 1, end.column + 1)

    def node(self, node: Any, depth: int, key_span: Span | None, in_flow: bool = False) -> _Node:
        span = self.span(node)
        self.count += 1
        if depth > MAX_DEPTH:
            raise _Limit(f"the YAML nests deeper than {MAX_DEPTH} levels", span)
        if self.count > MAX_NODES:
            raise _Limit(f"the YAML has more than {MAX_NODES} values (aliases expand)", span)
        kind = node.id  # "scalar" | "sequence" | "mapping"
        if kind == "sequence":
            flow = bool(node.flow_style)
            return _Node([self.node(item, depth + 1, None, flow) for item in node.value], span,
                         key_span)
        if kind == "mapping":
            return _Node(self.mapping(node, depth), span, key_span)
        if node.tag.endswith(":null"):
            return _Node(None, span, key_span, (span.line, span.col))
        value, lone = _joined_surrogates(str(node.value))
        if lone is not None:   # no UTF-8 text (a `.rapid` file, the generated module) holds it
            self.diagnostics.append(error(
                E_YAML_TEXT, f"this text holds a lone surrogate (U+{ord(lone):04X}), "
                "which UTF-8 text cannot hold", span,
                help="write the character itself, or a pair of escapes for one outside the BMP"))
            return _Node("", span, key_span, self.content_start(node, span), False)
        return _Node(value, span, key_span, self.content_start(node, span),
                     in_flow and not node.style)

    def mapping(self, node: Any, depth: int) -> dict[str, _Node]:
        out: dict[str, _Node] = {}
        for key_node, value_node in node.value:
            key_span = self.span(key_node)
            if key_node.id != "scalar":
                self.diagnostics.append(error(E_YAML_SHAPE, "a key must be a plain word",
                                              key_span))
                continue
            key = str(key_node.value)
            if key in out:
                first = out[key].key_span or key_span
                self.diagnostics.append(error(
                    E_YAML_DUPLICATE_KEY, f"`{key}` appears twice in this mapping", key_span,
                    label="second time", related=[("first here", first)],
                    help="keep one of them"))
                continue
            out[key] = self.node(value_node, depth + 1, key_span, bool(node.flow_style))
        return out

    def content_start(self, node: Any, span: Span) -> tuple[int, int]:
        style = getattr(node, "style", None)
        if style in ('"', "'"):
            return span.line, span.col + 1
        if style in ("|", ">"):
            # The text starts on the next non-blank line, at that line's indentation.
            for number in range(span.line, min(span.end_line, len(self.lines))):
                line = self.lines[number]
                if line.strip():
                    return number + 1, len(line) - len(line.lstrip(" ")) + 1
        return span.line, span.col
