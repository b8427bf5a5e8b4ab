"""What `rapidc bench nonprehensile` writes and reads back on `--resume` (docs/benchmark.md):
the header, each run's record (rapid_dsl/bench/nonprehensile/harness.py trial_record, with the run's
`execution`), and the results file that holds them by scene.

`--resume` validates every record strictly against these models (rapid_dsl/language/safe_json.py),
so a record the table could not use (a `success` that is not a boolean, no `execution`, a `key` that
is not text) is refused with its line and JSON path before any run starts, never after.
"""

from __future__ import annotations

from typing import Literal

from pydantic import BaseModel, ConfigDict, Field

from rapid_dsl.bench.nonprehensile.job import FORMAT
from rapid_dsl.runtime.verification.schema import Count, Execution, Number, Outcome, Poses


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


class BenchSettings(_Strict):
    tasks: list[str]
    scenes: Count
    trials: Count
    robot: str
    samples: int | None
    iterations: int | None
    test_seed: int


class BenchHeader(_Strict):
    format: Literal[FORMAT]
    rapidc: str
    settings: BenchSettings
    fingerprint: str


class BenchPhase(_Strict):
    name: str
    primitive: str
    status: Literal["succeeded", "failed", "not run"]
    on_fail: Literal["stop", "continue"]
    failure: str | None


class Criterion(_Strict):
    success: bool
    value: Number | None
    text: str


class BenchRecord(_Strict):
    """One run: a trial of the task's strategy (trial 0, 1, ...) or the control (trial null)."""

    key: str = Field(description="`T1/003/0`, `T1/003/control` (job.py run_key)")
    task: str
    scene: Count
    trial: Count | None
    seed: int
    scene_file: str
    binding: dict[str, str]
    binding_note: str | None
    outcome: Outcome
    strategy_failure: str | None
    phases: list[BenchPhase]
    criterion: Criterion | None
    success: bool
    reason: str | None
    final_poses: Poses
    execution: Execution


class BenchScene(BaseModel):
    """A test scene of the results file: its draw (not read back) and its runs."""

    model_config = ConfigDict(extra="allow", strict=True, frozen=True)
    trials: list[BenchRecord]
    control: BenchRecord | None


class BenchResults(BenchHeader):
    """The results file; of what follows the header, `--resume` reads only the runs."""

    model_config = ConfigDict(extra="allow")
    complete: bool
    scenes: list[BenchScene]

