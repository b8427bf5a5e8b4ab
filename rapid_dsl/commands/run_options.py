"""The options `rapidc run` and `rapidc verify` share, and what they mean for a checked program:
the entry, pinned roles, hints, a primitive entry's arguments and the CEM budgets.
"""

from __future__ import annotations

import argparse
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from rapid_dsl.commands.bind import HINT_HELP
from rapid_dsl.commands.common import positive_int, seed_int
from rapid_dsl.frontend import ir
from rapid_dsl.language.limits import MAX_ITERATIONS, MAX_SAMPLES


def add_run_options(parser: argparse.ArgumentParser) -> None:
    """--entry, --bind, --hint, --best, --arg, --samples, --iterations, --planning-dt and
    --execute-elites (each command adds its own --seed)."""
    parser.add_argument("--entry", metavar="NAME",
                        help="the primitive or strategy to run (default: the file's one "
                             "strategy, else its one primitive)")
    parser.add_argument("--bind", action="append", default=[], metavar="ROLE=ENTITY",
                        help="pin a role to a scene entity (repeatable)")
    parser.add_argument("--hint", action="append", default=[], metavar="ROLE=TEXT",
                        help=HINT_HELP)
    parser.add_argument("--best", action="store_true",
                        help="when the binding is ambiguous, take the top-ranked one (and say so)")
    parser.add_argument("--arg", action="append", default=[], metavar="PARAM=VALUE",
                        help="a primitive entry's param value, with units (repeatable)")
    parser.add_argument("--samples", type=budget(MAX_SAMPLES), metavar="N",
                        help="CEM samples per iteration for every phase (overrides the program; "
                             f"at most {MAX_SAMPLES})")
    parser.add_argument("--iterations", type=budget(MAX_ITERATIONS), metavar="N",
                        help="CEM iterations for every phase (overrides the program; at most "
                             f"{MAX_ITERATIONS})")
    parser.add_argument("--planning-dt", type=seconds, metavar="SECONDS",
                        help="timestep of the CEM's rollouts (default 0.004; it must divide the "
                             "0.02 s control period); motions are executed and judged at the "
                             "world's 0.002 s whatever it is")
    parser.add_argument("--execute-elites", type=seed_int, metavar="N",
                        help="run the N best final CEM samples at the world's timestep and "
                             "execute the best of them (default 0: every final elite; 1: the "
                             "CEM's best only)")


def budget(maximum: int) -> Callable[[str], int]:
    """argparse type: a positive integer of at most `maximum` (language/limits.py, the same
    maxima the checker enforces in programs)."""
    def parse(text: str) -> int:
        value = positive_int(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(f"must be at most {maximum}")
        return value
    return parse


def seconds(text: str) -> float:
    """argparse type: a positive, finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"`{text}` is not a number of seconds") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError("must be a positive number of seconds")
    return value


@dataclass(frozen=True, slots=True)
class RunInputs:
    entry: str
    pins: dict[str, str]
    hints: dict[str, str]
    arguments: dict[str, object]     # a primitive entry's --arg values, SI


def run_inputs(program: ir.Program, args: argparse.Namespace) -> RunInputs:
    """The entry and the --bind/--hint/--arg values. Raises ValueError (a usage error)."""
    from rapid_dsl.api.compilation import choose_entry
    from rapid_dsl.commands.arguments import ArgumentProblem, parse_arguments, split_pairs

    entry = choose_entry(program, args.entry)
    pins = split_pairs(args.bind, "--bind")
    hints = split_pairs(args.hint, "--hint")
    decl_is_primitive = entry in {p.name for p in program.primitives}
    if args.arg and not decl_is_primitive:
        raise ArgumentProblem(f"`{entry}` is a strategy: it takes no --arg (its phases "
                              "compute their own arguments)")
    arguments = parse_arguments(args.arg, program.primitive(entry)) if decl_is_primitive else {}
    return RunInputs(entry, pins, hints, arguments)


def design(args: argparse.Namespace) -> dict[str, Any]:
    """The executor design options given (RunConfig fields): planning_dt, execute_elites."""
    return {key: value for key, value in (("planning_dt", args.planning_dt),
                                         ("execute_elites", args.execute_elites))
            if value is not None}
