"""`--format sarif`: the SARIF 2.1.0 log of `rapidc check` and `rapidc lint`.

Real logs are validated against the official OASIS schema (tests/data/sarif/README.md says where
it comes from), with the `uri` and `uri-reference` formats checked too; the rules' help is the
copy of docs/diagnostics.md in rapid_dsl/code_docs.json; the GitHub Action's `sarif` input runs
the real step script of action.yml.
"""

from __future__ import annotations

import contextlib
import email.message
import io
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
from datetime import timedelta
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from jsonschema import Draft4Validator, FormatChecker
from ruamel.yaml import YAML

from rapid_dsl import __version__
from rapid_dsl.cli import main
from rapid_dsl.language.codes import CODES

from .programs import BAD, CLEAN, WARNS

ROOT = Path(__file__).resolve().parents[2]
DATA = ROOT / "tests" / "data" / "sarif"
CODE_DOCS = ROOT / "rapid_dsl" / "code_docs.json"
DIAGNOSTICS_PAGE = ROOT / "docs" / "diagnostics.md"

# RFC 3986: the characters a URI may hold, and percent escapes.
_URI_TEXT = re.compile(r"(?:[A-Za-z0-9\-._~:/?#\[\]@!$&'()*+,;=]|%[0-9A-Fa-f]{2})*")
_SCHEME = re.compile(r"[A-Za-z][A-Za-z0-9+.-]*:")
FORMATS = FormatChecker()


@FORMATS.checks("uri")
def _is_uri(value: object) -> bool:
    return not isinstance(value, str) or bool(_SCHEME.match(value) and _URI_TEXT.fullmatch(value))


@FORMATS.checks("uri-reference")
def _is_uri_reference(value: object) -> bool:
    if not isinstance(value, str):
        return True
    first = value.split("/", 1)[0]   # a relative reference's first segment holds no colon
    return bool(_URI_TEXT.fullmatch(value)) and (":" not in first or bool(_SCHEME.match(value)))


VALIDATOR = Draft4Validator(json.loads((DATA / "sarif-schema-2.1.0.json").read_text()),
                            format_checker=FORMATS)


def validate(log: object) -> None:
    errors = sorted(VALIDATOR.iter_errors(log), key=lambda e: list(e.absolute_path))
    assert not errors, "\n".join(f"{list(e.absolute_path)}: {e.message}" for e in errors)


def utf16_column(line: str, column: int) -> int:
    """The SARIF column of a code-point column: every character past U+FFFF counts twice."""
    return 1 + sum(2 if ord(c) > 0xFFFF else 1 for c in line[: column - 1])


def lint_project(rapidc, tmp_path: Path, monkeypatch, *argv: str):
    shutil.copytree(DATA / "project", tmp_path / "project")
    monkeypatch.chdir(tmp_path)
    return rapidc("lint", "--format", "sarif", *argv, "project")


# ---------------------------------------------------------------------------------- the log

def test_project_log_is_valid_sarif_and_matches_the_golden(rapidc, tmp_path, monkeypatch,
                                                           golden):
    run = lint_project(rapidc, tmp_path, monkeypatch)
    assert run.code == 1 and run.err == ""
    log = json.loads(run.out)
    validate(log)
    golden(DATA / "project.expected.sarif",
           run.out.replace(f'Version": "{__version__}"', 'Version": "{version}"')
           .replace(f'"version": "{__version__}"', '"version": "{version}"') + "\n")
    assert lint_project(rapidc, tmp_path / "again", monkeypatch).out == run.out


