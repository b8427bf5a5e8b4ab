"""`rapidc verify PROGRAM --scene SCENE --variants N`: judge a program on a scene and its variants.

Checks and compiles PROGRAM once, then runs it, as `rapidc run` would, on SCENE and on variants
0 .. N-1 of seed S (runtime/variants/sampler.py, drawn here as jobs are handed out), in this
process, in `--jobs J` worker processes or on a Dask cluster (`--cluster`). A run whose start
state fails one of the program's filter clauses is rejected, not run. Every finished run goes
to the report's journal at once; the report (docs/verify.md) is written at the end, or on Ctrl-C,
and `--resume REPORT` continues where a run stopped.
Exit status: 0 every run that was not rejected succeeded (or at least `--min-success`), 1 some
failed (or every run was rejected), 2 bad input, 3 internal error, 130 interrupted.
"""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import Any

from rapid_dsl.commands.building import check_program
from rapid_dsl.commands.common import add_input_options, fail_usage, positive_int, seed_int
from rapid_dsl.commands.run_options import add_run_options, run_inputs

MAX_JOBS = 256


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "verify", help="run a program on a scene and its seeded variants, in parallel",
        description="Check and compile PROGRAM, run it on SCENE and on N seeded variants of it "
                    "(variants whose start state fails a filter clause are rejected, not run), "
                    "and summarize: success rate, rejections by filter clause, failures by phase "
                    "and first failing clause. Exit status: 0 every run succeeded (or "
                    "--min-success), 1 some failed, 2 bad input, 3 internal error.",
        epilog="The report's format is in docs/verify.md; `rapidc schema --report` prints its "
               "JSON Schema.")
    parser.add_argument("program", metavar="PROGRAM", help="a .rapid file (or the YAML form)")
    parser.add_argument("--scene", required=True, metavar="SCENE", help="scene YAML file")
    parser.add_argument("--variants", type=positive_int, required=True, metavar="N",
                        help="how many seeded variants of the scene to run (at most 10000)")
    parser.add_argument("--seed", type=seed_int, default=0, metavar="S",
                        help="variant seed (default 0): variant i of seed S is always the same")
    parser.add_argument("--ranges", metavar="FILE",
                        help="ranges YAML file (docs/variants.md; default: the default ranges)")
    parser.add_argument("--jobs", type=positive_int, metavar="J",
                        help=f"run J jobs at once in worker processes (default 1: in this "
                             f"process; at most {MAX_JOBS})")
    parser.add_argument("--cluster", metavar="ADDRESS",
                        help="run the jobs on a Dask scheduler (tcp://host:8786), or on a "
                             "LocalCluster of N worker processes started for this run (local:N)")
    parser.add_argument("--report", metavar="REPORT.json",
                        help="write the JSON report (with its journal REPORT.json.journal while "
                             "running)")
    parser.add_argument("--resume", metavar="REPORT.json",
                        help="continue an interrupted verify: keep the runs REPORT.json (or its "
                             "journal) holds, run the rest, write the report there unless "
                             "--report says elsewhere")
    parser.add_argument("--min-success", type=_fraction, default=1.0, metavar="F",
                        help="exit 0 when at least this fraction (0 .. 1) of the runs that were "
                             "not rejected succeed (default 1: all)")
    parser.add_argument("--media", metavar="DIR",
                        help="write a PNG strip of key frames of each run's motion into DIR "
                             "(needs offscreen GL, like run --keyframes)")
    parser.add_argument("--html", metavar="PAGE.html",
                        help="also write the report as one self-contained HTML page: success "
                             "rate, failures, cost curves, key frames (--media) and the program "
                             "with its failing lines marked")
    add_run_options(parser)
    parser.add_argument("--cem-seed", type=seed_int, metavar="N",
                        help="CEM seed of every run (default: the primitive's "
                             "`optimize { seed }`, else 0)")
    add_input_options(parser)
    return parser


def _fraction(text: str) -> float:
    """argparse type: a number from 0 to 1."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"`{text}` is not a number") from None
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError("must be from 0 to 1")
    return value


def run(args: argparse.Namespace) -> int:
    gl_backend = None
    if args.media is not None:
        # first: mujoco picks its GL back end once, when something first imports it
        if Path(args.media).exists() and not Path(args.media).is_dir():
            return fail_usage(f"--media {args.media}: a file, not a folder")
        from rapid_dsl.runtime.gl import RenderError, start_rendering
        from rapid_dsl.runtime.verification.worker import rendering_backend

        try:
            start_rendering()
        except RenderError as exc:
            return fail_usage(str(exc))
        gl_backend = rendering_backend()
    from rapid_dsl.runtime.variants.sampler import MAX_SEED, MAX_VARIANTS

    if args.variants > MAX_VARIANTS:
        return fail_usage(f"--variants {args.variants}: at most {MAX_VARIANTS}")
    if args.seed > MAX_SEED:
        return fail_usage(f"--seed {args.seed}: at most {MAX_SEED}")
    if args.jobs is not None and args.jobs > MAX_JOBS:
        return fail_usage(f"--jobs {args.jobs}: at most {MAX_JOBS}")
    if args.jobs is not None and args.cluster is not None:
        return fail_usage("--jobs and --cluster: choose one (a cluster's workers are its jobs)")
    if args.cluster is not None:
        from rapid_dsl.runtime.verification.cluster import ClusterError, check_address

        try:
            check_address(args.cluster)
        except ClusterError as exc:
            return fail_usage(str(exc))
    checked = check_program(args.program, args)
    if isinstance(checked, int):
        return 2   # program errors are bad input, as for `run`
    try:
        given = run_inputs(checked.program, args)
    except ValueError as exc:
        return fail_usage(str(exc))

    from rapid_dsl.commands.verify_plan import VerifyError, plan

    try:
        verification = plan(args, checked, given, gl_backend)
    except VerifyError as exc:
        return exc.status
    return verification.run()
