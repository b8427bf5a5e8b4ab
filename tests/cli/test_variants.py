"""`rapidc variants`: byte-identical seeded scene files, safe writing, clear errors."""

from __future__ import annotations

import json
import math
import os
import shutil
from pathlib import Path

import pytest

from rapid_dsl.runtime.scenes.scene import load_scene

ROOT = Path(__file__).resolve().parents[2]
SCENE = ROOT / "examples" / "scenes" / "push_box.yaml"

MESH_SCENE = """\
robot: floating_gripper
floor_height: -0.75
objects:
  - {name: table, kind: surface, shape: box, size: [1.0, 1.2, 0.75],
     pose: {position: [0.55, 0.0, -0.375]}}
  - {name: nut, kind: object, shape: mesh, mesh: meshes/hex.obj, size: [0.06, 0.06, 0.03],
     pose: {position: [0.5, 0.1, 0.015]}, mass: 0.1}
  - {name: box, kind: object, shape: box, size: [0.1, 0.08, 0.04],
     pose: {position: [0.6, -0.1, 0.02]}, mass: 0.2}
"""


def hex_prism() -> str:
    ring = [(math.cos(a * math.pi / 3), math.sin(a * math.pi / 3)) for a in range(6)]
    lines = [f"v {x} {y} {z}" for z in (0, 1) for x, y in ring]
    faces = [(1, 2 + i, 3 + i) for i in range(4)] + [(7, 9 + i, 8 + i) for i in range(4)]
    faces += [f for i in range(6) for f in ((1 + i, 1 + (i + 1) % 6, 7 + (i + 1) % 6),
                                            (1 + i, 7 + (i + 1) % 6, 7 + i))]
    return "\n".join(lines + [f"f {a} {b} {c}" for a, b, c in faces]) + "\n"


def files(folder: Path) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes()
            for p in sorted(folder.rglob("*")) if p.is_file()}


def test_the_same_command_writes_the_same_bytes(rapidc, tmp_path: Path):
    first = rapidc("variants", SCENE, "-n", 4, "--seed", 7, "-o", tmp_path / "a")
    assert first.code == 0, first.err
    assert rapidc("variants", SCENE, "-n", 4, "--seed", 7, "-o", tmp_path / "b").code == 0
    written = files(tmp_path / "a")
    assert list(written) == [f"push_box-7-000{i}.yaml" for i in range(4)]
    assert written == files(tmp_path / "b")
    assert len(set(written.values())) == 4
    # another seed gives other files; fewer variants give the same first files
    assert rapidc("variants", SCENE, "-n", 2, "--seed", 8, "-o", tmp_path / "c").code == 0
    assert set(files(tmp_path / "c").values()).isdisjoint(written.values())
    assert rapidc("variants", SCENE, "-n", 2, "--seed", 7, "-o", tmp_path / "d").code == 0
    assert files(tmp_path / "d") == {k: v for k, v in written.items() if k[-6] in "01"}
    assert first.out == ""
    assert first.err.startswith(f"wrote 4 variants of {SCENE} to {tmp_path / 'a'} "
                                "(push_box-7-0000.yaml .. push_box-7-0003.yaml): ")


def test_variants_load_as_scenes_and_vary_the_box(rapidc, tmp_path: Path):
    assert rapidc("variants", SCENE, "-n", 3, "-o", tmp_path, "-q").code == 0
    base = load_scene(SCENE).object("box")
    for path in sorted(tmp_path.glob("*.yaml")):
        box = load_scene(path).object("box")
        assert box.pose.position[:2] != base.pose.position[:2]
        assert abs(box.pose.position[2] - box.extents[2] / 2) < 1e-8   # still on the table


