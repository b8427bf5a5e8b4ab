"""How `rapidc run` shows a run: progress on stderr, the result table on stdout.

Progress is a rich progress bar per phase on a terminal and plain lines otherwise (logs, CI,
agents). The table lists each phase (status, arguments, planned and executed cost, rollouts,
time) and every requirement and success clause with its value and whether it held at the start,
so a failed run says which clause failed and by how much, and a vacuous one says so.
"""

from __future__ import annotations

import math
import sys
from typing import Any, TextIO

from rich import box
from rich.console import Console
from rich.markup import escape
from rich.progress import BarColumn, Progress, TextColumn, TimeElapsedColumn
from rich.table import Table

from rapid_dsl.commands.common import shown
from rapid_dsl.runtime.executor import Event
from rapid_dsl.runtime.results import (
    ClauseResult,
    RunResult,
    attempt_label,
    format_cost,
    format_value,
)


class ProgressPrinter:
    """Receives executor events; prints nothing when quiet."""

    def __init__(self, *, quiet: bool, color: bool) -> None:
        self.quiet = quiet
        self.tty = sys.stderr.isatty()
        self._progress: Progress | None = None
        self._tasks: dict[str, Any] = {}
        if self.tty and not quiet:
            self._progress = Progress(TextColumn("{task.description}"), BarColumn(),
                                      TextColumn("{task.completed}/{task.total}"),
                                      TimeElapsedColumn(),
                                      console=make_console(sys.stderr, color=color))

    def __call__(self, event: Event) -> None:
        if self.quiet:
            return
        if self._progress is not None:
            self._rich(event)
        else:
            line = _plain_line(event)
            if line:
                print(line, file=sys.stderr, flush=True)

    def _rich(self, event: Event) -> None:
        progress = self._progress
        assert progress is not None
        if event.kind == "binding":
            progress.console.print(f"binding: {_text(event.message)}")
        elif event.kind == "phase":
            progress.start()
            # The total is known from the start: the bar never shows `0/None`.
            self._tasks[event.phase] = progress.add_task(
                _text(f"{event.phase} ({event.message})"), total=event.iterations or None)
        elif event.kind == "iteration" and event.phase in self._tasks:
            progress.update(self._tasks[event.phase], completed=event.iteration,
                            total=event.iterations,
                            description=_text(f"{event.phase}: best cost "
                                              f"{event.best_cost:.4g}"))
        elif event.kind == "phase_done" and event.phase in self._tasks:
            task = self._tasks[event.phase]
            done = progress.tasks[task].total or 1
            progress.update(task, description=_text(f"{event.phase}: {event.message}"
                                                    + _costs(event)),
                            total=done, completed=done)

    def close(self) -> None:
        if self._progress is not None:
            self._progress.stop()


def make_console(stream: TextIO, *, color: bool, width: int | None = None) -> Console:
    """A rich console on `stream` that styles only when `color` (bold too, not only colours) and
    acts as a terminal only on one: the environment (FORCE_COLOR, TTY_COMPATIBLE) does not decide.
    """
    tty = stream.isatty()
    console = Console(file=stream, force_terminal=tty, no_color=not color, highlight=False,
                      color_system=("auto" if tty else "standard") if color else None,
                      width=width)
    if console.width < _MIN_WIDTH:   # COLUMNS=0 made rich print nothing at all
        console.width = 80
    return console


_MIN_WIDTH = 20


def _text(text: str) -> str:
    """Program, scene and path text for rich: its brackets are not markup (`[a, b, c]` would
    vanish, `[/]` would raise) and its control characters are shown escaped."""
    return escape(shown(text, None))


def _plain_line(event: Event) -> str | None:
    if event.kind == "binding":
        return f"binding: {event.message}"
    if event.kind == "phase":
        return f"phase {event.phase} ({event.message}): optimizing"
    if event.kind == "iteration":
        return (f"phase {event.phase}: iteration {event.iteration}/{event.iterations}, "
                f"best cost {event.best_cost:.4g}")
    if event.kind == "phase_done":
        return f"phase {event.phase}: {event.message}{_costs(event)}"
    return None


