"""The language docs stay equal to the code: the builtin list comes from the registry, the
diagnostics page from language/codes.py and the golden cases, and every example checks clean.
`pytest --update-goldens` regenerates the generated parts.
"""

from __future__ import annotations

import re
from pathlib import Path

from rapid_dsl.frontend.driver import check_text
from rapid_dsl.language.codes import CODES
from rapid_dsl.language.diagnostics import Diagnostic, render_human
from rapid_dsl.language.registry import BUILTINS

from .test_golden_diagnostics import CASES, FOLDER, STUBS

ROOT = Path(__file__).parent.parent.parent
LANGUAGE = ROOT / "docs" / "language.md"
DIAGNOSTICS = ROOT / "docs" / "diagnostics.md"
BEGIN, END = "<!-- builtins:begin -->", "<!-- builtins:end -->"

# The fix for codes whose diagnostic has no help line, and examples too long to quote.
FIXES = {
    "E0101": "write what the message says is expected at that place",
    "E0116": "flatten the YAML; do not let an alias refer to itself",
    "E0301": "give both sides the same dimension, e.g. `distance(a, b) + 1cm`",
    "E0312": "take a component of a vector only, e.g. `pos(box).z`",
    "E0406": "use a positive integer (a non-negative one for `seed`), a positive duration or "
             "spread, a non-negative weight",
}
EXAMPLES = {
    "E0103": 'primitive p { goal "unfinished"   # and the file ends here',
    "E0107": "def deep() -> Real = (((( ... 101 levels ... 1 ... ))))",
    "E0409": "def long() -> Real = 1 + 1 + 1 + ...   # 500 terms",
}


def builtin_table() -> str:
    rows = ["| Builtin | Signature | |", "|---|---|---|"]
    for b in BUILTINS.values():
        rows.append(f"| `{b.name}` | `{b.signature}` | {b.doc.replace('|', '/')} |")
    return "\n".join(rows)


def test_language_reference_lists_every_builtin(update_goldens: bool) -> None:
    text = LANGUAGE.read_text()
    start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    generated = "\n" + builtin_table() + "\n"
    if update_goldens:
        LANGUAGE.write_text(text[:start] + generated + text[end:])
        text = LANGUAGE.read_text()
        start, end = text.index(BEGIN) + len(BEGIN), text.index(END)
    assert text[start:end] == generated


def _example(path: Path, d: Diagnostic, sources: dict[str, str]) -> str:
    code = d.code
    if code in EXAMPLES:
        return EXAMPLES[code]
    source = sources.get(d.span.path, "")
    lines = source.splitlines()
    return lines[d.span.line - 1].strip() if 0 < d.span.line <= len(lines) else ""


def diagnostics_page() -> str:
    import os

    from .test_golden_diagnostics import render_case  # noqa: F401  (same setup as the goldens)

    out = ["# Diagnostics", "",
           "Every code `rapidc` reports, with a one-line example and its fix. Generated from",
           "`rapid_dsl/language/codes.py` and the golden cases in `tests/data/diagnostics/`",
           "(each shows the full output); regenerate with `pytest --update-goldens`. E01xx are",
           "syntax (E011x the YAML form), E02xx names, scopes and modules, E03xx types and",
           "dimensions, E04xx block structure, E05xx role maps and arguments, W01xx lint warnings",
           "(`rapidc lint`).",
           ""]
    section = None
    sections = {"E01": "Syntax", "E02": "Names, scopes and modules", "E03": "Types and dimensions",
                "E04": "Block structure", "E05": "Role maps and arguments", "W01": "Lint"}
    cases = {p.stem: p for p in CASES}
    for code, title in CODES.items():
        if sections[code[:3]] != section:
            section = sections[code[:3]]
            out += [f"## {section}", ""]
        path = cases[code]
        cwd = os.getcwd()
        os.chdir(FOLDER)
        try:
            from rapid_dsl.frontend.driver import check_file
            result = check_file(path.name, lint=True, stdlib=STUBS)
        finally:
            os.chdir(cwd)
        d = next(d for d in result.diagnostics if d.code == code)
        fix = d.help or FIXES[code]
        out += [f"### {code}: {title}", "",
                f"- Example: `{_example(path, d, result.sources)}`",
                f"- Message: {d.message}",
                f"- Fix: {fix}", ""]
    return "\n".join(out)


def test_diagnostics_page_lists_every_code(update_goldens: bool) -> None:
    page = diagnostics_page()
    if update_goldens:
        DIAGNOSTICS.write_text(page)
    assert DIAGNOSTICS.read_text() == page
    for code in CODES:
        assert f"### {code}:" in page


def test_docs_examples_check_clean() -> None:
    """Every ```rapid block of docs/language.md that is a whole program checks clean."""
    text = LANGUAGE.read_text()
    blocks = re.findall(r"```rapid\n(.*?)```", text, re.S)
    assert len(blocks) >= 3
    for i, block in enumerate(blocks):
        if block.startswith("# fragment"):
            continue
        result = check_text(block, str(ROOT / "tests" / "data" / "language" / f"docs_{i}.rapid"),
                            stdlib=STUBS)
        report = "\n".join(render_human(d, result.sources.get(d.span.path))
                           for d in result.diagnostics)
        assert result.diagnostics == [], report


def test_language_reference_names_every_code_range_and_default() -> None:
    text = LANGUAGE.read_text()
    for needle in ("| `optimize samples` | 64 |", "| `motion spread` | 2cm |",
                   "| `motion duration` | 2s |", "| `motion spread_angle` | 10deg |",
                   "## 11. Decisions"):
        assert needle in text
