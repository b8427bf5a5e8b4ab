"""Positions: the project's spans and LSP positions, the one place the server converts them.

The project counts lines and columns from 1, columns in code points, in the text as the checker
reads it (`syntax.source_text`: a leading BOM dropped). LSP counts lines and columns from 0,
columns in code units of the encoding agreed at `initialize`: UTF-16 unless the client offers
UTF-8 or UTF-32. A line ends at LF, CRLF or a lone CR in both, and at nothing else:
`str.splitlines` would also end lines at form feeds, U+2028 and other characters that the parser
reads as ordinary text, so it is not used. The editor's text may keep a BOM: then the first line's
columns are one code point further right than the checker's.
"""

from __future__ import annotations

import re
from bisect import bisect_right

from lsprotocol import types

from rapid_dsl.language.diagnostics import Span

UTF8, UTF16, UTF32 = "utf-8", "utf-16", "utf-32"
ENCODINGS = (UTF8, UTF16, UTF32)
_LINE_END = re.compile(r"\r\n|\r|\n")
_BOM = "\ufeff"


def units(text: str, encoding: str) -> int:
    """How many code units of `encoding` `text` takes (a lone surrogate counts as one UTF-16
    unit and three UTF-8 bytes, as its UTF-16 and WTF-8 forms do)."""
    if encoding == UTF32 or text.isascii():
        return len(text)
    if encoding == UTF16:
        return len(text.encode("utf-16-le", "surrogatepass")) // 2
    return len(text.encode("utf-8", "surrogatepass"))


class Text:
    """One document's text with its line table, for converting positions either way."""

    def __init__(self, text: str, encoding: str = UTF16) -> None:
        if encoding not in ENCODINGS:
            raise ValueError(f"unknown position encoding {encoding!r}")
        self.text = text
        self.encoding = encoding
        self.bom = 1 if text.startswith(_BOM) else 0
        self.starts = [0]           # offset of each line's first character
        self.ends: list[int] = []   # offset of each line's end (before its line break)
        for match in _LINE_END.finditer(text):
            self.ends.append(match.start())
            self.starts.append(match.end())
        self.ends.append(len(text))

    @property
    def line_count(self) -> int:
        return len(self.starts)

    def line(self, index: int) -> str:
        """The text of 0-based line `index`, without its line break."""
        return self.text[self.starts[index]:self.ends[index]]

    # project -> LSP ----------------------------------------------------------------------------
    def position(self, line: int, col: int) -> types.Position:
        """The LSP position of the project's (1-based line, 1-based column in code points),
        clamped to the document: a line past the end is the end of the document."""
        if line < 1:
            return types.Position(0, 0)
        index = line - 1
        if index >= self.line_count:
            return self.end()
        text = self.line(index)
        points = max(col - 1, 0) + (self.bom if index == 0 else 0)
        return types.Position(index, units(text[:points], self.encoding))

    def range(self, span: Span) -> types.Range:
        start = self.position(span.line, span.col)
        end = self.position(span.end_line, span.end_col)
        if (end.line, end.character) < (start.line, start.character):
            end = start
        return types.Range(start, end)

    def end(self) -> types.Position:
        last = self.line_count - 1
        return types.Position(last, units(self.line(last), self.encoding))

    # LSP -> project ----------------------------------------------------------------------------
    def offset(self, position: types.Position) -> int:
        """The index in the text of an LSP position. A column past the line's end means its end
        (as the specification says); one inside a character (half a surrogate pair, a byte of a
        UTF-8 sequence) means that character's start; a line past the end is the text's end."""
        if position.line < 0:
            return 0
        if position.line >= self.line_count:
            return len(self.text)
        start, end = self.starts[position.line], self.ends[position.line]
        return start + _points(self.text[start:end], max(position.character, 0), self.encoding)

    def location(self, position: types.Position) -> tuple[int, int]:
        """The project's (1-based line, 1-based column) of an LSP position."""
        offset = self.offset(position)
        index = bisect_right(self.starts, offset) - 1
        col = offset - self.starts[index] + 1
        if index == 0:
            col = max(col - self.bom, 1)
        return index + 1, col

    def apply(self, change_range: types.Range | None, new_text: str) -> str:
        """The text after an incremental change (a whole-text change has no range)."""
        if change_range is None:
            return new_text
        start, end = self.offset(change_range.start), self.offset(change_range.end)
        end = max(start, end)
        return self.text[:start] + new_text + self.text[end:]


def _points(line: str, wanted: int, encoding: str) -> int:
    """How many code points of `line` its first `wanted` code units hold (whole points only)."""
    if encoding == UTF32 or line.isascii():
        return min(wanted, len(line))
    count = 0
    for i, char in enumerate(line):
        count += units(char, encoding)
        if count > wanted:
            return i
    return len(line)
