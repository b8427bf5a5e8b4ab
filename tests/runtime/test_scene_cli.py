"""`rapidc run` on hostile scene files: exit status 2 and a located scene error, never exit 3,
never a hang, never the file's content echoed."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from mesh_files import write_obj

from rapid_dsl.cli import main

ROOT = Path(__file__).resolve().parents[2]
PROGRAM = str(ROOT / "examples" / "flip_box.rapid")
FLIP = (ROOT / "examples" / "scenes" / "flip_box.yaml").read_text()
FRANKA = FLIP.replace("robot: floating_gripper", "robot: franka")
BOMB = "x0: &a [1, 1, 1, 1, 1, 1, 1, 1, 1]\n" + "".join(
    f"x{i + 1}: &{chr(98 + i)} [{', '.join(['*' + chr(97 + i)] * 9)}]\n" for i in range(9))
MESH = "shape: mesh\n    mesh: {}"

CASES = {
    "tiny_mass": (FLIP.replace("mass: 0.3kg", "mass: 1e-300"), "objects[2].mass: must lie in"),
    "world": (FLIP.replace("name: wall", "name: world"), "objects[1].name: `world` is reserved"),
    "carriage": (FLIP.replace("name: wall", "name: carriage"), "`carriage` is reserved"),
    "link0": (FRANKA.replace("name: wall", "name: link0"), "`link0` is reserved"),
    "cartesian_ref": (FRANKA.replace("name: wall", "name: cartesian_ref"), "reserved"),
    "huge_integer": (FLIP.replace("mass: 0.3kg", "mass: " + "9" * 401), "is too large"),
    "brackets": (FLIP.replace("label: flat box", "label: " + "[" * 5000 + "]" * 5000),
                 "the YAML nests deeper than 20 levels"),
    "reach": (FRANKA.replace("[0.30, 0.0, 0.10]", "[1.5, 0.0, 0.10]"),
              "gripper_start.position: the hand start [1.5, 0.0, 0.1] is 1.503 m from robot_base"),
    "base": (FRANKA.replace("floor_height", "robot_base: [3, 0, 0]\nfloor_height"),
             "beyond the franka's reach"),
    "floating_reach": (FLIP.replace("[0.30, 0.0, 0.10]", "[1.5, 0.0, 0.10]"),
                       "beyond the floating_gripper's reach of 1 m"),
    "alias_bomb": (BOMB + FLIP, "the YAML has more than 20000 values"),
    "mesh_outside": (FLIP.replace("shape: box\n    size: [14cm, 20cm, 3cm]",
                                  MESH.format("../outside.obj")), "is outside the scene file's"),
    "flat_mesh": (FLIP.replace("shape: box\n    size: [14cm, 20cm, 3cm]", MESH.format("flat.obj")),
                  "objects[2].mesh: the mesh is flat"),
}


@pytest.fixture
def folder(tmp_path: Path) -> Path:
    (tmp_path / "scenes").mkdir()
    write_obj(tmp_path / "outside.obj")
    (tmp_path / "scenes" / "flat.obj").write_text(
        "v 0 0 0\nv 0.1 0 0\nv 0 0.1 0\nv 0.1 0.1 0\nf 1 2 3\nf 2 4 3\n")
    return tmp_path / "scenes"


def run(scene: Path, capsys: pytest.CaptureFixture[str]) -> tuple[int, str]:
    status = main(["run", PROGRAM, "--scene", str(scene), "--samples", "2", "--iterations", "1",
                   "--quiet"])
    out, err = capsys.readouterr()
    assert "internal error" not in out + err and "Traceback" not in out + err
    return status, err


@pytest.mark.parametrize("case", sorted(CASES))
def test_a_hostile_scene_exits_2_with_a_located_error(case: str, folder: Path, capsys):
    text, message = CASES[case]
    scene = folder / f"{case}.yaml"
    scene.write_text(text)
    status, err = run(scene, capsys)
    assert status == 2
    assert err.startswith(f"{scene}:") and ": error: " in err and message in err, err
    assert len(err) < 1000


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_scene_exits_2(folder: Path, capsys):
    os.mkfifo(folder / "fifo.yaml")
    assert run(folder / "fifo.yaml", capsys) == (
        2, f"{folder / 'fifo.yaml'}:1:1: error: cannot read scene file: not a regular file\n")


def test_a_huge_scene_exits_2_without_echoing_it(folder: Path, capsys):
    with (folder / "big.yaml").open("wb") as f:
        f.write(b"robot: " + b"SECRET" * 100)
        f.truncate(1 << 30)
    status, err = run(folder / "big.yaml", capsys)
    assert status == 2 and "larger than the input limit" in err and "SECRET" not in err
