"""`rapidc report REPORT.json --html PAGE.html`: render an existing verify report as an HTML page.

The same page as `rapidc verify --html` (runtime/verification/page.py), made again from a report on
disk. The report is untrusted: it is read strictly (runtime/verification/report.py read_report), and
the files it names are read only inside the report's own folder tree or an `--allow-path`
folder (docs/security.md). The program's text comes from `--program`, else from the file the
report names if it is a program file (`.rapid`, `.rapid.yaml`, `.rapid.yml`) there; key frames
from `--media`, else from the report's media folder if it is there, and only as the PNG strips
verify writes. A named file outside is not read: the page says so, and so does stderr.
Exit status: 0 written, 2 bad input (not a report, an unwritable page).
"""

from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Any

from rapid_dsl.commands.common import fail_usage, folder, shown

PROGRAM_SUFFIXES = (".rapid", ".rapid.yaml", ".rapid.yml")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "report", help="render a verify report as a self-contained HTML page",
        description="Write the report `rapidc verify --report` wrote as one self-contained HTML "
                    "page (inline CSS and SVG, images as data: URIs, no script): success rate, "
                    "failures by first failing clause, values against bounds, CEM cost curves, "
                    "key frames and the program with its failing lines marked. The program and "
                    "media folder the report names are read only inside the report's folder tree "
                    "(or --allow-path). Exit status: 0 written, 2 bad input.")
    parser.add_argument("report", metavar="REPORT.json", help="a rapidc verify report")
    parser.add_argument("--html", required=True, metavar="PAGE.html", help="the page to write")
    parser.add_argument("--program", metavar="FILE",
                        help="the program's text (default: the file the report names)")
    parser.add_argument("--media", metavar="DIR",
                        help="the key-frame strips verify --media wrote (default: the "
                             "report's media folder)")
    parser.add_argument(
        "--allow-path", action="append", default=[], type=folder, metavar="DIR",
        dest="allowed_dirs",
        help="also read the program and media folder the report names in DIR and below it "
             "(by default only inside the report's own folder tree; repeatable)")
    return parser


def run(args: argparse.Namespace) -> int:
    import jinja2

    from rapid_dsl.commands.verify_display import check_html
    from rapid_dsl.runtime.verification.page import write_html
    from rapid_dsl.runtime.verification.report import ReportProblem, read_report

    problem = check_html(args.html, [p for p in (args.report, args.program) if p is not None])
    if problem is not None:
        return fail_usage(problem)
    try:
        report = read_report(args.report)
    except ReportProblem as exc:
        return fail_usage(str(exc))
    roots = [os.path.dirname(os.path.abspath(args.report)), *args.allowed_dirs]
    program, media, notes = args.program, args.media, {}
    named = report["program"]
    if program is None and named.endswith(PROGRAM_SUFFIXES):
        program, notes["program"] = _confined(args.report, "program", named, roots)
    if media is None and report["settings"]["media"] is not None:
        media, notes["media"] = _confined(args.report, "media folder", report["settings"]["media"],
                                          roots)
    for note in notes.values():
        if note:
            print(f"rapidc: warning: {shown(note, None)}", file=sys.stderr)
    inputs = [p for p in (args.report, program) if p is not None and Path(p).exists()]
    try:
        write_html(args.html, report, program=program, media=media, inputs=inputs,
                   notes={k: v for k, v in notes.items() if v})
    except ReportProblem as exc:
        return fail_usage(str(exc))
    except jinja2.TemplateError as exc:   # the report's shapes are checked: not expected
        return fail_usage(f"{args.report}: the page cannot be made ({exc})")
    print(f"wrote {args.html}")
    return 0


def _confined(report: str, what: str, path: str, roots: list[str]) -> tuple[str | None, str]:
    """`path` as the report names it (relative paths from the current folder, as verify wrote
    them) if it lies in one of `roots`, else None and why it is not read."""
    from rapid_dsl.language.files import inside

    if inside(path, roots):
        return path, ""
    return None, (f"{report}: the {what} it names ({path}) lies outside the report's folder; "
                  f"not read (give it with --{'program' if what == 'program' else 'media'}, or "
                  "allow its folder with --allow-path DIR)")
