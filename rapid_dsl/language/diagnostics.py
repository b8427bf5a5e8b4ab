"""Diagnostics: source spans, the `Diagnostic` record, and its human, JSON and GitHub renderings.

Imports nothing from the rest of rapid_dsl, so every phase (and the runtime) may use it.
"""

from __future__ import annotations

import enum
import json
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field


@dataclass(frozen=True, slots=True)
class Span:
    """Half-open character range [start, end) in one source; line and column are 1-based."""

    path: str
    start: int
    end: int
    line: int
    col: int
    end_line: int
    end_col: int

    @staticmethod
    def point(path: str, line: int = 1, col: int = 1, offset: int = 0) -> Span:
        return Span(path, offset, offset, line, col, line, col)

    def to(self, other: Span) -> Span:
        """The span from the start of `self` to the end of `other`."""
        return Span(self.path, self.start, other.end, self.line, self.col,
                    other.end_line, other.end_col)


class Severity(enum.Enum):
    ERROR = "error"
    WARNING = "warning"
    NOTE = "note"


@dataclass(frozen=True, slots=True)
class Diagnostic:
    code: str                           # stable, documented in docs/diagnostics.md
    severity: Severity
    message: str                        # lower-case start, no trailing period
    span: Span
    label: str | None = None            # text under the carets
    help: str | None = None
    related: tuple[tuple[str, Span], ...] = field(default=())   # ("declared here", span)

    @property
    def is_error(self) -> bool:
        return self.severity is Severity.ERROR


def error(code: str, message: str, span: Span, *, label: str | None = None,
          help: str | None = None, related: Sequence[tuple[str, Span]] = ()) -> Diagnostic:
    return Diagnostic(code, Severity.ERROR, message, span, label, help, tuple(related))


def warning(code: str, message: str, span: Span, *, label: str | None = None,
            help: str | None = None, related: Sequence[tuple[str, Span]] = ()) -> Diagnostic:
    return Diagnostic(code, Severity.WARNING, message, span, label, help, tuple(related))


class RapidError(Exception):
    """A user-facing failure carrying one or more diagnostics."""

    def __init__(self, diagnostics: Sequence[Diagnostic]) -> None:
        self.diagnostics = tuple(diagnostics)
        super().__init__("\n".join(f"{d.code}: {d.message}" for d in self.diagnostics))


def sort_key(d: Diagnostic) -> tuple[str, int, int, str]:
    return (d.span.path, d.span.line, d.span.col, d.code)


# ---------------------------------------------------------------------------------------- human

_COLORS = {"error": "\x1b[1;31m", "warning": "\x1b[1;33m", "note": "\x1b[1;36m"}
_BOLD, _BLUE, _RESET = "\x1b[1m", "\x1b[1;34m", "\x1b[0m"


def render_human(d: Diagnostic, source: str | None, *, color: bool = False) -> str:
    """rustc-style block: header, numbered source line, carets under the span, help.

    ```
    flip.rapid:14:9: error[E0302]: cannot compare Length with Real
       |
    14 |     gap < 2
       |     ^^^^^^^ `gap` is a Length
       = help: give the bound a unit, e.g. `2cm`
    ```
    """
    def paint(text: str, style: str) -> str:
        return f"{style}{text}{_RESET}" if color else text

    sev = d.severity.value
    message = paint(visible(d.message), _BOLD) if color else visible(d.message)
    header = (f"{visible(d.span.path)}:{d.span.line}:{d.span.col}: "
              f"{paint(f'{sev}[{d.code}]', _COLORS[sev])}: {message}")
    lines = [header]
    line_text = _source_line(source, d.span.line)
    if line_text is not None:
        number = str(d.span.line)
        gutter = " " * len(number)
        expanded = visible(line_text.expandtabs(4))
        prefix = visible(line_text[: max(d.span.col - 1, 0)].expandtabs(4))
        if d.span.end_line == d.span.line:
            width = len(visible(line_text[: max(d.span.end_col - 1, 0)].expandtabs(4))) \
                - len(prefix)
        else:
            width = len(expanded) - len(prefix)
        expanded, prefix, width = _window(expanded, len(prefix), max(width, 1))
        carets = "^" * width
        label = f" {d.label}" if d.label else ""
        lines.append(f"{gutter} {paint('|', _BLUE)}")
        lines.append(f"{paint(number, _BLUE)} {paint('|', _BLUE)} {expanded.rstrip()}")
        lines.append(f"{gutter} {paint('|', _BLUE)} {prefix}"
                     f"{paint(carets + label, _COLORS[sev])}")
        eq = f"{gutter} {paint('=', _BLUE)}"
    else:
        eq = "  ="
    for text, span in d.related:
        lines.append(f"{eq} note: {visible(text)} at {visible(span.path)}:{span.line}:{span.col}")
    if d.help:
        lines.append(f"{eq} help: {visible(d.help)}")
    return "\n".join(lines)


