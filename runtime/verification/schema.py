"""The verify report's format (docs/verify.md): the one definition of what `rapidc verify
--report` writes and what `--resume` and `rapidc report` read back.

The JSON Schema shipped beside this module (report.schema.json, printed by `rapidc schema
--report`) is generated from these models (a test keeps the two equal). Reading validates with
them strictly (no coercion, no unknown field, finite numbers), so a hand-edited or truncated
report or journal is refused with the JSON path of each problem (rapid_dsl/language/safe_json.py),
never half-used.
"""

from __future__ import annotations

from typing import Annotated, Any, Literal

from pydantic import BaseModel, ConfigDict, Field

from rapid_dsl.runtime.verification.job import REPORT_FORMAT

Number = Annotated[float, Field(allow_inf_nan=False)]
Count = Annotated[int, Field(ge=0)]
Value = Number | list[Number] | None
Outcome = Literal["succeeded", "failed", "rejected", "error"]
Stage = Literal["binding", "screening", "requires", "success", "phase", "error"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, frozen=True)


class Clause(_Strict):
    """One requires, success or filter clause as judged."""

    text: str
    origin: str = Field(description="FILE:LINE, as the runtime reports it")
    holds: bool
    value: Value = Field(description="left side of a comparison, SI")
    bound: Value = Field(description="right side of a comparison, SI")
    unit: str = Field(description="SI unit of value and bound; empty for a relation")
    at_start: bool | None = Field(description="a success clause's truth in the start state")
    location: str | None = Field(description="FILE:LINE:COLUMN of the clause in its source")


class Attempt(_Strict):
    number: Annotated[int, Field(ge=1)]
    status: Literal["succeeded", "failed"]
    failure: str | None
    moved: bool = Field(description="whether it executed a motion (an attempt that failed "
                                    "before moving ends the retries)")
    planned_cost: Number | None
    executed_cost: Number | None


class Phase(_Strict):
    name: str
    primitive: str
    origin: str
    binding: dict[str, str]
    on_fail: Literal["stop", "continue"]
    status: Literal["succeeded", "failed", "not run"]
    failure: str | None
    arguments: dict[str, Value]
    units: dict[str, str]
    planned_cost: Number | None = Field(
        description="the executed motion's cost at the planning timestep")
    executed_cost: Number | None = Field(description="its cost as executed at the world's "
                                                     "timestep")
    planned_success: bool | None
    samples: Count
    iterations: Count
    rollouts: Count
    unstable_rollouts: Count
    best_cost_per_iteration: list[Number | None] = Field(
        default=[], description="CEM: the best cost found by each iteration (null: not finite)")
    mean_cost_per_iteration: list[Number | None] = Field(
        default=[], description="CEM: the mean of the samples' finite costs at each iteration "
                                "(null: none was finite)")
    requires: list[Clause]
    success: list[Clause]
    retry: Count = Field(default=0, description="how many more times the phase is tried when it "
                                                "fails (`retry N`); absent in reports written "
                                                "before retries")
    attempts: list[Attempt] = Field(
        default=[], description="every attempt of the phase, in order (one unless it was "
                                "retried; none if it did not run); the phase's other fields are "
                                "the last attempt's")


class Failure(_Strict):
    """Where a run failed first: the phase a strategy stopped at and its first false clause, the
    strategy's false success clause (phase null), or a run that could not start."""

    stage: Stage
    phase: str | None
    primitive: str | None
    clause: Clause | None
    location: str | None
    message: str | None


class Rejection(_Strict):
    """The first false filter clause of a rejected start state."""

    where: str | None
    phase: str | None
    primitive: str | None
    clause: Clause | None
    location: str | None
    message: str | None


class Parameters(BaseModel):
    """The variant's draw (runtime/variants/sampler.py Variant.describe)."""

    model_config = ConfigDict(extra="allow", strict=True, frozen=True)
    index: Count
    seed: Count
    attempts: Annotated[int, Field(ge=1)]
    objects: list[dict[str, Any]]
    distractors: list[dict[str, Any]]


class Filter(_Strict):
    where: str
    clauses: list[Clause]


class RunWarning(_Strict):
    origin: str
    message: str
    phase: str | None = None


class Execution(_Strict):
    """How the job ran: not part of its result."""

    attempts: Annotated[int, Field(ge=1)]
    seconds: Number
    cpu_seconds: Number = Field(description="CPU time of the process that ran it, its rollout "
                                            "threads included")


Poses = dict[str, dict[str, list[Number]]]


class Record(_Strict):
    """One run: the scene's (variant null) or a variant's."""

    variant: Count | None = Field(description="variant index; null: the scene itself")
    seed: Count | None
    parameters: Parameters | None
    outcome: Outcome
    cem_seed: int | None
    binding: dict[str, str]
    binding_note: str | None
    failure: str | None
    first_failure: Failure | None
    rejection: Rejection | None
    filters: list[Filter]
    phases: list[Phase]
    success: list[Clause]
    warnings: list[RunWarning]
    final_poses: Poses
    media: str | None = Field(description="PNG strip of key frames (--media)")
    media_error: str | None = None
    execution: Execution


class Run(_Strict):
    seed: int | None
    samples: int | None
    iterations: int | None
    planning_dt: Number | None = None
    execute_elites: Count | None = None


class Settings(_Strict):
    entry: str
    run: Run
    pins: dict[str, str]
    hints: dict[str, str]
    best: bool
    arguments: dict[str, Value]
    media: str | None


class Fingerprint(_Strict):
    """Digests of what a resumed run must share with the run it continues."""

    program: str
    scene: str
    ranges: str
    seed: str
    settings: str


class Header(_Strict):
    """What a report starts with, and a journal's first line."""

    format: Literal[REPORT_FORMAT]
    rapidc: str
    program: str
    entry: str
    kind: Literal["strategy", "primitive"]
    scene: str
    ranges: str | None
    seed: Count
    variants: Annotated[int, Field(ge=1)]
    settings: Settings
    fingerprint: Fingerprint


class Group(_Strict):
    """Runs that were rejected by the same filter clause, or failed first at the same clause."""

    stage: Stage | None = None
    where: str | None = None
    phase: str | None
    primitive: str | None
    clause: str | None
    location: str | None
    example: str | None = None
    count: Annotated[int, Field(ge=1)]
    variants: list[int | None]


class Summary(_Strict):
    runs: Count
    succeeded: Count
    failed: Count
    rejected: Count
    error: Count
    success_rate: Annotated[float, Field(ge=0, le=1)] | None = Field(
        description="succeeded / runs not rejected; null when every run was rejected")
    scene: Outcome | None
    rejections: list[Group]
    failures: list[Group]


class Report(Header):
    complete: bool = Field(description="false: interrupted; --resume continues it")
    summary: Summary
    results: list[Record]
    seconds: Number


def generated_schema() -> dict[str, Any]:
    """The JSON Schema of the report (what report.schema.json holds)."""
    generated = {k: v for k, v in Report.model_json_schema().items()
                 if k not in ("title", "description")}
    return {"$schema": "https://json-schema.org/draft/2020-12/schema",
            "title": "rapidc verify report",
            "description": "What `rapidc verify --report` writes (docs/verify.md).", **generated}
