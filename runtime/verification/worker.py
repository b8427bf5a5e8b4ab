"""Where verification jobs run: entry points for the command's process, a process pool and Dask.

Light at import (standard library and runtime/verification/job.py only): a worker imports mujoco
without GL (runtime/gl.py), or with the back end the command rendered with when the job has a
media folder (`gl_backend`, e.g. `egl`: workers inherit MUJOCO_GL=disable), then makes the
job's runner once (`job.runner`: verify's `Runner`, or the benchmark's `BenchRunner`, which load
the programs) and keeps it for every job of the same programs and settings, identified by
`job.digest()`. A process-pool worker does this in its initializer; a Dask
worker on its first job. Pool workers ignore SIGINT: Ctrl-C is the command's to handle.
"""

from __future__ import annotations

import importlib
import os
import signal
import threading
from typing import Any

from rapid_dsl.runtime.verification.job import Job, JobRunner

_runners: dict[tuple[str, int], JobRunner] = {}
_lock = threading.Lock()          # a Dask worker may run several jobs in threads
_installed: tuple[Job, int, str | None] | None = None


def runner(job: Job, threads: int, gl_backend: str | None = None) -> JobRunner:
    """This process's runner for `job` (made on first use)."""
    key = (job.digest(), threads)
    with _lock:
        if key not in _runners:
            _import_mujoco(gl_backend if job.media is not None else None)
            _runners[key] = job.runner(threads)
        return _runners[key]


def rendering_backend() -> str:
    """The GL back end this process's mujoco renders with (after gl.start_rendering)."""
    import mujoco

    return str(getattr(mujoco.GLContext, "__module__", "")).rpartition(".")[2]


def _import_mujoco(gl_backend: str | None) -> None:
    from rapid_dsl.runtime import gl

    if gl_backend is None:
        with gl.without_gl():
            importlib.import_module("mujoco")
    else:
        os.environ["MUJOCO_GL"] = gl_backend
        gl.start_rendering()


def install(job: Job, threads: int, gl_backend: str | None) -> None:
    """Process-pool initializer: load the program once in this worker."""
    global _installed
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    _installed = (job, threads, gl_backend)
    runner(job, threads, gl_backend)


def run_installed(index: int | None, scene: Any) -> tuple[dict[str, Any], dict[str, float]]:
    """A pool worker's job: the installed program on `scene` (variant `index`)."""
    assert _installed is not None, "install() runs first, as the pool's initializer"
    return runner(*_installed).run(index, scene)


def run_job(job: Job, threads: int, gl_backend: str | None, index: int | None,
            scene: Any) -> tuple[dict[str, Any], dict[str, float]]:
    """A Dask worker's job (the job itself is sent to each worker once, scattered)."""
    return runner(job, threads, gl_backend).run(index, scene)
