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


HOSTILE = "\x1b]0;pwned\x07\x1b[2J\u202e\x00"


def test_diagnostics_show_control_characters_of_program_text_as_escapes(rapidc, write):
    """A program cannot drive the terminal that shows its diagnostics: escape sequences, bidi
    overrides and NUL in its text appear as `\\x1b`-style escapes, with the carets still under
    the span."""
    path = write("esc.rapid", f'use "{HOSTILE}.rapid"\n')
    run = rapidc("check", path)
    assert run.code == 1
    assert not any(c in run.out for c in HOSTILE if not c.isprintable())
    assert '"\\x1b]0;pwned\\x07\\x1b[2J\\u202e\\x00.rapid"' in run.out
    lines = run.out.splitlines()
    source = next(i for i, line in enumerate(lines) if line.startswith("1 | "))
    assert lines[source + 1].index("^") == lines[source].index("u")
    assert lines[source + 1].rstrip().endswith("^") and \
        len(lines[source + 1].strip(" |")) == len(lines[source][4:].rstrip())


def test_fmt_shows_control_characters_of_file_names_as_escapes(rapidc, write):
    path = write("a\x1b[2J.rapid", "strategy s {\ngoal \"g\"\n}\n")
    run = rapidc("fmt", "--check", path.parent)
    assert "\x1b" not in run.out + run.err


def test_an_empty_output_folder_is_a_usage_error(rapidc, write):
    program = write("p.rapid", 'strategy s {\n  goal "g"\n}\n')
    for argv in (("compile", program, "-o", ""), ("variants", program, "-n", "1", "-o", " ")):
        try:
            code = rapidc(*argv).code
        except SystemExit as exit:   # argparse rejects the value itself
            code = exit.code
        assert code == 2, argv


def test_fmt_write_leaves_a_read_only_file_alone(rapidc, write):
    path = write("p.rapid", 'strategy   s {\n  goal "g"\n}\n')
    path.chmod(0o444)
    run = rapidc("fmt", "-w", path)
    assert run.code == 2 and "read-only" in run.err
    assert path.read_text() == 'strategy   s {\n  goal "g"\n}\n'


def test_output_that_cannot_be_written_is_exit_2_not_an_internal_error(tmp_path):
    """A full disk (/dev/full) or a closed standard output ends the process with a reason."""
    import subprocess
    import sys

    program = tmp_path / "p.rapid"
    program.write_text("".join(f"def d{i}(x: Length) -> Real = x\n" for i in range(300)))
    command = [sys.executable, "-m", "rapid_dsl", "check", str(program)]
    with open("/dev/full", "w") as full:
        run = subprocess.run(command, stdout=full, stderr=subprocess.PIPE, text=True, timeout=60)
    assert run.returncode == 2 and "cannot write the output: No space left" in run.stderr
    closed = subprocess.run(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                            text=True, timeout=60, close_fds=True,
                            preexec_fn=lambda: __import__("os").close(1))
    assert closed.returncode == 1 and "internal error" not in closed.stderr


def test_carets_stay_on_their_line_after_unicode_line_separators_in_comments(rapidc, write):
    """Only LF, CR and CRLF end lines, for the parser and the diagnostic alike."""
    path = write("ls.rapid", "def f(x: Length) -> Length = x # a\u2028b\x85c\x0cd\n"
                             "strategy s {\n  goal 1\n}\n")
    run = rapidc("check", path)
    assert ":3:8: error[E0101]" in run.out
    assert "3 |   goal 1\n  |        ^" in run.out


def test_a_long_source_line_is_shown_around_its_span(rapidc, write):
    chain = " + ".join(["x"] * 2000)
    run = rapidc("check", write("long.rapid", f"def f(x: Length) -> Length = {chain} + 1\n"))
    shown = [line for line in run.out.splitlines() if line.startswith("1 | ")]
    assert shown and all(len(line) < 200 for line in run.out.splitlines())
    assert shown[0].endswith("...")
