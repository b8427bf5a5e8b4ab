"""How much the server runs at once, and the calls that wait for their turn.

Two pools of slots, each a first-come-first-served queue (docs/security.md, "Limits"):
- worker processes: a long call (run, verify, variants, scene from-rgbd) takes one slot per process
  its command keeps busy: one, or verify's `jobs` (its coordinating process only waits for them).
  There are `rapidc mcp --workers N` of them, by default one per core this process may use, and a
  call's `jobs` is lowered to N.
- quick commands (check, lint, fmt, compile, bind, explain) run in threads of the server, at most
  QUICK_THREADS at once. A cancelled one is not waited for, but its thread holds its slot until its
  command returns (a thread cannot be stopped), so a run of cancelled calls cannot pile up threads.
A call that must wait says so in a progress notification, and leaves the queue if cancelled.
"""

from __future__ import annotations

import os
from collections import deque
from collections.abc import AsyncIterator, Awaitable, Callable
from contextlib import asynccontextmanager
from dataclasses import dataclass, field

import anyio

QUICK_THREADS = 4

Queued = Callable[[str], Awaitable[None]]   # tells the client the call waits, and why


def default_workers() -> int:
    """One worker process per core this process may run on."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:   # not on Linux
        return os.cpu_count() or 1


@dataclass(eq=False)
class _Waiter:
    weight: int
    granted: anyio.Event = field(default_factory=anyio.Event)


class Slots:
    """`total` slots, handed out in the order calls ask for them."""

    def __init__(self, total: int, what: str) -> None:
        self.total = total
        self.free = total
        self.what = what                  # "worker processes", said in the queued message
        self._queue: deque[_Waiter] = deque()

    async def acquire(self, weight: int, queued: Queued) -> None:
        """Take `weight` slots (at most all of them), waiting behind earlier calls."""
        weight = min(weight, self.total)
        if not self._queue and self.free >= weight:
            self.free -= weight
            return
        waiter = _Waiter(weight)
        self._queue.append(waiter)
        try:
            ahead = len(self._queue) - 1
            await queued(f"queued: {self.total - self.free} of {self.total} {self.what} busy, "
                         f"{ahead} call{'s' * (ahead != 1)} ahead")
            await waiter.granted.wait()
        except BaseException:   # cancelled while waiting: leave the queue, or give back
            if waiter.granted.is_set():
                self.release(weight)
            else:
                self._queue.remove(waiter)
                self._grant()      # a smaller call behind it may fit now
            raise

    def release(self, weight: int) -> None:
        self.free += min(weight, self.total)
        self._grant()

    @asynccontextmanager
    async def held(self, weight: int, queued: Queued) -> AsyncIterator[None]:
        await self.acquire(weight, queued)
        try:
            yield
        finally:
            self.release(weight)

    def _grant(self) -> None:
        while self._queue and self._queue[0].weight <= self.free:
            waiter = self._queue.popleft()
            self.free -= waiter.weight
            waiter.granted.set()


@dataclass(frozen=True, eq=False)
class Pools:
    """The server's two pools."""

    workers: Slots
    quick: Slots


def pools(workers: int) -> Pools:
    return Pools(Slots(workers, "worker processes"), Slots(QUICK_THREADS, "quick-command threads"))
