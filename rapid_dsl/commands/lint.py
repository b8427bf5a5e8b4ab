"""`rapidc lint PATH...`: `check` plus lint warnings (W codes)."""

from __future__ import annotations

import argparse
from typing import Any

from rapid_dsl.commands.common import add_input_options, check_paths


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "lint", help="check, then warn about likely mistakes",
        description="Check programs and add lint warnings (unused roles and params, run-time "
                    "requirements, ...). Warnings fail only with --strict.")
    parser.add_argument("paths", nargs="+", metavar="PATH", help="files or folders")
    add_input_options(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    return check_paths(args, lint=True)
