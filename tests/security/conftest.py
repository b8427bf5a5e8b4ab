"""Fixtures for the security tests: `rapidc` run in-process, as tests/cli runs it."""

from __future__ import annotations

import contextlib
import io
from collections.abc import Callable
from dataclasses import dataclass

import pytest

from rapid_dsl.cli import main


@dataclass
class Run:
    code: int
    out: str
    err: str


def run_rapidc(*argv: object) -> Run:
    """`rapidc ARGV` in this process, its output captured (usable inside hypothesis tests)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    return Run(code, out.getvalue(), err.getvalue())


@pytest.fixture
def rapidc() -> Callable[..., Run]:
    """`rapidc("compile", path, "-o", "-")` -> Run(code, stdout, stderr)."""
    return run_rapidc