def _costs(event: Event) -> str:
    """`, planned cost 0.0228, executed cost 81`: what the plan promised and what happened."""
    if math.isnan(event.best_cost):
        return ""
    return f", planned cost {event.best_cost:.4g}, executed cost {event.executed_cost:.4g}"


def print_result(result: RunResult, *, color: bool) -> None:
    """The result tables on stdout."""
    console = make_console(sys.stdout, color=color, width=None if sys.stdout.isatty() else 160)
    outcome = "[yellow]REJECTED[/]" if result.rejected else \
        "[green]SUCCESS[/]" if result.succeeded else "[red]FAILED[/]"
    console.print(_text(f"{result.entry} ({result.kind}) on {result.scene}, seed "
                        f"{result.seed}: ") + outcome)
    if result.binding:
        console.print("binding: " + _text(", ".join(f"{r}={e}"
                                                    for r, e in result.binding.items())))
    if result.binding_note:
        console.print(f"note: {_text(result.binding_note)}")
    if result.phases:
        console.print(_phase_table(result))
    clauses = [(f"{p.name}: ", c) for p in result.phases for c in p.requires + p.success]
    if result.kind == "strategy":
        clauses += [("success: ", c) for c in result.success]
    if result.rejected:   # the filters decided; nothing ran
        clauses += [(f"filter of {where}: ", c) for where, checks in result.filters.items()
                    for c in checks]
    if clauses:
        console.print(_clause_table(clauses))
    for warning in result.warnings:
        console.print(f"[yellow]warning:[/] {_text(warning.origin)}: {_text(warning.message)}")
    if result.failure:
        console.print(f"[red]failure:[/] {_text(result.failure)}")
    console.print(f"time: {result.seconds.get('total', 0.0):.2f}s")


def _phase_table(result: RunResult) -> Table:
    table = Table(box=box.SIMPLE, header_style="bold")
    for column in ("phase", "primitive", "status", "arguments", "planned cost", "executed cost",
                   "rollouts", "time"):
        table.add_column(column, overflow="fold")
    for p in result.phases:
        # the earlier attempts of a retried phase, in brief; the record itself is the last one's
        for attempt in p.attempts[:-1]:
            table.add_row(_text(attempt_label(p.name, attempt.number)), _text(p.primitive),
                          _status(attempt.status), _text(_arguments(attempt.arguments, p.units)),
                          format_cost(attempt.planned_cost), format_cost(attempt.executed_cost),
                          "-", f"{attempt.seconds:.2f}s")
        # the CEM's first best cost, then the planned cost of the motion executed
        costs = p.best_cost_per_iteration
        planned = format_cost(p.planned_cost)
        cost = f"{costs[0]:.3g} -> {planned}" if len(costs) > 1 else planned
        table.add_row(_text(attempt_label(p.name, len(p.attempts) or 1)), _text(p.primitive),
                      _status(p.status), _text(_arguments(p.arguments, p.units)), cost,
                      format_cost(p.executed_cost),
                      f"{p.rollouts} ({p.samples}x{p.iterations})" if p.rollouts else "-",
                      f"{p.seconds['total']:.2f}s" if "total" in p.seconds else "-")
    return table


def _status(status: str) -> str:
    return {"succeeded": "[green]succeeded[/]", "failed": "[red]failed[/]"}.get(status, status)


def _arguments(arguments: dict[str, float | list[float]], units: dict[str, str]) -> str:
    return ", ".join(f"{k}={format_value(v, units.get(k, ''))}"
                     for k, v in arguments.items()) or "-"


def _clause_table(clauses: list[tuple[str, ClauseResult]]) -> Table:
    table = Table(box=box.SIMPLE, header_style="bold")
    for column in ("clause", "where", "value", "bound", "holds", "at start"):
        table.add_column(column, overflow="fold")
    for prefix, c in clauses:
        holds = "[green]yes[/]" if c.holds else "[red]no[/]"
        # a success clause already true before the motion is no evidence of it
        at_start = "-" if c.at_start is None else "[yellow]yes[/]" if c.at_start else "no"
        table.add_row(_text(prefix + c.text), _text(c.origin), format_value(c.value, c.unit),
                      format_value(c.bound, c.unit), holds, at_start)
    return table

