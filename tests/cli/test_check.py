"""`rapidc check` and `rapidc lint`: exit codes, output formats, colour, folders, bad input."""

from __future__ import annotations

import io
import json
import re
import sys
from pathlib import Path

import pytest

from rapid_dsl.cli import main

from .programs import BAD, CLEAN, WARNS

ANSI = re.compile(r"\x1b\[[0-9;]*m")


def test_clean_file_exits_0_with_summary_on_stderr(rapidc, write):
    run = rapidc("check", write("ok.rapid", CLEAN))
    assert (run.code, run.out) == (0, "")
    assert run.err.strip() == "0 errors, 0 warnings in 1 file"


def test_error_exits_1_and_points_at_the_line(rapidc, write):
    path = write("bad.rapid", BAD)
    run = rapidc("check", path)
    assert run.code == 1
    assert run.out.startswith(f"{path}:5:17: error[E0301]: cannot add Length and Angle\n")
    assert "5 |   cost final = (distance(hand, target) + 10deg) / 1cm" in run.out
    assert run.err.strip() == "1 error, 0 warnings in 1 file"


def test_summary_counts_files_errors_and_warnings(rapidc, write, tmp_path):
    write("a/ok.rapid", CLEAN)
    write("a/bad.rapid", BAD)
    write("a/b/worse.rapid", BAD.replace("touching(hand, target)", "touching(hand, target) + 1"))
    run = rapidc("check", tmp_path / "a")
    assert run.code == 1
    assert run.err.strip() == "3 errors, 0 warnings in 3 files"


def test_quiet_drops_the_summary(rapidc, write):
    run = rapidc("check", "--quiet", write("bad.rapid", BAD))
    assert run.code == 1 and run.err == "" and "E0301" in run.out


def test_json_format_is_one_array_with_the_documented_fields(rapidc, write):
    path = write("bad.rapid", BAD)
    run = rapidc("check", "--format", "json", path)
    assert run.code == 1
    items = json.loads(run.out)
    assert items == [{"file": str(path), "line": 5, "column": 17, "end_line": 5,
                      "end_column": 47, "severity": "error", "code": "E0301",
                      "message": "cannot add Length and Angle", "help": None}]
    assert run.err == ""


def test_json_format_of_a_clean_file_is_an_empty_array(rapidc, write):
    run = rapidc("--format", "json", "check", write("ok.rapid", CLEAN))
    assert (run.code, json.loads(run.out)) == (0, [])


def test_github_format_prints_annotations(rapidc, write):
    path = write("bad.rapid", BAD)
    run = rapidc("check", "--format", "github", path)
    assert run.code == 1
    assert run.out == (f"::error file={path},line=5,endLine=5,col=17,endColumn=47,"
                       "title=rapidc (E0301)::cannot add Length and Angle\n")


def test_options_before_the_command_apply_and_after_it_override(rapidc, write):
    path = write("bad.rapid", BAD)
    assert rapidc("--format", "json", "check", path).out.startswith("[")
    assert rapidc("--format", "json", "check", "--format", "github", path).out.startswith("::")


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _run_on_terminal(argv: list[str]) -> tuple[int, str]:
    out, saved = _Terminal(), sys.stdout
    sys.stdout = out
    try:
        return main(argv), out.getvalue()
    finally:
        sys.stdout = saved


@pytest.mark.parametrize(("color", "terminal", "no_color", "expect"), [
    ("auto", False, None, False),
    ("auto", True, None, True),
    ("auto", True, "1", False),
    ("always", False, None, True),
    ("always", True, "1", True),
    ("never", True, None, False),
])
def test_colour(color, terminal, no_color, expect, write, monkeypatch, capsys):
    if no_color is None:
        monkeypatch.delenv("NO_COLOR", raising=False)
    else:
        monkeypatch.setenv("NO_COLOR", no_color)
    argv = ["check", "--color", color, str(write("bad.rapid", BAD))]
    if terminal:
        code, out = _run_on_terminal(argv)
    else:
        code, out = main(argv), capsys.readouterr().out
    assert code == 1
    assert bool(ANSI.search(out)) is expect
    assert "cannot add Length and Angle" in ANSI.sub("", out)


def test_folders_expand_to_rapid_and_yaml_files_only(rapidc, write, tmp_path):
    write("p/ok.rapid", CLEAN)
    write("p/sub/bad.rapid", BAD)
    write("p/prog.rapid.yml", "- relation: far\n  params: {a: Body, b: Body}\n"
                              "  body: distance(a, b) > 1cm\n")
    write("p/notes.txt", "not a program")
    write("p/scene.yaml", "not: [a program")
    write("p/.hidden/bad.rapid", BAD)
    run = rapidc("check", "--format", "json", tmp_path / "p")
    assert run.code == 1
    assert [d["file"] for d in json.loads(run.out)] == [str(tmp_path / "p/sub/bad.rapid")]
    run = rapidc("check", tmp_path / "p")
    assert run.err.strip().endswith("in 3 files")


