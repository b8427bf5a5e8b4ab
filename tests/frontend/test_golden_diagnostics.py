"""Golden diagnostics: for every code, a program and the exact human rendering of all its
diagnostics. `pytest --update-goldens` rewrites the `.expected.txt` files; review the diff.
"""

from __future__ import annotations

import os
import re
from pathlib import Path

import pytest

from rapid_dsl.frontend.driver import check_file
from rapid_dsl.language.codes import CODES
from rapid_dsl.language.diagnostics import render_human

DATA = Path(__file__).parent.parent / "data"
FOLDER = DATA / "diagnostics"
STUBS = DATA / "stub_stdlib"
CASES = sorted(p for p in FOLDER.iterdir() if re.fullmatch(r"[EW]\d{4}\.(rapid|ya?ml)", p.name))
_EXPECT = re.compile(r"^# expect: ([EW]\d{4})$")


def render_case(path: Path) -> tuple[str, list[str]]:
    """All diagnostics of the case, rendered as `rapidc lint` would (no colour), and their codes.

    Run from the case's folder so paths in the output are as a user would type them.
    """
    cwd = os.getcwd()
    os.chdir(FOLDER)
    try:
        result = check_file(path.name, lint=True, stdlib=STUBS)
    finally:
        os.chdir(cwd)
    text = "\n".join(render_human(d, result.sources.get(d.span.path)) for d in result.diagnostics)
    return text + "\n", [d.code for d in result.diagnostics]


@pytest.mark.parametrize("path", CASES, ids=lambda p: p.name)
def test_golden(path: Path, update_goldens: bool) -> None:
    first = path.read_text(encoding="utf-8").splitlines()[0]
    match = _EXPECT.match(first)
    assert match, f"{path.name}: the first line must be `# expect: CODE`"
    code = match.group(1)
    assert path.stem == code
    rendered, codes = render_case(path)
    assert code in codes, rendered
    expected = path.with_suffix(".expected.txt")
    if update_goldens:
        expected.write_text(rendered, encoding="utf-8")
    assert expected.exists(), f"run `pytest --update-goldens` to create {expected.name}"
    assert rendered == expected.read_text(encoding="utf-8")


def test_every_code_has_a_golden_case() -> None:
    have = {p.stem for p in CASES}
    missing = sorted(set(CODES) - have)
    assert not missing, f"codes without a golden case in {FOLDER}: {missing}"
    unknown = sorted(have - set(CODES))
    assert not unknown, f"golden cases for codes that are not in language/codes.py: {unknown}"


def test_e0302_golden_has_the_layout_of_the_language_reference() -> None:
    """LANGUAGE.md section 8: header, empty gutter, numbered line, carets with label, help."""
    lines = (FOLDER / "E0302.expected.txt").read_text().splitlines()
    assert lines[0] == "E0302.rapid:14:5: error[E0302]: cannot compare Length with Real"
    assert lines[1:5] == [
        "   |",
        "14 |     gap < 2",
        "   |     ^^^^^^^ `gap` is a Length",
        "   = help: give the bound a unit, e.g. `2cm`",
    ]


def test_codes_table_lists_the_yaml_form_codes() -> None:
    from rapid_dsl.frontend.yaml import CODES as YAML_CODES
    assert {c: CODES[c] for c in YAML_CODES} == YAML_CODES
