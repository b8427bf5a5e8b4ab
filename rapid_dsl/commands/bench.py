"""`rapidc bench TARGET`: performance numbers. Targets: `check` (front end speed).

Each target is a function in `TARGETS`; add one with a parser line in `add_parser` and an entry.
"""

from __future__ import annotations

import argparse
from typing import Any

from rapid_dsl.commands.common import add_output_options


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser("bench", help="measure performance",
                                   description="Measure and print performance numbers.")
    targets = parser.add_subparsers(dest="target", metavar="TARGET", required=True)
    check = targets.add_parser("check", help="front-end speed: lines/s, warm check, start-up",
                               description="Check generated programs and the standard library; "
                                           "print lines/s, a warm 200-line check and the "
                                           "start-up of `rapidc check` (--format json: one "
                                           "JSON object).")
    add_output_options(check, defaults=False)
    check.add_argument("--lines", type=int, default=2000, help="size of the generated program")
    check.add_argument("--runs", type=int, default=5, help="repetitions per measurement")
    return parser


def run(args: argparse.Namespace) -> int:
    return TARGETS[args.target](args)


def bench_check(args: argparse.Namespace) -> int:
    from rapid_dsl.bench.check import main

    return main(lines=args.lines, runs=args.runs, as_json=args.format == "json")


TARGETS = {"check": bench_check}
