"""Positions: the project's 1-based code-point columns and LSP's 0-based UTF-16 (or UTF-8, UTF-32)
columns, with characters outside the BMP, CR, CRLF and a BOM; checked against a plain reference,
and end to end through the server."""

from __future__ import annotations

from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st
from lsprotocol.types import Position, Range

from rapid_dsl.frontend.syntax import source_text
from rapid_dsl.language.diagnostics import Span
from rapid_dsl.lsp.positions import UTF8, UTF16, UTF32, Text, units

from .client import Client, position

# Letters that take 1 to 4 UTF-8 bytes and 1 or 2 UTF-16 units, line ends of all three kinds, and
# characters that str.splitlines takes for line ends but the language does not.
ALPHABET = st.sampled_from(list("ab é€🤖🦾\n\r\t") + ["\r\n", "\f", "\u2028", "\x85", "\v"])
TEXTS = st.lists(ALPHABET, max_size=40).map("".join)
ENCODING = st.sampled_from([UTF8, UTF16, UTF32])


def reference_lines(text: str) -> list[str]:
    """Lines as LSP defines them: ended by LF, CRLF or CR only."""
    return text.replace("\r\n", "\n").replace("\r", "\n").split("\n")


def reference_units(chars: str, encoding: str) -> int:
    if encoding == UTF8:
        return len(chars.encode("utf-8"))
    if encoding == UTF16:
        return len(chars.encode("utf-16-le")) // 2
    return len(chars)


def test_columns_count_utf16_code_units() -> None:
    text = Text("a🤖b\n€x")
    assert text.position(1, 3) == Position(0, 3)       # after `a🤖`: 1 + 2 units
    assert text.position(1, 4) == Position(0, 4)
    assert text.position(2, 2) == Position(1, 1)
    assert text.location(Position(0, 3)) == (1, 3)
    assert text.location(Position(0, 2)) == (1, 2)     # inside the pair: the emoji's start
    assert Text("a🤖b", UTF8).position(1, 3) == Position(0, 5)
    assert Text("a🤖b", UTF32).position(1, 3) == Position(0, 2)


def test_lines_end_at_lf_crlf_and_cr_only() -> None:
    text = Text("a\r\nb\rc\nd\fe\u2028f")
    assert text.line_count == 4
    assert [text.line(i) for i in range(4)] == ["a", "b", "c", "d\fe\u2028f"]
    assert text.position(4, 5) == Position(3, 4)
    assert text.offset(Position(1, 0)) == 3


def test_a_bom_shifts_the_first_line_only() -> None:
    text = Text("\ufeffab\ncd")
    assert text.position(1, 1) == Position(0, 1)       # the checker's column 1 is after the BOM
    assert text.position(2, 1) == Position(1, 0)
    assert text.location(Position(0, 1)) == (1, 1)
    assert text.location(Position(0, 0)) == (1, 1)


def test_positions_past_the_end_are_clamped() -> None:
    text = Text("ab\ncd")
    assert text.position(1, 99) == Position(0, 2)
    assert text.position(9, 1) == Position(1, 2)
    assert text.position(0, 0) == Position(0, 0)
    assert text.offset(Position(0, 99)) == 2            # a column past the end: the line's end
    assert text.offset(Position(7, 0)) == 5
    assert text.range(Span("p", 0, 0, 2, 3, 1, 1)) == Range(Position(1, 2), Position(1, 2))


def test_unknown_encoding_is_refused() -> None:
    with pytest.raises(ValueError):
        Text("", "utf-7")


@given(TEXTS, ENCODING, st.data())
def test_every_position_round_trips(text: str, encoding: str, data: st.DataObject) -> None:
    """A project position inside the text goes to the reference's LSP position and back."""
    lines = reference_lines(text)
    converted = Text(text, encoding)
    assert converted.line_count == len(lines)
    index = data.draw(st.integers(0, len(lines) - 1))
    col = data.draw(st.integers(1, len(lines[index]) + 1))
    expected = Position(index, reference_units(lines[index][:col - 1], encoding))
    assert converted.position(index + 1, col) == expected
    assert converted.location(expected) == (index + 1, col)


