"""`rapidc explain CODE`: what a diagnostic code means."""

from __future__ import annotations

import argparse
from typing import Any

from rapid_dsl.commands.common import fail_usage


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser("explain", help="say what a diagnostic code means",
                                   description="Print the title of a diagnostic code, e.g. "
                                               "rapidc explain E0302")
    parser.add_argument("code", metavar="CODE")
    return parser


def run(args: argparse.Namespace) -> int:
    from rapid_dsl.language.codes import CODES

    code = args.code.strip().upper()
    if code not in CODES:
        return fail_usage(f"unknown diagnostic code `{args.code}`; docs/diagnostics.md lists "
                          "them all")
    print(f"{code}: {CODES[code]}")
    return 0
