"""The slow part of serving documents, off the event loop: checking a document and building its
model run in THREADS worker threads, so that a request about one document is not held up by a
large other one (the event loop goes on reading and answering while they run).

Jobs have keys (a document's check, its model); one job of a key runs at a time, the others of
that key wait for it, and a job that became `stale` while it waited (its document changed or
closed, or what it would build is there already) does not run. A job that runs is not stopped:
Python threads cannot be; its result is dropped if its document changed meanwhile.
"""

from __future__ import annotations

import asyncio
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from typing import TypeVar

THREADS = 4
T = TypeVar("T")


class Work:
    def __init__(self) -> None:
        self._pool = ThreadPoolExecutor(THREADS, thread_name_prefix="rapidc-lsp")
        self._running: dict[str, asyncio.Future[object]] = {}

    async def run(self, key: str, job: Callable[[], T], stale: Callable[[], bool]) -> T | None:
        """`job()` in a worker thread once no other job of `key` runs; None, without running
        it, if by then `stale()`."""
        while (running := self._running.get(key)) is not None:
            await asyncio.wait([running])
        if stale():
            return None
        future = asyncio.get_running_loop().run_in_executor(self._pool, job)
        self._running[key] = future   # type: ignore[assignment]

        def done(_: object) -> None:
            if self._running.get(key) is future:
                del self._running[key]
        future.add_done_callback(done)
        # a cancelled request stops waiting; the job runs on, and the next of its key waits
        return await asyncio.shield(future)

    def stop(self) -> None:
        self._pool.shutdown(wait=False, cancel_futures=True)
