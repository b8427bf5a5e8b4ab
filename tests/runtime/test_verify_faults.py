"""`rapidc verify` survives faults and loses nothing: a killed worker process (its jobs run once
more), a lost Dask worker, and Ctrl-C (the finished runs are kept and `--resume` continues).
Each test runs the real command in its own process and interferes with it mid-run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

ROOT = Path(__file__).resolve().parents[2]
PUSH = ROOT / "examples" / "push_box.rapid"
SCENE = ROOT / "examples" / "scenes" / "push_box.yaml"
VARIANTS = 10   # enough runs left after the first two that an interrupt lands mid-run under load
BUDGET = ("--samples", "16", "--iterations", "2")   # about a second a job: time to interfere


def start(report: Path, *options: str) -> subprocess.Popen[str]:
    command = [sys.executable, "-m", "rapid_dsl", "verify", str(PUSH), "--scene", str(SCENE),
               "--variants", str(VARIANTS), *BUDGET, "--report", str(report), *options]
    return subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)


def wait_for_records(report: Path, count: int, process: subprocess.Popen[str]) -> None:
    """Until the journal holds `count` finished runs (its first line is the header)."""
    journal = Path(f"{report}.journal")
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        assert process.poll() is None, process.communicate()
        if journal.exists() and journal.read_text().count("\n") >= count + 1:
            return
        time.sleep(0.05)
    raise AssertionError("the run finished no job in time")


def workers(process: subprocess.Popen[str]) -> list[psutil.Process]:
    """The worker processes (spawned interpreters) below the command's process."""
    found = []
    for child in psutil.Process(process.pid).children(recursive=True):
        try:
            if any("spawn_main" in part for part in child.cmdline()):
                found.append(child)
        except psutil.NoSuchProcess:
            continue
    return found


def finish(process: subprocess.Popen[str]) -> tuple[int, str, str]:
    out, err = process.communicate(timeout=300)
    return process.returncode, out, err


@pytest.mark.slow
@pytest.mark.parametrize("backend", [("--jobs", "2"), ("--cluster", "local:2")],
                         ids=["process pool", "local Dask cluster"])
def test_a_killed_worker_loses_nothing(tmp_path: Path, backend: tuple[str, str]):
    report = tmp_path / "r.json"
    process = start(report, *backend)
    wait_for_records(report, 1, process)
    victims = workers(process)
    assert victims, "no worker processes found"
    victims[0].kill()
    code, out, err = finish(process)
    assert code in (0, 1), err
    data = json.loads(report.read_text())
    assert data["complete"] and len(data["results"]) == VARIANTS + 1
    assert [r["variant"] for r in data["results"]] == [None, *range(VARIANTS)]
    assert all(r["outcome"] in ("succeeded", "failed") for r in data["results"]), err
    if backend[0] == "--jobs":   # the pool's lost jobs ran again (Dask reschedules its own)
        assert any(r["execution"]["attempts"] == 2 for r in data["results"]), err
    assert not Path(f"{report}.journal").exists()


@pytest.mark.slow
@pytest.mark.parametrize("jobs", ["1", "2"])
def test_ctrl_c_keeps_the_finished_runs_and_resume_continues(tmp_path: Path, jobs: str):
    report = tmp_path / "r.json"
    process = start(report, "--jobs", jobs)
    wait_for_records(report, 2, process)
    os.killpg(process.pid, signal.SIGINT)   # as a terminal does: the command and its workers
    code, out, err = finish(process)
    assert code == 130, err
    assert "Traceback" not in err
    assert f"{report} keeps them: continue with --resume {report}" in err
    interrupted = json.loads(report.read_text())
    assert not interrupted["complete"]
    kept = interrupted["results"]
    assert 2 <= len(kept) < VARIANTS + 1
    assert f"rapidc: interrupted after {len(kept)} of {VARIANTS + 1} runs" in err
    resumed = subprocess.run(
        [sys.executable, "-m", "rapid_dsl", "verify", str(PUSH), "--scene", str(SCENE),
         "--variants", str(VARIANTS), *BUDGET, "--resume", str(report)],
        capture_output=True, text=True, timeout=300)
    assert resumed.returncode in (0, 1), resumed.stderr
    done = json.loads(report.read_text())
    assert done["complete"] and len(done["results"]) == VARIANTS + 1
    by_variant = {r["variant"]: r for r in done["results"]}
    assert all(by_variant[r["variant"]] == r for r in kept)   # not run again
    assert resumed.stderr.count("verify: ") == VARIANTS + 1 - len(kept)
