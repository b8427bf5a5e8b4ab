"""`rapidc schema`: print the JSON Schema of the YAML form."""

from __future__ import annotations

import argparse
import json
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    return subparsers.add_parser(
        "schema", help="print the JSON Schema of the YAML form",
        description="Print the JSON Schema (draft 2020-12) of YAML programs, for editors and "
                    "tools that emit programs: rapidc schema > rapid.schema.json")


def run(args: argparse.Namespace) -> int:
    from rapid_dsl.yaml_form import json_schema

    print(json.dumps(json_schema(), indent=2))
    return 0
