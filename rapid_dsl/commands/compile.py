"""`rapidc compile FILE -o DIR`: write the Python CEM program generated from FILE.

The module is DIR/<stem>.py (`-o -` prints it). It imports only rapid_dsl.runtime, maps every
step back to its `.rapid` line with `# SOURCES[i]:LINE` comments, and is byte-for-byte the same
for the same input. It is written atomically, never through a symlink and never over the program
or a file it uses (rapid_dsl/language/files.py write_atomic).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path
from typing import Any

from rapid_dsl.api.compilation import module_stem
from rapid_dsl.commands.building import check_program
from rapid_dsl.commands.common import add_input_options, fail_usage, path_argument
from rapid_dsl.language.files import FileProblem, write_atomic


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "compile", help="compile a program to a Python CEM program",
        description="Check FILE and write the generated Python module DIR/<stem>.py. "
                    "Exit status: 0 written, 1 program errors, 2 usage or I/O error.")
    parser.add_argument("file", metavar="FILE", help="a .rapid file (or the YAML form)")
    parser.add_argument("-o", "--output", metavar="DIR", required=True, type=path_argument,
                        help="folder to write <stem>.py into, or - for standard output")
    add_input_options(parser)
    return parser


def run(args: argparse.Namespace) -> int:
    from rapid_dsl.compiler import compile_program

    checked = check_program(args.file, args)
    if isinstance(checked, int):
        return checked
    module = compile_program(checked.program)
    if args.output == "-":
        sys.stdout.write(module.source)
        return 0
    target = Path(args.output) / f"{module_stem(args.file)}.py"
    if target.parent.exists() and not target.parent.is_dir():
        return fail_usage(f"-o {args.output}: a file, not a folder")
    try:
        write_atomic(target, module.source, inputs=checked.inputs)
    except FileProblem as exc:
        return fail_usage(f"cannot write {target}: {exc}")
    if not args.quiet:
        print(f"wrote {target}", file=sys.stderr)
    return 0