def test_ranges_file_shapes_and_distractors(rapidc, write, tmp_path: Path):
    ranges = write("ranges.yaml", "shapes: [box, cylinder]\ndistractors: [1, 2]\n"
                                  "distractor: {clearance: 3cm}\n")
    result = rapidc("variants", SCENE, "-n", 6, "--seed", 2, "--ranges", ranges,
                    "-o", tmp_path / "out", "--format", "json")
    assert result.code == 0, result.err
    report = json.loads(result.out)
    assert [Path(v["file"]).name for v in report["variants"]] == \
        [f"push_box-2-000{i}.yaml" for i in range(6)]
    shapes = set()
    for entry in report["variants"]:
        scene = load_scene(entry["file"])
        assert 1 <= len(entry["distractors"]) <= 2
        names = [obj.name for obj in scene.objects]
        assert names[:2] == ["table", "box"] and names[2:] == [d["name"] for d in
                                                               entry["distractors"]]
        shapes.add(scene.object("box").shape)
    assert shapes == {"box", "cylinder"}
    assert "shape change" in result.err and "distractor" in result.err


def test_meshes_are_copied_so_the_folder_stands_alone(rapidc, write, tmp_path: Path):
    write("scene/meshes/hex.obj", hex_prism())
    scene = write("scene/nuts.yaml", MESH_SCENE)
    ranges = write("scene/ranges.yaml", "meshes: [meshes/hex.obj]\n"
                                        "objects: {box: {shapes: [mesh]}}\n")
    out = tmp_path / "out"
    result = rapidc("variants", scene, "-n", 2, "--ranges", ranges, "-o", out)
    assert result.code == 0, result.err
    copies = sorted((out / "meshes").iterdir())
    assert len(copies) == 1 and copies[0].read_text() == hex_prism()
    assert "1 mesh copied" in result.err
    moved = tmp_path / "elsewhere"
    shutil.move(str(out), moved)
    shutil.rmtree(tmp_path / "scene")
    for path in sorted(moved.glob("*.yaml")):
        variant = load_scene(path)
        assert variant.object("box").shape == "mesh"
        assert Path(variant.object("nut").mesh).parent == (moved / "meshes").resolve()


def test_meshes_outside_the_scene_folder_need_allow_path(rapidc, write, tmp_path: Path):
    shared = write("shared/hex.obj", hex_prism()).parent
    scene = write("scene/nuts.yaml", MESH_SCENE.replace("meshes/hex.obj", "../shared/hex.obj"))
    refused = rapidc("variants", scene, "-n", 1, "-o", tmp_path / "out")
    assert refused.code == 2 and "objects[1].mesh" in refused.err
    assert not (tmp_path / "out").exists()
    allowed = rapidc("variants", scene, "-n", 1, "-o", tmp_path / "out", "--allow-path", shared)
    assert allowed.code == 0, allowed.err
    variant = load_scene(tmp_path / "out" / "nuts-0-0000.yaml")
    assert Path(variant.object("nut").mesh).parent == (tmp_path / "out" / "meshes").resolve()


@pytest.mark.slow
def test_progress_for_many_variants_and_quiet(rapidc, tmp_path: Path):
    many = rapidc("variants", SCENE, "-n", 50, "-o", tmp_path / "a")
    assert many.code == 0
    lines = many.err.splitlines()
    assert lines[:10] == [f"variants: {5 * k}/50" for k in range(1, 11)]
    assert lines[10].startswith("wrote 50 variants") and len(lines) == 11
    quiet = rapidc("variants", SCENE, "-n", 50, "-o", tmp_path / "b", "--quiet")
    assert (quiet.code, quiet.out, quiet.err) == (0, "", "")


def test_an_output_that_is_a_file_is_refused(rapidc, write):
    target = write("out", "not a folder\n")
    result = rapidc("variants", SCENE, "-n", 1, "-o", target)
    assert (result.code, result.err) == (2, f"rapidc: error: -o {target}: a file, not a folder\n")
    assert target.read_text() == "not a folder\n"


def test_never_writes_through_a_symlink(rapidc, write, tmp_path: Path):
    victim = write("victim.txt", "keep me\n")
    out = tmp_path / "out"
    out.mkdir()
    os.symlink(victim, out / "push_box-0-0000.yaml")
    result = rapidc("variants", SCENE, "-n", 1, "-o", out)
    assert result.code == 2
    assert result.err == (f"rapidc: error: cannot write {out / 'push_box-0-0000.yaml'}: is a "
                          "symbolic link; refusing to write through it\n")
    assert victim.read_text() == "keep me\n"


