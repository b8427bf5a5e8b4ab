"""Usage errors (`rapidc: error: ...`, exit 2) print no terminal control sequences."""

from __future__ import annotations


def test_usage_errors_escape_control_characters_of_file_names(rapidc, tmp_path):
    (tmp_path / "bad\x1b[2J.rapid").write_bytes(b"\xff")     # found by walking the folder
    run = rapidc("check", tmp_path)
    assert run.code == 2
    assert "bad\\x1b[2J.rapid: not UTF-8 text" in run.err and "\x1b" not in run.err


def test_usage_errors_escape_control_characters_of_arguments(rapidc):
    run = rapidc("explain", "\x1b]0;title\x07")
    assert run.code == 2
    assert "unknown diagnostic code `\\x1b]0;title\\x07`" in run.err
    assert "\x1b" not in run.err and "\x07" not in run.err
