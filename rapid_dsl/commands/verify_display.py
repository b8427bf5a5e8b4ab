"""How `rapidc verify` shows its work: a progress bar on stderr, the summary on stdout, and
the `--html` page (checked before anything runs, written at the end).

On a terminal the progress is one rich bar (runs done, succeeded, failed, rejected, time left);
elsewhere (logs, CI, agents) one plain line per finished run. The summary gives the success rate,
the runs rejected by each filter clause and the failures grouped by phase and first failing
clause, each with its source location, so it reads like the report it summarizes.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from rich.progress import (
    BarColumn,
    Progress,
    TaskID,
    TextColumn,
    TimeElapsedColumn,
    TimeRemainingColumn,
)

from rapid_dsl.commands.common import fail_usage, shown
from rapid_dsl.commands.run_report import make_console

Record = dict[str, Any]


def run_name(variant: int | None) -> str:
    return "the scene" if variant is None else f"variant {variant}"


class VerifyProgress:
    """Receives each finished record; prints nothing when quiet."""

    def __init__(self, total: int, done: int, *, quiet: bool, color: bool) -> None:
        self.total, self.done, self.quiet = total, done, quiet
        self.tally = {"succeeded": 0, "failed": 0, "rejected": 0, "error": 0}
        self._progress: Progress | None = None
        self._task: TaskID | None = None
        if sys.stderr.isatty() and not quiet:
            self._progress = Progress(
                TextColumn("verify"), BarColumn(), TextColumn("{task.completed}/{task.total}"),
                TextColumn("{task.fields[tally]}"), TimeElapsedColumn(), TimeRemainingColumn(),
                console=make_console(sys.stderr, color=color))
            self._progress.start()
            self._task = self._progress.add_task("verify", total=total, completed=done,
                                                 tally=self._tally())

    def update(self, record: Record) -> None:
        self.done += 1
        self.tally[record["outcome"]] += 1
        if self.quiet:
            return
        if self._progress is not None and self._task is not None:
            self._progress.update(self._task, completed=self.done, tally=self._tally())
            return
        line = f"verify: {self.done}/{self.total} {run_name(record['variant'])}: " \
               f"{record['outcome']}"
        reason = record["failure"] if record["outcome"] != "succeeded" else None
        print(line + (f": {shown(reason, 200)}" if reason else ""), file=sys.stderr, flush=True)

    def lost(self, variant: int | None, why: str) -> None:
        """A job whose worker went away: it runs once more."""
        message = f"verify: {run_name(variant)} was lost ({shown(why, 120)}); running it again"
        if self._progress is not None:
            self._progress.console.print(message, markup=False, highlight=False)
        elif not self.quiet:
            print(message, file=sys.stderr, flush=True)

    def _tally(self) -> str:
        t = self.tally
        return (f"{t['succeeded']} succeeded, {t['failed'] + t['error']} failed, "
                f"{t['rejected']} rejected")

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()
            self._progress = None


def summary_lines(report: Record) -> list[str]:
    """The summary, as printed on stdout."""
    s = report["summary"]
    ran = s["succeeded"] + s["failed"] + s["error"]
    rate = "-" if s["success_rate"] is None else f"{100 * s['success_rate']:.1f}%"
    variants = report["variants"]
    lines = [shown(f"{report['entry']} ({report['kind']}) on {report['scene']} and "
                   f"{variants} variant{'s' if variants != 1 else ''} of seed {report['seed']}: "
                   f"{s['succeeded']} of {ran} runs succeeded ({rate}), {s['rejected']} "
                   "rejected", None)]
    if s["scene"] is not None:
        lines.append(f"  the scene itself: {s['scene']}")
    if not report["complete"]:
        lines.append(f"  incomplete: {s['runs']} of {variants + 1} runs finished")
    if s["rejections"]:
        lines.append("rejected by filters:")
        for row in s["rejections"]:
            where = f"phase `{row['phase']}` ({row['primitive']})" if row["phase"] \
                else f"`{row['where']}`"
            clause = f"`{row['clause']}`" if row["clause"] else "a filter"
            lines.append(shown(f"  {row['count']}x  {where}: {clause}{_at(row)}  "
                               f"({_runs(row['variants'])})", None))
    if s["failures"]:
        lines.append("failures by phase and first failing clause:")
        for row in s["failures"]:
            where = f"phase `{row['phase']}` ({row['primitive']})" if row["phase"] \
                else "the entry"
            what = f"{row['stage']} `{row['clause']}`" if row["clause"] else row["stage"]
            lines.append(shown(f"  {row['count']}x  {where}, {what}{_at(row)}  "
                               f"({_runs(row['variants'])})", None))
            if row["example"]:
                lines.append("        e.g. " + shown(row["example"], 300))
    return lines


def _at(row: Record) -> str:
    return f" at {row['location']}" if row["location"] else ""


def _runs(variants: list[int | None]) -> str:
    names = ["the scene" if v is None else str(v) for v in variants[:12]]
    more = f" and {len(variants) - 12} more" if len(variants) > 12 else ""
    label = "variants " if any(v is not None for v in variants) else ""
    return label + ", ".join(names) + more


def print_report(report: dict[str, Any], args: argparse.Namespace,
                 page_inputs: list[str]) -> int | None:
    """Write the --html page (never over one of `page_inputs`), then the summary on stdout
    (`--format json`: the whole report; `--quiet`: one line). Returns 2 when the page cannot be
    written, else None."""
    if args.html is not None:
        from rapid_dsl.runtime.verification.page import write_html
        from rapid_dsl.runtime.verification.report import ReportProblem

        try:
            write_html(args.html, report, program=args.program, media=args.media,
                       inputs=page_inputs)
        except ReportProblem as exc:
            return fail_usage(str(exc))
    if args.format == "json":
        print(json.dumps(report, indent=1))
        return None
    lines = summary_lines(report)
    print(lines[0] if args.quiet else "\n".join(lines))
    return None


def check_html(page: str, inputs: list[str]) -> str | None:
    """Why the --html page cannot be written (a folder, a symbolic link, an input), or None:
    found before anything runs. Inputs are compared by device and inode."""
    from rapid_dsl.language.files import identities

    path = Path(page)
    if path.is_symlink():
        return f"--html {page}: is a symbolic link; refusing to write through it"
    if path.is_dir():
        return f"--html {page}: a folder, not a file"
    mine = identities([path])
    for given in inputs:
        if mine & identities([given]):
            return f"--html {page}: it is one of the inputs ({given})"
    return None