def test_never_overwrites_an_input(rapidc, write, tmp_path: Path):
    ranges = write("out/push_box-0-0000.yaml", "position: 1cm\n")
    result = rapidc("variants", SCENE, "-n", 1, "--ranges", ranges, "-o", tmp_path / "out")
    assert result.code == 2
    assert "is an input of this command; refusing to overwrite it" in result.err
    assert ranges.read_text() == "position: 1cm\n"


def test_bad_counts_and_seeds_are_usage_errors(rapidc, tmp_path: Path):
    for argv, message in [
        (("-n", 0), "argument -n/--count: must be at least 1"),
        (("-n", "x"), "argument -n/--count: `x` is not an integer"),
        (("-n", 10001), "rapidc: error: -n 10001: at most 10000 variants per run"),
        (("-n", 1, "--seed", -1), "argument --seed: must be at least 0"),
        (("-n", 1, "--seed", 2**63), f"rapidc: error: --seed {2**63}: at most {2**63 - 1}"),
    ]:
        result = rapidc("variants", SCENE, *argv, "-o", tmp_path)
        assert result.code == 2 and message in result.err, (argv, result.err)
    assert list(tmp_path.iterdir()) == []


def test_a_bad_scene_names_its_line(rapidc, write, tmp_path: Path):
    scene = write("bad.yaml", SCENE.read_text().replace("mass: 0.3kg", "mass: 3cm"))
    result = rapidc("variants", scene, "-n", 1, "-o", tmp_path / "out")
    assert result.code == 2
    assert result.err.startswith(f"{scene}:20:11: error: objects[1].mass: `3cm` is a Length, "
                                 "expected a Mass")
    assert not (tmp_path / "out").exists()
    missing = rapidc("variants", tmp_path / "nope.yaml", "-n", 1, "-o", tmp_path / "out")
    assert missing.code == 2 and "nope.yaml:1:1: error: cannot read scene file" in missing.err


def test_a_bad_ranges_file_names_its_line_and_field(rapidc, write, tmp_path: Path):
    ranges = write("ranges.yaml", "position: 1cm\nobjects:\n  table: {yaw: 5deg}\n  box: "
                                  "{mass: 2kg}\n")
    result = rapidc("variants", SCENE, "-n", 1, "--ranges", ranges, "-o", tmp_path / "out")
    assert result.code == 2
    assert result.err.splitlines() == [
        f"{ranges}:4:15: error: objects.box.mass: `2kg` is a Mass, expected a Real"]
    fixture = write("fixture.yaml", "objects:\n  table: {yaw: 5deg}\n")
    result = rapidc("variants", SCENE, "-n", 1, "--ranges", fixture, "-o", tmp_path / "out")
    assert result.err.splitlines() == [
        f"{fixture}:2:3: error: objects.table: `table` is a surface; only objects (kind "
        "`object`) vary"]
    missing = rapidc("variants", SCENE, "-n", 1, "--ranges", tmp_path / "no.yaml", "-o", tmp_path)
    assert missing.code == 2
    assert missing.err == (f"{tmp_path / 'no.yaml'}:1:1: error: cannot read ranges file: no such "
                           "file\n")


@pytest.mark.slow
def test_ranges_that_leave_no_room_are_a_clear_error(rapidc, write, tmp_path: Path):
    ranges = write("ranges.yaml", "distractors: 20\ndistractor: {size: [40cm, 50cm]}\n")
    result = rapidc("variants", SCENE, "-n", 1, "--ranges", ranges, "-o", tmp_path / "out")
    assert result.code == 2
    assert result.err.startswith(f"rapidc: error: {SCENE}: variant 0 of seed 0: every one of 50 "
                                 "draws was rejected")
    assert result.err.rstrip().endswith("narrow the ranges")
    assert "Traceback" not in result.err
