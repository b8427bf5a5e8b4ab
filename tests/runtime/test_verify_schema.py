"""The verify report's format has one definition, the models of runtime/verification/schema.py: the
JSON Schema `rapidc schema --report` prints is generated from them."""

from __future__ import annotations

import json

from rapid_dsl.runtime.verification.report import SCHEMA, schema
from rapid_dsl.runtime.verification.schema import generated_schema


def test_the_shipped_schema_is_the_models_schema() -> None:
    assert json.loads(SCHEMA.read_text(encoding="utf-8")) == generated_schema() == schema(), (
        "runtime/verification/report.schema.json is stale: write generated_schema() to it")
