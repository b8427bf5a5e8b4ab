"""`rapidc scene render` and `rapidc scene from-rgbd`: scenes to RGB-D frames and back.

- `rapidc scene render SCENE [--camera NAME] [--size WxH] -o DIR` renders the scene offscreen
  (runtime/reconstruction/rgbd_render.py) to the files `from-rgbd` reads: rgb.png, depth.png (mm),
  depth.npy (m), intrinsics.json, extrinsics.json, labels.json and masks/<name>.png per object and
  fixture.
- `rapidc scene from-rgbd --rgb ... --depth ... --intrinsics ... --masks DIR -o SCENE` rebuilds a
  scene file from such a frame (runtime/reconstruction/reconstruct.py, docs/reconstruction.md).
Exit status: 0 written, 2 bad input (a file missing or malformed, sizes that disagree, an empty
mask, no support plane), an unwritable output, or no offscreen GL for `render`.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

from rapid_dsl.commands.building import read_scene
from rapid_dsl.commands.common import add_input_options, add_output_options, fail_usage, shown

CAMERA_HELP = ("a named camera: workspace (the runtime's own, as in videos; the default), "
               "opposite (across the table, facing the robot), side (from -y), top")


def add_parser(subparsers: Any) -> argparse.ArgumentParser:
    parser = subparsers.add_parser(
        "scene", help="render scenes to RGB-D frames, reconstruct scenes from them",
        description="Render a scene to an RGB-D frame with object masks, or reconstruct a "
                    "scene file from one (docs/reconstruction.md).")
    actions = parser.add_subparsers(dest="action", metavar="ACTION", required=True)

    render = actions.add_parser(
        "render", help="render a scene to RGB, depth, masks and camera files",
        description="Render SCENE offscreen (MUJOCO_GL=egl or osmesa on a machine without a "
                    "display) from a named camera and write DIR/rgb.png, depth.png (16-bit, "
                    "mm), depth.npy (float32, m), intrinsics.json, extrinsics.json, labels.json "
                    "and masks/<name>.png for every object and fixture in view. Exit status: 0 "
                    "written, 2 bad input, no GL, or unwritable output.")
    add_output_options(render, defaults=False)
    render.add_argument("scene", metavar="SCENE", help="scene YAML file")
    render.add_argument("--camera", default="workspace", metavar="NAME", help=CAMERA_HELP)
    render.add_argument("--size", type=_size, default=(640, 480), metavar="WxH",
                        help="image size in pixels (default 640x480)")
    render.add_argument("-o", "--output", required=True, type=_path, metavar="DIR",
                        help="folder to write the frame into (made if missing)")
    add_input_options(render)

    rebuild = actions.add_parser(
        "from-rgbd", help="reconstruct a scene file from one RGB-D frame and object masks",
        description="Back-project each mask's depth pixels, remove outliers, find the support "
                    "plane (RANSAC), fit each object as a box or a convex mesh resting on its "
                    "support, and write the scene (meshes next to it), validated by loading it "
                    "back. Exit status: 0 written, 2 bad input or unwritable output.",
        epilog="Formats: docs/reconstruction.md.")
    add_output_options(rebuild, defaults=False)
    rebuild.add_argument("--rgb", required=True, metavar="RGB.png", help="colour image (PNG, "
                                                                         "JPEG)")
    rebuild.add_argument("--depth", required=True, metavar="DEPTH",
                         help="depth: a 16-bit PNG in millimetres or a float .npy in metres")
    rebuild.add_argument("--intrinsics", required=True, metavar="K.json",
                         help="pinhole intrinsics: fx, fy, cx, cy, width, height (pixels)")
    rebuild.add_argument("--masks", required=True, metavar="DIR",
                         help="folder of one PNG mask per object, named <object>.png")
    rebuild.add_argument("--labels", metavar="labels.json",
                         help="per object a label, or label, kind, mass and friction")
    rebuild.add_argument("--extrinsics", metavar="T.json",
                         help="camera-to-world pose (default: the runtime's workspace camera)")
    rebuild.add_argument("--robot", choices=("floating_gripper", "franka"),
                         default="floating_gripper", help="the scene's robot (default "
                                                          "floating_gripper)")
    rebuild.add_argument("-o", "--output", required=True, type=_path, metavar="SCENE.yaml",
                         help="scene file to write (meshes are written next to it)")
    return parser


def _size(text: str) -> tuple[int, int]:
    """argparse type: `640x480`."""
    width, sep, height = text.lower().partition("x")
    if not sep or not width.isdigit() or not height.isdigit():
        raise argparse.ArgumentTypeError(f"`{shown(text)}` is not WIDTHxHEIGHT, e.g. 640x480")
    return int(width), int(height)


def _path(text: str) -> str:
    if not text.strip():
        raise argparse.ArgumentTypeError("needs a file or folder name")
    return text


def run(args: argparse.Namespace) -> int:
    return _render(args) if args.action == "render" else _from_rgbd(args)


def _render(args: argparse.Namespace) -> int:
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        return fail_usage(f"-o {args.output}: a file, not a folder")
    from rapid_dsl.runtime.gl import RenderError, start_rendering

    try:   # first: mujoco picks its GL back end once, when something first imports it
        start_rendering()
    except RenderError as error:
        return fail_usage(str(error))
    from rapid_dsl.runtime.reconstruction.rgbd import RgbdError, write_frame
    from rapid_dsl.runtime.reconstruction.rgbd_render import CAMERAS, render_frame
    from rapid_dsl.runtime.scenes.world import build_world

    if args.camera not in CAMERAS:
        return fail_usage(f"--camera {args.camera}: no such camera (cameras: "
                          f"{', '.join(CAMERAS)})")
    scene = read_scene(args)
    if isinstance(scene, int):
        return scene
    width, height = args.size
    try:
        frame = render_frame(build_world(scene), args.camera, width=width, height=height)
    except ValueError as error:
        return fail_usage(f"--size {width}x{height}: {error}")
    except RenderError as error:
        return fail_usage(str(error))
    inputs = [args.scene] + [obj.mesh for obj in scene.objects if obj.mesh]
    try:
        files = write_frame(frame, out, inputs=inputs)
    except RgbdError as error:
        _print_error(error)
        return 2
    hidden = sorted(obj.name for obj in scene.objects
                    if obj.kind != "surface" and obj.name not in frame.masks)
    if args.format == "json":
        print(json.dumps({"scene": args.scene, "camera": args.camera, "size": [width, height],
                          "files": [str(f) for f in files], "masks": list(frame.masks),
                          "not_in_view": hidden}, indent=2))
    if not args.quiet:
        masks = ", ".join(frame.masks) or "none"
        print(f"rendered {args.scene} from camera `{args.camera}` ({width}x{height}) to "
              f"{args.output}: rgb.png, depth.png (mm), depth.npy (m), intrinsics.json, "
              f"extrinsics.json, labels.json, masks: {masks}", file=sys.stderr)
        if hidden:
            print(f"not in view (no mask written): {', '.join(hidden)}", file=sys.stderr)
    return 0


def _from_rgbd(args: argparse.Namespace) -> int:
    from rapid_dsl.runtime.reconstruction.rgbd import RgbdError
    from rapid_dsl.runtime.reconstruction.scene import scene_from_rgbd

    try:
        result = scene_from_rgbd(args.rgb, args.depth, args.intrinsics, args.masks, args.output,
                                 labels=args.labels, extrinsics=args.extrinsics,
                                 robot=args.robot)
    except RgbdError as error:
        _print_error(error)
        return 2
    report = result.as_json()
    if args.format == "json":
        print(json.dumps(report, indent=2))
    if not args.quiet:
        print(_summary(report), file=sys.stderr)
    return 0


def _print_error(error: Exception) -> None:
    # located messages (`file:line:column: error: ...`) that may quote file names from a folder
    for line in str(error).splitlines():
        print(shown(line, None), file=sys.stderr)


def _summary(report: dict[str, Any]) -> str:
    support, floor = report["support"], report["floor"]
    size = " x ".join(f"{s:.2f}" for s in support["size"][:2])
    lines = [f"wrote {report['scene']}: support `{support['name']}` at z = "
             f"{_fixed(support['height'], 3)} m ({size} m seen, "
             f"{_fixed(support['tilt_deg'], 1)}deg from level), floor at z = "
             f"{_fixed(floor['height'], 3)} m "
             f"({'seen' if floor['seen'] else 'not seen: assumed'})"]
    rows = [("object", "kind", "shape", "position [m]", "yaw", "size [cm]", "on", "points",
             "free", "surface")]
    for obj in report["objects"]:
        rows.append((obj["name"], obj["kind"], obj["shape"],
                     "[" + ", ".join(_fixed(p, 3) for p in obj["position"]) + "]",
                     f"{_fixed(obj['yaw_deg'], 1)}deg",
                     " x ".join(f"{s * 100:.1f}" for s in obj["size"]), obj["rests_on"],
                     f"{obj['points']} (-{obj['outliers']})", f"{obj['free']:.2f}",
                     f"{obj['surface']:.2f}"))
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    lines += ["  " + "  ".join(cell.ljust(w) for cell, w in zip(row, widths, strict=True))
              .rstrip() for row in rows]
    lines += [f"note: {note}" for note in report["notes"]]
    if report["meshes"]:
        lines.append("meshes: " + ", ".join(report["meshes"]))
    return "\n".join(lines)


def _fixed(value: float, digits: int) -> str:
    """`value` with `digits` decimals, never `-0.0`."""
    return f"{round(value, digits) + 0.0:.{digits}f}"