def test_project_log_holds_every_diagnostic_with_its_rule(rapidc, tmp_path, monkeypatch):
    sarif = lint_project(rapidc, tmp_path, monkeypatch)
    diagnostics = json.loads(rapidc("lint", "--format", "json", "project").out)
    (run,) = json.loads(sarif.out)["runs"]
    results = run["results"]
    assert run["tool"]["driver"]["name"] == "rapidc"
    assert run["tool"]["driver"]["version"] == __version__
    assert run["invocations"] == [{"executionSuccessful": True}]
    assert run["columnKind"] == "utf16CodeUnits"
    assert {d["severity"] for d in diagnostics} == {"error", "warning"}
    assert len(results) == len(diagnostics) == 7
    for result, d in zip(results, diagnostics, strict=True):
        location = result["locations"][0]["physicalLocation"]
        assert location["artifactLocation"] == {
            "uri": d["file"], "uriBaseId": "SRCROOT"}   # relative, with `/`, no `./`
        line = (tmp_path / d["file"]).read_text(encoding="utf-8").split("\n")[d["line"] - 1]
        end_line = (tmp_path / d["file"]).read_text(encoding="utf-8").split("\n")[
            d["end_line"] - 1]
        assert location["region"] == {
            "startLine": d["line"], "startColumn": utf16_column(line, d["column"]),
            "endLine": d["end_line"], "endColumn": utf16_column(end_line, d["end_column"])}
        assert (result["ruleId"], result["level"]) == (d["code"], d["severity"])
        help_line = f"\nhelp: {d['help']}" if d["help"] else ""
        assert result["message"]["text"] == d["message"] + help_line
    rules = run["tool"]["driver"]["rules"]
    assert [r["id"] for r in rules] == sorted({d["code"] for d in diagnostics})
    for result in results:
        rule = rules[result["ruleIndex"]]
        assert rule["id"] == result["ruleId"]
        assert rule["shortDescription"]["text"] == CODES[rule["id"]]
        assert rule["defaultConfiguration"]["level"] == (
            "warning" if rule["id"].startswith("W") else "error")


def test_columns_count_utf16_code_units_after_non_bmp_characters(rapidc, tmp_path, monkeypatch):
    results = json.loads(lint_project(rapidc, tmp_path, monkeypatch).out)["runs"][0]["results"]
    regions = {(r["ruleId"], r["locations"][0]["physicalLocation"]["artifactLocation"]["uri"]):
               r["locations"][0]["physicalLocation"]["region"] for r in results}
    # `goal "🎯 hit the 𝒯arget" roles`: `roles` is code point 41, UTF-16 unit 43.
    assert regions["E0101", "project/sub/astral.rapid"] == {
        "startLine": 2, "startColumn": 43, "endLine": 2, "endColumn": 48}
    # The YAML line has `goal: "Push 🎯 the 𝒷ox"` before the comparison at code points 103-129.
    assert regions["E0302", "project/sub/form.rapid.yaml"] == {
        "startLine": 2, "startColumn": 105, "endLine": 2, "endColumn": 131}


def test_notes_are_related_locations_and_labels_are_location_messages(rapidc, tmp_path,
                                                                      monkeypatch):
    results = json.loads(lint_project(rapidc, tmp_path, monkeypatch).out)["runs"][0]["results"]
    twice = next(r for r in results if r["ruleId"] == "E0202")
    assert twice["relatedLocations"] == [{
        "id": 1,
        "physicalLocation": {
            "artifactLocation": {"uri": "project/errors.rapid", "uriBaseId": "SRCROOT"},
            "region": {"startLine": 5, "startColumn": 11, "endLine": 5, "endColumn": 19}},
        "message": {"text": "first declared"}}]
    compare = next(r for r in results if r["ruleId"] == "E0302")
    assert compare["locations"][0]["message"] == {"text": "`distance(a, b)` is a Length"}
    assert compare["message"]["text"] == ("cannot compare Length with Real\n"
                                          "help: give the bound a unit, e.g. `2cm`")


def test_rules_carry_the_diagnostics_page(rapidc, write):
    log = json.loads(rapidc("check", "--format", "sarif", write("bad.rapid", BAD)).out)
    (rule,) = log["runs"][0]["tool"]["driver"]["rules"]
    assert rule["id"] == "E0301"
    assert rule["shortDescription"] == {"text": "mismatched dimensions"}
    assert rule["fullDescription"] == {
        "text": "mismatched dimensions. Fix: give both sides the same dimension, e.g. "
                "`distance(a, b) + 1cm`"}
    section = DIAGNOSTICS_PAGE.read_text().split("### E0301: mismatched dimensions\n\n")[1]
    entry = section.split("\n\n")[0]
    assert entry in rule["help"]["markdown"]
    assert "docs/diagnostics.md#e0301-mismatched-dimensions" in rule["help"]["text"]
    assert "rapidc explain E0301" in rule["help"]["text"]
    # The project declares no URL, and SARIF wants absolute ones: none is made up.
    assert "helpUri" not in rule and "informationUri" not in log["runs"][0]["tool"]["driver"]


