"""`rapidc run PROGRAM --scene SCENE`: check, compile in memory, bind and execute on MuJoCo.

Runs the one strategy the file declares (or its one primitive; `--entry NAME` to choose), prints
progress on stderr and a result table on stdout, and optionally writes the JSON trace and a video.
Exit status: 0 the success predicate holds, 1 the program ran and failed or a filter rejected the
scene (the table says why), 2 bad input (program errors, scene errors, unknown entity or param, bad
argument, unwritable output), 3 internal error.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

from rapid_dsl.commands.bind import HINT_HELP, choose
from rapid_dsl.commands.building import check_program, choose_entry, module_stem
from rapid_dsl.commands.common import (
    add_input_options,
    fail_usage,
    positive_int,
    seed_int,
    wants_color,
)
from rapid_dsl.runtime.limits import MAX_ITERATIONS, MAX_SAMPLES


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "run", help="run a program on a scene (CEM over MuJoCo rollouts)",
        description="Check and compile PROGRAM, bind its roles in SCENE, and execute it. "
                    "Exit status: 0 success, 1 ran and failed, 2 bad input, 3 internal error.",
        epilog="--arg values are constants in the language's syntax, with units: "
               "--arg displacement=[10cm,0cm,0cm], --arg angle=90deg, --arg approach=-up.")
    parser.add_argument("program", metavar="PROGRAM", help="a .rapid file (or the YAML form)")
    parser.add_argument("--scene", required=True, metavar="SCENE", help="scene YAML file")
    parser.add_argument("--entry", metavar="NAME",
                        help="the primitive or strategy to run (default: the file's one "
                             "strategy, else its one primitive)")
    parser.add_argument("--bind", action="append", default=[], metavar="ROLE=ENTITY",
                        help="pin a role to a scene entity (repeatable)")
    parser.add_argument("--hint", action="append", default=[], metavar="ROLE=TEXT",
                        help=HINT_HELP)
    parser.add_argument("--best", action="store_true",
                        help="when the binding is ambiguous, take the top-ranked one (and say so)")
    parser.add_argument("--arg", action="append", default=[], metavar="PARAM=VALUE",
                        help="a primitive entry's param value, with units (repeatable)")
    parser.add_argument("--seed", type=seed_int, metavar="N",
                        help="CEM seed (default: the primitive's `optimize { seed }`, else 0)")
    parser.add_argument("--samples", type=_budget(MAX_SAMPLES), metavar="N",
                        help="CEM samples per iteration for every phase (overrides the program; "
                             f"at most {MAX_SAMPLES})")
    parser.add_argument("--iterations", type=_budget(MAX_ITERATIONS), metavar="N",
                        help="CEM iterations for every phase (overrides the program; at most "
                             f"{MAX_ITERATIONS})")
    parser.add_argument("--planning-dt", type=_seconds, metavar="SECONDS",
                        help="timestep of the CEM's rollouts (default 0.004; it must divide the "
                             "0.02 s control period); motions are executed and judged at the "
                             "world's 0.002 s whatever it is")
    parser.add_argument("--execute-elites", type=seed_int, metavar="N",
                        help="run the N best final CEM samples at the world's timestep and "
                             "execute the best of them (default 0: every final elite; 1: the "
                             "CEM's best only)")
    parser.add_argument("--trace", type=_output, metavar="OUT.json",
                        help="write the run's trace as JSON")
    parser.add_argument("--video", type=_video, metavar="OUT.mp4",
                        help="render the executed motion (" + ", ".join(VIDEO_SUFFIXES) + ")")
    parser.add_argument("--keyframes", type=_output, metavar="DIR",
                        help="write PNG key frames of the executed motion (5, evenly spaced)")
    add_input_options(parser)
    return parser


def _budget(maximum: int) -> Callable[[str], int]:
    """argparse type: a positive integer of at most `maximum` (runtime/limits.py, the same
    maxima the checker enforces in programs)."""
    def parse(text: str) -> int:
        value = positive_int(text)
        if value > maximum:
            raise argparse.ArgumentTypeError(f"must be at most {maximum}")
        return value
    return parse


# Containers that imageio's ffmpeg writes H.264 into; others fail only after the run, some with
# an ignored traceback from a fallback writer (.mpg) or pages of ffmpeg log (.webm).
VIDEO_SUFFIXES = (".mp4", ".mkv", ".mov", ".avi")


def _output(text: str) -> str:
    """argparse type: a file or folder name to write (an empty one would silently write nothing)."""
    if not text.strip():
        raise argparse.ArgumentTypeError("needs a file name")
    return text


def _video(text: str) -> str:
    """argparse type: a video file name whose extension says a container ffmpeg writes."""
    if Path(_output(text)).suffix.lower() not in VIDEO_SUFFIXES:
        raise argparse.ArgumentTypeError("the file name must end in " + ", ".join(VIDEO_SUFFIXES))
    return text


def _seconds(text: str) -> float:
    """argparse type: a positive, finite number of seconds."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"`{text}` is not a number of seconds") from None
    if not (math.isfinite(value) and value > 0):
        raise argparse.ArgumentTypeError("must be a positive number of seconds")
    return value


