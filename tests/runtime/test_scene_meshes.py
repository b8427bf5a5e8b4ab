"""Mesh objects: paths stay inside the scene's folder tree (or allowed folders), files are read
within bounds, and degenerate meshes are scene errors at the `mesh:` line."""

from __future__ import annotations

import os
import sys
from pathlib import Path

import mujoco
import numpy as np
import pytest
from mesh_files import write_obj

from rapid_dsl.runtime.scenes import meshes
from rapid_dsl.runtime.scenes import schema as scene_schema
from rapid_dsl.runtime.scenes.meshes import MAX_HULL_VERTICES, load_hull
from rapid_dsl.runtime.scenes.scene import SceneError, load_scene
from rapid_dsl.runtime.scenes.world import build_world

SCENE = """\
robot: floating_gripper
objects:
  - name: mug
    kind: object
    shape: mesh
    mesh: {mesh}
    pose: {{position: [0.5, 0, 0.05]}}
    mass: 0.3kg
"""


def scene_file(folder: Path, mesh: str, name: str = "scene.yaml") -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / name
    path.write_text(SCENE.format(mesh=mesh))
    return path


def mesh_problem(path: Path, **kwargs) -> str:
    """The one problem of a scene file, which must be at its `mesh:` line."""
    with pytest.raises(SceneError) as caught:
        load_scene(path, **kwargs)
    (problem,) = caught.value.problems
    assert (problem.line, problem.field) == (6, "objects[0].mesh"), problem
    assert len(str(problem)) < 400 and str(problem).isprintable()
    return problem.message


def write_points(path: Path, points: np.ndarray) -> Path:
    """An .obj of the points (as one triangle fan, so trimesh keeps every vertex)."""
    lines = [f"v {float(x)!r} {float(y)!r} {float(z)!r}" for x, y, z in points]
    lines += [f"f 1 {i} {i + 1}" for i in range(2, len(points))]
    path.write_text("\n".join(lines) + "\n")
    return path


# --- where a mesh may be ---------------------------------------------------------------------

def test_paths_inside_the_scene_folder_tree_load(tmp_path: Path):
    (tmp_path / "meshes").mkdir()
    write_obj(tmp_path / "meshes" / "mug.obj")
    for mesh in ("meshes/mug.obj", "meshes/../meshes/mug.obj", str(tmp_path / "meshes/mug.obj")):
        mug = load_scene(scene_file(tmp_path, mesh)).object("mug")
        assert mug.mesh == str((tmp_path / "meshes" / "mug.obj").resolve())


@pytest.mark.parametrize("mesh", ["../outside.obj", "{outside}", "inner/../../outside.obj"])
def test_paths_leaving_the_scene_folder_are_refused(tmp_path: Path, mesh: str):
    outside = write_obj(tmp_path / "outside.obj")
    path = scene_file(tmp_path / "scene", mesh.format(outside=outside))
    assert mesh_problem(path).endswith("is outside the scene file's folder")


def test_a_symlink_out_of_the_tree_is_refused(tmp_path: Path):
    outside = write_obj(tmp_path / "outside.obj")
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene" / "mug.obj").symlink_to(outside)
    assert "outside" in mesh_problem(scene_file(tmp_path / "scene", "mug.obj"))
    # a link inside the tree to a file inside it is fine
    write_obj(tmp_path / "scene" / "real.obj")
    (tmp_path / "scene" / "alias.obj").symlink_to(tmp_path / "scene" / "real.obj")
    load_scene(scene_file(tmp_path / "scene", "alias.obj"))


def test_allowed_dirs_widen_the_tree(tmp_path: Path):
    shared = tmp_path / "shared"
    shared.mkdir()
    write_obj(shared / "mug.obj")
    (tmp_path / "scene").mkdir()
    (tmp_path / "scene" / "link.obj").symlink_to(shared / "mug.obj")
    for mesh in ("../shared/mug.obj", str(shared / "mug.obj"), "link.obj"):
        path = scene_file(tmp_path / "scene", mesh)
        assert "and the allowed folders" in mesh_problem(path, allowed_dirs=[tmp_path / "other"])
        assert load_scene(path, allowed_dirs=[shared]).object("mug").extents == \
            pytest.approx((0.08, 0.06, 0.1))
        assert load_scene(path, allowed_dirs=[str(shared)]).object("mug").mesh


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="needs FIFOs")
def test_a_fifo_mesh_is_refused_without_blocking(tmp_path: Path):
    os.mkfifo(tmp_path / "mug.obj")
    assert mesh_problem(scene_file(tmp_path, "mug.obj")) == \
        "cannot read the mesh file: not a regular file"