def test_an_explicit_file_of_any_extension_is_checked(rapidc, write):
    assert rapidc("check", write("prog.txt", BAD)).code == 1


def test_a_folder_without_programs_is_clean(rapidc, tmp_path):
    run = rapidc("check", tmp_path)
    assert run.code == 0
    assert "no .rapid or .rapid.yaml files found" in run.err


def test_missing_file_exits_2(rapidc, write, tmp_path):
    run = rapidc("check", write("ok.rapid", CLEAN), tmp_path / "nope.rapid")
    assert run.code == 2
    assert f"no such file or folder: {tmp_path / 'nope.rapid'}" in run.err
    assert "Traceback" not in run.err


def test_unreadable_file_exits_2(rapidc, write):
    path = write("latin1.rapid", "")
    path.write_bytes(b'primitive p { goal "caf\xe9" }\n')
    run = rapidc("check", path)
    assert run.code == 2
    assert "not UTF-8 text" in run.err


@pytest.mark.parametrize("argv", [
    [], ["check"], ["check", "--bogus", "x.rapid"], ["--format", "xml", "check", "x.rapid"],
    ["--color", "sometimes", "check", "x.rapid"], ["frobnicate"],
    ["fmt", "--check", "--write", "x"], ["schema", "extra"], ["explain", "E0101", "E0102"],
    ["bench"], ["explain"],
])
def test_usage_errors_exit_2(rapidc, argv):
    run = rapidc(*argv)
    assert run.code == 2
    assert "usage:" in run.err and "Traceback" not in run.err


def test_help_and_version_exit_0(rapidc):
    assert rapidc("--help").code == 0
    assert rapidc("check", "--help").code == 0
    run = rapidc("--version")
    assert run.code == 0 and run.out.startswith("rapidc ")


def test_internal_error_exits_3_without_traceback(rapidc, write, monkeypatch):
    def broken(*args, **kwargs):
        raise ZeroDivisionError("boom")

    monkeypatch.setattr("rapid_dsl.frontend.driver.check_file", broken)
    monkeypatch.delenv("RAPIDC_DEBUG", raising=False)
    run = rapidc("check", write("ok.rapid", CLEAN))
    assert run.code == 3
    assert "rapidc: internal error: ZeroDivisionError: boom" in run.err
    assert "please report it" in run.err and "Traceback" not in run.err


def test_lint_adds_warnings_that_fail_only_with_strict(rapidc, write):
    path = write("warns.rapid", WARNS)
    assert rapidc("check", path).code == 0
    run = rapidc("lint", path)
    assert run.code == 0
    assert "warning[W0101]: role `table` is never used" in run.out
    assert run.err.strip() == "0 errors, 1 warning in 1 file"
    assert rapidc("lint", "--strict", path).code == 1
    assert rapidc("--strict", "lint", path).code == 1
    assert rapidc("lint", "--strict", write("ok.rapid", CLEAN)).code == 0


def test_lint_json_reports_warning_severity(rapidc, write):
    run = rapidc("lint", "--format", "json", write("warns.rapid", WARNS))
    assert [(d["severity"], d["code"]) for d in json.loads(run.out)] == [("warning", "W0101")]


def test_lint_exit_codes_for_errors_and_missing_files(rapidc, write, tmp_path):
    assert rapidc("lint", write("bad.rapid", BAD)).code == 1
    assert rapidc("lint", tmp_path / "missing.rapid").code == 2


def test_the_examples_and_standard_library_check_clean(rapidc):
    root = Path(__file__).resolve().parents[2]
    run = rapidc("check", root / "stdlib_primitives", root / "examples")
    assert run.code == 0, run.out


def test_a_param_that_only_shapes_the_path_is_not_an_effect_param(rapidc, write):
    """W0107 asks success to read the effect params, those the final cost judges; a param only
    `cost progress` reads (how to approach) does not make it warn."""
    path = write("p.rapid", """primitive reach_it {
  goal "Touch the target"
  roles { target: Object, hand: Manipulator }
  params { approach: Direction = [0, 0, -1] }
  success { touching(hand, target) }
  cost final = distance(hand, target) / 1cm
  cost progress = norm(cross(normalize(pos(target) - pos(hand)), approach))
  motion { keypoint reach = pos(target) }
}
""")
    run = rapidc("lint", path)
    assert "W0107" not in run.out, run.out
