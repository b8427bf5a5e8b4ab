"""`rapidc`: the command-line entry point.

Each subcommand is a small module in `rapid_dsl.commands` with `add_parser(subparsers)` (returns its
argparse parser) and `run(args) -> int`; add one by naming its module in `COMMANDS`. Command modules
import only what parsing their arguments needs, so `rapidc check` starts fast (no numpy, mujoco,
pydantic, jinja2 or rich on that path).

Exit status: 0 clean, 1 errors found (warnings too with `--strict`), 2 usage or I/O error,
3 internal error (a bug in rapidc; the message asks for a report and no traceback is printed unless
RAPIDC_DEBUG is set).
"""

from __future__ import annotations

import argparse
import errno
import importlib
import os
import sys
from collections.abc import Sequence

from rapid_dsl import __version__
from rapid_dsl.commands.common import add_output_options, format_problem
from rapid_dsl.runtime.gl import without_gl

COMMANDS = ("check", "lint", "fmt", "schema", "explain", "bench", "compile", "bind", "run",
            "variants", "verify", "report", "lsp", "scene", "mcp", "guide", "demo")

EXIT_OK, EXIT_ERRORS, EXIT_USAGE, EXIT_INTERNAL = 0, 1, 2, 3
# Commands that leave nothing open when they return (their files are written and closed): run as
# the `rapidc` process, they end it at once, without tearing the interpreter down (as mypy does),
# which is about a seventh of `rapidc check` on a small file. Called with an argv, main returns.
# `lsp` too: its protocol streams are closed at `exit`, and its stdin reader thread, which may still
# wait for input, must not hold the process.
_QUICK_EXIT = frozenset({"check", "lint", "fmt", "explain", "lsp"})


def build_parser(argv: Sequence[str] | None = None) -> argparse.ArgumentParser:
    """The parser of every command; with `argv` that names one, of that command only, so its
    start-up does not import the modules (and build the options) of all the others."""
    parser = argparse.ArgumentParser(
        prog="rapidc",
        description="Check, compile, run and verify RAPID robot programs (.rapid, YAML) on MuJoCo "
                    "scenes; serve them to editors and coding agents.",
        epilog="Exit status: 0 clean, 1 errors found, 2 usage or I/O error, 3 internal error.")
    parser.add_argument("--version", action="version", version=f"rapidc {__version__}")
    add_output_options(parser, defaults=True)
    subparsers = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)
    named = _named_command(argv) if argv is not None else None
    for name in (named,) if named is not None else COMMANDS:
        module = importlib.import_module(f"rapid_dsl.commands.{name}")
        sub = module.add_parser(subparsers)
        # Options may also follow the command; there they override the ones before it.
        add_output_options(sub, defaults=False)
        sub.set_defaults(run=module.run)
    return parser


def _named_command(argv: Sequence[str]) -> str | None:
    """The command `argv` names after the global options, or None if that is not plain (then
    every command is built, so help and usage errors list them all)."""
    i = 0
    while i < len(argv):
        arg = argv[i]
        if arg in COMMANDS:
            return arg
        if arg in ("--format", "--color"):
            i += 2
        elif arg.startswith("-") and arg not in ("-h", "--help"):
            i += 1
        else:
            return None
    return None


def main(argv: Sequence[str] | None = None) -> int:
    """Run rapidc with `argv` (default: sys.argv[1:]) and return the exit status; never raises.
    Without `argv` (the `rapidc` process), a command of `_QUICK_EXIT` ends the process instead."""
    try:
        parser = build_parser(sys.argv[1:] if argv is None else argv)
        try:
            args = parser.parse_args(argv)
            if (problem := format_problem(args)) is not None:
                parser.error(problem)
            with without_gl():   # mujoco, if a command imports it, comes without GL (gl.py)
                status = int(args.run(args))
        except SystemExit as exit_:  # argparse: --help, --version, usage errors
            status = _status(exit_.code)
        if sys.stdout is not None:   # None: started with standard output closed
            sys.stdout.flush()
        if argv is None and _named_command(sys.argv[1:]) in _QUICK_EXIT:
            if sys.stderr is not None:
                sys.stderr.flush()
            os._exit(status)
        return status
    except KeyboardInterrupt:
        print("rapidc: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        # The reader went away (`rapidc schema | head`); stop writing quietly.
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
        return EXIT_USAGE
    except OSError as exc:
        if exc.errno not in _OUTPUT_ERRNOS:
            return _internal_error(exc)
        # Standard output or an output file cannot take what is written (a full disk, ...).
        print(f"rapidc: cannot write the output: {exc.strerror or exc}", file=sys.stderr)
        return EXIT_USAGE
    except Exception as exc:  # noqa: BLE001 - the one place that turns bugs into a clean report
        return _internal_error(exc)


_OUTPUT_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EIO, errno.EROFS}


def _status(code: object) -> int:
    if code is None:
        return EXIT_OK
    if isinstance(code, int):
        return code
    print(code, file=sys.stderr)
    return EXIT_USAGE


def _internal_error(exc: BaseException) -> int:
    print(f"rapidc: internal error: {type(exc).__name__}: {exc}", file=sys.stderr)
    print("rapidc: this is a bug in rapidc, not in your program; please report it with the "
          "command line and the input files (set RAPIDC_DEBUG=1 to see the traceback)",
          file=sys.stderr)
    if os.environ.get("RAPIDC_DEBUG"):
        import traceback

        traceback.print_exception(exc, file=sys.stderr)
    return EXIT_INTERNAL
