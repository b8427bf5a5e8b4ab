"""`rapidc check PATH...`: parse and type-check programs (.rapid and YAML)."""

from __future__ import annotations

import argparse
from typing import Any

from rapid_dsl.commands.common import add_input_options, check_paths


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "check", help="parse and type-check programs",
        description="Parse and type-check programs. A folder stands for every *.rapid, "
                    "*.rapid.yaml and *.rapid.yml file below it.")
    parser.add_argument("paths", nargs="+", metavar="PATH", help="files or folders")
    add_input_options(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    return check_paths(args, lint=False)