def test_declared_project_urls_become_information_and_help_uris(rapidc, write, monkeypatch):
    meta = email.message.Message()
    meta["Name"] = "rapid-dsl"
    meta["Project-URL"] = "Homepage, https://example.org/rapid"
    meta["Project-URL"] = "Documentation, https://example.org/rapid/docs/"
    monkeypatch.setattr("importlib.metadata.metadata", lambda name: meta)
    log = json.loads(rapidc("check", "--format", "sarif", write("bad.rapid", BAD)).out)
    validate(log)
    driver = log["runs"][0]["tool"]["driver"]
    assert driver["informationUri"] == "https://example.org/rapid"
    assert driver["rules"][0]["helpUri"] == (
        "https://example.org/rapid/docs/diagnostics.md#e0301-mismatched-dimensions")


def test_every_anchor_is_a_heading_of_the_diagnostics_page():
    from rapid_dsl.language.sarif import anchor

    headings = re.findall(r"^### (.+)$", DIAGNOSTICS_PAGE.read_text(), re.M)
    assert len(headings) == len(CODES)
    # GitHub's rule: lower case, punctuation other than `-` and `_` dropped, spaces to `-`.
    assert {anchor(code) for code in CODES} == {
        re.sub(r"[^\w\- ]", "", h.lower()).replace(" ", "-") for h in headings}
    assert anchor("E0108") == "e0108-use-names-no-declaration"
    assert anchor("E0115") == ("e0115-a-text-holds-a-line-break-or-a-lone-surrogate-which-rapid-"
                               "text-cannot-hold")


def test_a_clean_run_is_an_empty_valid_log(rapidc, write):
    run = rapidc("check", "--format", "sarif", write("ok.rapid", CLEAN))
    assert run.code == 0 and run.err == ""
    log = json.loads(run.out)
    validate(log)
    assert log["runs"][0]["results"] == [] and log["runs"][0]["tool"]["driver"]["rules"] == []


def test_strict_lint_fails_on_warnings_in_sarif_too(rapidc, write):
    path = write("warns.rapid", WARNS)
    assert rapidc("lint", "--format", "sarif", path).code == 0
    run = rapidc("--format", "sarif", "lint", "--strict", path)
    assert run.code == 1
    (result,) = json.loads(run.out)["runs"][0]["results"]
    assert (result["ruleId"], result["level"]) == ("W0101", "warning")


def test_an_unreadable_input_is_an_unsuccessful_execution(rapidc, write):
    good = write("bad.rapid", BAD)
    latin1 = write("latin1.rapid", "")
    latin1.write_bytes(b'primitive p { goal "caf\xe9" }\n')
    run = rapidc("check", "--format", "sarif", good, latin1)
    assert run.code == 2
    assert "not UTF-8 text" in run.err
    log = json.loads(run.out)
    validate(log)
    (invocation,) = log["runs"][0]["invocations"]
    assert invocation["executionSuccessful"] is False
    (notification,) = invocation["toolExecutionNotifications"]
    assert notification["level"] == "error" and "not UTF-8 text" in notification["message"]["text"]
    assert [r["ruleId"] for r in log["runs"][0]["results"]] == ["E0301"]


def test_names_are_percent_encoded_and_files_outside_the_folder_absolute(rapidc, tmp_path,
                                                                         monkeypatch):
    work = tmp_path / "work"
    (work / "odd dir").mkdir(parents=True)
    (work / "odd dir" / "a%b#c ü.rapid").write_text(BAD)
    Path(os.fsdecode(os.fsencode(work / "odd dir") + b"/raw\xff.rapid")).write_text(BAD)
    (tmp_path / "outside.rapid").write_text(BAD)
    monkeypatch.chdir(work)
    run = rapidc("check", "--format", "sarif", "odd dir", tmp_path / "outside.rapid")
    assert run.code == 1, run.err
    log = json.loads(run.out)
    validate(log)
    locations = [r["locations"][0]["physicalLocation"]["artifactLocation"]
                 for r in log["runs"][0]["results"]]
    assert locations == [
        {"uri": "odd%20dir/a%25b%23c%20%C3%BC.rapid", "uriBaseId": "SRCROOT"},
        {"uri": "odd%20dir/raw%FF.rapid", "uriBaseId": "SRCROOT"},
        {"uri": (tmp_path / "outside.rapid").as_uri()}]


