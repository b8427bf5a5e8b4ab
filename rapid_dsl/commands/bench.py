"""`rapidc bench TARGET`: performance numbers. Targets: `check` (front end speed), `rollouts`
(the executor's CEM throughput against the machine's limit), `primitives` (CEM wall time of
each stdlib primitive on its demo scene), `verify` (variants per minute with 1 and 2 jobs) and
`nonprehensile` (the eight-task benchmark, rapid_dsl/bench/nonprehensile/run.py).

Each target is a function in `TARGETS`; add one with a parser line in `add_parser` and an entry.
"""

from __future__ import annotations

import argparse
from collections.abc import Callable
from typing import Any

from rapid_dsl.commands.common import (
    add_output_options,
    fail_usage,
    path_argument,
    positive_int,
    seed_int,
    wants_color,
)
from rapid_dsl.language.limits import MAX_ITERATIONS, MAX_SAMPLES

# Bounds that keep `bench check` to minutes and its memory to about a gigabyte at most.
MAX_LINES = 100_000
MAX_TERMS = 100_000
MIN_TERMS = 1000     # a single expression of n terms must be past the parser's depth limit
MAX_RUNS = 100
MAX_VERIFY_VARIANTS = 1000
MAX_BENCH_SCENES = 1000
MAX_JOBS = 256


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser("bench", help="measure performance",
                                   description="Measure and print performance numbers.")
    targets = parser.add_subparsers(dest="target", metavar="TARGET", required=True)
    check = targets.add_parser("check", help="front-end speed: lines/s, warm check, start-up",
                               description="Check generated programs and the standard library; "
                                           "print lines/s, a warm 200-line check, the "
                                           "start-up of `rapidc check` and how checking time "
                                           "scales with operator chains and prefix runs "
                                           "(--format json: one JSON object).")
    add_output_options(check, defaults=False)
    check.add_argument("--lines", type=_at_most(MAX_LINES), default=2000,
                       help=f"size of the generated program (at most {MAX_LINES})")
    check.add_argument("--runs", type=_at_most(MAX_RUNS), default=5,
                       help=f"repetitions per measurement (at most {MAX_RUNS})")
    check.add_argument("--terms", type=_at_most(MAX_TERMS, MIN_TERMS), default=10_000,
                       help="n of the scaling table: terms at n and 4n "
                            f"(default 10000, from {MIN_TERMS} to {MAX_TERMS})")

    rollouts = targets.add_parser(
        "rollouts", help="CEM physics steps/s of `rapidc run` vs raw mj_step x cores",
        description="Run examples/push_box.rapid on each robot's push scene and divide the "
                    "physics steps its CEM simulates by the CEM's wall time; compare with the "
                    "raw single-thread mj_step rate of the same scene x cores, measured in the "
                    "same run (target: ratio >= 0.75). Also prints the synthetic batch figure.")
    add_output_options(rollouts, defaults=False)
    rollouts.add_argument("--robot", action="append", choices=("floating_gripper", "franka"),
                          help="robot(s) to measure (default: both)")
    rollouts.add_argument("--repeats", type=positive_int, default=5,
                          help="CEM runs per robot; the best counts (default 5)")
    rollouts.add_argument("--seed", type=seed_int, default=0, help="CEM seed (default 0)")
    rollouts.add_argument("--no-synthetic", action="store_true",
                          help="skip the secondary synthetic batch")
    rollouts.add_argument("--json", metavar="OUT.json", help="also write the results as JSON")

    primitives = targets.add_parser(
        "primitives", help="CEM wall time of each stdlib primitive on its demo scene",
        description="Run each stdlib primitive at its default budget as a phase of its example "
                    "program on the example's scene; print CEM wall time, rollouts, steps, "
                    "steps/s and success per primitive (target: under 3 s each).")
    add_output_options(primitives, defaults=False)
    primitives.add_argument("--primitive", action="append", metavar="NAME",
                            help="primitive(s) to measure (default: all)")
    primitives.add_argument("--seeds", type=seed_int, nargs="+", default=[0], metavar="N",
                            help="CEM seeds (default: 0); the table shows the slowest")
    primitives.add_argument("--repeats", type=positive_int, default=1,
                            help="runs per seed; the fastest counts (default 1)")
    primitives.add_argument("--json", metavar="OUT.json", help="also write the results as JSON")

    verify = targets.add_parser(
        "verify", help="rapidc verify's variants per minute with 1 and 2 jobs",
        description="Verify examples/push_box.rapid on the same seeded variants of its scene "
                    "with 1 and then 2 worker processes (one rollout thread each); print "
                    "variants per minute, success rate and the speed-up (target: 2 jobs >= "
                    "1.8x 1 job on 2 cores).")
    add_output_options(verify, defaults=False)
    verify.add_argument("--variants", type=_at_most(MAX_VERIFY_VARIANTS), default=8,
                        help=f"variants per measurement (default 8, at most "
                             f"{MAX_VERIFY_VARIANTS})")
    verify.add_argument("--seed", type=seed_int, default=0, help="variant seed (default 0)")
    verify.add_argument("--samples", type=_at_most(MAX_SAMPLES), metavar="N",
                        help="CEM samples per iteration (default: the program's)")
    verify.add_argument("--iterations", type=_at_most(MAX_ITERATIONS), metavar="N",
                        help="CEM iterations (default: the program's)")
    verify.add_argument("--repeats", type=_at_most(MAX_RUNS), default=1,
                        help="runs per pool size, taking turns; the best counts (default 1)")
    verify.add_argument("--json", metavar="OUT.json", help="also write the results as JSON")

    nonprehensile = targets.add_parser(
        "nonprehensile", help="the eight-task nonprehensile benchmark on seeded test scenes",
        description="Run each task's strategy (bound automatically, no pins) on seeded test "
                    "scenes of its family, judge the task's criterion on the final state, run "
                    "the grasp-and-lift control once per scene, and print the table in the "
                    "paper's form: per task success mean +- std over trials, the control's "
                    "rate, the median wall time per scene, the average (docs/benchmark.md). "
                    "Exit status: 0 done, 2 bad input, 130 interrupted (--resume continues).")
    add_output_options(nonprehensile, defaults=False)
    nonprehensile.add_argument("--tasks", metavar="T1,T2",
                               help="comma-separated task keys (default: all eight)")
    nonprehensile.add_argument("--scenes", type=_at_most(MAX_BENCH_SCENES), default=50,
                               metavar="N", help="test scenes per task (default 50)")
    nonprehensile.add_argument("--trials", type=_at_most(MAX_RUNS), default=3, metavar="N",
                               help="runs of each strategy per scene (default 3)")
    nonprehensile.add_argument("--jobs", type=_at_most(MAX_JOBS), metavar="J",
                               help="run J runs at once in worker processes (default 1)")
    nonprehensile.add_argument("--cluster", metavar="ADDRESS",
                               help="run on a Dask scheduler (tcp://host:8786), or on a "
                                    "LocalCluster of N workers started for this run (local:N)")
    nonprehensile.add_argument("--robot", choices=("franka", "floating_gripper"),
                               help="the scenes' robot (default: franka, the benchmark's)")
    nonprehensile.add_argument("--out", type=path_argument, default="bench-nonprehensile",
                               metavar="DIR", help="folder for the test scenes, results.json "
                                                   "and its journal (default "
                                                   "bench-nonprehensile)")
    nonprehensile.add_argument("--resume", action="store_true",
                               help="keep the runs an interrupted run left in DIR, run the rest")
    nonprehensile.add_argument("--json", metavar="OUT.json",
                               help="also write the results there (always in DIR/results.json)")
    nonprehensile.add_argument("--samples", type=_at_most(MAX_SAMPLES), metavar="N",
                               help="CEM samples per iteration (default: each primitive's)")
    nonprehensile.add_argument("--iterations", type=_at_most(MAX_ITERATIONS), metavar="N",
                               help="CEM iterations (default: each primitive's)")
    return parser


