"""Running verification jobs: in the command's process, in a pool of worker processes, or on a
Dask cluster (runtime/verification/cluster.py), through one loop that retries lost jobs once.

A backend takes jobs (a variant index and its scene), runs up to `capacity` of them at a time and
reports each as done, lost (the process or worker running it died) or raising (a bug: it stops
the run). `drive` keeps the backend busy, hands every finished record to `on_done` the moment it
arrives, and resubmits a lost job once; a job lost twice is recorded as an `error`. The pool keeps
no more jobs in flight than it has workers, so a dead worker loses only the jobs that were running.
"""

from __future__ import annotations

import multiprocessing
import os
from collections import deque
from collections.abc import Callable, Iterator
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from typing import Any, Protocol

from rapid_dsl.runtime.verification.job import Job

Task = tuple[Any, Any]                        # (index, payload); verify: (variant index or
                                              # None for the scene, its Scene)
Outcome = tuple[dict[str, Any], dict[str, float]]                   # record, timing
Finished = tuple[Any, Outcome | None, BaseException | None]         # handle, outcome, error
OnDone = Callable[[Any, dict[str, Any], dict[str, float], int], None]   # ..., attempts
OnLost = Callable[[Any, str], None]                                 # index, why
MAX_ATTEMPTS = 2                               # a lost job is run once more


class Lost(Exception):
    """The process or cluster worker running a job went away before it finished."""


class Backend(Protocol):
    @property
    def capacity(self) -> int: ...
    def submit(self, task: Task) -> Any: ...
    def wait(self, handles: list[Any]) -> list[Finished]: ...
    def recover(self) -> None: ...
    def close(self, *, abort: bool) -> None: ...


def drive(backend: Backend, tasks: Iterator[Task], on_done: OnDone,
          on_lost: OnLost | None = None,
          lost_record: Callable[[str], dict[str, Any]] | None = None) -> None:
    """Run every task on `backend`; `on_done(index, record, timing, attempts)` for each as it
    finishes, `on_lost(index, why)` for a job that will run again; a job lost twice is done
    with `lost_record(why)` (default: a verify record with outcome `error`). Exceptions of the
    tasks iterator and of a job (not a lost one) propagate."""
    from rapid_dsl.runtime.verification.records import failed_record

    if lost_record is None:
        def lost_record(why: str) -> dict[str, Any]:
            return failed_record("error", why)

    retry: deque[tuple[Task, int]] = deque()
    running: dict[Any, tuple[Task, int]] = {}
    exhausted = False
    while True:
        while len(running) < backend.capacity and (retry or not exhausted):
            if retry:
                task, attempt = retry.popleft()
            else:
                task_or_none = next(tasks, None)
                if task_or_none is None:
                    exhausted = True
                    continue
                task, attempt = task_or_none, 1
            running[backend.submit(task)] = (task, attempt)
        if not running:
            return
        lost = False
        for handle, outcome, error in backend.wait(list(running)):
            task, attempt = running.pop(handle)
            if isinstance(error, Lost):
                lost = True
                if attempt < MAX_ATTEMPTS:
                    retry.append((task, attempt + 1))
                    if on_lost is not None:
                        on_lost(task[0], str(error))
                else:
                    on_done(task[0], lost_record(f"the job was lost {attempt} times (its "
                                                 f"worker process died: {error})"),
                            {"seconds": 0.0, "cpu_seconds": 0.0}, attempt)
            elif error is not None:
                raise error
            else:
                assert outcome is not None
                record, timing = outcome
                on_done(task[0], record, timing, attempt)
        if lost:
            backend.recover()


class InlineBackend:
    """Jobs in this process, one at a time (`--jobs 1`): Ctrl-C stops the running one."""

    def __init__(self, job: Job, threads: int) -> None:
        from rapid_dsl.runtime.verification.worker import runner

        self.runner = runner(job, threads)   # this process chose its GL back end already
        self._queued: dict[int, Task] = {}
        self._submitted = 0

    @property
    def capacity(self) -> int:
        return 1

    def submit(self, task: Task) -> Any:
        self._submitted += 1
        self._queued[self._submitted] = task
        return self._submitted

    def wait(self, handles: list[Any]) -> list[Finished]:
        handle = handles[0]
        index, scene = self._queued.pop(handle)
        return [(handle, self.runner.run(index, scene), None)]

    def recover(self) -> None:
        pass

    def close(self, *, abort: bool) -> None:
        pass


class PoolBackend:
    """Jobs in `jobs` worker processes (spawned: a fresh interpreter each, no inherited threads
    or locks), each loading the program once in its initializer."""

    def __init__(self, job: Job, jobs: int, threads: int, gl_backend: str | None) -> None:
        self.job, self.jobs, self.threads, self.gl_backend = job, jobs, threads, gl_backend
        self._pool = self._start()
        self._generation = 0                        # pools started so far, less one
        self._born: dict[Future[Any], int] = {}     # which pool each running job is in
        self._broken = False                        # the current pool lost a worker

    def _start(self) -> ProcessPoolExecutor:
        from rapid_dsl.runtime.verification.worker import install

        return ProcessPoolExecutor(max_workers=self.jobs,
                                   mp_context=multiprocessing.get_context("spawn"),
                                   initializer=install,
                                   initargs=(self.job, self.threads, self.gl_backend))

    @property
    def capacity(self) -> int:
        return self.jobs

    def submit(self, task: Task) -> Future[Any]:
        from rapid_dsl.runtime.verification.worker import run_installed

        try:
            future = self._pool.submit(run_installed, *task)
        except BrokenProcessPool:
            # A worker died after the last wait and before any of its jobs reported it: the
            # pool refuses new work, so replace it now (its running jobs come back as lost).
            self._broken = True
            self.recover()
            future = self._pool.submit(run_installed, *task)
        self._born[future] = self._generation
        return future

    def wait(self, handles: list[Any]) -> list[Finished]:
        done, _ = wait(handles, return_when=FIRST_COMPLETED)
        finished: list[Finished] = []
        for future in done:
            error = future.exception()
            if isinstance(error, BrokenProcessPool):
                # every job of a broken pool is lost; only the current pool needs replacing
                self._broken |= self._born[future] == self._generation
                finished.append((future, None, Lost(str(error) or "a worker process died")))
            else:
                finished.append((future, None if error else future.result(), error))
            del self._born[future]
        return finished

    def recover(self) -> None:
        """A worker died: its pool is broken for good; start another."""
        if self._broken:
            self._pool.shutdown(wait=False, cancel_futures=True)
            self._pool = self._start()
            self._generation += 1
            self._broken = False

    def close(self, *, abort: bool) -> None:
        if abort:
            # Python 3.11 has no public way to stop running workers (3.14: terminate_workers).
            for process in list(getattr(self._pool, "_processes", {}).values()):
                process.terminate()
        self._pool.shutdown(wait=True, cancel_futures=True)


def local_threads(jobs: int) -> int:
    """Native rollout threads per job so that `jobs` jobs share the machine's cores."""
    return max(1, (os.cpu_count() or 1) // jobs)
