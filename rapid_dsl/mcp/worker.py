"""Run a long command (run, verify, variants) in a worker process of its own.

The worker is spawned (a fresh interpreter: none of the server's threads, locks or imports) in a
process group of its own, runs the command with capture.invoke, sends every line the command
prints on stderr as it prints it, then the outcome. The server polls the pipe between short sleeps,
so its event loop stays free for other requests. When the call is cancelled, or the server stops,
the group is interrupted as Ctrl-C would interrupt the command (verify writes its report and stops
its pool), and killed if it has not ended within GRACE seconds. A worker that dies (a crash in
MuJoCo, killed from outside) is an error result of that call only.

This module imports nothing of the `mcp` SDK: the worker does not need it.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time
from collections.abc import Awaitable, Callable
from contextlib import suppress
from multiprocessing.connection import Connection
from typing import Any

import anyio

from rapid_dsl.mcp import capture
from rapid_dsl.mcp.capture import Outcome

GRACE = 10.0           # seconds an interrupted worker has to end before it is killed
_POLL = 0.05           # seconds between looks at the pipe


async def run(argv: list[str], on_line: Callable[[str], Awaitable[None]],
              gl_backend: str) -> Outcome:
    """`rapidc ARGV` in a worker process; `on_line` gets each stderr line as it is printed.
    `gl_backend`: the user's MUJOCO_GL (the server itself runs without GL, as every command)."""
    context = multiprocessing.get_context("spawn")
    receiver, sender = context.Pipe(duplex=False)
    process = context.Process(target=_main, args=(sender, argv, gl_backend),
                              name=f"rapidc-mcp-{argv[0]}")
    process.start()
    sender.close()
    done = False
    try:
        while True:
            while receiver.poll():
                try:
                    message = receiver.recv()
                except (EOFError, OSError):
                    return await _lost(process, argv)
                if message[0] == "line":
                    await on_line(message[1])
                else:
                    done = True
                    return Outcome(*message[1:])
            if not process.is_alive() and not receiver.poll():
                return await _lost(process, argv)
            await anyio.sleep(_POLL)
    finally:
        with anyio.CancelScope(shield=True):
            await _stop(process, interrupt=not done)
        receiver.close()


async def _lost(process: Any, argv: list[str]) -> Outcome:
    await _stop(process, interrupt=False)
    return Outcome(3, "", f"rapidc: internal error: the worker process of `rapidc {argv[0]}` "
                          f"ended without a result (exit code {process.exitcode})\n")


async def _stop(process: Any, *, interrupt: bool) -> None:
    """Let a worker that sent its outcome end by itself (its exit handlers still run), interrupt
    one that did not; kill either after GRACE, and reap it."""
    if process.exitcode is None:
        if interrupt:
            _signal(process, signal.SIGINT)
        deadline = time.monotonic() + GRACE
        while process.is_alive() and time.monotonic() < deadline:
            await anyio.sleep(_POLL)
        if process.is_alive():
            _signal(process, signal.SIGKILL)
    await anyio.to_thread.run_sync(process.join)


def _signal(process: Any, sig: signal.Signals) -> None:
    try:
        os.killpg(process.pid, sig)   # the worker and the processes it started (verify --jobs)
    except (ProcessLookupError, PermissionError):   # not yet its own group
        with suppress(ProcessLookupError):
            os.kill(process.pid, sig)


def _main(sender: Connection, argv: list[str], gl_backend: str) -> None:
    """The worker process."""
    os.setpgid(0, 0)
    # Cancelling interrupts the worker as Ctrl-C would. A server its host started with SIGINT
    # ignored (a background job) hands that on across exec, and the worker could not be cancelled.
    signal.signal(signal.SIGINT, signal.default_int_handler)
    if gl_backend:
        os.environ["MUJOCO_GL"] = gl_backend
    else:
        os.environ.pop("MUJOCO_GL", None)
    capture.install()
    lock = threading.Lock()

    def line(text: str) -> None:
        with lock:
            sender.send(("line", text))

    outcome = capture.invoke(argv, on_line=line)
    with lock:
        sender.send(("done", outcome.status, outcome.stdout, outcome.stderr))
    sender.close()
