"""Verification jobs on a Dask distributed cluster (the optional `rapid-dsl[cluster]` extra).

`--cluster tcp://HOST:8786` connects to a running scheduler; `--cluster local:N` starts a
LocalCluster of N worker processes (one thread each, listening on localhost only) for this run and
stops it afterwards. The job is scattered to every worker once; each task is one variant. Dask
reschedules the tasks of a worker that dies (its scheduler's `allowed-failures`); a task that
still fails because its worker went away (KilledWorker, a lost connection) counts as lost, and
runtime/verification/backends.py runs it once more.
"""

from __future__ import annotations

import logging
import re
from typing import Any

from rapid_dsl.runtime.verification.backends import Finished, Lost, Task
from rapid_dsl.runtime.verification.job import Job

LOCAL = re.compile(r"local:(\d+)")
MAX_LOCAL_WORKERS = 256


class ClusterError(Exception):
    """Dask is not installed, the address is malformed, or the scheduler cannot be reached."""


def check_address(address: str) -> None:
    """Raise ClusterError for an address that is neither `local:N` nor a scheduler address."""
    match = LOCAL.fullmatch(address)
    if match:
        if not 1 <= int(match.group(1)) <= MAX_LOCAL_WORKERS:
            raise ClusterError(f"--cluster {address}: local:N takes 1 to {MAX_LOCAL_WORKERS} "
                               "workers")
    elif address.startswith("local") or not re.fullmatch(r"[A-Za-z0-9+.-]+://\S+|\S+:\d+",
                                                          address):
        raise ClusterError(f"--cluster {address}: expected local:N or a scheduler address such "
                           "as tcp://host:8786")


class DaskBackend:
    """Jobs as Dask tasks; capacity follows the cluster's worker threads."""

    def __init__(self, job: Job, address: str, gl_backend: str | None,
                 timeout: float = 30.0) -> None:
        check_address(address)
        try:
            from distributed import Client, LocalCluster
        except ImportError:
            raise ClusterError("--cluster needs Dask: pip install 'rapid-dsl[cluster]'") \
                from None
        self.cluster: Any = None
        match = LOCAL.fullmatch(address)
        try:
            if match:
                self.cluster = LocalCluster(n_workers=int(match.group(1)), threads_per_worker=1,
                                            processes=True, host="127.0.0.1",
                                            dashboard_address=None,
                                            silence_logs=logging.ERROR)
                self.client = Client(self.cluster)
            else:
                self.client = Client(address, timeout=timeout)
        except (OSError, TimeoutError) as exc:
            self.close(abort=True)
            raise ClusterError(f"--cluster {address}: cannot reach the scheduler: {exc}") \
                from None
        self.gl_backend = gl_backend
        self._job = self.client.scatter(job, broadcast=True, hash=False)

    @property
    def capacity(self) -> int:
        threads = sum(self.client.nthreads().values())
        return max(1, 2 * threads)   # one queued behind each running job keeps workers busy

    def submit(self, task: Task) -> Any:
        from rapid_dsl.runtime.verification.worker import run_job

        # Threads per job: 1; a worker's threads are the cluster's unit of parallelism.
        return self.client.submit(run_job, self._job, 1, self.gl_backend, *task, pure=False)

    def wait(self, handles: list[Any]) -> list[Finished]:
        from concurrent.futures import CancelledError

        from distributed import wait

        try:
            done, _ = wait(handles, return_when="FIRST_COMPLETED")
        except CancelledError:
            # The scheduler forgot tasks whose worker went away ("already forgotten"): they are
            # lost like a killed worker's, and run once more.
            done = {future for future in handles if future.done()}
        finished: list[Finished] = []
        for future in done:
            if future.status == "finished":
                finished.append((future, future.result(), None))
                continue
            error = future.exception() if future.status == "error" else None
            if error is None or _lost(error):
                finished.append((future, None, Lost(f"{type(error).__name__}: {error}"
                                                    if error else future.status)))
            else:
                finished.append((future, None, error))
        return finished

    def recover(self) -> None:
        pass   # the scheduler replaces lost workers (a LocalCluster's nanny restarts them)

    def close(self, *, abort: bool) -> None:
        # Closing the client releases its futures: the scheduler forgets tasks nobody wants,
        # so an aborted run leaves nothing running on a shared cluster.
        client = getattr(self, "client", None)
        if client is not None:
            client.close()
        if self.cluster is not None:
            self.cluster.close()


def _lost(error: BaseException) -> bool:
    """A task that failed because its worker went away, not because of the job."""
    from distributed.comm.core import CommClosedError
    from distributed.scheduler import KilledWorker

    return isinstance(error, KilledWorker | CommClosedError | OSError)
