"""Shared pytest options. `pytest --update-goldens` rewrites golden files instead of comparing."""

from __future__ import annotations

import signal
from collections.abc import Callable
from pathlib import Path

import pytest

# A test run started as a background job (`cmd &`, as CI scripts may) has SIGINT ignored, and an
# ignored signal stays ignored across exec: the commands the interrupt tests start would never see
# their Ctrl-C. A handler is reset to the default in a child, so the children get Python's own.
if signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
    signal.signal(signal.SIGINT, signal.default_int_handler)


def pytest_addoption(parser: pytest.Parser) -> None:
    parser.addoption("--update-goldens", action="store_true", default=False,
                     help="rewrite golden files (tests/data/**/*.expected.*) from current output")


@pytest.fixture
def update_goldens(request: pytest.FixtureRequest) -> bool:
    return bool(request.config.getoption("--update-goldens"))


@pytest.fixture
def golden(update_goldens: bool) -> Callable[[Path, str], None]:
    """`golden(path, actual)`: assert `actual` equals the file, or rewrite it with
    --update-goldens."""
    def check(path: Path, actual: str) -> None:
        if update_goldens:
            path.write_text(actual, encoding="utf-8")
            return
        assert path.exists(), f"{path} is missing; run pytest --update-goldens and review it"
        expected = path.read_text(encoding="utf-8")
        assert actual == expected, (
            f"{path} differs; run pytest --update-goldens and review the diff")
    return check
