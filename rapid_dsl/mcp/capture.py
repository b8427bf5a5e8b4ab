"""Run a `rapidc` command in this process and capture what it prints.

Commands print with `print(..., file=sys.stderr)` and `sys.stdout.write`, looking the streams up
when they print. `install()` replaces sys.stdout and sys.stderr with routers that send each thread's
output to that thread's capture while it runs a command, and everything else to the streams they
replaced (in the server: its stderr, never the protocol's stdout). So a command run in a worker
thread has its output to itself, and a stray print elsewhere cannot corrupt the protocol.
"""

from __future__ import annotations

import io
import sys
import threading
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from typing import TextIO

LineSink = Callable[[str], None]


@dataclass(frozen=True, slots=True)
class Outcome:
    """What a command did: its exit status and everything it printed."""

    status: int
    stdout: str
    stderr: str


class _Capture(threading.local):
    out: _Buffer | None = None
    err: _Buffer | None = None


class _Buffer(io.StringIO):
    """Collects text; with `on_line`, also hands over each complete line as it is written."""

    def __init__(self, on_line: LineSink | None = None) -> None:
        super().__init__()
        self._on_line = on_line
        self._pending = ""

    def write(self, text: str) -> int:
        if self._on_line is not None:
            *lines, self._pending = (self._pending + text).split("\n")
            for line in lines:
                self._on_line(line)
        return super().write(text)

    def isatty(self) -> bool:
        return False


_capture = _Capture()


class _Router(io.TextIOBase):
    """A standard stream that writes to the current thread's capture, if it has one."""

    def __init__(self, fallback: TextIO, pick: Callable[[], _Buffer | None]) -> None:
        super().__init__()
        self.fallback = fallback
        self._pick = pick

    @property
    def encoding(self) -> str:   # type: ignore[override]
        return "utf-8"

    def _target(self) -> TextIO:
        return self._pick() or self.fallback

    def write(self, text: str) -> int:
        return self._target().write(text)

    def flush(self) -> None:
        self._target().flush()

    def isatty(self) -> bool:
        return self._target().isatty()

    def fileno(self) -> int:
        return self._target().fileno()   # a capture has none: io.UnsupportedOperation


def install() -> Callable[[], None]:
    """Route sys.stdout and sys.stderr through the captures; returns what undoes it."""
    if isinstance(sys.stdout, _Router):
        return lambda: None
    saved = sys.stdout, sys.stderr
    sys.stdout = _Router(sys.stdout, lambda: _capture.out)
    sys.stderr = _Router(sys.stderr, lambda: _capture.err)

    def restore() -> None:
        sys.stdout, sys.stderr = saved
    return restore


@contextmanager
def captured(on_line: LineSink | None = None) -> Iterator[tuple[_Buffer, _Buffer]]:
    """This thread's stdout and stderr go to two buffers while the block runs."""
    out, err = _Buffer(), _Buffer(on_line)
    _capture.out, _capture.err = out, err
    try:
        yield out, err
    finally:
        _capture.out = _capture.err = None


def invoke(argv: list[str], on_line: LineSink | None = None) -> Outcome:
    """`rapidc ARGV` run by the command line's own main function, its output captured.

    Several threads may run commands at once. The process-wide state a command sets while it runs
    is the same for all of them in the server: MUJOCO_GL is `disable` (the server itself runs as
    a command, gl.py) and the recursion limit is raised for the whole server (server.py); the
    parser's caches are thread-safe."""
    from rapid_dsl.cli import main

    with captured(on_line) as (out, err):
        try:
            status = main(argv)
        except Exception as exc:  # noqa: BLE001 - main reports bugs itself; this is a last guard
            print(f"rapidc: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
            status = 3
        return Outcome(status, out.getvalue(), err.getvalue())
