"""One verified run as a report record, and the summary of many (docs/verify.md, the schema
runtime/verification/report.schema.json).

A record is the run's outcome, its binding, per phase the arguments, the planned and executed
cost and every clause's value against its bound, and the first failing clause with its source
span: what a coding agent needs to revise the program. It holds no timings (they go to the
record's `execution`, written by the command), so a record is the same whichever worker ran it.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Iterable, Mapping
from typing import Any

from rapid_dsl.runtime.results import RunResult

Record = dict[str, Any]
Spans = Mapping[str, Mapping[str, Any]]

_PHASE_FIELDS = ("name", "primitive", "origin", "binding", "on_fail", "status", "failure",
                 "arguments", "units", "planned_cost", "executed_cost", "planned_success",
                 "samples", "iterations", "rollouts", "unstable_rollouts",
                 "best_cost_per_iteration", "mean_cost_per_iteration")
_ATTEMPT_FIELDS = ("number", "status", "failure", "moved", "planned_cost", "executed_cost")
_COST_CURVES = ("best_cost_per_iteration", "mean_cost_per_iteration")


def location_key(origin: str, text: str) -> str:
    """How a run-time clause (its `FILE:LINE` origin and its text) finds its source span."""
    return f"{origin}\n{text}"


def run_record(result: RunResult, spans: Spans, *, primitives: Mapping[str, str] | None = None,
               media: str | None = None, media_error: str | None = None) -> Record:
    """The record of one run (outcome, binding, filters, phases, success, first failure);
    `primitives`: a strategy's phase -> primitive, to name the one whose filter rejects."""
    data = result.to_json()
    phases = []
    for phase in data["phases"]:
        entry = {key: phase[key] for key in _PHASE_FIELDS}
        for key in _COST_CURVES:   # an iteration whose rollouts all diverged costs inf: not JSON
            entry[key] = [c if math.isfinite(c) else None for c in entry[key]]
        entry["requires"] = [_clause(c, spans) for c in phase["requires"]]
        entry["success"] = [_clause(c, spans) for c in phase["success"]]
        entry["retry"] = phase["retry"]
        entry["attempts"] = [{key: a[key] for key in _ATTEMPT_FIELDS} for a in phase["attempts"]]
        phases.append(entry)
    record: Record = {
        "outcome": data["outcome"],
        "cem_seed": data["seed"],
        "binding": data["binding"],
        "binding_note": data["binding_note"],
        "failure": data["failure"],
        "first_failure": None,
        "rejection": None,
        "filters": [{"where": where, "clauses": [_clause(c, spans) for c in clauses]}
                    for where, clauses in data["filters"].items()],
        "phases": phases,
        "success": [_clause(c, spans) for c in data["success"]],
        "warnings": data["warnings"],
        "final_poses": data["final_poses"],
        "media": media,
    }
    if media_error:
        record["media_error"] = media_error
    if result.rejected:
        record["rejection"] = _rejection(record, result, primitives or {})
    elif not result.succeeded:
        record["first_failure"] = _first_failure(record, result)
    return record


def failed_record(stage: str, message: str) -> Record:
    """A run that did not get to execute: an ambiguous binding, or a job lost twice."""
    return {"outcome": "error" if stage == "error" else "failed", "cem_seed": None,
            "binding": {}, "binding_note": None, "failure": message,
            "first_failure": _failure(stage, None, None, message), "rejection": None,
            "filters": [], "phases": [], "success": [], "warnings": [], "final_poses": {},
            "media": None}


def _clause(clause: Mapping[str, Any], spans: Spans) -> Record:
    span = spans.get(location_key(clause["origin"], clause["text"]))
    return {**clause, "location": _location(span)}


def _location(span: Mapping[str, Any] | None) -> str | None:
    return None if span is None else f"{span['file']}:{span['line']}:{span['col']}"


