"""Tooling for other projects' CI: the GitHub Action's script, pre-commit hooks, start-up cost."""

from __future__ import annotations

import os
import re
import shutil
import socket
import subprocess
import sys
from pathlib import Path

import pytest
from ruamel.yaml import YAML

from .programs import BAD, CLEAN, WARNS

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "scripts" / "action_check.sh"


def _env(**extra: str) -> dict[str, str]:
    env = {**os.environ, "PYTHON": sys.executable, **extra}
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [str(ROOT), env.get("PYTHONPATH")]))
    return env


def _action(folder: Path, *paths: str, **env: str) -> subprocess.CompletedProcess[str]:
    return subprocess.run(["bash", str(SCRIPT), *paths], cwd=folder, env=_env(**env),
                          capture_output=True, text=True, timeout=60, check=False)


def test_action_script_annotates_errors_and_fails(tmp_path):
    (tmp_path / "progs").mkdir()
    (tmp_path / "progs" / "bad.rapid").write_text(BAD)
    (tmp_path / "progs" / "ok.rapid").write_text(CLEAN)
    result = _action(tmp_path, "progs")
    assert result.returncode == 1, result.stderr
    assert result.stdout.splitlines() == [
        ("::error file=progs/bad.rapid,line=5,endLine=5,col=17,endColumn=47,"
         "title=rapidc (E0301)::cannot add Length and Angle")]


def test_action_script_defaults_to_the_current_folder_and_passes_clean_code(tmp_path):
    (tmp_path / "ok.rapid").write_text(CLEAN)
    result = _action(tmp_path)
    assert (result.returncode, result.stdout) == (0, "")


def test_action_script_lint_with_strict_fails_on_warnings(tmp_path):
    (tmp_path / "warns.rapid").write_text(WARNS)
    assert _action(tmp_path, ".", RAPIDC_COMMAND="lint").returncode == 0
    result = _action(tmp_path, ".", RAPIDC_COMMAND="lint", RAPIDC_ARGS="--strict")
    assert result.returncode == 1
    assert result.stdout.startswith("::warning file=./warns.rapid,")


def test_action_script_missing_path_and_bad_command_exit_2(tmp_path):
    assert _action(tmp_path, "nope").returncode == 2
    assert _action(tmp_path, ".", RAPIDC_COMMAND="rm").returncode == 2


def test_action_definition():
    action = YAML(typ="safe").load((ROOT / "action.yml").read_text())
    assert action["runs"]["using"] == "composite"
    assert action["inputs"]["paths"]["default"] == "."
    steps = action["runs"]["steps"]
    assert steps[0]["uses"].startswith("actions/setup-python@")
    assert steps[0]["with"]["python-version"] == "3.11"
    assert "${{ github.action_path }}" in steps[1]["run"]
    assert "scripts/action_check.sh" in steps[2]["run"]
    assert all(step.get("shell", "bash") == "bash" for step in steps[1:])


def test_pre_commit_hooks_select_program_files():
    hooks = YAML(typ="safe").load((ROOT / ".pre-commit-hooks.yaml").read_text())
    assert [h["id"] for h in hooks] == ["rapidc-check", "rapidc-lint"]
    for hook in hooks:
        assert hook["language"] == "python"
        assert hook["entry"] == f"rapidc {hook['id'].removeprefix('rapidc-')}"
        files = re.compile(hook["files"])
        assert all(files.search(n) for n in ("a.rapid", "d/b.rapid.yaml", "c.rapid.yml"))
        assert not any(files.search(n) for n in ("scene.yaml", "a.rapid.txt", "rapid", "x.yml"))


def _pypi_reachable() -> bool:
    try:
        socket.create_connection(("pypi.org", 443), timeout=3).close()
        return True
    except OSError:
        return False


@pytest.mark.skipif(os.environ.get("RAPIDC_OFFLINE") == "1" or not _pypi_reachable(),
                    reason="needs network: pre-commit pip-installs rapid_dsl and its dependencies "
                           "from PyPI into a fresh environment (about 30 s); runs in CI")
@pytest.mark.slow
def test_pre_commit_try_repo_fails_on_a_bad_program(tmp_path):
    if shutil.which("git") is None:
        pytest.skip("git is not installed")
    repo = tmp_path / "consumer"
    repo.mkdir()
    (repo / "bad.rapid").write_text(BAD)
    (repo / "notes.txt").write_text("not a program")
    identity = {"GIT_AUTHOR_NAME": "t", "GIT_AUTHOR_EMAIL": "t@example.invalid",
                "GIT_COMMITTER_NAME": "t", "GIT_COMMITTER_EMAIL": "t@example.invalid"}
    env = {**os.environ, **identity, "PRE_COMMIT_HOME": str(tmp_path / "cache")}
    for argv in (["git", "init", "-q"], ["git", "add", "."], ["git", "commit", "-qm", "x"]):
        subprocess.run(argv, cwd=repo, env=env, check=True, timeout=60)
    result = subprocess.run(
        [sys.executable, "-m", "pre_commit", "try-repo", str(ROOT), "rapidc-check",
         "--files", "bad.rapid", "notes.txt"],
        cwd=repo, env=env, capture_output=True, text=True, timeout=600, check=False)
    output = result.stdout + result.stderr
    assert result.returncode == 1, output
    assert re.search(r"rapidc check\.+Failed", output), output
    assert "bad.rapid:5:17: error[E0301]: cannot add Length and Angle" in output


def test_check_does_not_import_heavy_modules(tmp_path):
    program = tmp_path / "ok.rapid"
    program.write_text(CLEAN)
    yaml_program = tmp_path / "ok.rapid.yaml"
    yaml_program.write_text("- relation: far\n  params: {a: Body, b: Body}\n"
                            "  body: distance(a, b) > 1cm\n")
    result = subprocess.run([sys.executable, "-X", "importtime", "-m", "rapid_dsl", "check",
                             str(program)], env=_env(), capture_output=True, text=True,
                            timeout=60, check=False)
    assert result.returncode == 0, result.stderr
    imported = {line.split("|")[-1].strip().split(".")[0]
                for line in result.stderr.splitlines() if line.startswith("import time:")}
    assert "rapid_dsl" in imported
    assert not imported & {"mujoco", "numpy", "pydantic", "jinja2", "rich", "casadi", "trimesh"}