@given(TEXTS, TEXTS, ENCODING, st.data())
def test_an_incremental_change_replaces_the_range(text: str, new: str, encoding: str,
                                                  data: st.DataObject) -> None:
    """An edit given in LSP positions replaces exactly the code points between them."""
    lines = reference_lines(text)
    converted = Text(text, encoding)

    def point() -> tuple[Position, int]:
        index = data.draw(st.integers(0, len(lines) - 1))
        col = data.draw(st.integers(0, len(lines[index])))
        return Position(index, reference_units(lines[index][:col], encoding)), \
            converted.starts[index] + col

    (a, i), (b, j) = sorted([point(), point()], key=lambda p: p[1])
    assert converted.apply(Range(a, b), new) == text[:i] + new + text[j:]
    assert converted.apply(None, new) == new


@given(TEXTS, ENCODING)
def test_the_checker_and_the_editor_agree_on_lines(text: str, encoding: str) -> None:
    """The checker's text (`source_text`) has the same lines as the editor's, so a span of it
    converts to the same characters."""
    checked = source_text(text).split("\n")
    converted = Text(text, encoding)
    assert [converted.line(i) for i in range(converted.line_count)] == checked


def test_units_of_a_lone_surrogate() -> None:
    assert units("\ud800", UTF16) == 1
    assert units("\ud800", UTF8) == 3


# ------------------------------------------------------------------------------- end to end

EMOJI = ('use stdlib.push\n\nstrategy s {\n'
         '  roles { box: Object, table: Surface, wall: Fixture, hand: Manipulator }\n'
         '  requires { on(box, table); reachable(hand, box) }\n'
         '  goal "🤖🦾 push"; success { distance(box, wall) < 0.05 }\n'
         '  phase p: push(target=box, support=table, hand=hand) { displacement = 5cm * up }\n'
         '}\n')


@pytest.mark.parametrize("line_end", ["\n", "\r\n", "\r"], ids=["lf", "crlf", "cr"])
def test_positions_through_the_server(server: Client, project: Path, line_end: str) -> None:
    """With emoji before the error on its line and every kind of line end, the diagnostic's
    range, a hover and an incremental change all use UTF-16 columns."""
    path = project / f"emoji_{len(line_end)}_{line_end == chr(13)}.rapid"
    text = EMOJI.replace("\n", line_end)
    uri = client_open(server, path, text)
    [diagnostic] = server.diagnostics(uri)
    start = position(EMOJI, "distance(box")
    assert start == {"line": 5, "character": 30}          # 28 code points, two of them pairs
    assert diagnostic["range"] == {"start": start, "end": position(EMOJI, "0.05 }", after=4)}
    hover = server.request("textDocument/hover", {"textDocument": {"uri": uri},
                                                  "position": position(EMOJI, "wall) <")})
    assert "role wall: Fixture" in hover["contents"]["value"]
    bound = position(EMOJI, "0.05")
    server.notify("textDocument/didChange", {
        "textDocument": {"uri": uri, "version": 2},
        "contentChanges": [{"range": {"start": bound, "end": {
            "line": bound["line"], "character": bound["character"] + 4}}, "text": "5cm"}]})
    assert server.diagnostics(uri, version=2) == []


def client_open(client: Client, path: Path, text: str) -> str:
    path.write_text(text, encoding="utf-8", newline="")
    return client.open(path, text)


@pytest.mark.slow
def test_utf8_positions_when_the_client_asks(project: Path) -> None:
    client = Client(cwd=project)
    try:
        result = client.initialize(project, {"general": {"positionEncodings": ["utf-8"]}})
        assert result["capabilities"]["positionEncoding"] == "utf-8"
        uri = client_open(client, project / "emoji_utf8.rapid", EMOJI)
        [diagnostic] = client.diagnostics(uri)
        line = EMOJI.splitlines()[5]
        prefix = line[:line.index("distance")]
        assert diagnostic["range"]["start"] == {"line": 5,
                                                "character": len(prefix.encode("utf-8"))}
    finally:
        client.close()
