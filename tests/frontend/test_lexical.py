"""Line ends and the byte-order mark (docs/language.md, section 1): LF, CRLF and a lone CR all
end a line, and a leading BOM is ignored, for `check` and `fmt` alike, from files and from text
handed over by an editor; positions count lines that way.
"""

from __future__ import annotations

import contextlib
import io
from pathlib import Path

import pytest

from rapid_dsl.cli import main
from rapid_dsl.frontend.driver import check_text, parse_source
from rapid_dsl.frontend.formatter import format_source
from rapid_dsl.frontend.parser import parse_module
from rapid_dsl.language.diagnostics import render_human

# Line 4 has a mistake at column 34; line 2 is blank, line 3 a comment.
PROGRAM = ("relation near(a: Body, b: Body) = distance(a, b) < 5cm\n"
           "\n"
           "# the next one has no unit\n"
           "relation far(a: Body, b: Body) = distance(a, b) > 5\n")
ENDINGS = {"LF": "\n", "CRLF": "\r\n", "CR": "\r"}


def rapidc(*argv: object) -> tuple[int, str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        code = main([str(a) for a in argv])
    return code, out.getvalue()


def ended(text: str, ending: str) -> str:
    return text.replace("\n", ending)


@pytest.mark.parametrize("ending", ENDINGS.values(), ids=ENDINGS.keys())
def test_every_line_end_gives_the_same_positions(ending: str) -> None:
    result = check_text(ended(PROGRAM, ending), "p.rapid")
    [d] = result.diagnostics
    assert (d.code, d.span.line, d.span.col, d.span.end_line, d.span.end_col) == \
        ("E0302", 4, 34, 4, 52)
    rendered = render_human(d, result.sources["p.rapid"])
    assert "4 | relation far(a: Body, b: Body) = distance(a, b) > 5\n" in rendered
    assert "\r" not in rendered


@pytest.mark.parametrize("ending", ENDINGS.values(), ids=ENDINGS.keys())
def test_a_syntax_error_after_cr_lines_is_at_its_line(ending: str) -> None:
    text = ended("relation near(a: Body, b: Body) = distance(a, b) < 5cm\n"
                 "relation far(a: Body b: Body) = distance(a, b) > 5cm\n", ending)
    [d] = check_text(text, "p.rapid").diagnostics
    assert (d.code, d.span.line, d.span.col) == ("E0101", 2, 22)


def test_clause_text_and_snippets_have_no_carriage_returns() -> None:
    text = ended('primitive p {\n  goal "g"\n  roles { target: Object, hand: Manipulator }\n'
                 "  success {\n    touching(hand, target)\n    distance(hand, target) < 1cm\n  }\n"
                 "  cost final = distance(hand, target) / 1cm\n"
                 "  motion { keypoint reach = pos(target) }\n}\n", "\r\n")
    result = check_text(text, "p.rapid")
    assert result.diagnostics == []
    assert result.program is not None
    assert [c.text for c in result.program.primitive("p").success] == \
        ["touching(hand, target)", "distance(hand, target) < 1cm"]


def test_a_line_continuation_may_end_in_crlf() -> None:
    assert check_text("relation near(a: Body, b: Body) = \\\r\n  distance(a, b) < 5cm\r\n",
                      "p.rapid").diagnostics == []


def test_a_cr_inside_a_string_ends_the_line_and_the_string() -> None:
    [d] = check_text('primitive p {\n  goal "two\rlines"\n}\n', "p.rapid").diagnostics
    assert (d.code, d.span.line) == ("E0104", 2)


def test_a_leading_bom_is_ignored_in_text_and_positions_do_not_count_it() -> None:
    text = "\ufeff" + PROGRAM
    [d] = check_text(text, "p.rapid").diagnostics
    assert (d.code, d.span.line, d.span.col) == ("E0302", 4, 34)
    [d] = check_text("\ufeffrelation far(a: Body, b: Body) = distance(a, b) > 5\n",
                     "p.rapid").diagnostics
    assert (d.code, d.span.line, d.span.col) == ("E0302", 1, 34)
    module, diagnostics = parse_source("\ufeff" + PROGRAM, "p.rapid")
    assert module is not None and diagnostics == []
    assert parse_module("\ufeff" + PROGRAM, "p.rapid")[0] == module
    yaml = '\ufeff- relation: near\n  params: {a: Body, b: Body}\n  body: "distance(a, b) < 5cm"\n'
    assert check_text(yaml, "p.rapid.yaml").diagnostics == []


def test_only_a_leading_bom_is_ignored() -> None:
    [d] = check_text("relation near(a: Body, b: Body) = distance(a, b) < 5cm \ufeff\n",
                     "p.rapid").diagnostics
    assert d.code == "E0102"


@pytest.mark.parametrize("ending", ENDINGS.values(), ids=ENDINGS.keys())
def test_fmt_output_is_lf_and_checks_clean(ending: str) -> None:
    clean = PROGRAM.replace("> 5\n", "> 5cm\n")
    formatted, diagnostics = format_source("\ufeff" + ended(clean, ending), "p.rapid")
    assert diagnostics == [] and formatted is not None
    assert formatted == format_source(clean, "p.rapid")[0]
    assert "\r" not in formatted and not formatted.startswith("\ufeff")
    assert check_text(formatted, "p.rapid").diagnostics == []


@pytest.mark.parametrize("ending", ENDINGS.values(), ids=ENDINGS.keys())
def test_check_and_fmt_agree_on_files(tmp_path: Path, ending: str) -> None:
    """The finding: a lone CR was a line end to one command and an error to the other."""
    clean = ended(PROGRAM.replace("> 5\n", "> 5cm\n"), ending)
    for name, text in (("plain.rapid", clean), ("bom.rapid", "\ufeff" + clean)):
        path = tmp_path / name
        path.write_bytes(text.encode("utf-8"))
        assert rapidc("check", path)[0] == 0
        code, out = rapidc("fmt", path)
        assert code == 0
        assert check_text(out, name).diagnostics == []
        assert rapidc("fmt", "--write", path)[0] == 0
        assert rapidc("check", path)[0] == 0
        assert b"\r" not in path.read_bytes()
    bad = tmp_path / "bad.rapid"
    bad.write_bytes(ended(PROGRAM, ending).encode("utf-8"))
    code, out = rapidc("check", bad)
    assert code == 1 and "bad.rapid:4:34: error[E0302]" in out
