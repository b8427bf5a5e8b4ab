"""`rapidc mcp` as a command: its options, a client that closes at once, a missing SDK."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from rapid_dsl.cli import main


def test_a_root_that_is_not_a_folder_is_a_usage_error(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["mcp", "--root", str(tmp_path / "missing")]) == 2
    assert "is not a folder" in capsys.readouterr().err
    assert main(["mcp", "--allow-path", str(tmp_path / "missing")]) == 2


@pytest.mark.parametrize("workers, message", [("0", "at least 1"), ("257", "at most 256"),
                                              ("many", "")])
def test_workers_is_a_count(workers: str, message: str,
                            capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["mcp", "--workers", workers]) == 2
    assert message in capsys.readouterr().err


@pytest.mark.slow
def test_the_server_ends_when_its_client_closes_the_connection(tmp_path: Path) -> None:
    done = subprocess.run([sys.executable, "-m", "rapid_dsl", "mcp", "--root", str(tmp_path)],
                          input="", capture_output=True, text=True, timeout=60, check=False)
    assert (done.returncode, done.stdout) == (0, "")
    assert "Traceback" not in done.stderr


def test_without_the_mcp_sdk_it_says_what_to_install(monkeypatch: pytest.MonkeyPatch,
                                                     capsys: pytest.CaptureFixture[str]) -> None:
    monkeypatch.setitem(sys.modules, "mcp", None)     # `import mcp` raises ImportError
    monkeypatch.setitem(sys.modules, "rapid_dsl.mcp.server", None)
    assert main(["mcp"]) == 2
    err = capsys.readouterr().err
    assert "pip install 'rapid-dsl[mcp]'" in err and "Traceback" not in err
