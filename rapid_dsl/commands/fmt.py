"""`rapidc fmt`: print, check or rewrite programs in the canonical `.rapid` layout.

Comments and blank lines of `.rapid` files are kept (see frontend/formatter.py). A YAML program is
printed as `.rapid` text, which drops its YAML comments; `--check` and `--write` therefore take
`.rapid` files only. A file is formatted when its bytes are the canonical text (so a BOM or CRLF
line endings count as unformatted).

`--write` replaces a file atomically (language/files.py write_atomic), keeping its mode; through a
symlink it replaces the link's target, and the link stays. A file with several hard links is
refused rather than rewritten: a rename would leave the other names with the old text, and writing
in place would not be atomic.
"""

from __future__ import annotations

import argparse
import os
import sys
from typing import Any

from rapid_dsl.commands.common import (
    Report,
    add_input_options,
    expand_paths,
    fail_usage,
    is_yaml,
)
from rapid_dsl.language.diagnostics import github_command, visible
from rapid_dsl.language.files import FileProblem, decode_text, read_bytes, write_atomic
from rapid_dsl.language.sources import RAPID_SUFFIXES, SOURCE_SUFFIXES


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "fmt", help="print programs in the canonical layout",
        description="Print a .rapid or YAML program as canonical .rapid text. With --check, "
                    "exit 1 if a .rapid file is not formatted; with --write, rewrite .rapid files "
                    "in place. Comments are kept.")
    parser.add_argument("paths", nargs="+", metavar="PATH",
                        help="files or folders (folders: *.rapid files below them)")
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--check", action="store_true",
                      help="change nothing; exit 1 if some file would be reformatted")
    mode.add_argument("-w", "--write", action="store_true", help="rewrite files in place")
    add_input_options(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    in_place = args.check or args.write
    files, problems = expand_paths(args.paths, RAPID_SUFFIXES if in_place else SOURCE_SUFFIXES,
                                   args.allowed_dirs)
    for problem in problems:
        fail_usage(problem)
    if problems:
        return 2
    if in_place:
        yaml_files = [f for f in files if is_yaml(f)]
        if yaml_files:
            return fail_usage(f"--check and --write take .rapid files; {yaml_files[0]} is YAML "
                              f"(print it as .rapid with `rapidc fmt {yaml_files[0]}`)")
    elif len(files) != 1:
        return fail_usage(f"fmt prints one file, got {len(files)}; use --check or --write for "
                          "several")
    report = Report()
    contents: dict[str, bytes] = {}
    texts: dict[str, str] = {}
    for path in files:
        try:
            contents[path] = read_bytes(path)
            texts[path] = decode_text(contents[path])
        except FileProblem as exc:
            return fail_usage(f"{path}: {exc}")
    unformatted: list[str] = []
    written = 0
    for path, text in texts.items():
        report.files += 1
        formatted = _format(path, text, report)
        if formatted is None:
            continue
        if not in_place:
            sys.stdout.write(formatted)
        elif formatted.encode("utf-8") != contents[path]:
            unformatted.append(path)
            if args.write:
                try:
                    _write(path, formatted)
                except FileProblem as exc:
                    return fail_usage(f"cannot write {path}: {exc}")
                written += 1
                if not args.quiet:
                    print(f"reformatted {visible(path)}", file=sys.stderr)
    if report.diagnostics:
        report.print(args)
    if args.check:
        _print_unformatted(args, unformatted)
    if args.write and not args.quiet:
        print(f"{written} reformatted, {len(texts) - written} unchanged", file=sys.stderr)
    failed = bool(report.diagnostics and report.exit_status(strict=False))
    return 1 if failed or (args.check and unformatted) else 0


def _format(path: str, text: str, report: Report) -> str | None:
    """Canonical text, or None (and diagnostics in `report`) if the file does not parse."""
    from rapid_dsl.frontend.driver import deep_recursion, too_deep
    from rapid_dsl.frontend.formatter import format_module, format_source

    try:
        with deep_recursion():
            if is_yaml(path):
                from rapid_dsl.frontend.yaml import parse_yaml_module

                module, diagnostics = parse_yaml_module(text, path)
                result = format_module(module) if module is not None else None
            else:
                result, diagnostics = format_source(text, path)
    except RecursionError:
        result, diagnostics = None, [too_deep(path, "format")]
    if result is None:
        report.add(diagnostics, {path: text})
    return result


def _print_unformatted(args: argparse.Namespace, paths: list[str]) -> None:
    for path in paths:
        if args.format == "github":
            print(github_command("error", [("file", path), ("title", "rapidc fmt")],
                                 f"{path} is not formatted; run rapidc fmt --write {path}"))
        else:
            print(f"would reformat {visible(path)}", file=sys.stdout if args.format == "human"
                  else sys.stderr)
    if not args.quiet:
        count = len(paths)
        print(f"{count} file{'s' * (count != 1)} would be reformatted" if count
              else "all files formatted", file=sys.stderr)


def _write(path: str, text: str) -> None:
    """Replace the file (through a symlink: its target) atomically, keeping its mode."""
    try:
        info = os.stat(path)
        links, writable = info.st_nlink, bool(info.st_mode & 0o222)
    except OSError:
        links, writable = 1, True   # write_atomic says what is wrong with it
    if links > 1:
        raise FileProblem(f"it has {links} hard links, which rewriting would separate; format a "
                          f"copy, or print it with `rapidc fmt {path}`")
    if not writable:   # a rename needs only the folder's permission: honour the file's own
        raise FileProblem("it is read-only; make it writable to rewrite it")
    write_atomic(path, text, through_links=True)
