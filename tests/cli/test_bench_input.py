"""`rapidc bench` on bad input: usage errors (exit 2), never an internal error or a hang."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize("argv, message", [
    (["check", "--lines", "99999999999"], "--lines: must be at most 100000"),
    (["check", "--runs", "101"], "--runs: must be at most 100"),
    (["check", "--lines", "0"], "--lines: must be at least 1"),
    (["check", "--terms", "100001"], "--terms: must be at most 100000"),
    (["check", "--terms", "999"], "--terms: must be at least 1000"),
])
def test_bench_check_sizes_are_bounded(rapidc, argv, message):
    run = rapidc("bench", *argv)
    assert run.code == 2 and message in run.err


def test_an_unknown_primitive_is_a_usage_error():
    # A new process: bench imports mujoco (without GL), which this one may need with GL later;
    # a GL back end that cannot start does not matter to it.
    env = {**os.environ, "MUJOCO_GL": "bogus"}
    run = subprocess.run([sys.executable, "-m", "rapid_dsl", "bench", "primitives",
                          "--primitive", "nosuch"], cwd=ROOT, env=env, capture_output=True,
                         text=True, timeout=120, check=False)
    assert run.returncode == 2, run.stderr
    assert "--primitive: unknown primitive(s) nosuch; known: push" in run.stderr
    assert "Traceback" not in run.stderr and "internal error" not in run.stderr
