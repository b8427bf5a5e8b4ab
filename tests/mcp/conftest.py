"""Fixtures of the MCP tests: `rapidc mcp` started as a subprocess and driven by the SDK's own
stdio client (mcp.client.stdio), from synchronous tests through an anyio blocking portal."""

from __future__ import annotations

import json
import sys
from collections.abc import Awaitable, Callable, Iterator
from contextlib import asynccontextmanager, contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

import pytest
from anyio.from_thread import BlockingPortal, start_blocking_portal
from mcp import ClientSession, StdioServerParameters, stdio_client
from mcp.types import CallToolResult

REPO = Path(__file__).resolve().parents[2]
EXAMPLES = REPO / "examples"
PUSH_BOX = EXAMPLES / "push_box.rapid"
PUSH_SCENE = EXAMPLES / "scenes" / "push_box.yaml"

# The README's tour program, with its two mistakes (E0508 at 8:20, E0302 at 10:13).
NUDGE = """\
use stdlib.push

strategy nudge {
  goal "Push the box 5 cm toward the wall"
  roles { box: Object, table: Surface, wall: Fixture, hand: Manipulator }
  requires { on(box, table) }
  phase shove: push(target=box, support=table, hand=hand) {
    displacement = 5 * direction(box, wall)
  }
  success { distance(box, wall) < 0.05 }
}
"""


@dataclass
class Progress:
    """The progress notifications of one call: (progress, total, message)."""

    events: list[tuple[float, float | None, str | None]] = field(default_factory=list)

    async def __call__(self, progress: float, total: float | None, message: str | None) -> None:
        self.events.append((progress, total, message))

    @property
    def messages(self) -> list[str]:
        return [m or "" for _, _, m in self.events]


@dataclass
class Server:
    """A running `rapidc mcp` and its client session; `log` is the server's stderr."""

    portal: BlockingPortal
    session: ClientSession
    log: TextIO
    root: Path

    def call(self, tool: str, arguments: dict[str, Any] | None = None,
             progress: Progress | None = None) -> CallToolResult:
        result: CallToolResult = self.portal.call(
            lambda: self.session.call_tool(tool, arguments or {}, progress_callback=progress))
        return result

    def body(self, tool: str, arguments: dict[str, Any] | None = None,
             progress: Progress | None = None) -> dict[str, Any]:
        """The call's structured content, checked against its text copy."""
        result = self.call(tool, arguments, progress)
        assert result.structured_content is not None
        assert json.loads(result.content[0].text) == result.structured_content
        body: dict[str, Any] = result.structured_content
        assert result.is_error == (body["exit_status"] >= 2)
        return body

    def run(self, scenario: Callable[[ClientSession], Awaitable[Any]]) -> Any:
        return self.portal.call(scenario, self.session)

    def workers(self) -> list[int]:
        """The processes the server has started that are still running (Linux /proc), but
        multiprocessing's resource tracker, which lives as the server."""
        mine = [p for p in _processes() if "\0mcp\0--root\0" + str(self.root) + "\0"
                in _cmdline(p)]
        assert len(mine) == 1, mine
        return [p for p in _processes() if _parent(p) == mine[0]
                and "multiprocessing.resource_tracker" not in _cmdline(p)]

    def stderr(self) -> str:
        self.log.flush()
        return Path(self.log.name).read_text(encoding="utf-8")


def _processes() -> list[int]:
    return [int(p.name) for p in Path("/proc").iterdir() if p.name.isdigit()]


def _cmdline(pid: int) -> str:
    try:
        return "\0" + Path(f"/proc/{pid}/cmdline").read_text(errors="replace")
    except OSError:
        return ""


def _parent(pid: int) -> int | None:
    try:
        status = Path(f"/proc/{pid}/status").read_text()
    except OSError:
        return None
    return next((int(line.split()[1]) for line in status.splitlines()
                 if line.startswith("PPid:")), None)


@asynccontextmanager
async def client(root: Path, options: tuple[str, ...], log: TextIO,
                 env: dict[str, str] | None = None) -> Any:
    # the SDK starts a server with a few of the environment's variables only, and `env`; the
    # server imports the rapid_dsl under test, wherever the installed one is
    params = StdioServerParameters(command=sys.executable,
                                   args=["-m", "rapid_dsl", "mcp", "--root", str(root), *options],
                                   cwd=str(root), env={"PYTHONPATH": str(REPO), **(env or {})})
    async with stdio_client(params, errlog=log) as (read, write), \
            ClientSession(read, write) as session:
        await session.initialize()
        yield session


@contextmanager
def serving(root: Path, *options: str, env: dict[str, str] | None = None) -> Iterator[Server]:
    """`rapidc mcp --root ROOT OPTIONS` for the block; the server stops when it ends."""
    with (root / ".server.log").open("w+", encoding="utf-8") as log, \
            start_blocking_portal() as portal, \
            portal.wrap_async_context_manager(client(root, options, log, env)) as session:
        yield Server(portal, session, log, root)


def make_project(root: Path) -> Path:
    """A project folder: nudge.rapid (two errors), lib/ok.rapid (clean)."""
    (root / "lib").mkdir(parents=True, exist_ok=True)
    (root / "nudge.rapid").write_text(NUDGE, encoding="utf-8")
    fixed = NUDGE.replace("5 * direction", "5cm * direction").replace("< 0.05", "< 5cm")
    (root / "lib" / "ok.rapid").write_text(fixed, encoding="utf-8")
    return root


@pytest.fixture(scope="module")
def project(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return make_project(tmp_path_factory.mktemp("project"))


@pytest.fixture(scope="module")
def server(project: Path) -> Iterator[Server]:
    """One server per test module, rooted in the project, allowed to read the examples (a
    server takes about a second to start)."""
    with serving(project, "--allow-path", str(EXAMPLES)) as running:
        yield running