def test_a_huge_mesh_file_is_refused_unread(tmp_path: Path, monkeypatch):
    monkeypatch.setattr(scene_schema, "MAX_MESH_BYTES", 64 << 20)   # the file's own limit first
    with (tmp_path / "mug.stl").open("wb") as f:
        f.truncate(11 << 20)
    assert mesh_problem(scene_file(tmp_path, "mug.stl")).startswith(
        "cannot read the mesh file: larger than the input limit of 10 MiB")


def test_the_scenes_mesh_files_together_stay_within_a_budget(tmp_path: Path, monkeypatch):
    write_obj(tmp_path / "a.obj")
    write_obj(tmp_path / "b.obj", extents=(0.05, 0.05, 0.05))
    size = (tmp_path / "a.obj").stat().st_size
    monkeypatch.setattr(scene_schema, "MAX_MESH_BYTES", size + 10)
    text = SCENE.format(mesh="a.obj") + SCENE.format(mesh="b.obj").split("objects:\n")[1] \
        .replace("name: mug", "name: cup").replace("0.5, 0,", "0.3, 0,")
    (tmp_path / "scene.yaml").write_text(text)
    with pytest.raises(SceneError, match=r"scene.yaml:12:11: error: objects\[1\].mesh: the "
                                         r"scene's mesh files are larger than 0 MiB together"):
        load_scene(tmp_path / "scene.yaml")
    (tmp_path / "scene.yaml").write_text(text.replace("b.obj", "a.obj"))   # the same file twice
    load_scene(tmp_path / "scene.yaml")
    # the budget is checked before a file is read: one past it is refused unparsed
    (tmp_path / "b.obj").write_bytes(b"not a mesh\n" * 100)
    (tmp_path / "scene.yaml").write_text(text)
    with pytest.raises(SceneError) as caught:
        load_scene(tmp_path / "scene.yaml")
    assert [p.message for p in caught.value.problems] == [
        "the scene's mesh files are larger than 0 MiB together"]


@pytest.mark.parametrize("mesh", ["mug.dae", "mug", "mug.obj.exe", "mug\u202e.obj"])
def test_only_obj_stl_and_ply_files_and_plain_paths(tmp_path: Path, mesh: str):
    message = mesh_problem(scene_file(tmp_path, f'"{mesh}"'))
    assert "is not a .obj, .stl, .ply file" in message or "one line of plain text" in message


# --- what a mesh may be ----------------------------------------------------------------------

def test_a_flat_mesh_is_a_scene_error_without_networkx(tmp_path: Path, monkeypatch):
    monkeypatch.setitem(sys.modules, "networkx", None)   # an optional trimesh dependency
    points = np.array([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0.1, 0.1, 0], [0.05, 0.05, 0]])
    write_points(tmp_path / "flat.obj", points)
    assert mesh_problem(scene_file(tmp_path, "flat.obj")) == \
        "the mesh is flat: all its vertices lie in one plane (or on a line)"
    monkeypatch.delitem(sys.modules, "networkx")
    write_obj(tmp_path / "box.obj")
    load_scene(scene_file(tmp_path, "box.obj"))   # a solid mesh needs no networkx either


@pytest.mark.parametrize(("points", "message"), [
    ([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0]], "fewer than 4 vertices"),
    ([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, np.nan]], "not finite numbers (NaN or inf)"),
    ([[0, 0, 0], [0.1, 0, 0], [0, 0.1, 0], [0, 0, np.inf]], "not finite numbers (NaN or inf)"),
    ([[0, 0, 0], [1e7, 0, 0], [0, 0.1, 0], [0, 0, 0.1]], "coordinates beyond 1e+06"),
    ([[0, 0, 0], [0.1, 0.1, 0.1], [0.2, 0.2, 0.2], [0.3, 0.3, 0.3]], "flat"),
    # a needle along the diagonal: its bounding box is a 10 cm cube
    ([[0, 0, 0], [0.1, 0.1, 0.1], [0.001, 0, 0], [0, 0.001, 0], [0, 0, 0.001]], "too thin"),
    ([[0, 0, 0], [80, 0, 0], [0, 60, 0], [0, 0, 100]],
     "the mesh file's extents (its units taken as m) are [80 m, 60 m, 100 m]"),
])
def test_degenerate_meshes(tmp_path: Path, points, message):
    write_points(tmp_path / "bad.obj", np.array(points, dtype=float))
    assert message in mesh_problem(scene_file(tmp_path, "bad.obj"))


