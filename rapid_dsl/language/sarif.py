"""`--format sarif`: the diagnostics of `rapidc check` and `rapidc lint` as one SARIF 2.1.0 log.

GitHub code scanning and other SARIF viewers read it. The log is deterministic: the same inputs in
the same folder give the same bytes (no timestamps, no absolute paths of the machine; rules sorted
by code, results in the order the other formats print them). A file below the working folder is
named by a percent-encoded URI relative to the base id `SRCROOT`, any other file by its absolute
`file:` URI. Regions count columns in UTF-16 code units (SARIF's default), converted from the
project's code-point columns with the source text.

The rules' help comes from docs/diagnostics.md through `code_docs.json`, the copy of its entries
that ships in the package (tests/cli/test_sarif.py keeps the two equal).
"""

from __future__ import annotations

import json
import os
import re
from collections.abc import Mapping, Sequence
from functools import cache
from importlib import metadata, resources
from pathlib import Path
from urllib.parse import quote

from rapid_dsl import __version__
from rapid_dsl.language.codes import CODES
from rapid_dsl.language.diagnostics import Diagnostic, Span

SCHEMA_URI = ("https://docs.oasis-open.org/sarif/sarif/v2.1.0/errata01/os/schemas/"
              "sarif-schema-2.1.0.json")
SRCROOT = "SRCROOT"
DOCS_PAGE = "docs/diagnostics.md"
_LINE_END = re.compile(r"\r\n|\r|\n")   # where the parser ends lines (lsp/positions.py agrees)
_DISTRIBUTION = "rapid-dsl"


def render_sarif(diagnostics: Sequence[Diagnostic], sources: Mapping[str, str], *,
                 problems: Sequence[str] = ()) -> str:
    """The log as JSON text. `problems` are inputs that could not be read (reported on stderr
    too): the run then did not succeed, and each becomes a tool execution notification."""
    return json.dumps(sarif_log(diagnostics, sources, problems=problems), indent=2)


def sarif_log(diagnostics: Sequence[Diagnostic], sources: Mapping[str, str], *,
              problems: Sequence[str] = ()) -> dict[str, object]:
    root = _working_folder()
    codes = sorted({d.code for d in diagnostics})
    index = {code: i for i, code in enumerate(codes)}
    columns = _Columns(sources)

    def location(span: Span, message: str | None) -> dict[str, object]:
        artifact = _artifact_location(span.path, root)
        found: dict[str, object] = {"physicalLocation": {"artifactLocation": artifact,
                                                         "region": columns.region(span)}}
        if message:
            found["message"] = {"text": message}
        return found

    results = []
    for d in diagnostics:
        result: dict[str, object] = {
            "ruleId": d.code,
            "ruleIndex": index[d.code],
            "level": d.severity.value,   # error, warning, note: SARIF's names too
            "message": {"text": d.message + (f"\nhelp: {d.help}" if d.help else "")},
            "locations": [location(d.span, d.label)],
        }
        if d.related:
            result["relatedLocations"] = [{"id": i, **location(span, text)}
                                          for i, (text, span) in enumerate(d.related, 1)]
        results.append(result)

    driver: dict[str, object] = {"name": "rapidc", "version": __version__,
                                 "semanticVersion": __version__}
    urls = _project_urls()
    if "homepage" in urls:
        driver["informationUri"] = urls["homepage"]
    driver["rules"] = [_rule(code, urls.get("documentation")) for code in codes]
    invocation: dict[str, object] = {"executionSuccessful": not problems}
    if problems:
        invocation["toolExecutionNotifications"] = [
            {"level": "error", "message": {"text": problem}} for problem in problems]
    # SRCROOT has a description only: its absolute URI would differ from machine to machine, and
    # SARIF lets a producer leave it out for a deterministic log (section 3.14.14); viewers such
    # as GitHub resolve it to the checkout.
    run: dict[str, object] = {
        "tool": {"driver": driver}, "invocations": [invocation],
        "originalUriBaseIds": {SRCROOT: {"description": {"text": "the folder rapidc ran in"}}},
        "columnKind": "utf16CodeUnits", "results": results}
    return {"$schema": SCHEMA_URI, "version": "2.1.0", "runs": [run]}


# ------------------------------------------------------------------------------------ locations

def _working_folder() -> str | None:
    try:
        return os.getcwd()
    except OSError:   # the folder was removed under us: every path is named absolutely then
        return None