def _at_most(maximum: int, minimum: int = 1) -> Callable[[str], int]:
    """argparse type: an integer from `minimum` (default: 1) to `maximum`."""
    def parse(text: str) -> int:
        value = positive_int(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(f"must be at most {maximum}")
        if value < minimum:
            raise argparse.ArgumentTypeError(f"must be at least {minimum}")
        return value
    return parse


def run(args: argparse.Namespace) -> int:
    return TARGETS[args.target](args)


def bench_check(args: argparse.Namespace) -> int:
    from rapid_dsl.bench.check import main

    return main(lines=args.lines, runs=args.runs, terms=args.terms,
                as_json=args.format == "json")


def bench_rollouts(args: argparse.Namespace) -> int:
    from rapid_dsl.bench.rollouts import main

    return main(robots=args.robot, repeats=args.repeats, seed=args.seed,
                synthetic=not args.no_synthetic, json_path=args.json)


def bench_primitives(args: argparse.Namespace) -> int:
    from rapid_dsl.bench.primitives import UnknownPrimitive, main

    try:
        return main(primitives=args.primitive, seeds=tuple(args.seeds), repeats=args.repeats,
                    json_path=args.json)
    except UnknownPrimitive as exc:
        return fail_usage(f"--primitive: {exc}")


def bench_verify(args: argparse.Namespace) -> int:
    from rapid_dsl.bench.verify import main

    return main(variants=args.variants, seed=args.seed, samples=args.samples,
                iterations=args.iterations, repeats=args.repeats, json_path=args.json)


def bench_nonprehensile(args: argparse.Namespace) -> int:
    import sys
    from pathlib import Path

    from rapid_dsl.bench.nonprehensile.run import Settings, main
    from rapid_dsl.bench.nonprehensile.tasks import keys as task_keys

    if args.jobs is not None and args.cluster is not None:
        return fail_usage("--jobs and --cluster: choose one (a cluster's workers are its jobs)")
    if args.cluster is not None:
        from rapid_dsl.runtime.verification.cluster import ClusterError, check_address

        try:
            check_address(args.cluster)
        except ClusterError as exc:
            return fail_usage(str(exc))
    keys = task_keys() if args.tasks is None else \
        [k.strip() for k in args.tasks.split(",") if k.strip()]
    if not keys:
        return fail_usage("--tasks: name at least one task, e.g. T1,T2")
    if len(set(k.upper() for k in keys)) != len(keys):
        return fail_usage(f"--tasks {args.tasks}: a task is listed twice")
    return main(Settings(keys, args.scenes, args.trials, Path(args.out), robot=args.robot,
                         jobs=args.jobs, cluster=args.cluster, resume=args.resume,
                         json_path=args.json, samples=args.samples,
                         iterations=args.iterations, quiet=args.quiet,
                         color=wants_color(args.color, sys.stderr),
                         as_json=args.format == "json"))


TARGETS = {"check": bench_check, "rollouts": bench_rollouts, "primitives": bench_primitives,
           "verify": bench_verify, "nonprehensile": bench_nonprehensile}