def _ball(count: int, seed: int = 0) -> np.ndarray:
    """`count` points on a 5 cm sphere: every one of them is a hull vertex."""
    points = np.random.default_rng(seed).normal(size=(count, 3))
    return points * 0.05 / np.linalg.norm(points, axis=1, keepdims=True)


@pytest.mark.slow
def test_a_hull_with_too_many_vertices_is_thinned(tmp_path: Path):
    from scipy.spatial import ConvexHull

    points = _ball(25_000)   # more than the 20,000 hull vertices once refused
    full = ConvexHull(points)
    hull = load_hull(write_points(tmp_path / "ball.obj", points))
    assert len(hull.vertices) <= MAX_HULL_VERTICES
    # the outermost vertex along each axis is kept: the same extents; the volume nearly all
    assert hull.extents == pytest.approx(np.ptp(points, axis=0), abs=1e-12)
    assert 0.98 * full.volume < ConvexHull(hull.vertices).volume <= full.volume


@pytest.mark.slow
def test_many_large_hulls_make_a_small_model(tmp_path: Path):
    # 5,000 hull vertices each used to go to MuJoCo whole: its compile time and model size grow
    # with them (40 meshes of 19,000 took 37 s and 2.6 GB to bind).
    objects = []
    for i in range(3):
        write_points(tmp_path / f"ball{i}.obj", _ball(5000, seed=i))
        objects.append(SCENE.format(mesh=f"ball{i}.obj").split("objects:\n")[1]
                       .replace("name: mug", f"name: ball{i}")
                       .replace("[0.5, 0, 0.05]", f"[0.5, {0.15 * i - 0.15}, 0.05]"))
    (tmp_path / "scene.yaml").write_text("robot: floating_gripper\nobjects:\n" + "".join(objects))
    model = build_world(load_scene(tmp_path / "scene.yaml")).model
    assert model.nmesh == 3 and model.nmeshvert <= 3 * MAX_HULL_VERTICES
    assert model.nbuffer < 4_000_000   # bytes: 1.9 MB, unthinned 8.1 MB


def test_unreadable_mesh_files_quote_nothing_of_them(tmp_path: Path):
    (tmp_path / "bad.obj").write_text("v 0 0 0\nf 1 2 99999999\nSECRET\n")
    (tmp_path / "bad.ply").write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex "
                                       b"1000000000\nproperty float x\nend_header\nSECRET")
    (tmp_path / "bad.stl").write_bytes(b"SECRET" * 20)
    for name in ("bad.obj", "bad.ply", "bad.stl"):
        message = mesh_problem(scene_file(tmp_path, name))
        assert "SECRET" not in message and "99999999" not in message


def test_an_obj_cannot_make_trimesh_open_other_files(tmp_path: Path, monkeypatch):
    opened: list[str] = []
    real_open = open

    def spy(file, *args, **kwargs):
        opened.append(str(file))
        return real_open(file, *args, **kwargs)

    write_obj(tmp_path / "mug.obj")
    text = (tmp_path / "mug.obj").read_text()
    (tmp_path / "mug.obj").write_text("mtllib /etc/passwd\nusemtl x\n" + text)
    monkeypatch.setattr("builtins.open", spy)
    load_scene(scene_file(tmp_path, "mug.obj"))
    assert not any("passwd" in name for name in opened)


def test_an_irregular_hull_builds_with_its_mass_and_outward_faces(tmp_path: Path):
    rng = np.random.default_rng(3)
    points = rng.uniform(-0.04, 0.04, size=(60, 3)) * [1.0, 0.6, 1.4]
    write_points(tmp_path / "rock.obj", points)
    hull = load_hull(tmp_path / "rock.obj")
    a, b, c = (hull.vertices[hull.faces[:, k]] for k in range(3))
    volume = np.einsum("ij,ij->i", a, np.cross(b, c)).sum() / 6   # > 0 iff faces point out
    assert volume > 0
    world = build_world(load_scene(scene_file(tmp_path, "rock.obj")))
    assert world.model.body("mug").mass[0] == pytest.approx(0.3)
    data = world.make_data()
    mujoco.mj_step(world.model, data, nstep=10)
    assert np.isfinite(data.qpos).all()


def test_hulls_are_cached_by_content(tmp_path: Path):
    write_obj(tmp_path / "m.obj")
    first = load_hull(tmp_path / "m.obj")
    assert load_hull(tmp_path / "m.obj") is first
    write_obj(tmp_path / "m.obj", extents=(0.05, 0.05, 0.05))   # same name, new content
    assert load_hull(tmp_path / "m.obj").extents == pytest.approx([0.05, 0.05, 0.05])
    assert len(meshes._hulls) <= meshes._CACHE_SIZE