def _artifact_location(path: str, root: str | None) -> dict[str, str]:
    full = os.path.normpath(path if root is None else os.path.join(root, path))  # absolute stays
    if root is not None and _below(full, root):
        return {"uri": _uri_reference(os.path.relpath(full, root)), "uriBaseId": SRCROOT}
    if os.path.isabs(full):
        return {"uri": Path(full).as_uri()}
    return {"uri": _uri_reference(full), "uriBaseId": SRCROOT}   # relative to an unknown folder


def _below(path: str, folder: str) -> bool:
    return os.path.commonpath([path, folder]) == folder


def _uri_reference(relative: str) -> str:
    # A name that is not UTF-8 on disk holds surrogate escapes: they become its original bytes.
    return quote(Path(relative).as_posix(), safe="/", errors="surrogateescape")


class _Columns:
    """Regions of spans, with code-point columns turned into UTF-16 code units."""

    def __init__(self, sources: Mapping[str, str]) -> None:
        self.sources = sources
        self.lines: dict[str, list[str] | None] = {}

    def region(self, span: Span) -> dict[str, int]:
        start_line = max(span.line, 1)
        start = self.utf16(span.path, start_line, span.col)
        end_line = max(span.end_line, start_line)
        end = self.utf16(span.path, end_line, span.end_col)
        if end_line == start_line:
            end = max(end, start)
        return {"startLine": start_line, "startColumn": start, "endLine": end_line,
                "endColumn": end}

    def utf16(self, path: str, line: int, col: int) -> int:
        points = max(col, 1) - 1
        lines = self._lines(path)
        if lines is None or line > len(lines):
            return points + 1
        text = lines[line - 1][:points]
        if text.isascii():
            return points + 1
        # Past the line's end (a span at its line break) the columns go on one per point.
        return len(text.encode("utf-16-le", "surrogatepass")) // 2 + points - len(text) + 1

    def _lines(self, path: str) -> list[str] | None:
        if path not in self.lines:
            text = self.sources.get(path)
            self.lines[path] = _LINE_END.split(text) if text is not None else None
        return self.lines[path]


# ---------------------------------------------------------------------------------------- rules

def _rule(code: str, documentation: str | None) -> dict[str, object]:
    title = CODES[code]
    entry = _code_docs()[code]
    example, message, fix = entry["example"], entry["message"], entry["fix"]
    where = f"{DOCS_PAGE}#{anchor(code)}"
    rule: dict[str, object] = {
        "id": code,
        "shortDescription": {"text": title},
        "fullDescription": {"text": f"{title}. Fix: {fix}"},
        "help": {
            "text": (f"{code}: {title}\nExample: {example}\nMessage: {message}\nFix: {fix}\n"
                     f"See {where}, or run `rapidc explain {code}`."),
            "markdown": (f"**{code}: {title}**\n\n- Example: `{example}`\n- Message: {message}\n"
                         f"- Fix: {fix}\n\nSee `{where}` in rapidc's documentation, or run "
                         f"`rapidc explain {code}`."),
        },
    }
    if documentation:
        rule["helpUri"] = f"{documentation.rstrip('/')}/diagnostics.md#{anchor(code)}"
    rule["defaultConfiguration"] = {"level": "warning" if code.startswith("W") else "error"}
    return rule


def anchor(code: str) -> str:
    """The anchor GitHub gives the heading `### CODE: title` of docs/diagnostics.md."""
    heading = f"{code}: {CODES[code]}".lower()
    return re.sub(r"[^\w\- ]", "", heading).replace(" ", "-")


@cache
def _code_docs() -> dict[str, dict[str, str]]:
    text = resources.files("rapid_dsl").joinpath("code_docs.json").read_text(encoding="utf-8")
    codes: dict[str, dict[str, str]] = json.loads(text)["codes"]
    return codes


def _project_urls() -> dict[str, str]:
    """The package's `[project.urls]` by lower-cased label: `Homepage` becomes the tool's
    informationUri, `Documentation` (the folder of these docs) the base of each rule's helpUri.
    SARIF wants both absolute, so without them (as now) they are left out."""
    try:
        entries = metadata.metadata(_DISTRIBUTION).get_all("Project-URL") or []
    except metadata.PackageNotFoundError:   # run from a source tree that is not installed
        return {}
    urls = {}
    for entry in entries:
        label, _, url = entry.partition(",")
        if url.strip():
            urls[re.sub(r"[\W_]", "", label).lower()] = url.strip()   # as PEP 753 compares
    return urls
