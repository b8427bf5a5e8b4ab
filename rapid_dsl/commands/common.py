"""What the subcommands share: output options, finding input files, printing diagnostics.

Imports only the standard library, rapid_dsl.language.diagnostics, rapid_dsl.language.sources and
rapid_dsl.language.files: every command module imports this at start-up.
"""

from __future__ import annotations

import argparse
import os
import sys
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, TextIO

from rapid_dsl.language.diagnostics import (
    Diagnostic,
    Severity,
    render_github,
    render_human,
    render_json,
)
from rapid_dsl.language.files import inside
from rapid_dsl.language.sources import SOURCE_SUFFIXES

FORMATS = ("human", "json", "github", "sarif")
SARIF_COMMANDS = ("check", "lint")     # the commands whose whole output is diagnostics


def add_output_options(parser: argparse.ArgumentParser, *, defaults: bool) -> None:
    """The options every command takes, before or after the command name.

    The top-level parser holds the defaults; a command's parser uses SUPPRESS so that its
    options override the top-level ones only when given.
    """
    def default(value: object) -> object:
        return value if defaults else argparse.SUPPRESS

    group = parser.add_argument_group("output options")
    group.add_argument("--format", choices=FORMATS, default=default("human"),
                       help="diagnostics as human text (default), a JSON array, GitHub "
                            "workflow annotations, or a SARIF 2.1.0 log (check and lint only)")
    group.add_argument("--strict", action="store_true", default=default(False),
                       help="warnings fail too (exit 1)")
    group.add_argument("--color", choices=("auto", "always", "never"), default=default("auto"),
                       help="colour human output (auto: only on a terminal and if NO_COLOR is "
                            "unset)")
    group.add_argument("-q", "--quiet", action="store_true", default=default(False),
                       help="print diagnostics only: no summary or progress lines")


def format_problem(args: argparse.Namespace) -> str | None:
    """Why the chosen --format does not fit the command, or None. A SARIF log holds diagnostics
    with their rules; `fmt --check`'s "would reformat" lines and the other commands' tables and
    reports are not diagnostics, so only check and lint write one."""
    if args.format == "sarif" and args.command not in SARIF_COMMANDS:
        return (f"--format sarif is for `rapidc check` and `rapidc lint`, not `rapidc "
                f"{args.command}`")
    return None


def add_input_options(parser: argparse.ArgumentParser) -> None:
    """The options of commands that read programs."""
    parser.add_argument(
        "--allow-path", action="append", default=[], type=folder, metavar="DIR",
        dest="allowed_dirs",
        help="also allow files in DIR and below it: `use` paths and scene meshes outside the "
             "program's (scene's) folder, and symlinks out of a folder given as PATH "
             "(repeatable)")


def folder(text: str) -> str:
    """argparse type: an existing folder."""
    if not os.path.isdir(text):
        raise argparse.ArgumentTypeError(f"`{text}` is not a folder")
    return text


def positive_int(text: str) -> int:
    """argparse type: an integer of at least 1."""
    return _int_at_least(text, 1)


