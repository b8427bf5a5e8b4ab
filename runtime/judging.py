"""Calling generated code and judging its clauses: success, requires, filters, and vacuity.

Generated functions raise many kinds of exception (a failed solve, a missing param, numpy); the
`Evaluator` turns each into a `PhaseError` naming the `.rapid` line, so problems of a program
become reported failures, never tracebacks. A clause holds when it holds for every sample and time
point it is evaluated on; `holds_per_sample` keeps the samples apart (judging several motions at
once). A success clause that already holds in the start state is no evidence of what a run did:
`vacuity` turns those into warnings.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import replace
from typing import Any

import numpy as np

from rapid_dsl.runtime.program import Checks, Comparison, Context, truth
from rapid_dsl.runtime.results import ClauseResult, RunWarning, format_value, plain

Locate = Callable[[BaseException], str | None]


class PhaseError(Exception):
    """A step of a run cannot go on: an argument out of range, a false requirement, a failed
    solve, an error in the program's expressions."""


class Evaluator:
    """Runs generated code; its errors become PhaseErrors that name the `.rapid` line."""

    def __init__(self, locate: Locate | None = None) -> None:
        self.locate = locate or (lambda exc: None)

    def guarded(self, function: Callable[..., Any], what: str) -> Callable[..., Any]:
        def call(*args: Any) -> Any:
            try:
                return function(*args)
            except PhaseError:
                raise
            except Exception as exc:  # generated code and the solver raise many types
                where = self.locate(exc)
                place = f" at {where}" if where else ""
                message = str(exc) or type(exc).__name__
                raise PhaseError(f"evaluating {what}{place} failed: {message}") from None
        return call

    def call(self, function: Callable[..., Any], context: Context, what: str) -> Any:
        return self.guarded(function, what)(context)

    def judge(self, checks: Checks, context: Context, what: str) -> list[ClauseResult]:
        """Every clause of `checks` on the context's frames (B=1 for the values reported)."""
        with np.errstate(all="ignore"):
            values = self.call(checks.evaluate, context, what)
        results = []
        for info, value in zip(checks.clauses, values, strict=True):
            holds = bool(np.all(truth(value)))
            if isinstance(value, Comparison):
                results.append(ClauseResult(info.text, info.origin, holds, plain(value.lhs),
                                            plain(value.rhs), info.unit))
            else:
                results.append(ClauseResult(info.text, info.origin, holds))
        return results

    def holds_per_sample(self, checks: Checks, context: Context, what: str) -> np.ndarray:
        """(B,) bool: every clause holds for that sample of the context's frames."""
        batch = context.frames.batch
        with np.errstate(all="ignore"):
            values = self.call(checks.evaluate, context, what)
        holds = np.ones(batch, dtype=bool)
        for value in values:
            clause = np.broadcast_to(truth(value), (batch, context.frames.steps))
            holds &= clause.all(axis=1)
        return holds


def clause_failure(block: str, clause: ClauseResult) -> str:
    """`success clause `gap < 2cm` (flip.rapid:20) is false: 3.1cm vs 2cm`."""
    if clause.value is None:
        return f"{block} clause `{clause.text}` ({clause.origin}) is false"
    return (f"{block} clause `{clause.text}` ({clause.origin}) is false: "
            f"{format_value(clause.value, clause.unit)} vs "
            f"{format_value(clause.bound, clause.unit)}")


def filter_rejection(where: str, clause: ClauseResult) -> str:
    """Why a start state is rejected: the first false filter clause, with its value."""
    value = "" if clause.value is None else \
        f": {format_value(clause.value, clause.unit)} vs {format_value(clause.bound, clause.unit)}"
    return f"rejected by the filter of {where}: `{clause.text}` ({clause.origin}) is false{value}"


def with_start(clauses: list[ClauseResult], start: list[ClauseResult]) -> list[ClauseResult]:
    """The clauses judged at the end, each marked with its truth in the start state."""
    return [replace(c, at_start=s.holds) for c, s in zip(clauses, start, strict=True)]


def vacuity(start: list[ClauseResult], *, phase: str | None, where: str,
            each: bool) -> list[RunWarning]:
    """Warnings for success clauses that hold in the start state, judged there.

    When the whole block holds, every clause is named: it is met without moving anything. With
    `each` (the entry's own success block), so is every comparison that holds: a stated amount
    (`bottom(box) - top(table) > 5cm`) already met says nothing about the motion. Relations (`on`,
    `settled`, `touching`, ...) are conditions a resting start state meets by nature, and a reused
    primitive's block keeps conditions its phase starts with (flip's `gap < 2cm` after a push to
    the wall): those are marked `at_start` in the report, not warned about.
    """
    if not start:
        return []
    whole = all(c.holds for c in start)
    warnings = []
    for clause in start:
        if not clause.holds or not (whole or (each and clause.value is not None)):
            continue
        values = "" if clause.value is None else (f" ({format_value(clause.value, clause.unit)} "
                                                  f"vs {format_value(clause.bound, clause.unit)})")
        owner = f"phase `{phase}`: " if phase else ""
        if whole:
            message = (f"{owner}the success block already holds in {where}: `{clause.text}`"
                       f"{values} is met before anything moves")
        else:
            message = (f"{owner}success clause `{clause.text}` already holds in {where}{values}: "
                       "it is no evidence of what the motion did")
        warnings.append(RunWarning(clause.origin, message, phase))
    return warnings
