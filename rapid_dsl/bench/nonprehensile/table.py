"""The table of `rapidc bench nonprehensile`, in the paper's form, and its progress display.

Per task: the success rate's mean and std over trials (each trial's rate over the scenes), the
control's rate, the median wall time of a strategy run, the paper's number; then the average.
"""

from __future__ import annotations

import statistics
import sys
from collections.abc import Mapping
from typing import Any

from rapid_dsl.bench.nonprehensile.job import run_key

PAPER = {"T1": 0.933, "T2": 0.847, "T3": 0.700, "T4": 0.787, "T5": 0.793, "T6": 0.587,
         "T7": 0.807, "T8": 0.620}
PAPER_AVERAGE = 0.759
Record = dict[str, Any]


def table(records: Mapping[str, Record], tasks: Mapping[str, Any], scenes: int,
          trials: int) -> Record:
    """Per task the success mean and std over trials (of the per-trial rates over scenes), the
    control's rate and the median wall time per scene; the average of the task means."""
    rows = []
    for key, task in tasks.items():
        rates, times = [], []
        for trial in range(trials):
            runs = [records.get(run_key(key, i, trial)) for i in range(scenes)]
            ran = [r for r in runs if r is not None]
            times += [r["execution"]["seconds"] for r in ran]
            if ran:
                rates.append(sum(r["success"] for r in ran) / len(ran))
        controls = [r for i in range(scenes)
                    if (r := records.get(run_key(key, i, None))) is not None]
        rows.append({"task": key, "title": task.title,
                     "mean": statistics.fmean(rates) if rates else None,
                     "std": statistics.pstdev(rates) if rates else None,
                     "trial_rates": rates,
                     "control": sum(r["success"] for r in controls) / len(controls)
                     if controls else None,
                     "median_seconds": statistics.median(times) if times else None,
                     "runs": len(times), "paper": PAPER.get(key)})
    means = [r["mean"] for r in rows if r["mean"] is not None]
    control_rates = [r["control"] for r in rows if r["control"] is not None]
    per_trial = [statistics.fmean(r["trial_rates"][t] for r in rows)
                 for t in range(trials)
                 if all(len(r["trial_rates"]) > t for r in rows)]
    average = {"mean": statistics.fmean(means) if means else None,
               "std": statistics.pstdev(per_trial) if per_trial else None,
               "control": statistics.fmean(control_rates) if control_rates else None,
               "paper": PAPER_AVERAGE if set(tasks) == set(PAPER) else None}
    return {"rows": rows, "average": average}


def table_lines(results: Record) -> list[str]:
    s = results["settings"]
    lines = [f"nonprehensile benchmark: {len(s['tasks'])} task(s) x {s['scenes']} test scene(s) x "
             f"{s['trials']} trial(s) on the {s['robot']} (test seed {s['test_seed']})"
             + ("" if results["complete"] else " (incomplete)"),
             f"{'task':<24} {'success':>15} {'control':>8} {'median s/scene':>15} {'paper':>6}"]
    for row in results["table"]["rows"]:
        lines.append(f"{row['task'] + ' ' + row['title']:<24} "
                     f"{_pm(row['mean'], row['std']):>15} {_rate(row['control']):>8} "
                     f"{_seconds(row['median_seconds']):>15} {_rate(row['paper']):>6}")
    a = results["table"]["average"]
    lines.append(f"{'Average':<24} {_pm(a['mean'], a['std']):>15} {_rate(a['control']):>8} "
                 f"{'':>15} {_rate(a['paper']):>6}")
    return lines


def _pm(mean: float | None, std: float | None) -> str:
    return "-" if mean is None else f"{mean:.3f} +- {std or 0.0:.3f}"


def _rate(value: float | None) -> str:
    return "-" if value is None else f"{value:.3f}"


def _seconds(value: float | None) -> str:
    return "-" if value is None else f"{value:.1f}"


class Progress:
    """A rich bar on a terminal's stderr; elsewhere one line per finished run (none if quiet)."""

    def __init__(self, total: int, done: int, *, quiet: bool, color: bool) -> None:
        self.total, self.done, self.quiet = total, done, quiet
        self.succeeded = 0
        self._bar: Any = None
        if sys.stderr.isatty() and not quiet:
            from rich.progress import (
                BarColumn,
                TextColumn,
                TimeElapsedColumn,
                TimeRemainingColumn,
            )
            from rich.progress import Progress as Bar

            from rapid_dsl.commands.run_report import make_console

            self._bar = Bar(TextColumn("bench"), BarColumn(),
                            TextColumn("{task.completed}/{task.total}"),
                            TextColumn("{task.fields[tally]}"), TimeElapsedColumn(),
                            TimeRemainingColumn(), console=make_console(sys.stderr, color=color))
            self._bar.start()
            self._task = self._bar.add_task("bench", total=total, completed=done,
                                            tally="")

    def update(self, record: Record) -> None:
        self.done += 1
        self.succeeded += bool(record["success"])
        if self.quiet:
            return
        if self._bar is not None:
            self._bar.update(self._task, completed=self.done,
                             tally=f"{self.succeeded} succeeded")
            return
        verdict = "success" if record["success"] else f"failed: {record['reason']}"
        print(f"bench: {self.done}/{self.total} {record['key']}: {verdict}"[:300],
              file=sys.stderr, flush=True)

    def lost(self, key: str, why: str) -> None:
        if not self.quiet:
            print(f"bench: {key} was lost ({why[:120]}); running it again", file=sys.stderr,
                  flush=True)

    def close(self) -> None:
        if self._bar is not None:
            self._bar.stop()
            self._bar = None
