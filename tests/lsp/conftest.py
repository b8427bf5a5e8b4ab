"""Fixtures of the language-server tests: a small project on disk and a running `rapidc lsp`."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest

from .client import Client

HELPERS = "def clearance(a: Body, b: Body) -> Length = distance(a, b) - 1cm\n"

# Line 11 (0-based) has the error: the bound of a Length has no unit (E0302). `let margin=1cm`
# is not in the canonical layout.
MAIN = """\
use stdlib.push
use "lib/helpers.rapid"

strategy nudge {
  goal "Push the box toward the wall"
  roles { box: Object, table: Surface, wall: Fixture, hand: Manipulator }
  requires { on(box, table); reachable(hand, box) }
  let margin=1cm
  phase shove: push(target=box, support=table, hand=hand) {
    displacement = (clearance(box, wall) - margin) * direction(box, wall)
  }
  success { distance(box, wall) < 0.05 }
}
"""


def make_project(folder: Path) -> Path:
    """main.rapid, which `use`s lib/helpers.rapid and stdlib.push, in `folder`."""
    (folder / "lib").mkdir(parents=True, exist_ok=True)
    (folder / "lib" / "helpers.rapid").write_text(HELPERS, encoding="utf-8")
    (folder / "main.rapid").write_text(MAIN, encoding="utf-8")
    return folder


@pytest.fixture(scope="session")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The project of the test session (each test opens documents of its own names in it)."""
    return make_project(tmp_path_factory.mktemp("project"))


@pytest.fixture(scope="session")
def server(project: Path) -> Iterator[Client]:
    """One `rapidc lsp` for the tests that need no other, started in the project's folder and
    initialized (a server takes most of a second to start)."""
    client = Client(cwd=project)
    try:
        client.initialize(project)
        yield client
    finally:
        if client.process.poll() is None:
            client.close()
