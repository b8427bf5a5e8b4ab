"""`rapidc bind PROGRAM --scene SCENE`: the ranked bindings of a program's roles in a scene.

Lists Bind_E(roles, requires) best first (runtime/ranking.py, docs/binding.md), says how many
there are and how many are shown, whether the best is unambiguous, and why each entity a user would
expect for a role was rejected. `rapidc run` uses `choose` and `candidate_lines` from here to
refuse an ambiguous binding (or take the top one with --best).
Exit status: 0 one best binding (the only one, or ranked strictly above the next), 1 no binding or
an ambiguous one, 2 bad input (program or scene errors, a bad --bind or --hint), 3 internal error.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import TYPE_CHECKING, Any

from rapid_dsl.api.compilation import choose_entry
from rapid_dsl.commands.building import check_program, read_scene
from rapid_dsl.commands.common import add_input_options, fail_usage, positive_int

if TYPE_CHECKING:
    from rapid_dsl.runtime.program import Program
    from rapid_dsl.runtime.ranking import Ranking
    from rapid_dsl.runtime.scenes.world import World
    from rapid_dsl.runtime.session import AmbiguousBinding

DEFAULT_LIMIT = 10   # bindings listed unless --limit says otherwise (run's refusal too)
CHOICES = "pin roles with --bind role=entity, match names and labels with --hint role=text"
HINT_HELP = "words to match against entity names and labels for a role (repeatable)"


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "bind", help="list the ranked bindings of a program's roles in a scene",
        description="Check PROGRAM, and list the bindings of its entry's roles in SCENE that "
                    "satisfy its requires, ranked by how well entity names and labels match the "
                    "role names and hints; say why expected entities were rejected. Exit status: "
                    "0 one best binding, 1 none or ambiguous, 2 bad input, 3 internal error.",
        epilog="--format json prints one JSON object (docs/binding.md).")
    parser.add_argument("program", metavar="PROGRAM", help="a .rapid file (or the YAML form)")
    parser.add_argument("--scene", required=True, metavar="SCENE", help="scene YAML file")
    parser.add_argument("--entry", metavar="NAME",
                        help="the primitive or strategy whose roles to bind (default: as `run`)")
    parser.add_argument("--bind", action="append", default=[], metavar="ROLE=ENTITY",
                        help="pin a role to a scene entity (repeatable)")
    parser.add_argument("--hint", action="append", default=[], metavar="ROLE=TEXT",
                        help=HINT_HELP)
    parser.add_argument("--limit", type=positive_int, default=DEFAULT_LIMIT, metavar="N",
                        help=f"list at most N bindings (default {DEFAULT_LIMIT})")
    add_input_options(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    checked = check_program(args.program, args)
    if isinstance(checked, int):
        return 2   # program errors are bad input here, as for `run`
    from rapid_dsl.commands.arguments import split_pairs

    try:
        entry = choose_entry(checked.program, args.entry)
        pins = split_pairs(args.bind, "--bind")
        hints = split_pairs(args.hint, "--hint")
    except ValueError as exc:
        return fail_usage(str(exc))

    from rapid_dsl.api.compilation import compile_checked
    from rapid_dsl.runtime.binding import BindingError
    from rapid_dsl.runtime.entry_ranking import RequirementError, rank_entry
    from rapid_dsl.runtime.loader import LoadError
    from rapid_dsl.runtime.session import Session

    try:
        session = Session(compile_checked(checked.program, args.program, entry))
    except LoadError as exc:    # the loader refused the generated module; nothing of it ran
        return fail_usage(str(exc))
    scene = read_scene(args)
    if isinstance(scene, int):
        return scene
    world = session.world(scene)
    try:
        ranking = rank_entry(session.program, world, entry, pins=pins, hints=hints)
    except BindingError as exc:
        return fail_usage(str(exc))
    except RequirementError as exc:
        print(f"rapidc: {exc}", file=sys.stderr)
        return 1
    if args.format == "json":
        report = {"program": args.program, "entry": entry, "scene": args.scene,
                  **ranking.to_json(args.limit)}
        print(json.dumps(report, indent=2))
    else:
        _print_human(ranking, f"{entry} on {args.scene}", args.limit)
    return 0 if ranking.best is not None else 1


def _print_human(ranking: Ranking, what: str, limit: int) -> None:
    shown = min(limit, len(ranking.candidates))
    print(f"{what}: {ranking.count}" + (f", showing {shown}" if ranking.candidates else ""))
    for line in candidate_lines(ranking, limit):
        print(line)
    print(verdict(ranking))
    if ranking.rejections:
        print("rejected:")
        for rejection in ranking.rejections:
            print(f"  {rejection.text}")


def candidate_lines(ranking: Ranking, limit: int) -> list[str]:
    """`  1. box=box, table=table  (score 2, 0 alternatives)`, best first, at most `limit`."""
    return [f"  {i}. {_binding_text(c.binding)}  (score {c.score:g}, "
            f"{_plural(c.alternatives, 'alternative')})"
            for i, c in enumerate(ranking.candidates[:limit], start=1)]


def verdict(ranking: Ranking) -> str:
    """One line: which binding is best and why, or why there is none."""
    status = ranking.status()
    if status == "none":
        return ranking.reason or "no binding"
    if status == "unique":
        return "unique: the only binding"
    top, second = ranking.candidates[0], ranking.candidates[1]
    if status == "best":
        return f"best: the top-ranked binding scores {top.score:g}, the next {second.score:g}"
    return (f"ambiguous: {_ties(ranking)} bindings tie at score {top.score:g}; {CHOICES}, or "
            "take the top-ranked one with `rapidc run --best`")


def _ties(ranking: Ranking) -> int:
    from rapid_dsl.runtime.session import ties

    return ties(ranking)


def choose(program: Program, world: World, entry: str, pins: dict[str, str],
           hints: dict[str, str], *, best: bool) -> tuple[dict[str, str], str | None] | int:
    """For `rapidc run`: the pins that select the binding to run, and a note on how it was chosen
    (runtime/session.py `choose_binding`). An ambiguous binding without `best` is refused
    (printed with its candidates, returns 2); bad pins or hints are a usage error (2)."""
    from rapid_dsl.runtime.binding import BindingError
    from rapid_dsl.runtime.session import AmbiguousBinding, choose_binding

    try:
        choice = choose_binding(program, world, entry, pins, hints, best=best)
    except BindingError as exc:
        return fail_usage(str(exc))
    except AmbiguousBinding as exc:
        refuse_ambiguous(exc)
        return 2
    return choice.pins, choice.note


def refuse_ambiguous(exc: AmbiguousBinding) -> None:
    """Print why an ambiguous binding is refused, with the candidates, on stderr."""
    shown = min(DEFAULT_LIMIT, len(exc.ranking.candidates))
    fail_usage(f"{exc} ({exc.ranking.count} in all, showing {shown}, best first):")
    print("\n".join(candidate_lines(exc.ranking, DEFAULT_LIMIT)), file=sys.stderr)
    print(f"  = help: {CHOICES}, or take the top-ranked one with --best", file=sys.stderr)


def _binding_text(binding: dict[str, str]) -> str:
    return ", ".join(f"{role}={entity}" for role, entity in binding.items())


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"
