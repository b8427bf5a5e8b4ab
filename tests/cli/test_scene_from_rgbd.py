"""`rapidc scene render` and `rapidc scene from-rgbd` through the real CLI: a frame rendered from
examples/scenes/flip_box.yaml becomes a scene that binds and runs examples/flip_box.rapid to
success, and every kind of bad input is exit 2 with a located message, never a traceback.

Rendering runs in a new process (MuJoCo picks its GL back end once per process, and in-process
commands import it without GL); reconstruction needs no GL and runs in-process.
"""

from __future__ import annotations

import json
import os
import shutil
import struct
import subprocess
import sys
import zlib
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from rapid_dsl.runtime.scenes.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
FLIP = ROOT / "examples" / "scenes" / "flip_box.yaml"


def rapidc_process(*argv: object, gl: str | None = None) -> subprocess.CompletedProcess[str]:
    env = {**os.environ, "MUJOCO_GL": gl or os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run([sys.executable, "-m", "rapid_dsl", *map(str, argv)], cwd=ROOT,
                          env=env, capture_output=True, text=True, timeout=300, check=False)


@pytest.fixture(scope="module")
def rendered(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, str]:
    """flip_box.yaml rendered from the workspace camera: the folder, and render's stderr."""
    folder = tmp_path_factory.mktemp("flip") / "frame"
    run = rapidc_process("scene", "render", FLIP, "-o", folder)
    assert run.returncode == 0, run.stderr
    return folder, run.stderr


@pytest.fixture
def frame(rendered: tuple[Path, str], tmp_path: Path) -> Path:
    """A copy of the rendered frame that a test may spoil."""
    return Path(shutil.copytree(rendered[0], tmp_path / "frame"))


def inputs(folder: Path, **changes: object) -> list[str]:
    """from-rgbd's options for a frame folder; a change replaces one (None drops it)."""
    options = {"rgb": folder / "rgb.png", "depth": folder / "depth.png",
               "intrinsics": folder / "intrinsics.json", "masks": folder / "masks",
               "labels": folder / "labels.json", "extrinsics": folder / "extrinsics.json"}
    options.update(changes)
    return [item for key, value in options.items() if value is not None
            for item in (f"--{key}", str(value))]


@pytest.mark.slow
def test_render_writes_the_frame_files(rendered: tuple[Path, str]):
    folder, stderr = rendered
    assert sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file()) \
        == ["depth.npy", "depth.png", "extrinsics.json", "intrinsics.json", "labels.json",
            "masks/box.png", "masks/wall.png", "rgb.png"]
    assert "from camera `workspace` (640x480)" in stderr and "masks: box, wall" in stderr
    with Image.open(folder / "depth.png") as depth:
        assert (depth.mode, depth.size) == ("I;16", (640, 480))
    assert json.loads((folder / "labels.json").read_text())["wall"] == {"label": "wall",
                                                                        "kind": "fixture"}


@pytest.mark.slow
def test_render_takes_a_camera_and_a_size_and_reports_as_json(tmp_path: Path):
    run = rapidc_process("scene", "render", FLIP, "--camera", "top", "--size", "320x240",
                         "--format", "json", "-o", tmp_path / "top")
    assert run.returncode == 0, run.stderr
    report = json.loads(run.stdout)
    assert (report["camera"], report["size"], report["masks"]) == ("top", [320, 240],
                                                                  ["box", "wall"])
    assert json.loads((tmp_path / "top" / "intrinsics.json").read_text())["width"] == 320


@pytest.mark.parametrize(("argv", "gl", "message"), [
    (["--camera", "ceiling"], None, "--camera ceiling: no such camera (cameras: workspace, "),
    (["--size", "4000x4000"], None, "--size 4000x4000: a frame is 16 to 1920 pixels"),
    ([], "disable", "offscreen rendering is unavailable: MUJOCO_GL=disable"),
], ids=["camera", "size", "no-gl"])
@pytest.mark.slow
def test_render_refuses_bad_options_and_a_missing_gl(tmp_path, argv, gl, message):
    run = rapidc_process("scene", "render", FLIP, *argv, "-o", tmp_path / "out", gl=gl)
    assert run.returncode == 2 and message in run.stderr, run.stderr
    assert not (tmp_path / "out").exists()


