"""The job loop and the journal of `rapidc verify`: a lost job runs once more, twice lost it is an
`error` record, a job's own exception stops the run; the journal keeps every finished run, is
only ever appended to, a torn line is dropped, and nothing is written through a link or over an
input."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from rapid_dsl.runtime.verification.backends import Lost, drive
from rapid_dsl.runtime.verification.records import failed_record
from rapid_dsl.runtime.verification.report import (
    Journal,
    ReportProblem,
    check_output,
    journal_path,
    read_previous,
)


class Flaky:
    """A backend whose jobs succeed except those `lose` names, lost that many times each."""

    def __init__(self, lose: dict[int | None, int], capacity: int = 2,
                 fail: int = -1) -> None:
        self.lose, self.fail = dict(lose), fail
        self._capacity = capacity
        self.handles: dict[int, tuple[int | None, Any]] = {}
        self.recovered = 0
        self.running_max = 0

    @property
    def capacity(self) -> int:
        return self._capacity

    def submit(self, task: tuple[int | None, Any]) -> int:
        handle = len(self.handles)
        self.handles[handle] = task
        return handle

    def wait(self, handles: list[int]) -> list[tuple[Any, Any, BaseException | None]]:
        self.running_max = max(self.running_max, len(handles))
        handle = handles[0]
        index, scene = self.handles[handle]
        if self.lose.get(index, 0) > 0:
            self.lose[index] -= 1
            return [(handle, None, Lost("the worker process died"))]
        if index == self.fail:
            return [(handle, None, RuntimeError("a bug"))]
        return [(handle, ({"outcome": "succeeded", "scene": scene},
                          {"seconds": 0.5, "cpu_seconds": 0.4}), None)]

    def recover(self) -> None:
        self.recovered += 1

    def close(self, *, abort: bool) -> None:
        pass


def tasks(count: int) -> list[tuple[int | None, str]]:
    return [(None, "scene"), *((i, f"variant {i}") for i in range(count))]


def run(backend: Flaky, count: int) -> tuple[dict[int | None, tuple[dict, int]], list]:
    done: dict[int | None, tuple[dict, int]] = {}
    lost: list = []
    drive(backend, iter(tasks(count)),
          lambda index, record, timing, attempts: done.__setitem__(index, (record, attempts)),
          lambda index, why: lost.append(index))
    return done, lost


def test_every_job_runs_once_within_the_capacity():
    backend = Flaky({}, capacity=3)
    done, lost = run(backend, 5)
    assert sorted(done, key=lambda i: -1 if i is None else i) == [None, 0, 1, 2, 3, 4]
    assert all(attempts == 1 and record["outcome"] == "succeeded"
               for record, attempts in done.values())
    assert lost == [] and backend.recovered == 0 and backend.running_max == 3


def test_a_lost_job_runs_once_more_and_twice_lost_it_is_an_error():
    backend = Flaky({1: 1, 3: 2})
    done, lost = run(backend, 4)
    assert done[1] == ({"outcome": "succeeded", "scene": "variant 1"}, 2)
    record, attempts = done[3]
    assert attempts == 2 and record["outcome"] == "error"
    assert record["first_failure"]["stage"] == "error"
    assert "lost 2 times" in record["failure"]
    assert lost == [1, 3] and backend.recovered == 3
    assert all(done[i][1] == 1 for i in (None, 0, 2))


def test_a_job_that_raises_stops_the_run():
    with pytest.raises(RuntimeError, match="a bug"):
        run(Flaky({}, fail=2), 4)


@pytest.mark.slow
def test_an_unreachable_scheduler_is_a_cluster_error():
    from rapid_dsl.runtime.compiled import CompiledProgram
    from rapid_dsl.runtime.verification.cluster import ClusterError, DaskBackend
    from rapid_dsl.runtime.verification.job import VerifyJob

    job = VerifyJob(CompiledProgram("", "p", "e", "p.rapid"), {})
    with pytest.raises(ClusterError, match="cannot reach the scheduler"):
        DaskBackend(job, "tcp://127.0.0.1:9", None, timeout=1)


HEADER = {"format": "rapidc-verify/1", "rapidc": "0.1.0", "program": "p.rapid", "entry": "e",
          "kind": "strategy", "scene": "s.yaml", "ranges": None, "seed": 0, "variants": 4,
          "settings": {"entry": "e", "run": {"seed": None, "samples": 8, "iterations": 1},
                       "pins": {}, "hints": {}, "best": False, "arguments": {}, "media": None},
          "fingerprint": {"program": "a", "scene": "b", "ranges": "c", "seed": "d",
                          "settings": "e"}}


def record(variant: int | None, outcome: str = "failed") -> dict[str, Any]:
    """A valid journal record (a run that could not start, as runtime/verification/records.py
    writes it)."""
    return {"variant": variant, "seed": None, "parameters": None,
            **failed_record("error" if outcome == "error" else "binding", "x"),
            "execution": {"attempts": 1, "seconds": 0.5, "cpu_seconds": 0.25}}


def test_the_journal_keeps_finished_runs_and_drops_a_torn_last_line(tmp_path: Path):
    report = tmp_path / "r.json"
    journal = Journal(journal_path(report), HEADER, [record(None)])
    journal.append(record(0))
    journal.close()
    with journal_path(report).open("a") as f:
        f.write('{"variant": 1, "outc')            # killed while writing
    header, records, read = read_previous(report)
    assert header == HEADER and read == journal_path(report)
    assert records == [record(None), record(0)]
    journal_path(report).write_text(json.dumps(HEADER) + "\nnot json\n{}\n")
    with pytest.raises(ReportProblem, match=r"r.json.journal:2:1: not JSON: Expecting value"):
        read_previous(report)


def test_a_resumed_journal_is_appended_to_after_the_torn_line_never_rewritten(tmp_path: Path):
    path = journal_path(tmp_path / "r.json")
    journal = Journal(path, HEADER, [record(None), record(0)])
    journal.close()
    torn = path.read_bytes() + b'{"variant": 1, "outc'
    path.write_bytes(torn)
    resumed = Journal(path, HEADER, [record(None), record(0)], append=True)
    resumed.append(record(1))
    resumed.close()
    text = path.read_bytes()
    assert text.startswith(torn + b"\n")     # every byte kept; the torn line ended
    assert text[len(torn) + 1:].decode().splitlines() == [
        json.dumps(HEADER, separators=(",", ":")), json.dumps(record(1), separators=(",", ":"))]
    header, records, _ = read_previous(tmp_path / "r.json")   # the torn line is skipped
    assert header == HEADER and records == [record(None), record(0), record(1)]


@pytest.mark.parametrize(("line", "message"), [
    ('{"variant": 1, "outc', ":3:16: not JSON: Unterminated string"),   # torn, not last
    (json.dumps({**record(1), "success": "yes"}), ":3: $.success: Input should be a valid list"),
    (json.dumps({**HEADER, "fingerprint": {**HEADER["fingerprint"], "seed": "z"}}),
     ":3: the header of another run"),
    (json.dumps({k: v for k, v in record(1).items() if k != "execution"}),
     ":3: $.execution: required field is missing"),
])
def test_a_bad_line_is_refused_with_its_number_and_the_journal_is_left_alone(
        tmp_path: Path, line: str, message: str):
    path = journal_path(tmp_path / "r.json")
    lines = [json.dumps(HEADER), json.dumps(record(None)), line, json.dumps(record(0))]
    path.write_text("\n".join(lines) + "\n")
    before = path.read_bytes()
    with pytest.raises(ReportProblem) as error:
        read_previous(tmp_path / "r.json")
    assert str(error.value).startswith(f"{path}{message}"), error.value
    assert path.read_bytes() == before


def test_no_report_or_journal_is_written_through_a_link_or_over_an_input(tmp_path: Path):
    target = tmp_path / "target.json"
    link = tmp_path / "link.json"
    link.symlink_to(target)
    with pytest.raises(ReportProblem, match="symbolic link"):
        check_output(link)
    journal_link = tmp_path / "r.json.journal"
    journal_link.symlink_to(target)
    with pytest.raises(ReportProblem, match="symbolic link"):
        check_output(tmp_path / "r.json")
    with pytest.raises(ReportProblem, match="symbolic link"):
        Journal(journal_link, HEADER, [])
    assert not target.exists()
    scene = tmp_path / "scene.yaml"
    scene.write_text("robot: floating_gripper\n")
    with pytest.raises(ReportProblem, match="one of the inputs"):
        check_output(scene, [scene])
    assert scene.read_text() == "robot: floating_gripper\n"