def visible(text: str) -> str:
    """`text` safe to print on a terminal: control and format characters (escape sequences,
    bidirectional overrides, NUL) are shown as `\\x1b`-style escapes instead of acting."""
    if text.isprintable():
        return text
    return "".join(c if c.isprintable() or c == " " else _escape(c) for c in text)


def _escape(c: str) -> str:
    code = ord(c)
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}" if code < 0x10000 \
        else f"\\U{code:08x}"


SHOWN_BEFORE, SHOWN_SPAN, SHOWN_AFTER = 40, 80, 40   # columns of a long source line shown


def _window(line: str, start: int, width: int) -> tuple[str, str, int]:
    """A long line cut around the span at column `start` (0-based) of `width` columns: the shown
    line, the blank prefix under which the carets start, and the carets' width."""
    if len(line) <= SHOWN_BEFORE + SHOWN_SPAN + SHOWN_AFTER:
        return line, " " * start, width
    head = ""
    if start > SHOWN_BEFORE:
        line, start, head = line[start - SHOWN_BEFORE:], SHOWN_BEFORE, "..."
    width = min(width, SHOWN_SPAN)
    end = start + width + SHOWN_AFTER
    tail = "..." if len(line) > end else ""
    return head + line[:end] + tail, " " * (start + len(head)), width


_LINE_BREAK = re.compile(r"\r\n|\r|\n")


def _source_line(source: str | None, line: int) -> str | None:
    if source is None or line < 1:
        return None
    # LF, CR and CRLF end lines, as for the parser and YAML; str.splitlines would also split at
    # U+2028, U+0085, form feeds, ... and put the carets on the wrong line.
    lines = _LINE_BREAK.split(source)
    if lines and lines[-1] == "":
        lines.pop()
    if line > len(lines):
        return "" if line == len(lines) + 1 else None
    return lines[line - 1]


# ------------------------------------------------------------------------------ machine formats

def to_json(d: Diagnostic) -> dict[str, object]:
    """One object per diagnostic; line and column are 1-based, end column exclusive."""
    return {
        "file": d.span.path,
        "line": d.span.line,
        "column": d.span.col,
        "end_line": d.span.end_line,
        "end_column": d.span.end_col,
        "severity": d.severity.value,
        "code": d.code,
        "message": d.message,
        "help": d.help,
    }


def render_json(diagnostics: Iterable[Diagnostic]) -> str:
    return json.dumps([to_json(d) for d in diagnostics], indent=2)


def github_command(command: str, properties: Sequence[tuple[str, object]], message: str) -> str:
    """`::command k=v,...::message` with values and message escaped as GitHub documents, so that no
    file name or message can end the command early or start another one. The one place every
    workflow command of rapidc is made."""
    props = ",".join(f"{key}={_escape_property(str(value))}" for key, value in properties)
    return f"::{command} {props}::{_escape_data(message)}" if props \
        else f"::{command}::{_escape_data(message)}"


def _escape_data(text: str) -> str:
    return text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")


def _escape_property(text: str) -> str:
    return _escape_data(text).replace(":", "%3A").replace(",", "%2C")


def render_github(d: Diagnostic) -> str:
    """A GitHub Actions workflow command (`::error file=...::message`)."""
    command = {"error": "error", "warning": "warning", "note": "notice"}[d.severity.value]
    props: list[tuple[str, object]] = [("file", d.span.path), ("line", d.span.line),
                                       ("endLine", d.span.end_line)]
    if d.span.end_line == d.span.line:  # GitHub rejects columns on multi-line ranges
        props += [("col", d.span.col), ("endColumn", d.span.end_col)]
    props.append(("title", f"rapidc ({d.code})"))
    message = d.message + (f"\n  help: {d.help}" if d.help else "")
    return github_command(command, props, message)