def test_render_refuses_a_bad_scene_and_an_output_that_is_a_file(rapidc, tmp_path, write):
    taken = write("taken", "")
    run = rapidc("scene", "render", FLIP, "-o", taken)
    assert (run.code, run.err) == (2, f"rapidc: error: -o {taken}: a file, not a folder\n")
    bad = write("bad.yaml", FLIP.read_text().replace("mass: 0.3kg", "mass: 3cm"))
    run = rapidc_process("scene", "render", bad, "-o", tmp_path / "out")
    assert run.returncode == 2 and "objects[2].mass: `3cm` is a Length" in run.stderr


@pytest.mark.slow
@pytest.mark.parametrize("depth", ["depth.png", "depth.npy"])
def test_a_reconstruction_binds_and_runs_the_flip_strategy(rapidc, frame, tmp_path, depth):
    scene = tmp_path / "out" / "flip.yaml"
    run = rapidc("scene", "from-rgbd", *inputs(frame, depth=frame / depth), "-o", scene)
    assert run.code == 0, run.err
    assert "support `table` at z = 0.000 m" in run.err and "floor at z = -0.75" in run.err
    loaded = load_scene(scene)
    assert [(o.name, o.kind, o.shape) for o in loaded.objects] == [
        ("table", "surface", "box"), ("box", "object", "box"), ("wall", "fixture", "box")]
    assert loaded.object("box").label == "flat box"
    run = rapidc("bind", ROOT / "examples" / "flip_box.rapid", "--scene", scene)
    assert run.code == 0 and "box=box" in run.out and "wall=wall" in run.out, run.out + run.err
    trace = tmp_path / "trace.json"
    run = rapidc("run", ROOT / "examples" / "flip_box.rapid", "--scene", scene, "--seed", "0",
                 "--samples", "24", "--iterations", "3", "--quiet", "--trace", trace)
    result = json.loads(trace.read_text())
    assert run.code == 0 and result["succeeded"], result.get("failure")


@pytest.mark.slow
def test_reconstruction_needs_no_gl(frame, tmp_path):
    run = rapidc_process("scene", "from-rgbd", *inputs(frame), "-o", tmp_path / "s.yaml",
                         gl="bogus")
    assert run.returncode == 0, run.stderr
    assert load_scene(tmp_path / "s.yaml").object("wall").kind == "fixture"


@pytest.mark.slow
def test_the_report_as_json_and_quiet(rapidc, frame, tmp_path):
    run = rapidc("--format", "json", "scene", "from-rgbd", *inputs(frame), "-o",
                 tmp_path / "s.yaml", "--quiet")
    assert run.code == 0 and run.err == ""
    report = json.loads(run.out)
    assert report["scene"] == str(tmp_path / "s.yaml") and report["meshes"] == []
    box = {o["name"]: o for o in report["objects"]}["box"]
    assert box["shape"] == "box" and box["rests_on"] == "table"
    assert np.allclose(box["position"], [0.55, 0.0, 0.015], atol=0.01)
    assert np.allclose(box["size"], [0.14, 0.20, 0.03], rtol=0.1)


@pytest.mark.slow
def test_labels_name_the_support_too(rapidc, frame, tmp_path):
    labels = edit_json(frame / "l.json", '{"table": {"label": "desk", "friction": 0.5}, '
                                         '"box": {"label": "cereal", "mass": "250g"}}')
    run = rapidc("scene", "from-rgbd", *inputs(frame, labels=labels), "-o", tmp_path / "s.yaml")
    assert run.code == 0, run.err
    scene = load_scene(tmp_path / "s.yaml")
    assert (scene.object("table").label, scene.object("table").friction) == ("desk", 0.5)
    assert (scene.object("box").label, scene.object("box").mass) == ("cereal", 0.25)
    assert scene.object("wall").kind == "object"     # no label: masks are objects


