"""`rapidc fmt`: golden layouts, comments kept, --check and --write, exit codes."""

from __future__ import annotations

import stat
from pathlib import Path

import pytest

from rapid_dsl.frontend.formatter import format_module, format_source
from rapid_dsl.frontend.parser import MAX_DEPTH, parse_module
from rapid_dsl.frontend.yaml import parse_yaml_module

from .programs import BAD, CLEAN

FOLDER = Path(__file__).resolve().parents[1] / "data" / "fmt"
INPUTS = sorted(p for p in FOLDER.iterdir()
                if p.name.endswith((".rapid", ".rapid.yaml")) and ".expected." not in p.name)


def _expected(path: Path) -> Path:
    stem = path.name.removesuffix(".yaml").removesuffix(".rapid")
    return path.with_name(f"{stem}.expected.rapid")


def _comments(text: str) -> list[str]:
    return [line[line.index("#"):].strip() for line in text.splitlines()
            if "#" in line and '"' not in line.split("#")[0]]


@pytest.mark.parametrize("path", INPUTS, ids=lambda p: p.name)
def test_golden(path: Path, rapidc, golden):
    run = rapidc("fmt", path)
    assert run.code == 0, run.out + run.err
    golden(_expected(path), run.out)


@pytest.mark.parametrize("path", INPUTS, ids=lambda p: p.name)
def test_golden_output_is_formatted_and_means_the_same(path: Path):
    text = path.read_text(encoding="utf-8")
    expected = _expected(path).read_text(encoding="utf-8")
    if path.name.endswith(".yaml"):
        original, _ = parse_yaml_module(text, "x")
    else:
        original, _ = parse_module(text, "x")
        assert _comments(expected) == _comments(text)
    assert original is not None
    assert parse_module(expected, "x")[0] == original
    assert format_source(expected, "x")[0] == expected
    assert format_module(original) == format_module(parse_module(expected, "x")[0])


def test_check_passes_formatted_and_fails_unformatted_files(rapidc, write):
    good = write("good.rapid", format_source(CLEAN, "x")[0])
    messy = write("messy.rapid", CLEAN.replace("  goal", "goal"))
    assert rapidc("fmt", "--check", good).code == 0
    run = rapidc("fmt", "--check", good, messy)
    assert run.code == 1
    assert run.out == f"would reformat {messy}\n"
    assert "1 file would be reformatted" in run.err
    assert messy.read_text() == CLEAN.replace("  goal", "goal")


def test_check_in_github_format_annotates(rapidc, write):
    messy = write("messy.rapid", CLEAN.replace("  goal", "goal"))
    run = rapidc("fmt", "--check", "--format", "github", messy)
    assert run.code == 1
    assert run.out.startswith(f"::error file={messy},title=rapidc fmt::")


def test_write_rewrites_in_place_keeping_comments_and_mode(rapidc, write, tmp_path):
    path = write("prog.rapid", "# header\n" + CLEAN.replace("  goal", "goal") + "# end\n")
    path.chmod(0o640)
    run = rapidc("fmt", "-w", tmp_path)
    assert run.code == 0
    assert f"reformatted {path}" in run.err
    text = path.read_text()
    assert text.startswith("# header\nprimitive reach_it {\n  goal") and text.endswith("}\n# end\n")
    assert stat.S_IMODE(path.stat().st_mode) == 0o640
    assert [p.name for p in tmp_path.iterdir()] == ["prog.rapid"]  # no temporary file left
    again = rapidc("fmt", "--write", path)
    assert again.code == 0 and "0 reformatted, 1 unchanged" in again.err
    assert rapidc("fmt", "--check", path).code == 0


def test_syntax_errors_exit_1_and_change_nothing(rapidc, write):
    path = write("broken.rapid", "primitive p {\n  goal\n}\n")
    for argv in (["fmt", path], ["fmt", "--check", path], ["fmt", "--write", path]):
        run = rapidc(*argv)
        assert run.code == 1
        assert "error[E0101]" in run.out
    assert path.read_text() == "primitive p {\n  goal\n}\n"


def test_type_errors_do_not_stop_formatting(rapidc, write):
    run = rapidc("fmt", write("bad.rapid", BAD))
    assert run.code == 0 and "10deg" in run.out


def test_yaml_is_printed_as_rapid_but_not_rewritten(rapidc, write):
    path = write("p.rapid.yaml", "- relation: far\n  params: {a: Body, b: Body}\n"
                                 "  body: distance(a, b) > 1cm\n")
    run = rapidc("fmt", path)
    assert (run.code, run.out) == (0, "relation far(a: Body, b: Body) = distance(a, b) > 1cm\n")
    run = rapidc("fmt", "--write", path)
    assert run.code == 2 and "is YAML" in run.err


def test_bad_yaml_exits_1(rapidc, write):
    run = rapidc("fmt", write("p.rapid.yaml", "- relation: [\n"))
    assert run.code == 1 and "error[E0110]" in run.out


@pytest.mark.parametrize("setup", ["two files", "missing", "not utf-8", "empty folder"])
def test_usage_and_io_errors_exit_2(setup, rapidc, write, tmp_path):
    if setup == "two files":
        argv = ["fmt", write("a.rapid", CLEAN), write("b.rapid", CLEAN)]
    elif setup == "missing":
        argv = ["fmt", "--check", tmp_path / "nope.rapid"]
    elif setup == "not utf-8":
        path = write("x.rapid", "")
        path.write_bytes(b"\xff\xfe")
        argv = ["fmt", path]
    else:
        argv = ["fmt", tmp_path]
    run = rapidc(*argv)
    assert run.code == 2
    assert run.err.startswith("rapidc: error:")


def test_a_failed_write_exits_2_and_leaves_the_file(rapidc, write, tmp_path, monkeypatch):
    messy = CLEAN.replace("  goal", "goal")
    path = write("prog.rapid", messy)

    def refuse(*args: object, **kwargs: object) -> None:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr("rapid_dsl.commands.fmt.os.replace", refuse)
    run = rapidc("fmt", "--write", path)
    assert run.code == 2
    assert f"cannot write {path}: Permission denied" in run.err
    assert path.read_text() == messy
    assert [p.name for p in tmp_path.iterdir()] == ["prog.rapid"]


@pytest.mark.slow
def test_a_program_too_deep_to_format_is_a_diagnostic_not_a_crash(rapidc, write):
    chain = " + ".join(["x"] * MAX_DEPTH)
    ok = write("long.rapid", f"def f(x: Length) -> Length = {chain}\n")
    assert rapidc("fmt", ok).code == 0          # as the parser allows: formatted
    for terms in (MAX_DEPTH + 1, 20000):
        text = "def f(x: Length) -> Length = " + " + ".join(["x"] * terms) + "\n"
        deep = write("deep.rapid", text)
        run = rapidc("fmt", "--write", deep)
        assert run.code == 1 and "E0409" in run.out and "deeper than 400 levels" in run.out
        assert deep.read_text() == text
