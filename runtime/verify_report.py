"""The verification report on disk: a journal written as runs finish, and the report made from it.

While `rapidc verify --report R` runs, every finished run is appended to the journal `R.journal`
(JSON lines: a header line, then one record per line, each flushed and fsynced), so a run that is
interrupted, killed or loses its machine keeps every variant that finished. The report `R` (one
JSON object, docs/verify.md, runtime/verify_report.schema.json) is assembled from them and
written atomically (runtime/files.py) at the end, and after an interruption with
`"complete": false`; once a complete report is written the journal is removed. `--resume R`
reads the journal if there is one (a torn last line is dropped), else the report, and keeps the
records whose header matches this run's (the same program, scene, ranges, seed and settings).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path
from typing import Any

from rapid_dsl.runtime.files import (
    FileProblem,
    identities,
    output_folder,
    read_bytes,
    write_atomic,
)
from rapid_dsl.runtime.verify_job import REPORT_FORMAT
from rapid_dsl.runtime.verify_records import Record, summarize

JOURNAL_SUFFIX = ".journal"
MAX_REPORT_BYTES = 1 << 30     # a report of 10,000 variants is about 50 MB
SCHEMA = Path(__file__).with_name("verify_report.schema.json")


class ReportProblem(Exception):
    """A report or journal that cannot be read or written (the message says which and why)."""


def journal_path(report: str | os.PathLike[str]) -> Path:
    return Path(f"{os.fspath(report)}{JOURNAL_SUFFIX}")


def variant_key(record: Record) -> int | None:
    return record["variant"]


class Journal:
    """Append-only JSON lines: the header, then the records (kept ones first)."""

    def __init__(self, path: Path, header: Record, kept: Iterable[Record], *,
                 inputs: Iterable[str | os.PathLike[str]] = ()) -> None:
        self.path = path
        self._fd: int | None = None
        try:
            with output_folder(path.parent, inputs=inputs) as folder:
                self._fd = folder.create(path.name)
        except FileProblem as exc:
            raise ReportProblem(f"cannot write {path}: {exc}") from None
        self._write(header)
        for record in kept:
            self._write(record)

    def append(self, record: Record) -> None:
        self._write(record)

    def _write(self, data: Record) -> None:
        line = (json.dumps(data, separators=(",", ":"), allow_nan=False) + "\n").encode()
        assert self._fd is not None, "the journal is closed"
        try:
            os.write(self._fd, line)
            os.fsync(self._fd)
        except OSError as exc:
            raise ReportProblem(f"cannot write {self.path}: {exc.strerror or exc}") from None

    def close(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None

    def remove(self) -> None:
        """Once the complete report is written, the journal has nothing more to keep."""
        self.close()
        try:
            with output_folder(self.path.parent) as folder:
                folder.remove(self.path.name)
        except FileProblem as exc:
            raise ReportProblem(f"cannot remove {self.path}: {exc}") from None


def check_output(path: str | os.PathLike[str],
                 inputs: Iterable[str | os.PathLike[str]] = ()) -> None:
    """Refuse, before anything runs, a report path that is a folder, a symbolic link or one of
    the inputs (and the same for its journal). Raises ReportProblem."""
    for target in (Path(path), journal_path(path)):
        if target.is_symlink():
            raise ReportProblem(f"cannot write {target}: is a symbolic link; refusing to write "
                                "through it")
        if target.is_dir():
            raise ReportProblem(f"cannot write {target}: a folder, not a file")
        _refuse_inputs(target, inputs)


def read_previous(report: str | os.PathLike[str], *, kind: str = REPORT_FORMAT,
                  key: str = "variant") -> tuple[Record, list[Record]]:
    """The header and records of an earlier run of `report`: from its journal if there is one,
    else from the report. `kind` is the header's `format` and `key` a field every record has
    (the benchmark's results use other ones). Raises ReportProblem."""
    journal = journal_path(report)
    if journal.exists():
        lines = _read(journal).splitlines()
        parsed = []
        for number, line in enumerate(lines, start=1):
            try:
                parsed.append(json.loads(line))
            except json.JSONDecodeError:
                if number == len(lines):
                    break      # the last line was being written when the run stopped
                raise ReportProblem(f"{journal}:{number}: not a JSON line") from None
        if not parsed or not _is_header(parsed[0], kind):
            raise ReportProblem(f"{journal}:1: not a {_what(kind)} journal")
        return parsed[0], [r for r in parsed[1:] if isinstance(r, dict) and key in r]
    try:
        data = json.loads(_read(Path(report)))
    except json.JSONDecodeError as exc:
        raise ReportProblem(f"{report}:{exc.lineno}:{exc.colno}: not JSON: {exc.msg}") from None
    if not _is_header(data, kind) or not isinstance(data.get("results"), list):
        raise ReportProblem(f"{report}: not a {_what(kind)} report ({kind})")
    header = {name: value for name, value in data.items()
              if name not in ("complete", "summary", "results")}
    return header, [r for r in data["results"] if isinstance(r, dict) and key in r]


def assemble(header: Record, records: Iterable[Record], *, complete: bool) -> Record:
    """The report: the header, whether every run finished, the summary and the records (the
    scene first, then the variants by index)."""
    ordered = sorted(records, key=lambda r: -1 if r["variant"] is None else r["variant"])
    return {**header, "complete": complete, "summary": summarize(ordered), "results": ordered}


def write_report(path: str | os.PathLike[str], report: Record, *,
                 inputs: Iterable[str | os.PathLike[str]] = ()) -> None:
    """Write the report atomically, never through a symlink or over an input."""
    try:
        write_atomic(path, json.dumps(report, indent=1, allow_nan=False) + "\n", inputs=inputs)
    except FileProblem as exc:
        raise ReportProblem(f"cannot write {path}: {exc}") from None


def schema() -> Record:
    """The report's JSON Schema (draft 2020-12)."""
    result: Record = json.loads(SCHEMA.read_text(encoding="utf-8"))
    return result


def _is_header(data: Any, kind: str = REPORT_FORMAT) -> bool:
    return isinstance(data, dict) and data.get("format") == kind


def _what(kind: str) -> str:
    return "rapidc verify" if kind == REPORT_FORMAT else kind.partition("/")[0]


def _read(path: Path) -> str:
    try:
        return read_bytes(path, limit=MAX_REPORT_BYTES).decode("utf-8")
    except FileProblem as exc:
        raise ReportProblem(f"{path}: {exc}") from None
    except UnicodeDecodeError:
        raise ReportProblem(f"{path}: not UTF-8") from None


def _refuse_inputs(path: Path, inputs: Iterable[str | os.PathLike[str]]) -> None:
    """Compared by device and inode: a hard link to an input is that input."""
    mine = identities([path])
    for given in inputs:
        if mine & identities([given]):
            raise ReportProblem(f"cannot write {path}: it is one of the inputs ({given})")
