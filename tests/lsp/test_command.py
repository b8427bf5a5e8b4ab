"""`rapidc lsp` as a command: its options, its exit status, and what it says when the `lsp` extra
is missing."""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from rapid_dsl.cli import main

from .client import Client


@pytest.fixture
def rapidc(capsys: pytest.CaptureFixture[str]) -> Callable[..., tuple[int, str, str]]:
    """`rapidc(*argv)` in this process -> (status, stdout, stderr)."""
    def run(*argv: str) -> tuple[int, str, str]:
        code = main(list(argv))
        captured = capsys.readouterr()
        return code, captured.out, captured.err
    return run


Rapidc = Callable[..., tuple[int, str, str]]


def test_help_says_what_it_is(rapidc: Rapidc) -> None:
    code, out, _ = rapidc("lsp", "--help")
    assert code == 0
    assert "language server" in out and "--allow-path" in out
    assert "lsp" in rapidc("--help")[1]


def test_allow_path_must_be_a_folder(rapidc: Rapidc, tmp_path: Path) -> None:
    code, _, err = rapidc("lsp", "--allow-path", str(tmp_path / "missing"))
    assert code == 2 and "is not a folder" in err


def test_without_pygls(rapidc: Rapidc, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setitem(sys.modules, "pygls", None)         # as if it were not installed
    monkeypatch.delitem(sys.modules, "rapid_dsl.lsp.server", raising=False)
    monkeypatch.delitem(sys.modules, "rapid_dsl.lsp.documents", raising=False)
    code, _, err = rapidc("lsp")
    assert code == 2
    assert err == "rapidc: error: rapidc lsp needs pygls: pip install 'rapid-dsl[lsp]'\n"


@pytest.mark.slow
def test_exit_without_shutdown_is_status_1(tmp_path: Path) -> None:
    client = Client("--stdio", cwd=tmp_path)
    client.initialize(tmp_path)
    client.notify("exit")
    assert client.wait() == 1
    assert "internal error" not in client.stderr()


@pytest.mark.slow
def test_the_editor_going_away_ends_the_server(tmp_path: Path) -> None:
    """Standard input closed without `exit` (the editor crashed): the server ends by itself."""
    client = Client(cwd=tmp_path)
    client.initialize(tmp_path)
    assert client.process.stdin is not None
    client.process.stdin.close()
    assert client.wait() == 1
    assert "Traceback" not in client.stderr()