def _rejection(record: Record, result: RunResult, primitives: Mapping[str, str]) -> Record:
    """The first false filter clause (screening judges them in this order)."""
    for block in record["filters"]:
        clause = next((c for c in block["clauses"] if not c["holds"]), None)
        if clause is not None:
            phase = None if block["where"] == result.entry else block["where"]
            return {"where": block["where"], "phase": phase,
                    "primitive": primitives.get(phase) if phase else None,
                    "clause": clause, "location": clause["location"],
                    "message": result.failure}
    return {"where": None, "phase": None, "primitive": None, "clause": None, "location": None,
            "message": result.failure}


def _first_failure(record: Record, result: RunResult) -> Record:
    """Where the run failed first, as the executor decides its outcome (runtime/executor.py):
    the phase a strategy stopped at, else the false success clause, else a failed phase."""
    phases = record["phases"]
    stopped = next((p for p in phases if p["status"] == "failed" and p["on_fail"] == "stop"),
                   None)
    if stopped is not None:
        return _phase_failure(stopped)
    false = next((c for c in record["success"] if not c["holds"]), None)
    if false is not None and result.kind == "strategy":
        return _failure("success", None, false, result.failure)
    failed = next((p for p in phases if p["status"] == "failed"), None)
    if failed is not None:
        return _phase_failure(failed)
    stage = "binding" if not record["binding"] else "screening"
    return _failure(stage, None, None, result.failure)


def _phase_failure(phase: Record) -> Record:
    for stage in ("requires", "success"):
        clause = next((c for c in phase[stage] if not c["holds"]), None)
        if clause is not None:
            return _failure(stage, phase, clause, phase["failure"])
    return _failure("phase", phase, None, phase["failure"])


def _failure(stage: str, phase: Record | None, clause: Record | None,
             message: str | None) -> Record:
    return {"stage": stage, "phase": phase["name"] if phase else None,
            "primitive": phase["primitive"] if phase else None, "clause": clause,
            "location": clause["location"] if clause else None, "message": message}


# ------------------------------------------------------------------------------ summary

def summarize(records: Iterable[Record]) -> Record:
    """Counts, the success rate of what ran, rejections by filter clause and failures by phase
    and first failing clause (most frequent first)."""
    counts = {"succeeded": 0, "failed": 0, "rejected": 0, "error": 0}
    rejections: dict[tuple[Any, ...], Record] = {}
    failures: dict[tuple[Any, ...], Record] = {}
    key: tuple[Any, ...]
    variants: dict[tuple[Any, ...], list[int | None]] = defaultdict(list)
    scene: str | None = None
    total = 0
    for record in records:
        total += 1
        counts[record["outcome"]] += 1
        if record["variant"] is None:
            scene = record["outcome"]
        if record["rejection"] is not None:
            r = record["rejection"]
            key = ("rejection", r["where"], _clause_key(r["clause"]))
            rejections.setdefault(key, {"where": r["where"], "phase": r["phase"],
                                        "primitive": r["primitive"],
                                        "clause": _brief(r["clause"]),
                                        "location": r["location"]})
            variants[key].append(record["variant"])
        elif record["first_failure"] is not None:
            f = record["first_failure"]
            key = ("failure", f["stage"], f["phase"], _clause_key(f["clause"]))
            failures.setdefault(key, {"stage": f["stage"], "phase": f["phase"],
                                      "primitive": f["primitive"], "clause": _brief(f["clause"]),
                                      "location": f["location"], "example": f["message"]})
            variants[key].append(record["variant"])
    ran = counts["succeeded"] + counts["failed"] + counts["error"]
    return {
        "runs": total, **counts,
        "success_rate": counts["succeeded"] / ran if ran else None,
        "scene": scene,
        "rejections": _grouped(rejections, variants),
        "failures": _grouped(failures, variants),
    }


def _clause_key(clause: Record | None) -> tuple[Any, ...]:
    return (None,) if clause is None else (clause["origin"], clause["text"])


def _brief(clause: Record | None) -> str | None:
    return None if clause is None else clause["text"]


def _grouped(groups: dict[tuple[Any, ...], Record],
             variants: Mapping[tuple[Any, ...], list[int | None]]) -> list[Record]:
    rows = [{**row, "count": len(variants[key]), "variants": variants[key]}
            for key, row in groups.items()]
    return sorted(rows, key=lambda row: -row["count"])
