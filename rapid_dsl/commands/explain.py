"""`rapidc explain CODE`: what a diagnostic code means."""

from __future__ import annotations

import argparse
import importlib
import importlib.util
import sys
from typing import Any

from rapid_dsl.commands.common import fail_usage


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser("explain", help="say what a diagnostic code means",
                                   description="Print the title of a diagnostic code, e.g. "
                                               "rapidc explain E0302")
    parser.add_argument("code", metavar="CODE")
    return parser


def run(args: argparse.Namespace) -> int:
    code = args.code.strip().upper()
    table = _code_table()
    if table is None:
        print("rapidc: note: the table of checker codes is not available; only YAML-form codes "
              "are known", file=sys.stderr)
        table = {}
    from rapid_dsl.yaml_form import CODES as YAML_CODES

    title = table.get(code) or YAML_CODES.get(code)
    if not title:
        return fail_usage(f"unknown diagnostic code `{args.code}`")
    print(f"{code}: {title}")
    return 0


def _code_table() -> dict[str, str] | None:
    """`rapid_dsl.codes.CODES` (code -> title) if that module exists."""
    if importlib.util.find_spec("rapid_dsl.codes") is None:
        return None
    codes = importlib.import_module("rapid_dsl.codes")
    table = getattr(codes, "CODES", None)
    if not isinstance(table, dict):
        return None
    return {str(k): v if isinstance(v, str) else str(getattr(v, "title", v))
            for k, v in table.items()}