def test_a_removed_working_folder_names_files_absolutely(rapidc, tmp_path, monkeypatch):
    program = tmp_path / "bad.rapid"
    program.write_text(BAD)
    gone = tmp_path / "gone"
    gone.mkdir()
    monkeypatch.chdir(gone)
    gone.rmdir()
    run = rapidc("check", "--format", "sarif", program)
    assert run.code == 1, run.err
    log = json.loads(run.out)
    validate(log)
    location = log["runs"][0]["results"][0]["locations"][0]["physicalLocation"]
    assert location["artifactLocation"] == {"uri": program.as_uri()}


@pytest.mark.parametrize("argv", [
    ["fmt", "--check", "--format", "sarif", "x.rapid"], ["--format", "sarif", "fmt", "x.rapid"],
    ["compile", "--format", "sarif", "x.rapid", "-o", "out"], ["--format", "sarif", "schema"],
    ["--format", "sarif", "bench", "check"], ["explain", "E0101", "--format", "sarif"],
])
def test_commands_other_than_check_and_lint_refuse_sarif(rapidc, argv):
    run = rapidc(*argv)
    assert run.code == 2 and run.out == ""
    assert "--format sarif is for `rapidc check` and `rapidc lint`" in run.err
    assert "usage:" in run.err and "Traceback" not in run.err


def test_help_says_sarif_is_for_check_and_lint(rapidc):
    for argv in (["--help"], ["check", "--help"], ["fmt", "--help"]):
        text = " ".join(rapidc(*argv).out.split())
        assert "a SARIF 2.1.0 log (check and lint only)" in text, argv


# ------------------------------------------------------------------------------ property

WORK = Path(tempfile.mkdtemp(prefix="rapidc-sarif-"))


def _quiet(*argv: str) -> str:
    out = io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(io.StringIO()):
        main(list(argv))
    return out.getvalue()


@settings(max_examples=60, deadline=timedelta(seconds=5), database=None,
          derandomize=not os.environ.get("RAPIDC_HYPOTHESIS_RANDOM"),
          suppress_health_check=[HealthCheck.too_slow])
@given(st.text(st.characters(blacklist_categories=("Cs", "Cc"), blacklist_characters='"\\'),
               max_size=12))
def test_sarif_columns_are_the_json_columns_in_utf16(text):
    """Whatever characters stand before a diagnostic on its line, SARIF's columns are the JSON
    format's code-point columns counted in UTF-16 code units."""
    path = WORK / "goal.rapid"
    source = f'primitive p {{ goal "{text}" roles {{ t: Object }} }}\n'
    path.write_text(source, encoding="utf-8")
    diagnostics = json.loads(_quiet("check", "--format", "json", str(path)))
    log = json.loads(_quiet("check", "--format", "sarif", str(path)))
    validate(log)
    results = log["runs"][0]["results"]
    assert diagnostics and len(results) == len(diagnostics)
    lines = source.split("\n")
    for result, d in zip(results, diagnostics, strict=True):
        region = result["locations"][0]["physicalLocation"]["region"]
        assert region["startColumn"] == utf16_column(lines[d["line"] - 1], d["column"])
        assert region["endColumn"] == utf16_column(lines[d["end_line"] - 1], d["end_column"])


# ---------------------------------------------------------------------- the rules' help

def code_docs_from_page(page: str) -> dict[str, object]:
    """Each `### CODE: title` entry of docs/diagnostics.md: its example, message and fix."""
    codes: dict[str, dict[str, str]] = {}
    for match in re.finditer(r"^### (\w+): .*\n\n- Example: `(.*)`\n- Message: (.*)\n- Fix: (.*)$",
                             page, re.M):
        code, example, message, fix = match.groups()
        codes[code] = {"example": example, "message": message, "fix": fix}
    return {"source": "docs/diagnostics.md, copied by tests/cli/test_sarif.py "
                      "(pytest --update-goldens)", "codes": codes}


