"""What every verification job shares: the compiled program and the run's settings.

A job is a pure function of this, one scene (the scene itself or one variant) and its index, so
its result is the same whichever process or cluster worker computes it. This module is light
(standard library only): worker processes unpickle it before they choose their GL back end.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any, Protocol

from rapid_dsl.runtime.compiled import CompiledProgram

if TYPE_CHECKING:
    from rapid_dsl.runtime.verification.runner import Runner

REPORT_FORMAT = "rapidc-verify/1"


class JobRunner(Protocol):
    def run(self, index: Any, payload: Any) -> tuple[dict[str, Any], dict[str, float]]: ...


class Job(Protocol):
    """What the backends (runtime/verification/backends.py) run: `verify`'s jobs and the benchmark's
    (rapid_dsl/bench/nonprehensile/job.py). A worker makes the runner once per `digest()` and hands
    it each job's (index, payload); `media` is a folder to render into, or None (no GL)."""

    @property
    def media(self) -> str | None: ...
    def digest(self) -> str: ...
    def runner(self, threads: int) -> JobRunner: ...


@dataclass(frozen=True, slots=True)
class VerifyJob:
    program: CompiledProgram
    run: dict[str, Any]                     # RunConfig fields: seed, samples, iterations, ...
    pins: dict[str, str] = field(default_factory=dict)
    hints: dict[str, str] = field(default_factory=dict)
    best: bool = False
    arguments: dict[str, Any] = field(default_factory=dict)   # a primitive entry's, SI
    locations: dict[str, dict[str, Any]] = field(default_factory=dict)  # location_key -> span
    media: str | None = None                # folder for one key-frame strip per variant

    def settings(self) -> dict[str, Any]:
        """The settings a report records (and a resumed run must share)."""
        return {"entry": self.program.entry, "run": self.run, "pins": self.pins,
                "hints": self.hints, "best": self.best, "arguments": self.arguments,
                "media": self.media}

    def digest(self) -> str:
        """Identifies the program and settings (workers cache their loaded program by it)."""
        return digest({"program": self.program.source, **self.settings()})

    def runner(self, threads: int) -> Runner:
        from rapid_dsl.runtime.verification.runner import Runner

        return Runner(self, threads)


def digest(data: Any) -> str:
    """sha256 of `data` as canonical JSON."""
    text = json.dumps(data, sort_keys=True, separators=(",", ":"), default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()

