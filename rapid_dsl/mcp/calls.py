"""One tool call: its arguments made into an argv, the command run, its output made a result.

Quick commands run in a worker thread of the server (capture.invoke: one at a time, their output
captured per thread); a cancelled call stops waiting for one at once and its thread finishes the
command on its own. Long ones run in a worker process (worker.py) that reports progress and is
stopped when the call is cancelled. Whatever happens, the call returns a result; its exit status
says whether it is an error.
"""

from __future__ import annotations

import re
from collections.abc import Awaitable, Callable
from typing import Any

import anyio

from rapid_dsl.mcp import capture, worker
from rapid_dsl.mcp.arguments import CallProblem, Workspace, prepared
from rapid_dsl.mcp.results import envelope, is_progress, problem
from rapid_dsl.mcp.tools import ToolSpec

Report = Callable[[float, float | None, str], Awaitable[None]]   # progress, total, message

_RUNS = re.compile(r"verify: \d+/(\d+) ")


async def call(spec: ToolSpec, arguments: dict[str, Any], workspace: Workspace,
               report: Report, gl_backend: str) -> dict[str, Any]:
    """The call's result (tools.OUTPUT_SCHEMA); `report` gets its progress lines."""
    try:
        with prepared(spec, arguments, workspace) as ready:
            if spec.worker:
                outcome = await worker.run(ready.argv, _progress(report), gl_backend)
            else:
                outcome = await anyio.to_thread.run_sync(capture.invoke, ready.argv,
                                                         abandon_on_cancel=True)
            return envelope(ready, outcome)
    except CallProblem as exc:
        return problem(spec.name, str(exc))


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
