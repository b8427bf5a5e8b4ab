"""`rapidc run --trace/--video/--keyframes`: written atomically, never through a symlink, never
over the program, a file it uses or the scene; `--allow-path` reaches `use`d files elsewhere."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest
from mesh_files import write_obj

from rapid_dsl.cli import main

DATA = Path(__file__).resolve().parents[1] / "data" / "run"
FAST = ["--entry", "shove", "--arg", "displacement=[6cm, 0cm, 0cm]", "--samples", "8",
        "--iterations", "1", "--quiet"]


@pytest.fixture
def project(tmp_path: Path) -> Path:
    shutil.copy(DATA / "shove.rapid", tmp_path / "shove.rapid")
    shutil.copy(DATA / "tabletop.yaml", tmp_path / "tabletop.yaml")
    return tmp_path


def run(project: Path, capsys, *extra: object) -> tuple[int, str]:
    status = main(["run", str(project / "shove.rapid"), "--scene", str(project / "tabletop.yaml"),
                   *FAST, *map(str, extra)])
    return status, capsys.readouterr().err


def test_trace_is_never_written_through_a_symlink(project: Path, capsys) -> None:
    victim = project / "victim.txt"
    victim.write_text("keep me")
    (project / "trace.json").symlink_to(victim)
    status, err = run(project, capsys, "--trace", project / "trace.json")
    assert status == 2
    assert f"cannot write trace {project / 'trace.json'}: is a symbolic link" in err
    assert victim.read_text() == "keep me"


@pytest.mark.parametrize("name", ["shove.rapid", "tabletop.yaml"])
def test_trace_is_never_written_over_the_program_or_the_scene(name: str, project: Path,
                                                              capsys) -> None:
    before = (project / name).read_text()
    status, err = run(project, capsys, "--trace", project / name)
    assert status == 2 and "is an input of this command; refusing to overwrite it" in err
    assert (project / name).read_text() == before


def test_trace_replaces_an_old_trace_and_leaves_no_temporary(project: Path, capsys) -> None:
    (project / "out").mkdir()
    (project / "out" / "trace.json").write_text("old")
    status, err = run(project, capsys, "--trace", project / "out" / "trace.json")
    assert status == 0, err
    assert (project / "out" / "trace.json").read_text().startswith("{")
    assert [p.name for p in (project / "out").iterdir()] == ["trace.json"]


@pytest.mark.slow
def test_video_and_key_frames_refuse_inputs_and_symlinks(project: Path, capsys) -> None:
    keys = project / "keys"
    keys.mkdir()
    victim = project / "victim.txt"
    victim.write_text("keep me")
    (keys / "frame_0000.png").symlink_to(victim)
    scene = (project / "tabletop.yaml").read_text()
    os.link(project / "tabletop.yaml", project / "scene.mp4")   # the scene under a video's name
    status, err = run(project, capsys, "--video", project / "scene.mp4", "--keyframes", keys)
    if "rendering is unavailable" in err or "no display" in err:
        pytest.skip(f"no offscreen GL here: {err}")
    assert status == 2
    assert f"cannot write video `{project / 'scene.mp4'}`: is an input of this command" in err
    assert f"cannot write key frame `{keys / 'frame_0000.png'}`: is a symbolic link" in err
    assert (project / "tabletop.yaml").read_text() == scene
    assert victim.read_text() == "keep me"
    assert sorted(p.name for p in project.iterdir()) == ["keys", "scene.mp4", "shove.rapid",
                                                         "tabletop.yaml", "victim.txt"]


def test_allow_path_reaches_a_used_file_elsewhere(tmp_path: Path, capsys) -> None:
    (tmp_path / "lib").mkdir()
    (tmp_path / "project").mkdir()
    shutil.copy(DATA / "shove.rapid", tmp_path / "lib" / "shove.rapid")
    shutil.copy(DATA / "tabletop.yaml", tmp_path / "project" / "tabletop.yaml")
    (tmp_path / "project" / "main.rapid").write_text('use "../lib/shove.rapid"\n')
    argv = ["run", str(tmp_path / "project" / "main.rapid"), "--scene",
            str(tmp_path / "project" / "tabletop.yaml"), *FAST]
    assert main(argv) == 2
    out, err = capsys.readouterr()
    assert "error[E0216]" in err
    assert main([*argv, "--allow-path", str(tmp_path / "lib")]) == 0


def test_allow_path_reaches_a_scene_mesh_elsewhere(tmp_path: Path, capsys) -> None:
    project, meshes = tmp_path / "project", tmp_path / "meshes"
    meshes.mkdir()
    project.mkdir()
    shutil.copy(DATA / "shove.rapid", project / "shove.rapid")
    write_obj(meshes / "puck.obj", extents=(0.06, 0.06, 0.03), offset=(0.0, 0.0, 0.0))
    (project / "tabletop.yaml").write_text((DATA / "tabletop.yaml").read_text().replace(
        "    shape: cylinder\n    size: [6cm, 3cm]\n",
        "    shape: mesh\n    mesh: ../meshes/puck.obj\n"))
    status, err = run(project, capsys)
    assert status == 2 and "mesh" in err, err
    status, err = run(project, capsys, "--allow-path", meshes)
    assert status == 0, err
