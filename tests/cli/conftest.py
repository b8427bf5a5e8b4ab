"""Fixtures for the command-line tests: run `rapid_dsl.cli.main` in-process and capture output."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import pytest

from rapid_dsl.cli import main


@dataclass
class Run:
    code: int
    out: str
    err: str


@pytest.fixture
def rapidc(capsys: pytest.CaptureFixture[str]) -> Callable[..., Run]:
    """`rapidc("check", path)` -> Run(code, stdout, stderr)."""
    def run(*argv: object) -> Run:
        code = main([str(a) for a in argv])
        captured = capsys.readouterr()
        return Run(code, captured.out, captured.err)
    return run


@pytest.fixture
def write(tmp_path: Path) -> Callable[[str, str], Path]:
    """`write("a.rapid", text)` -> the path of a new file under tmp_path."""
    def make(name: str, text: str) -> Path:
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text, encoding="utf-8")
        return path
    return make
