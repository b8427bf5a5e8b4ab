"""The worker process of long tools, on its own: its outcome, its lines as they come, and how it
is stopped."""

from __future__ import annotations

import signal
from pathlib import Path

import anyio
import pytest

from rapid_dsl.mcp import worker

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"
PUSH_BOX, PUSH_SCENE = EXAMPLES / "push_box.rapid", EXAMPLES / "scenes" / "push_box.yaml"


async def _collect(lines: list[str], text: str) -> None:
    lines.append(text)


def test_a_worker_returns_the_commands_outcome_and_its_lines() -> None:
    lines: list[str] = []
    outcome = anyio.run(worker.run, ["explain", "E9999"], lambda t: _collect(lines, t), "")
    assert outcome.status == 2
    assert lines == ["rapidc: error: unknown diagnostic code `E9999`; docs/diagnostics.md lists "
                     "them all"]
    assert outcome.stderr == lines[0] + "\n" and outcome.stdout == ""


@pytest.mark.slow
def test_a_worker_that_sent_its_outcome_is_left_to_end_by_itself(
        monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> None:
    # Regression: the server sent SIGINT to a worker that had sent its outcome but was still
    # running its exit handlers; EGL's then printed a KeyboardInterrupt traceback.
    sent: list[signal.Signals] = []
    monkeypatch.setattr(worker, "_signal", lambda process, sig: sent.append(sig))
    lines: list[str] = []
    argv = ["run", str(PUSH_BOX), "--scene", str(PUSH_SCENE), "--samples", "8", "--iterations",
            "1", "--keyframes", str(tmp_path / "frames")]    # EGL takes a while to shut down
    outcome = anyio.run(worker.run, argv, lambda t: _collect(lines, t), "egl")
    if outcome.status == 2 and "rendering is unavailable" in outcome.stderr:
        pytest.skip(outcome.stderr)
    assert outcome.status == 0, outcome.stderr
    assert sent == []


@pytest.mark.slow
@pytest.mark.parametrize("parent_sigint", ["default", "ignored"])
def test_a_cancelled_worker_is_interrupted(parent_sigint: str) -> None:
    # "ignored": a server started as a background job hands SIGINT's SIG_IGN on to its workers
    previous = signal.getsignal(signal.SIGINT)
    if parent_sigint == "ignored":
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        _cancel_a_long_benchmark()
    finally:
        signal.signal(signal.SIGINT, previous)


def _cancel_a_long_benchmark() -> None:
    lines: list[str] = []

    async def cancelled() -> None:
        with anyio.move_on_after(3):
            await worker.run(["bench", "check", "--lines", "100000", "--runs", "100"],
                             lambda t: _collect(lines, t), "")
            raise AssertionError("the benchmark finished within 3 s")

    clock = anyio.run(_timed, cancelled)
    assert clock < 3 + worker.GRACE / 2     # Ctrl-C stopped it: it was not left to be killed


async def _timed(action: object) -> float:
    start = anyio.current_time()
    await action()   # type: ignore[operator]
    return anyio.current_time() - start
