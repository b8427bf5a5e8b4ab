"""Start-up of `rapidc`: a front-end command imports only what it needs (not lark, not the
simulation), builds only its own options, and ends its process without tearing the interpreter
down; options before the command, help and usage errors work as before.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import pytest

from rapid_dsl.frontend.parser import _runtime


def rapidc_process(*argv: object, cwd: Path) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "rapid_dsl", *map(str, argv)], cwd=cwd,
                          capture_output=True, text=True, timeout=120, check=False)


def test_rapidc_check_imports_only_what_checking_needs(tmp_path: Path) -> None:
    program = tmp_path / "p.rapid"
    program.write_text("relation near(a: Body, b: Body) = distance(a, b) < 5cm\n",
                       encoding="utf-8")
    _runtime()  # the tables are in the cache
    code = ("import sys\nfrom rapid_dsl.cli import main\n"
            f"status = main(['check', '--quiet', {str(program)!r}])\n"
            "print(status, ' '.join(sorted(sys.modules)))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=tmp_path).stdout.split()
    assert out[0] == "0"
    modules = set(out[1:])
    for heavy in ("lark", "numpy", "mujoco", "pydantic", "jinja2", "rich", "ruamel", "casadi",
                  "pickle"):
        assert heavy not in modules, heavy
    commands = {m for m in modules if m.startswith("rapid_dsl.commands.")}
    assert commands == {"rapid_dsl.commands.check", "rapid_dsl.commands.common"}
    assert "rapid_dsl.compiler" not in modules and "rapid_dsl.frontend.lint" not in modules


@pytest.mark.parametrize("argv", [["--format", "json", "check"], ["--format=json", "-q", "check"],
                                  ["--color", "never", "--strict", "check"]])
def test_options_before_the_command_still_apply(tmp_path: Path, argv: list[str],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    from rapid_dsl.cli import main

    program = tmp_path / "p.rapid"
    program.write_text("relation far(a: Body, b: Body) = distance(a, b) > 5\n", encoding="utf-8")
    assert main([*argv, str(program)]) == 1
    out = capsys.readouterr().out
    if "json" in " ".join(argv):
        assert json.loads(out)[0]["code"] == "E0302"
    else:
        assert "error[E0302]" in out


def test_help_and_unknown_commands_still_list_every_command(
        capsys: pytest.CaptureFixture[str]) -> None:
    from rapid_dsl.cli import COMMANDS, main

    assert main(["--help"]) == 0
    help_text = capsys.readouterr().out
    assert main(["chek", "x.rapid"]) == 2
    error = capsys.readouterr().err
    for command in COMMANDS:
        assert command in help_text and f"'{command}'" in error


@pytest.mark.slow
def test_a_quick_exit_keeps_the_output_and_the_status(tmp_path: Path) -> None:
    """check, lint, fmt and explain end the process at once: nothing of theirs is lost."""
    bad = tmp_path / "bad.rapid"
    bad.write_text("relation far(a: Body, b: Body) = distance(a, b) > 5\n", encoding="utf-8")
    run = rapidc_process("check", bad, cwd=tmp_path)
    assert run.returncode == 1
    assert run.stdout.startswith(f"{bad}:1:34: error[E0302]") and "= help:" in run.stdout
    assert run.stderr == "1 error, 0 warnings in 1 file\n"
    run = rapidc_process("--format", "json", "lint", bad, cwd=tmp_path)
    assert run.returncode == 1 and json.loads(run.stdout)[0]["code"] == "E0302"
    messy = tmp_path / "messy.rapid"
    messy.write_text("relation near(a:Body,b:Body)=distance(a,b)<5cm\n", encoding="utf-8")
    run = rapidc_process("fmt", "--write", messy, cwd=tmp_path)
    assert run.returncode == 0, run.stderr
    assert messy.read_text(encoding="utf-8") == \
        "relation near(a: Body, b: Body) = distance(a, b) < 5cm\n"
    run = rapidc_process("explain", "E0410", cwd=tmp_path)
    assert (run.returncode, run.stdout) == (0, "E0410: optimize budget above its maximum\n")
    many = "".join(f"relation r{i}(a: Body) = height(a) > {i}\n" for i in range(3000))
    (tmp_path / "many.rapid").write_text(many, encoding="utf-8")
    run = rapidc_process("check", "many.rapid", cwd=tmp_path)    # a large output, all of it
    assert run.returncode == 1 and run.stdout.count("error[E0302]") == 3000
