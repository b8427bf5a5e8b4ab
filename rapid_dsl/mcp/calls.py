"""One tool call: its arguments made into an argv, the command run, its output made a result.

Quick commands run in a thread of the server each (capture.invoke captures each thread's output),
several at once; a cancelled call stops waiting for its thread at once, and the thread finishes
the command on its own. Long ones run in a worker process (worker.py) that reports progress and is
stopped when the call is cancelled. Both wait for a slot of their pool first (slots.py); a call's
`jobs` is lowered to what the server runs at once. Whatever happens, the call returns a result;
its exit status says whether it is an error.
"""

from __future__ import annotations

import re
import threading
from collections.abc import Awaitable, Callable
from contextlib import suppress
from typing import Any

import anyio

from rapid_dsl.mcp import capture, worker
from rapid_dsl.mcp.arguments import CallProblem, Workspace, prepared
from rapid_dsl.mcp.capture import Outcome
from rapid_dsl.mcp.results import envelope, is_progress, problem
from rapid_dsl.mcp.slots import Pools, Queued, Slots
from rapid_dsl.mcp.tools import ToolSpec

Report = Callable[[float, float | None, str], Awaitable[None]]   # progress, total, message

_RUNS = re.compile(r"verify: \d+/(\d+) ")


async def call(spec: ToolSpec, arguments: dict[str, Any], workspace: Workspace,
               report: Report, gl_backend: str, pools: Pools) -> dict[str, Any]:
    """The call's result (tools.OUTPUT_SCHEMA); `report` gets its progress lines."""
    async def queued(message: str) -> None:
        await report(0, None, message)

    weight, note = _processes(spec, arguments, pools.workers.total)
    try:
        with prepared(spec, arguments, workspace) as ready:
            if spec.worker:
                async with pools.workers.held(weight, queued):
                    outcome = await worker.run(ready.argv, _progress(report), gl_backend)
            else:
                outcome = await _quick(ready.argv, pools.quick, queued)
            body = envelope(ready, outcome)
    except CallProblem as exc:
        return problem(spec.name, str(exc))
    if note is not None:
        body["messages"].insert(0, note)
    return body


def _processes(spec: ToolSpec, arguments: dict[str, Any], most: int) -> tuple[int, str | None]:
    """How many worker processes the call keeps busy, after lowering its `jobs` (in place) to
    `most`; and the message that says it was lowered. A value that is not a count is left for
    the command to refuse."""
    if spec.jobs is None:
        return 1, None
    asked = arguments.get(spec.jobs)
    if isinstance(asked, bool) or not isinstance(asked, int) or asked < 1:
        return 1, None
    if asked <= most:
        return asked, None
    arguments[spec.jobs] = most
    return most, (f"rapidc mcp: {spec.jobs} {asked} lowered to {most}, the worker processes "
                  "this server runs at once (rapidc mcp --workers)")


async def _quick(argv: list[str], slots: Slots, queued: Queued) -> Outcome:
    """`rapidc ARGV` in a thread of its own; its slot is free again when the command returns,
    also after the call was cancelled and stopped waiting for it."""
    await slots.acquire(1, queued)
    token = anyio.lowlevel.current_token()
    lock = threading.Lock()
    state = "waiting"     # -> "running" in the thread, or "dropped" if cancelled before that

    def command() -> Outcome:
        nonlocal state
        with lock:
            if state == "dropped":
                return Outcome(130, "", "")
            state = "running"
        try:
            return capture.invoke(argv)
        finally:
            with suppress(RuntimeError):   # RuntimeError: the server has stopped
                anyio.from_thread.run_sync(slots.release, 1, token=token)

    try:
        return await anyio.to_thread.run_sync(command, abandon_on_cancel=True)
    except BaseException:
        with lock:
            dropped, state = state == "waiting", "dropped" if state == "waiting" else state
        if dropped:
            slots.release(1)
        raise


def _progress(report: Report) -> Callable[[str], Awaitable[None]]:
    """Progress lines -> notifications: progress counts them; verify's give the total of runs."""
    count = 0
    total: float | None = None

    async def line(text: str) -> None:
        nonlocal count, total
        if not is_progress(text):
            return
        count += 1
        if (runs := _RUNS.match(text)) is not None:
            total = float(runs.group(1))
        await report(count, total, text)
    return line
