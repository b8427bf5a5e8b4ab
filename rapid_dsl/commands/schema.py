"""`rapidc schema`: print the JSON Schema of the YAML form."""

from __future__ import annotations

import argparse
import json
from typing import Any


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "schema", help="print the JSON Schema of the YAML form",
        description="Print the JSON Schema (draft 2020-12) of YAML programs, for editors and "
                    "tools that emit programs: rapidc schema > rapid.schema.json")
    parser.add_argument("--report", action="store_true",
                        help="print the schema of `rapidc verify --report` files instead")
    return parser


def run(args: argparse.Namespace) -> int:
    if args.report:
        from rapid_dsl.runtime.verification.report import schema

        print(json.dumps(schema(), indent=2))
        return 0
    from rapid_dsl.frontend.yaml import json_schema

    print(json.dumps(json_schema(), indent=2))
    return 0
