"""Commands that import mujoco but render nothing work whatever MUJOCO_GL says (runtime/gl.py).

Each runs in a new process: MuJoCo reads MUJOCO_GL once per process.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PROGRAM = "tests/data/run/shove.rapid"
SCENE = "tests/data/run/tabletop.yaml"


@pytest.mark.parametrize("argv", [
    ["compile", "examples/push_box.rapid", "-o", "{tmp}"],
    ["bind", PROGRAM, "--scene", SCENE],
    ["variants", SCENE, "-n", "1", "-o", "{tmp}"],
], ids=["compile", "bind", "variants"])
@pytest.mark.slow
def test_a_broken_gl_back_end_does_not_matter(tmp_path, argv):
    argv = [a.replace("{tmp}", str(tmp_path)) for a in argv]
    run = subprocess.run([sys.executable, "-m", "rapid_dsl", *argv], cwd=ROOT,
                         env={**os.environ, "MUJOCO_GL": "bogus"}, capture_output=True,
                         text=True, timeout=300, check=False)
    assert run.returncode == 0, run.stderr
    assert "internal error" not in run.stderr


def test_the_users_mujoco_gl_is_back_after_a_command(rapidc, monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    assert rapidc("explain", "E0302").code == 0
    assert os.environ["MUJOCO_GL"] == "egl"