def test_without_extrinsics_the_runtimes_camera_is_assumed(rapidc, frame, tmp_path):
    """flip_box's workspace camera looks 7.5 mm above the standard one: the reconstruction is
    that much lower, and otherwise the same."""
    run = rapidc("--format", "json", "scene", "from-rgbd", *inputs(frame, extrinsics=None),
                 "-o", tmp_path / "s.yaml")
    assert run.code == 0, run.err
    report = json.loads(run.out)
    assert abs(report["support"]["height"] + 0.0075) < 0.002
    box = {o["name"]: o for o in report["objects"]}["box"]
    assert np.allclose(box["position"], [0.55, 0.0, 0.0075], atol=0.01)


def png(path: Path, array: np.ndarray) -> Path:
    Image.fromarray(array).save(path)
    return path


def huge_png(path: Path, side: int = 100_000) -> Path:
    """A PNG header claiming side x side pixels (100000: its pixels would take 10 GB)."""
    def chunk(kind: bytes, data: bytes) -> bytes:
        return struct.pack(">I", len(data)) + kind + data + \
            struct.pack(">I", zlib.crc32(kind + data))
    header = struct.pack(">IIBBBBB", side, side, 8, 0, 0, 0, 0)
    path.write_bytes(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", header) + chunk(b"IEND", b""))
    return path


def edit_json(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


def upside_down(frame: Path) -> Path:
    """The camera turned half a turn about its optical axis: the table is no longer level."""
    pose = np.array(json.loads((frame / "extrinsics.json").read_text())["camera_to_world"])
    pose[:3, :2] *= -1
    return edit_json(frame / "turned.json", json.dumps({"camera_to_world": pose.tolist()}))


def nothing_around(frame: Path) -> Path:
    """Depth only inside the masks: nothing to find a support plane in."""
    depth = np.load(frame / "depth.npy")
    masks = [np.asarray(Image.open(p)) > 0 for p in (frame / "masks").glob("*.png")]
    depth[~np.logical_or.reduce(masks)] = np.nan
    np.save(frame / "objects_only.npy", depth)
    return frame / "objects_only.npy"


K = '{\n  "fx": 579.4,\n  "fy": 579.4,\n  "cx": 319.5,\n  "cy": 239.5,\n  "width": 640,\n' \
    '  "height": 480\n}\n'

# case -> (how to spoil the frame: options to change, expected message with {f} the folder)
BAD = {
    "missing rgb": (lambda f: {"rgb": f / "nope.png"}, "{f}/nope.png: error: cannot read: no "
                                                        "such file"),
    "rgb size": (lambda f: {"rgb": png(f / "small.png", np.zeros((240, 320, 3), np.uint8))},
                 "{f}/small.png: error: the image is 320x240 pixels, but {f}/intrinsics.json "
                 "says 640x480"),
    "rgb not an image": (lambda f: {"rgb": edit_json(f / "x.png", "hello")},
                         "{f}/x.png: error: not a readable PNG or JPEG image"),
    "huge image": (lambda f: {"rgb": huge_png(f / "huge.png")},
                   "{f}/huge.png: error: the image has more than 8,294,400 pixels"),
    "large image": (lambda f: {"rgb": huge_png(f / "large.png", 4000)},
                    "{f}/large.png: error: the image is 4000x4000 pixels; at most 8192 per side "
                    "and 8,294,400 in all"),
    "8-bit depth": (lambda f: {"depth": png(f / "d8.png", np.ones((480, 640), np.uint8))},
                    "{f}/d8.png: error: a depth PNG is 16-bit single-channel in millimetres, "
                    "this one is 8-bit"),
    "depth suffix": (lambda f: {"depth": f / "rgb.png.jpg"}, "depth is a 16-bit PNG in "
                                                             "millimetres or a .npy of metres"),
    "pickled depth": (lambda f: {"depth": _pickled(f)}, "{f}/obj.npy: error: not a readable .npy "
                                                        "array (object arrays are refused)"),
    "integer depth": (lambda f: {"depth": _integers(f)}, "{f}/int.npy: error: a depth .npy is a "
                                                         "2-D float array of metres, this one "
                                                         "is int64 with shape [480, 640]"),
    "no depth": (lambda f: {"depth": png(f / "zero.png", np.zeros((480, 640), np.uint16))},
                 "{f}/masks/box.png: error: none of the mask's 2553 pixels has a depth "
                 "measurement"),
    "no plane": (lambda f: {"depth": nothing_around(f)}, "{f}/objects_only.npy: error: no "
                                                         "support plane found: no pixel outside"),
    "upside down": (lambda f: {"extrinsics": upside_down(f)},
                    "{f}/depth.png: error: no support plane found: no level plane (within 10deg"),
    "intrinsics json": (lambda f: {"intrinsics": edit_json(f / "k.json", '{\n  "fx": 1,,\n}')},
                        "{f}/k.json:2:11: error: not JSON: Expecting property name"),
    "intrinsics field": (lambda f: {"intrinsics": edit_json(f / "k.json", K.replace(
        '"cy"', '"k1": 0.1,\n  "cy"'))}, "{f}/k.json:5:3: error: `k1`: unknown field"),
    "intrinsics missing": (lambda f: {"intrinsics": edit_json(f / "k.json", K.replace(
        '  "fx": 579.4,\n', ''))}, "{f}/k.json:1:1: error: `fx` is missing"),
    "intrinsics negative": (lambda f: {"intrinsics": edit_json(f / "k.json", K.replace(
        '"fy": 579.4', '"fy": -5'))}, "{f}/k.json:3:9: error: `fy` must be a positive focal"),
    "intrinsics tiny focal": (lambda f: {"intrinsics": edit_json(f / "k.json", K.replace(
        '"fx": 579.4', '"fx": 1e-308'))}, "{f}/k.json:2:9: error: `fx` must be a positive focal "
                                          "length in pixels giving a horizontal field of view"),
    "intrinsics size": (lambda f: {"intrinsics": edit_json(f / "k.json", K.replace(
        '"width": 640', '"width": 1280'))}, "{f}/rgb.png: error: the image is 640x480 pixels, "
                                            "but {f}/k.json says 1280x480"),
    "extrinsics shape": (lambda f: {"extrinsics": edit_json(f / "t.json", '{"camera_to_world"'
                                                            ': [[1, 0], [0, 1]]}')},
                         "{f}/t.json:1:21: error: `camera_to_world` must be 4 rows of 4 finite"),
    "extrinsics rotation": (lambda f: {"extrinsics": edit_json(f / "t.json", json.dumps(
        {"camera_to_world": [[2, 0, 0, 0], [0, 1, 0, 0], [0, 0, 1, 0], [0, 0, 0, 1]]}))},
        "error: `camera_to_world`: the upper-left 3x3 block is not a rotation"),
    "extrinsics NaN": (lambda f: {"extrinsics": edit_json(f / "t.json", '{"camera_to_world": '
                                                          '[[NaN]]}')},
                       "{f}/t.json:1:23: error: `NaN` is not a finite number"),
    "masks missing": (lambda f: {"masks": f / "none"}, "{f}/none: error: no such folder"),
    "masks empty": (lambda f: {"masks": _folder(f / "empty")}, "{f}/empty: error: no mask: the "
                                                               "folder holds no .png file"),
    "mask empty": (lambda f: {"masks": _mask(f, "box", np.zeros((480, 640), np.uint8))},
                   "{f}/m/box.png: error: the mask is empty (no pixel is set)"),
    "mask size": (lambda f: {"masks": _mask(f, "box", np.ones((48, 64), np.uint8))},
                  "{f}/m/box.png: error: the image is 64x48 pixels, but"),
    "mask name": (lambda f: {"masks": _mask(f, "my box", np.ones((480, 640), np.uint8))},
                  "{f}/m/my box.png: error: `my box` cannot name an object (String should "
                  "match pattern"),
    "mask reserved": (lambda f: {"masks": _mask(f, "gripper", np.ones((480, 640), np.uint8))},
                      "`gripper` cannot name an object (`gripper` is reserved: the scene's own"),
    "mask table": (lambda f: {"masks": _mask(f, "table", np.ones((480, 640), np.uint8))},
                   "{f}/m/table.png: error: the name `table` is the support surface's"),
    "mask link": (lambda f: {"masks": _link(f)}, "{f}/masks/box.png: error: a symbolic link to a "
                                                 "file outside {f}/masks"),
    "labels name": (lambda f: {"labels": edit_json(f / "l.json", '{\n  "bx": "box"\n}')},
                    "{f}/l.json:2:3: error: `bx`: no mask has this name (the names are box, "
                    "table, wall)"),
    "labels kind": (lambda f: {"labels": edit_json(f / "l.json", '{"wall": {"kind": "wal"}}')},
                    "{f}/l.json:1:19: error: `wall.kind`: must be one of object, fixture, "
                    "surface"),
    "labels mass": (lambda f: {"labels": edit_json(f / "l.json", '{"wall": {"kind": "fixture"'
                                                   ', "mass": "3kg"}}')},
                    "`wall.mass`: a fixture is static; `mass` only applies to objects"),
    "labels unit": (lambda f: {"labels": edit_json(f / "l.json", '{"box": {"mass": "3cm"}}')},
                    "{f}/l.json:1:18: error: `box.mass`: `3cm` is a Length, expected a Mass"),
    "labels twice": (lambda f: {"labels": edit_json(f / "l.json", '{"box": "a",\n "box": "b"}')},
                     "{f}/l.json:2:2: error: `box` is given twice"),
    "labels support": (lambda f: {"labels": edit_json(f / "l.json", '{"table": {"mass": 1}}')},
                       "{f}/l.json:1:12: error: `table.mass`: `table` is the support, a surface"),
    "labels field": (lambda f: {"labels": edit_json(f / "l.json", '{"box": {"colour": 1}}')},
                     "{f}/l.json:1:10: error: `box.colour`: unknown field (the fields are"),
}


def _pickled(folder: Path) -> Path:
    np.save(folder / "obj.npy", np.array([{"a": 1}], dtype=object), allow_pickle=True)
    return folder / "obj.npy"


def _integers(folder: Path) -> Path:
    np.save(folder / "int.npy", np.ones((480, 640), dtype=np.int64))
    return folder / "int.npy"


def _folder(path: Path) -> Path:
    path.mkdir()
    (path / "notes.txt").write_text("not a mask")
    return path


def _mask(folder: Path, name: str, array: np.ndarray) -> Path:
    """A masks folder with the frame's masks and one more (or a replaced one)."""
    masks = Path(shutil.copytree(folder / "masks", folder / "m"))
    png(masks / f"{name}.png", array * 255)
    return masks


def _link(folder: Path) -> Path:
    outside = folder.parent / "outside.png"
    shutil.move(folder / "masks" / "box.png", outside)
    (folder / "masks" / "box.png").symlink_to(outside)
    return folder / "masks"


@pytest.mark.parametrize("case", sorted(BAD))
def test_bad_input_is_exit_2_with_a_located_message(rapidc, frame, tmp_path, case):
    spoil, expected = BAD[case]
    changes = spoil(frame)
    run = rapidc("scene", "from-rgbd", *inputs(frame, **changes), "-o", tmp_path / "s.yaml")
    assert run.code == 2, run.err
    assert expected.format(f=frame) in run.err, run.err
    assert "internal error" not in run.err and "Traceback" not in run.err
    assert not (tmp_path / "s.yaml").exists()


@pytest.mark.slow
def test_outputs_that_cannot_be_written_are_refused(rapidc, frame, tmp_path):
    run = rapidc("scene", "from-rgbd", *inputs(frame), "-o", frame / "labels.json")
    assert run.code == 2
    assert f"{frame}/labels.json: error: cannot write: is an input of this command" in run.err
    run = rapidc("scene", "from-rgbd", *inputs(frame), "-o", frame)
    assert run.code == 2 and f"{frame}: error: cannot write: is a folder" in run.err
    (tmp_path / "link.yaml").symlink_to(tmp_path / "elsewhere.yaml")
    run = rapidc("scene", "from-rgbd", *inputs(frame), "-o", tmp_path / "link.yaml")
    assert run.code == 2 and "is a symbolic link; refusing to write through it" in run.err
    assert not (tmp_path / "elsewhere.yaml").exists()
