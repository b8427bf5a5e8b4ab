"""`rapidc report REPORT.json --html PAGE.html`: render an existing verify report as an HTML page.

The same page as `rapidc verify --html` (runtime/verify_html.py), made again from a report on
disk. The program's text comes from `--program`, else from the file the report names if it is a
program file (`.rapid`, `.rapid.yaml`, `.rapid.yml`); key frames from `--media`, else from the
report's media folder, and only as the PNG strips verify writes there.
Exit status: 0 written, 2 bad input (not a report, an unwritable page).
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

from rapid_dsl.commands.common import fail_usage

PROGRAM_SUFFIXES = (".rapid", ".rapid.yaml", ".rapid.yml")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "report", help="render a verify report as a self-contained HTML page",
        description="Write the report `rapidc verify --report` wrote as one self-contained HTML "
                    "page (inline CSS and SVG, images as data: URIs, no script): success rate, "
                    "failures by first failing clause, values against bounds, CEM cost curves, "
                    "key frames and the program with its failing lines marked. Exit status: 0 "
                    "written, 2 bad input.")
    parser.add_argument("report", metavar="REPORT.json", help="a rapidc verify report")
    parser.add_argument("--html", required=True, metavar="PAGE.html", help="the page to write")
    parser.add_argument("--program", metavar="FILE",
                        help="the program's text (default: the file the report names)")
    parser.add_argument("--media", metavar="DIR",
                        help="the key-frame strips verify --media wrote (default: the "
                             "report's media folder)")
    return parser


def run(args: argparse.Namespace) -> int:
    import jinja2

    from rapid_dsl.commands.verify import check_html
    from rapid_dsl.runtime.files import FileProblem, read_bytes
    from rapid_dsl.runtime.verify_html import write_html
    from rapid_dsl.runtime.verify_job import REPORT_FORMAT
    from rapid_dsl.runtime.verify_report import MAX_REPORT_BYTES, ReportProblem

    problem = check_html(args.html, [p for p in (args.report, args.program) if p is not None])
    if problem is not None:
        return fail_usage(problem)
    try:
        report = json.loads(read_bytes(args.report, limit=MAX_REPORT_BYTES).decode("utf-8"))
    except FileProblem as exc:
        return fail_usage(f"{args.report}: {exc}")
    except UnicodeDecodeError:
        return fail_usage(f"{args.report}: not UTF-8")
    except json.JSONDecodeError as exc:
        return fail_usage(f"{args.report}:{exc.lineno}:{exc.colno}: not JSON: {exc.msg}")
    if not (isinstance(report, dict) and report.get("format") == REPORT_FORMAT
            and isinstance(report.get("summary"), dict)
            and isinstance(report.get("results"), list)):
        return fail_usage(f"{args.report}: not a rapidc verify report ({REPORT_FORMAT})")
    program = args.program
    named = report.get("program")
    if program is None and isinstance(named, str) and named.endswith(PROGRAM_SUFFIXES):
        program = named
    media = args.media
    settings = report.get("settings")
    if media is None and isinstance(settings, dict) and isinstance(settings.get("media"), str):
        media = settings["media"]
    inputs = [p for p in (args.report, program) if p is not None and Path(p).exists()]
    try:
        write_html(args.html, report, program=program, media=media, inputs=inputs)
    except ReportProblem as exc:
        return fail_usage(str(exc))
    except (AttributeError, TypeError, ValueError, KeyError, jinja2.UndefinedError) as exc:
        # a hand-edited report whose parts have the wrong shapes
        return fail_usage(f"{args.report}: not a well-formed rapidc verify report ({exc})")
    print(f"wrote {args.html}")
    return 0
