"""The verification report on disk: a journal written as runs finish, and the report made from it.

While `rapidc verify --report R` runs, every finished run is appended to the journal `R.journal`
(JSON lines: a header line, then one record per line, each flushed and fsynced), so a run that is
interrupted, killed or loses its machine keeps every variant that finished. The report `R` (one
JSON object, docs/verify.md, runtime/verification/report.schema.json) is assembled from them and
written atomically (rapid_dsl/language/files.py) at the end, and after an interruption with
`"complete": false`; once a complete report is written the journal is removed. `--resume R`
reads the journal if there is one, else the report, and keeps the records whose header matches
this run's (the same program, scene, ranges, seed and settings).

A journal is append-only: a resumed run appends a copy of the header (it marks where the
resumption starts) and then its records, and never rewrites a byte already there. Reading it is
strict (rapid_dsl/language/safe_json.py, the models of runtime/verification/schema.py): a line that
is not a valid header or record is refused with its line number, and the run stops before touching
the file. The one line tolerated is a torn one, which a run killed while writing leaves: the last
line when the file does not end in a newline, or a line that is not JSON and is followed by a
resumption's header (the resumed run ended the torn line before appending).
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterable
from pathlib import Path

from pydantic import BaseModel

from rapid_dsl.language.files import (
    FileProblem,
    identities,
    output_folder,
    read_bytes,
    write_atomic,
)
from rapid_dsl.language.safe_json import JsonError, loads, validate
from rapid_dsl.runtime.verification.records import Record, summarize
from rapid_dsl.runtime.verification.schema import Header, Report
from rapid_dsl.runtime.verification.schema import Record as RecordModel

JOURNAL_SUFFIX = ".journal"
MAX_REPORT_BYTES = 1 << 30     # a report of 10,000 variants is about 50 MB
SCHEMA = Path(__file__).with_name("report.schema.json")


class ReportProblem(Exception):
    """A report or journal that cannot be read or written (the message says which and why)."""


def journal_path(report: str | os.PathLike[str]) -> Path:
    return Path(f"{os.fspath(report)}{JOURNAL_SUFFIX}")


def variant_key(record: Record) -> int | None:
    return record["variant"]


class Journal:
    """Append-only JSON lines: the header, then the records. A new journal (or one a run without
    --resume starts over) holds the header and the `kept` records first; `append=True` continues
    the journal a resumed run read, adding a copy of the header and nothing else before the new
    records."""

    def __init__(self, path: Path, header: Record, kept: Iterable[Record] = (), *,
                 inputs: Iterable[str | os.PathLike[str]] = (), append: bool = False) -> None:
        self.path = path
        self._fd: int | None = None
        try:
            with output_folder(path.parent, inputs=inputs) as folder:
                self._fd = folder.append(path.name) if append else folder.create(path.name)
            if append and not _ends_a_line(self._fd):
                os.write(self._fd, b"\n")   # end the torn line a killed run left
        except FileProblem as exc:
            raise ReportProblem(f"cannot write {path}: {exc}") from None
        except OSError as exc:
            raise ReportProblem(f"cannot write {path}: {exc.strerror or exc}") from None
        self._write(header)
        for record in () if append else kept:
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


def read_previous(report: str | os.PathLike[str]) -> tuple[Record, list[Record], Path | None]:
    """The header and records of an earlier run of `report`, from its journal if there is one,
    else from the report, and the journal read (None: the report). Raises ReportProblem."""
    journal = journal_path(report)
    if journal.exists():
        header, records = read_journal(journal, Header, RecordModel)
        return header, records, journal
    data = read_report(report)
    header = {name: value for name, value in data.items() if name in Header.model_fields}
    return header, data["results"], None


def read_report(path: str | os.PathLike[str]) -> Record:
    """A verify report, every field checked against runtime/verification/schema.py. Raises
    ReportProblem naming the line, column and JSON path of what is wrong."""
    text = _read(Path(path))
    try:
        data = loads(text, os.fspath(path))
        if not (isinstance(data, dict) and data.get("format") == _format(Header)):
            raise ReportProblem(f"{path}: not a {_what(Header)} report ({_format(Header)})")
        validate(Report, data, os.fspath(path), text=text)
    except JsonError as error:
        raise ReportProblem(error.first()) from None
    result: Record = data
    return result


def read_journal(path: Path, header: type[BaseModel], record: type[BaseModel]
                 ) -> tuple[Record, list[Record]]:
    """The header and records of a journal, each line checked against its model (the module
    doc says which torn line is tolerated). Raises ReportProblem with the line number."""
    lines = _read(path).split("\n")
    ended = lines[-1] == ""
    if ended:
        lines.pop()
    name, kind = os.fspath(path), _format(header)
    first: Record | None = None
    records: list[Record] = []
    for number, line in enumerate(lines, start=1):
        try:
            data = loads(line, name, line=number)
        except JsonError as error:
            last = number == len(lines)
            if (last and not ended) or (not last and _is_header(lines[number], kind)):
                continue   # torn: the run was killed while writing this line
            if first is None:
                raise ReportProblem(f"{path}:1: not a {_what(header)} journal") from None
            raise ReportProblem(error.first()) from None
        try:
            if first is None:
                if not (isinstance(data, dict) and data.get("format") == kind):
                    raise ReportProblem(f"{path}:{number}: not a {_what(header)} journal")
                validate(header, data, name, line=number)
                first = data
            elif isinstance(data, dict) and "format" in data:   # a resumption starts here
                validate(header, data, name, line=number)
                if data.get("fingerprint") != first.get("fingerprint"):
                    raise ReportProblem(f"{path}:{number}: the header of another run (its "
                                        "fingerprint is not line 1's)")
            else:
                validate(record, data, name, line=number)
                records.append(data)
        except JsonError as error:
            raise ReportProblem(error.first()) from None
    if first is None:
        raise ReportProblem(f"{path}:1: not a {_what(header)} journal")
    return first, records


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


def _format(header: type[BaseModel]) -> str:
    """The `format` a header model admits (its one Literal value)."""
    kind: str = header.model_fields["format"].annotation.__args__[0]  # type: ignore[union-attr]
    return kind


def _what(header: type[BaseModel]) -> str:
    kind = _format(header)
    return "rapidc verify" if header is Header else kind.partition("/")[0]


def _is_header(line: str, kind: str) -> bool:
    try:
        data = loads(line)
    except JsonError:
        return False
    return isinstance(data, dict) and data.get("format") == kind


def _ends_a_line(fd: int) -> bool:
    """Whether the file is empty or its last byte is a newline."""
    size = os.fstat(fd).st_size
    return size == 0 or os.pread(fd, 1, size - 1) == b"\n"


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