def test_code_docs_are_the_diagnostics_page(update_goldens):
    expected = json.dumps(code_docs_from_page(DIAGNOSTICS_PAGE.read_text(encoding="utf-8")),
                          indent=2, ensure_ascii=False) + "\n"
    if update_goldens:
        CODE_DOCS.write_text(expected, encoding="utf-8")
    assert CODE_DOCS.read_text(encoding="utf-8") == expected, (
        "rapid_dsl/code_docs.json differs from docs/diagnostics.md; run pytest --update-goldens")
    assert list(json.loads(expected)["codes"]) == list(CODES)


def test_code_docs_ship_in_the_package():
    pyproject = (ROOT / "pyproject.toml").read_text()
    assert re.search(r'rapid_dsl = \[[^\]]*"code_docs\.json"', pyproject)


# ------------------------------------------------------------------------- GitHub Action

ACTION = YAML(typ="safe").load((ROOT / "action.yml").read_text())
_EXPRESSION = re.compile(r"\$\{\{\s*(inputs|github)\.([\w-]+)\s*\}\}")


def _sarif_step() -> dict:
    (step,) = [s for s in ACTION["runs"]["steps"] if "RAPIDC_SARIF" in s.get("env", {})]
    return step


def _run_step(step: dict, folder: Path, **given: str) -> subprocess.CompletedProcess[str]:
    """Run a composite step's script as the runner would: `${{ inputs.X }}` and
    `${{ github.action_path }}` replaced, its env set, in the workspace `folder`."""
    inputs = {name: spec.get("default", "") for name, spec in ACTION["inputs"].items()}
    inputs.update(given)

    def expand(text: str) -> str:
        return _EXPRESSION.sub(
            lambda m: inputs[m[2]] if m[1] == "inputs" else {"action_path": str(ROOT)}[m[2]],
            text)

    env = {**os.environ, "PYTHON": sys.executable,
           **{key: expand(str(value)) for key, value in step["env"].items()}}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    return subprocess.run([step["shell"], "-c", expand(step["run"])], cwd=folder, env=env,
                          capture_output=True, text=True, timeout=60, check=False)


def test_action_has_a_sarif_input_wired_to_its_own_step():
    assert ACTION["inputs"]["sarif"]["default"] == ""
    assert "upload-sarif" in ACTION["inputs"]["sarif"]["description"]
    steps = ACTION["runs"]["steps"]
    step = _sarif_step()
    assert steps.index(step) == len(steps) - 1       # after the checking step, which it keeps
    assert "scripts/action_check.sh" in steps[2]["run"] and "RAPIDC_SARIF" not in steps[2]["env"]
    assert step["env"]["RAPIDC_SARIF"] == "${{ inputs.sarif }}"
    assert step["env"]["RAPIDC_COMMAND"] == "${{ inputs.command }}"
    assert step["env"]["RAPIDC_ARGS"].startswith("${{ inputs.args }}")
    condition = step["if"].replace(" ", "")
    # Runs when asked, also after the checking step failed on errors, not if rapidc is missing.
    assert "inputs.sarif!=''" in condition and "!cancelled()" in condition
    install = next(s for s in steps if s.get("id") == "install")
    assert "pip install" in install["run"]
    assert f"steps.{install['id']}.outcome=='success'" in condition


def test_action_sarif_step_writes_a_valid_log_and_passes_on_errors(tmp_path):
    (tmp_path / "progs").mkdir()
    (tmp_path / "progs" / "bad.rapid").write_text(BAD)
    (tmp_path / "progs" / "warns.rapid").write_text(WARNS)
    result = _run_step(_sarif_step(), tmp_path, paths="progs", command="lint",
                       sarif="reports/rapidc.sarif")
    assert result.returncode == 0, result.stderr
    log = json.loads((tmp_path / "reports" / "rapidc.sarif").read_text())
    validate(log)
    assert [(r["ruleId"], r["locations"][0]["physicalLocation"]["artifactLocation"]["uri"])
            for r in log["runs"][0]["results"]] == [("E0301", "progs/bad.rapid"),
                                                    ("W0101", "progs/warns.rapid")]


def test_action_sarif_step_fails_on_usage_errors(tmp_path):
    result = _run_step(_sarif_step(), tmp_path, paths="nope", sarif="out.sarif")
    assert result.returncode == 2
    assert "no such file or folder: nope" in result.stderr
    result = _run_step(_sarif_step(), tmp_path, sarif="out.sarif", command="rm")
    assert result.returncode == 2
