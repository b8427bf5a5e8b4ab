"""What `rapidc compile` and `rapidc run` share: check a file, print its diagnostics, compile it,
and pick the declaration to run.

Diagnostics go to stderr here (stdout may carry the generated module or the result table), in the
format chosen with --format, rendered by language.diagnostics as `rapidc check` renders them.
"""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

from rapid_dsl.commands.common import fail_usage, wants_color
from rapid_dsl.frontend import ir
from rapid_dsl.language.diagnostics import (
    Diagnostic,
    Severity,
    render_github,
    render_human,
    render_json,
)

if TYPE_CHECKING:   # the scene loader imports pydantic: only the commands that read one
    from rapid_dsl.runtime.scenes.scene import Scene, SceneError


@dataclass(frozen=True, slots=True)
class Checked:
    program: ir.Program
    diagnostics: list[Diagnostic]
    inputs: list[str]           # the program's files on disk: no output may replace one


def check_program(path: str, args: argparse.Namespace) -> Checked | int:
    """Check `path` (its `use`s may also reach `--allow-path` folders); print its diagnostics.
    Returns the program, or 1 (errors) / 2 (unreadable)."""
    from rapid_dsl.frontend.driver import InputError, check_file

    try:
        result = check_file(path, allowed_dirs=args.allowed_dirs)
    except InputError as exc:
        return fail_usage(exc.message)
    print_diagnostics(result.diagnostics, result.sources, args)
    failing = [d for d in result.diagnostics
               if d.is_error or (args.strict and d.severity is Severity.WARNING)]
    if result.program is None or failing:
        return 1
    return Checked(result.program, result.diagnostics, result.inputs)


def print_diagnostics(diagnostics: Sequence[Diagnostic], sources: dict[str, str],
                      args: argparse.Namespace) -> None:
    if not diagnostics:
        return
    if args.format == "json":
        print(render_json(diagnostics), file=sys.stderr)
    elif args.format == "github":
        for d in diagnostics:
            print(render_github(d), file=sys.stderr)
    else:
        color = wants_color(args.color, sys.stderr)
        print("\n\n".join(render_human(d, sources.get(d.span.path), color=color)
                          for d in diagnostics), file=sys.stderr)


def read_scene(args: argparse.Namespace) -> Scene | int:
    """The scene file `args.scene` (mesh paths inside its folder or `--allow-path`), or exit
    status 2 with every problem printed at its file:line:column."""
    from rapid_dsl.runtime.scenes.scene import SceneError, load_scene

    try:
        return load_scene(args.scene, allowed_dirs=args.allowed_dirs)
    except SceneError as error:
        print_scene_problems(error)
        return 2


def print_scene_problems(error: SceneError) -> None:
    for problem in error.problems:
        print(problem, file=sys.stderr)
