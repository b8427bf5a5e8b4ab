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
import sys
import time
from pathlib import Path
from typing import Any

from rapid_dsl.commands.bind import choose
from rapid_dsl.commands.building import check_program, read_scene
from rapid_dsl.commands.common import add_input_options, fail_usage, seed_int, wants_color
from rapid_dsl.commands.run_options import add_run_options, design, run_inputs


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "run", help="run a program on a scene (CEM over MuJoCo rollouts)",
        description="Check and compile PROGRAM, bind its roles in SCENE, and execute it. "
                    "Exit status: 0 success, 1 ran and failed, 2 bad input, 3 internal error.",
        epilog="--arg values are constants in the language's syntax, with units: "
               "--arg displacement=[10cm,0cm,0cm], --arg angle=90deg, --arg approach=-up.")
    parser.add_argument("program", metavar="PROGRAM", help="a .rapid file (or the YAML form)")
    parser.add_argument("--scene", required=True, metavar="SCENE", help="scene YAML file")
    add_run_options(parser)
    parser.add_argument("--seed", type=seed_int, metavar="N",
                        help="CEM seed (default: the primitive's `optimize { seed }`, else 0)")
    parser.add_argument("--trace", type=_output, metavar="OUT.json",
                        help="write the run's trace as JSON")
    parser.add_argument("--track", type=_output, metavar="OUT.json",
                        help="write the object and hand poses of the executed motion as a "
                             "track (docs/demos.md; `rapidc demo analyze` reads it)")
    parser.add_argument("--video", type=_video, metavar="OUT.mp4",
                        help="render the executed motion (" + ", ".join(VIDEO_SUFFIXES) + ")")
    parser.add_argument("--keyframes", type=_output, metavar="DIR",
                        help="write PNG key frames of the executed motion (5, evenly spaced)")
    add_input_options(parser)
    return parser


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


def run(args: argparse.Namespace) -> int:
    started = time.perf_counter()
    if args.track and args.trace and Path(args.track).absolute() == Path(args.trace).absolute():
        return fail_usage("--track and --trace name the same file")
    checked = check_program(args.program, args)
    if isinstance(checked, int):
        return 2   # program errors are bad input for `run`
    try:
        given = run_inputs(checked.program, args)
    except ValueError as exc:
        return fail_usage(str(exc))
    entry, pins, hints, arguments = given.entry, given.pins, given.hints, given.arguments

    if args.video or args.keyframes:   # else mujoco comes without GL (cli.py, runtime/gl.py)
        from rapid_dsl.runtime.gl import RenderError, start_rendering

        try:
            start_rendering()
        except RenderError as exc:
            return fail_usage(str(exc))

    from rapid_dsl.api.compilation import compile_checked
    from rapid_dsl.runtime.loader import LoadError
    from rapid_dsl.runtime.session import Session

    try:
        session = Session(compile_checked(checked.program, args.program, entry))
    except LoadError as exc:    # the loader refused the generated module; nothing of it ran
        return fail_usage(str(exc))
    compiled = time.perf_counter()

    from rapid_dsl.runtime.binding import BindingError
    from rapid_dsl.runtime.executor import ArgumentError, MemoryBudgetError, RunConfig

    scene = read_scene(args)
    if isinstance(scene, int):
        return scene
    world = session.world(scene)
    chosen = choose(session.program, world, entry, pins, hints, best=args.best)
    if isinstance(chosen, int):
        return chosen   # an ambiguous binding, refused with its candidates
    pins, binding_note = chosen
    from rapid_dsl.commands.run_report import ProgressPrinter, print_result

    progress = ProgressPrinter(quiet=args.quiet, color=wants_color(args.color, sys.stderr))
    try:
        config = RunConfig(seed=args.seed, samples=args.samples, iterations=args.iterations,
                           **design(args))
        executor = session.executor(world, config, on_event=progress)
    except ValueError as exc:   # a planning timestep that does not divide the control period
        progress.close()
        return fail_usage(f"--planning-dt: {exc}")
    try:
        result = session.execute(executor, pins=pins, arguments=arguments, scene=args.scene)
    except (BindingError, ArgumentError, MemoryBudgetError) as exc:
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
    inputs = [*checked.inputs, args.scene, *(obj.mesh for obj in scene.objects if obj.mesh)]
    if args.trace and _write_trace(result.to_json(), args.trace, inputs):
        status = 2
    if args.track and _write_track(executor, world, result, args.track, inputs):
        status = 2
    if args.video and _write_video(executor, world, args.video, inputs, quiet=args.quiet):
        status = 2
    if args.keyframes and _write_keyframes(executor, world, args.keyframes, inputs,
                                           quiet=args.quiet):
        status = 2
    return status


def _write_trace(trace: dict[str, Any], path: str, inputs: list[str]) -> bool:
    """Write the trace; True on failure (reported)."""
    return _write_text(json.dumps(trace, indent=2) + "\n", path, "trace", inputs)


def _write_track(executor: Any, world: Any, result: Any, path: str, inputs: list[str]) -> bool:
    """Write the track of the executed motions (runtime/demonstrations/track_record.py); True on
    failure."""
    from rapid_dsl.runtime.demonstrations.track import dump_track
    from rapid_dsl.runtime.demonstrations.track_record import record_track

    return _write_text(dump_track(record_track(world, executor.motions, result)), path, "track",
                       inputs)


def _write_text(text: str, path: str, what: str, inputs: list[str]) -> bool:
    """Write an output file atomically, never over an input; True on failure (reported)."""
    from rapid_dsl.language.files import FileProblem, write_atomic

    try:
        write_atomic(path, text, inputs=inputs)
    except FileProblem as exc:
        fail_usage(f"cannot write {what} {path}: {exc}")
        return True
    return False


def _write_keyframes(executor: Any, world: Any, folder: str, inputs: list[str], *,
                     quiet: bool) -> bool:
    """Render key frames of the executed motions; True on failure (reported)."""
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
    """Render the executed motions; True on failure (reported)."""
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