def path_argument(text: str) -> str:
    """argparse type: a path that names something (an empty one would mean the current folder
    without saying so)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; name a folder, e.g. `.`")
    return text


def seed_int(text: str) -> int:
    """argparse type: a random seed, an integer of at least 0."""
    return _int_at_least(text, 0)


def _int_at_least(text: str, least: int) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"`{text}` is not an integer") from None
    if value < least:
        raise argparse.ArgumentTypeError(f"must be at least {least}")
    return value


def wants_color(choice: str, stream: TextIO) -> bool:
    if choice != "auto":
        return choice == "always"
    if os.environ.get("NO_COLOR"):
        return False
    isatty = getattr(stream, "isatty", None)
    return bool(isatty and isatty())


def fail_usage(message: str) -> int:
    # Messages quote file names found in folders and text from the command line: no terminal
    # control sequences get through.
    print(f"rapidc: error: {shown(message, None)}", file=sys.stderr)
    return 2


def shown(text: str, limit: int | None = 60) -> str:
    """`text` safe to print: control and format characters escaped, at most `limit` characters."""
    safe = "".join(c if c.isprintable() else c.encode("unicode_escape").decode("ascii")
                   for c in text)
    return safe if limit is None or len(safe) <= limit else safe[: limit - 3] + "..."


def is_yaml(path: str) -> bool:
    return path.endswith((".yaml", ".yml"))


# ---------------------------------------------------------------------------------- inputs

def expand_paths(paths: Sequence[str], suffixes: tuple[str, ...] = SOURCE_SUFFIXES,
                 allowed_dirs: Sequence[str] = ()) -> tuple[list[str], list[str]]:
    """Files to process, and problems (a path that does not exist, a found file that links out).

    A folder stands for the files below it whose names end in one of `suffixes` (hidden folders
    such as .git are skipped), each of which must lie in that folder or in one of `allowed_dirs`
    once symlinks are resolved: a folder's content may be untrusted, the command line is not. A
    file named explicitly is taken whatever its extension.
    """
    files: list[str] = []
    problems: list[str] = []
    for given in paths:
        path = Path(given)
        if path.is_dir():
            found = []
            for top, subfolders, names in os.walk(path):
                subfolders[:] = [d for d in subfolders if not d.startswith(".")]
                found += [os.path.join(top, n) for n in names if n.endswith(suffixes)]
            for file in sorted(found):
                if inside(file, [given, *allowed_dirs]):
                    files.append(file)
                else:
                    problems.append(f"{file}: a symbolic link to a file outside {given} (name "
                                    "the file itself, or allow its folder with --allow-path DIR)")
        elif path.exists():
            files.append(given)
        else:
            problems.append(f"no such file or folder: {given}")
    return list(dict.fromkeys(files)), problems


# -------------------------------------------------------------------------------- checking

CheckFile = Callable[..., Any]  # check_file(path, *, lint, stdlib, allowed_dirs) -> CheckResult


def load_checker() -> tuple[CheckFile, type[Exception]]:
    """`rapid_dsl.frontend.driver.check_file` and the exception it raises for unreadable input."""
    from rapid_dsl.frontend.driver import InputError, check_file

    return check_file, InputError


@dataclass
class Report:
    """Diagnostics of one run, printed in the chosen format."""

    files: int = 0
    diagnostics: list[Diagnostic] = field(default_factory=list)
    sources: dict[str, str] = field(default_factory=dict)
    problems: list[str] = field(default_factory=list)   # inputs that could not be read
    _seen: set[tuple[object, ...]] = field(default_factory=set)
    _order: dict[str, int] = field(default_factory=dict)

    def add(self, diagnostics: Iterable[Diagnostic], sources: dict[str, str] | None = None) -> None:
        # Two checked files that use the same library would report its problems twice.
        for d in diagnostics:
            key = (d.span.path, d.span.line, d.span.col, d.span.end_line, d.span.end_col, d.code,
                   d.message)
            if key not in self._seen:
                self._seen.add(key)
                self._order.setdefault(d.span.path, len(self._order))
                self.diagnostics.append(d)
        self.sources.update(sources or {})

    def count(self, severity: Severity) -> int:
        return sum(d.severity is severity for d in self.diagnostics)

    def exit_status(self, strict: bool) -> int:
        failing = self.count(Severity.ERROR) + (self.count(Severity.WARNING) if strict else 0)
        return 1 if failing else 0

    def ordered(self) -> list[Diagnostic]:
        return sorted(self.diagnostics, key=lambda d: (self._order[d.span.path], d.span.line,
                                                       d.span.col, d.code))

    def print(self, args: argparse.Namespace) -> None:
        diagnostics = self.ordered()
        if args.format == "json":
            print(render_json(diagnostics))
        elif args.format == "github":
            for d in diagnostics:
                print(render_github(d))
        elif args.format == "sarif":
            from rapid_dsl.language.sarif import render_sarif

            print(render_sarif(diagnostics, self.sources, problems=self.problems))
        else:
            color = wants_color(args.color, sys.stdout)
            blocks = [render_human(d, self.sources.get(d.span.path), color=color)
                      for d in diagnostics]
            if blocks:
                print("\n\n".join(blocks))
            if not args.quiet:
                print(self.summary(), file=sys.stderr)

    def summary(self) -> str:
        errors, warnings = self.count(Severity.ERROR), self.count(Severity.WARNING)
        return (f"{_plural(errors, 'error')}, {_plural(warnings, 'warning')} in "
                f"{_plural(self.files, 'file')}")


def _plural(n: int, word: str) -> str:
    return f"{n} {word}" if n == 1 else f"{n} {word}s"


def check_paths(args: argparse.Namespace, *, lint: bool) -> int:
    """`rapidc check` and `rapidc lint`: check every file, print, return the exit status."""
    files, problems = expand_paths(args.paths, allowed_dirs=args.allowed_dirs)
    if problems:
        for problem in problems:
            fail_usage(problem)
        return 2
    check_file, input_error = load_checker()
    report = Report()
    for path in files:
        try:
            result = check_file(path, lint=lint, allowed_dirs=args.allowed_dirs)
        except input_error as exc:
            fail_usage(str(exc))
            report.problems.append(str(exc))
            continue
        report.files += 1
        report.add(result.diagnostics, result.sources)
    if not files and not args.quiet:
        print("rapidc: no .rapid or .rapid.yaml files found", file=sys.stderr)
    report.print(args)
    return 2 if report.problems else report.exit_status(args.strict)