def run(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    checked = check_program(args.program, args)
    if isinstance(checked, int):
        return 2   # program errors are bad input for `run`
    from rapid_dsl.commands.arguments import ArgumentProblem, parse_arguments, split_pairs

    program = checked.program
    try:
        entry = choose_entry(program, args.entry)
        pins = split_pairs(args.bind, "--bind")
        hints = split_pairs(args.hint, "--hint")
        decl_is_primitive = entry in {p.name for p in program.primitives}
        if args.arg and not decl_is_primitive:
            raise ArgumentProblem(f"`{entry}` is a strategy: it takes no --arg (its phases "
                                  "compute their own arguments)")
        arguments = parse_arguments(args.arg, program.primitive(entry)) \
            if decl_is_primitive else {}
    except ValueError as exc:
        return fail_usage(str(exc))

    from rapid_dsl.runtime.gl import RenderError, prepare

    try:
        prepare(rendering=bool(args.video or args.keyframes))
    except RenderError as exc:
        return fail_usage(str(exc))

    from rapid_dsl.compiler import compile_program
    from rapid_dsl.runtime.loader import LoadError, load

    module = compile_program(program)
    try:
        loaded = load(module.source, module_stem(args.program))
    except LoadError as exc:    # the loader refused the generated module; nothing of it ran
        return fail_usage(str(exc))
    compiled = time.perf_counter()

    from rapid_dsl.runtime.binding import BindingError
    from rapid_dsl.runtime.executor import ArgumentError, Executor, RunConfig
    from rapid_dsl.runtime.scene import SceneError, load_scene
    from rapid_dsl.runtime.world import build_world

    try:
        scene = load_scene(args.scene, allowed_dirs=args.allowed_dirs)
    except SceneError as exc:
        for problem in exc.problems:
            print(problem, file=sys.stderr)
        return 2
    world = build_world(scene)
    chosen = choose(loaded.program, world, entry, pins, hints, best=args.best)
    if isinstance(chosen, int):
        return chosen   # an ambiguous binding, refused with its candidates
    pins, binding_note = chosen
    from rapid_dsl.commands.run_report import ProgressPrinter, print_result

    progress = ProgressPrinter(quiet=args.quiet, color=wants_color(args.color, sys.stderr))
    design = {key: value for key, value in (("planning_dt", args.planning_dt),
                                           ("execute_elites", args.execute_elites))
              if value is not None}
    try:
        config = RunConfig(seed=args.seed, samples=args.samples, iterations=args.iterations,
                           **design)
        executor = Executor(loaded.program, world, config=config, on_event=progress,
                            locate=loaded.locate)
    except ValueError as exc:   # a planning timestep that does not divide the control period
        progress.close()
        return fail_usage(f"--planning-dt: {exc}")
    import numpy as np

    try:
        # A program's arithmetic may overflow (a keypoint 1e300 m away): the executor reports
        # non-finite costs and points as failures; numpy's warnings would only name its files.
        with np.errstate(all="ignore"):
            result = executor.run(entry, pins=pins, arguments=arguments, scene=args.scene)
    except (BindingError, ArgumentError) as exc:
        return fail_usage(str(exc))
    finally:
        progress.close()
    result.seconds["check_and_compile"] = compiled - started
    result.seconds["wall"] = time.perf_counter() - started
    result.binding_note = binding_note or result.binding_note

    status = 0 if result.succeeded else 1   # rejected by a filter: 1, nothing ran
    for warning in result.warnings:
        print(warning.text(), file=sys.stderr)
    verdict = "REJECTED" if result.rejected else "SUCCESS" if result.succeeded else "FAILED"
    if args.quiet:
        print(f"{entry}: {verdict}"
              + (f": {result.failure}" if result.failure else ""))
    else:
        print_result(result, color=wants_color(args.color, sys.stdout))
    # Outputs are written atomically, never through a symlink, never over what the run read.
    inputs = [*checked.inputs, args.scene]
    if args.trace and _write_trace(result.to_json(), args.trace, inputs):
        status = 2
    if args.video and _write_video(executor, world, args.video, inputs, quiet=args.quiet):
        status = 2
    if args.keyframes and _write_keyframes(executor, world, args.keyframes, inputs,
                                           quiet=args.quiet):
        status = 2
    return status


def _write_trace(trace: dict[str, Any], path: str, inputs: list[str]) -> bool:
    """Write the trace; True on failure (reported)."""
    from rapid_dsl.runtime.files import FileProblem, write_atomic

    try:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
        write_atomic(path, json.dumps(trace, indent=2) + "\n", inputs=inputs)
    except OSError as exc:
        fail_usage(f"cannot write trace {path}: {exc.strerror or exc}")
        return True
    except FileProblem as exc:
        fail_usage(f"cannot write trace {path}: {exc}")
        return True
    return False


def _write_keyframes(executor: Any, world: Any, folder: str, inputs: list[str], *,
                     quiet: bool) -> bool:
    """Render key frames of the replayed motions; True on failure (reported)."""
    from rapid_dsl.runtime.render import RenderError, frame_stride, save_keyframes

    try:
        written = save_keyframes(world, executor.states(frame_stride(world, 30.0)), folder,
                                 inputs=inputs)
    except RenderError as exc:
        fail_usage(str(exc))
        return True
    except OSError as exc:
        fail_usage(f"cannot write key frames to {folder}: {exc.strerror or exc}")
        return True
    if not quiet:
        print(f"wrote {len(written)} key frames to {folder}", file=sys.stderr)
    return False


def _write_video(executor: Any, world: Any, path: str, inputs: list[str], *,
                 quiet: bool) -> bool:
    """Render the replayed motions; True on failure (reported)."""
    from rapid_dsl.runtime.render import RenderError, frame_stride, render_video

    fps = 30.0
    try:
        render_video(world, executor.states(frame_stride(world, fps)), path, fps=fps,
                     inputs=inputs)
    except RenderError as exc:
        fail_usage(str(exc))
        return True
    if not quiet:
        print(f"wrote {path}", file=sys.stderr)
    return False
