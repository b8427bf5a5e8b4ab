"""`rapidc demo analyze TRACK.json`: the interaction phases of a track and the effect of each;
`rapidc demo schema`: the JSON Schema of tracks.

Reads a track (`rapidc run --track`, or a demonstration written in the same format; docs/demos.md),
segments it into phases and prints each one's effect, the primitive that shows it and that
primitive's argument: a table, or with `--format json` the whole analysis as one JSON object.
`--skeleton OUT.rapid` also writes a strategy that runs those primitives with those arguments.
Exit status: 0 analyzed, 1 a skeleton was asked for but no phase is a primitive's effect, 2 bad
input (an invalid track: each problem with its line, column and JSON path) or unwritable output.
"""

from __future__ import annotations

import argparse
import json
import sys
from typing import Any

from rapid_dsl.commands.common import add_output_options, fail_usage, path_argument, shown


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "demo", help="analyze a demonstration: its phases and their effects",
        description="Work with demonstrations recorded as tracks (docs/demos.md).")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)
    analyze = actions.add_parser(
        "analyze", help="segment a track into phases and measure each phase's effect",
        description="Segment TRACK.json into interaction phases (when each object moves and "
                    "how, grip changes) and measure each phase's effect: displacement, "
                    "rotation, lift, which object moved; name the standard primitive it shows "
                    "and its argument. Exit status: 0 analyzed, 1 no phase for a skeleton, 2 "
                    "bad input or unwritable output.",
        epilog="--format json prints the analysis as one JSON object (docs/demos.md).")
    add_output_options(analyze, defaults=False)
    analyze.add_argument("track", metavar="TRACK.json", type=path_argument,
                         help="a track (`rapidc run --track` writes them)")
    analyze.add_argument("--skeleton", metavar="OUT.rapid", type=path_argument,
                         help="also write a strategy skeleton: the phases' primitives with the "
                              "measured effects as their arguments")
    schema = actions.add_parser("schema", help="print the JSON Schema of track files",
                                description="Print the JSON Schema of the track format "
                                            "(rapid_dsl/runtime/demonstrations/track.schema.json).")
    add_output_options(schema, defaults=False)
    return parser


def run(args: argparse.Namespace) -> int:
    if args.action == "schema":
        from rapid_dsl.runtime.demonstrations.track import schema

        print(json.dumps(schema(), indent=2))
        return 0
    if args.format == "github":
        return fail_usage("demo analyze prints `--format human` or `json`")
    from rapid_dsl.runtime.demonstrations.analysis import analyze_track
    from rapid_dsl.runtime.demonstrations.track import TrackError

    try:
        analysis = analyze_track(args.track)
    except TrackError as exc:
        for problem in exc.problems:
            print(shown(problem.labelled(), None), file=sys.stderr)
        if exc.more:
            print(f"... and {exc.more} more problems", file=sys.stderr)
        return 2
    if args.format == "json":
        print(json.dumps(analysis, indent=2))
    else:
        print("\n".join(table(analysis)))
    return _write_skeleton(analysis, args) if args.skeleton else 0


def _write_skeleton(analysis: dict[str, Any], args: argparse.Namespace) -> int:
    from rapid_dsl.commands.demo_skeleton import SkeletonProblem, skeleton
    from rapid_dsl.language.files import FileProblem, write_atomic

    try:
        text = skeleton(analysis)
    except SkeletonProblem as exc:
        print(f"rapidc: {exc}", file=sys.stderr)
        return 1
    try:
        write_atomic(args.skeleton, text, inputs=[args.track])
    except FileProblem as exc:
        return fail_usage(f"cannot write skeleton {args.skeleton}: {exc}")
    if not args.quiet:
        print(f"wrote {args.skeleton} (rapidc check it, then make its numbers relations)",
              file=sys.stderr)
    return 0


def table(analysis: dict[str, Any]) -> list[str]:
    """The human form: a heading line, one row per phase, then what else moved."""
    from rapid_dsl.runtime.demonstrations.analysis import literal

    phases = analysis["phases"]
    count = f"{len(phases)} phase" + ("" if len(phases) == 1 else "s")
    lines = [f"{shown(analysis['track'], None)}: {count} in {analysis['duration']:.2f} s "
             f"({analysis['frames']} frames, hand {shown(analysis['hand'])})"]
    if not phases:
        return [*lines, "no object moved and no grip closed on one"]
    rows = [["#", "phase", "object", "time", "displacement", "distance", "rotation", "lift",
             "relations", "argument"]]
    notes = []
    for p in phases:
        effect = p["effect"]
        rotation = literal(effect["rotation_angle"], "rad")
        if effect["rotation_axis"] is not None:
            rotation += f" about {literal(effect['rotation_axis'], '')}"
        relations = ", ".join(f"{word} {shown(name)}" for word, name in
                              (("on", p["support"]), ("at", p["fixture"])) if name)
        rows.append([str(p["index"]), p["kind"], shown(p["object"]),
                     f"{p['start']:.2f}-{p['end']:.2f}s", literal(effect["displacement"], "m"),
                     literal(effect["distance"], "m"), rotation,
                     literal(effect["lift_height"], "m"), relations or "-",
                     ", ".join(f"{k}={v}" for k, v in p["argument_text"].items()) or "-"])
        for other in p["also_moved"]:
            notes.append(f"phase {p['index']} also moved {shown(other['object'])} by "
                         f"{literal(other['distance'], 'm')}, turning it "
                         f"{literal(other['rotation_angle'], 'rad')}")
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines += ["  " + "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True)).rstrip()
              for row in rows]
    return lines + notes
