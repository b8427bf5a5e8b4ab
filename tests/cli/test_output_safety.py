"""No data loss on output, no reading outside the project on input, through the real CLI.

Outputs (`compile -o`, `fmt -w`, `bench --json`) are written atomically, never through a symlink
rapidc did not create, never over an input; `fmt -w` writes through a symlink to the program it
read. Inputs are regular files within the size limit; a folder's files may not link out of it;
`--allow-path DIR` widens both that and `use` paths. GitHub annotations cannot be forged by a file
name.
"""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from rapid_dsl.frontend.formatter import format_source
from rapid_dsl.language.diagnostics import github_command

from .programs import CLEAN

MESSY = CLEAN.replace("  goal", "goal")
FORMATTED = format_source(CLEAN, "x")[0]
SECRET = "root:x:0:0:root:/root:/bin/bash"
RELATION = "relation near(a: Body, b: Body) = distance(a, b) < 1cm\n"


def _listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


# ------------------------------------------------------------------------------ compile -o

def test_compile_refuses_to_write_through_a_symlink(rapidc, write, tmp_path):
    """Regression: `compile -o` followed a symlink at DIR/<stem>.py and overwrote its target."""
    program = write("prog.rapid", CLEAN)
    victim = write("victim.txt", "keep me")
    out = tmp_path / "out"
    out.mkdir()
    (out / "prog.py").symlink_to(victim)
    run = rapidc("compile", program, "-o", out)
    assert run.code == 2
    assert run.err == (f"rapidc: error: cannot write {out / 'prog.py'}: is a symbolic link; "
                       "refusing to write through it\n")
    assert victim.read_text() == "keep me" and (out / "prog.py").is_symlink()
    assert _listing(out) == ["prog.py"]


def test_compile_never_overwrites_its_own_program(rapidc, write, tmp_path):
    """Regression: a program named x.py compiled into its own folder replaced itself."""
    program = write("x.py", CLEAN)
    run = rapidc("compile", program, "-o", tmp_path)
    assert run.code == 2
    assert "is an input of this command; refusing to overwrite it" in run.err
    assert program.read_text() == CLEAN


def test_compile_never_overwrites_a_file_the_program_uses(rapidc, write, tmp_path):
    write("lib/near.rapid", RELATION)
    program = write("main.rapid", 'use "lib/near.rapid"\n' + CLEAN)
    out = tmp_path / "out"
    out.mkdir()
    os.link(tmp_path / "lib" / "near.rapid", out / "main.py")   # the output name, hard-linked
    run = rapidc("compile", program, "-o", out)
    assert run.code == 2 and "is an input of this command" in run.err
    assert (tmp_path / "lib" / "near.rapid").read_text() == RELATION


def test_compile_replaces_an_old_output_atomically_keeping_its_mode(rapidc, write, tmp_path):
    program = write("prog.rapid", CLEAN)
    old = write("out/prog.py", "old module")
    old.chmod(0o600)
    run = rapidc("compile", program, "-o", tmp_path / "out")
    assert run.code == 0, run.err
    assert 'PROGRAM = RT.Program(path="prog.rapid"' in old.read_text()
    assert stat.S_IMODE(old.stat().st_mode) == 0o600
    assert _listing(tmp_path / "out") == ["prog.py"]


# ---------------------------------------------------------------------------------- fmt -w

def test_fmt_write_goes_through_a_symlink_and_keeps_it(rapidc, write, tmp_path):
    """Regression: `fmt -w` replaced a symlink by a regular file."""
    real = write("real/prog.rapid", MESSY)
    real.chmod(0o640)
    link = tmp_path / "prog.rapid"
    link.symlink_to(Path("real") / "prog.rapid")
    run = rapidc("fmt", "-w", link)
    assert run.code == 0, run.err
    assert link.is_symlink() and os.readlink(link) == os.path.join("real", "prog.rapid")
    assert real.read_text() == FORMATTED
    assert stat.S_IMODE(real.stat().st_mode) == 0o640
    assert _listing(tmp_path / "real") == ["prog.rapid"]


def test_fmt_write_refuses_a_hard_linked_file(rapidc, write, tmp_path):
    """Regression: `fmt -w` silently broke hard links (the other name kept the old text)."""
    path = write("prog.rapid", MESSY)
    other = tmp_path / "same.rapid.bak"
    os.link(path, other)
    run = rapidc("fmt", "-w", path)
    assert run.code == 2
    assert run.err.startswith(f"rapidc: error: cannot write {path}: it has 2 hard links")
    assert path.read_text() == MESSY and other.read_text() == MESSY
    assert os.stat(path).st_ino == os.stat(other).st_ino
    assert rapidc("fmt", "--check", path).code == 1    # --check reads, it is fine


def test_a_bom_is_unformatted_and_write_drops_it(rapidc, write):
    path = write("prog.rapid", "")
    path.write_bytes(b"\xef\xbb\xbf" + FORMATTED.encode())
    assert rapidc("check", path).code == 0          # the parser accepts it
    assert rapidc("fmt", "--check", path).code == 1
    assert rapidc("fmt", "-w", path).code == 0
    assert path.read_bytes() == FORMATTED.encode()


# ------------------------------------------------------------------- annotations for GitHub

@pytest.mark.parametrize("name", ["evil\n::warning::forged.rapid", "a%0Ab,c::d.rapid",
                                  "cr\rx.rapid"])
def test_fmt_check_github_escapes_file_names(name, rapidc, tmp_path):
    """Regression: `fmt --check --format github` printed file names as they were, so a name with a
    line break or `::` could start a workflow command of its own."""
    path = tmp_path / name
    path.write_text(MESSY)
    run = rapidc("fmt", "--check", "--format", "github", path)
    assert run.code == 1
    lines = run.out.split("\n")
    assert lines[1:] == [""] and lines[0].startswith("::error file=")
    assert "\r" not in lines[0]
    # The first `::` ends the properties (`:` is escaped in them); in the message it is text.
    props, message = lines[0][len("::error "):].split("::", 1)
    assert props.count(",") == 1                      # file=...,title=...
    assert _unescape(props.split(",")[0][len("file="):]) == str(path)
    assert _unescape(message).startswith(f"{path} is not formatted")


def test_check_github_escapes_file_names_the_same_way(rapidc, tmp_path):
    path = tmp_path / "x\n::error::y.rapid"
    path.write_text(CLEAN.replace("/ 1cm", "/ 1"))   # a cost that is not dimensionless
    run = rapidc("check", "--format", "github", path)
    assert run.code == 1
    assert run.out.count("\n") == 1 and "file=" + _escape_property(str(path)) in run.out


def _escape_property(text: str) -> str:
    return (text.replace("%", "%25").replace("\r", "%0D").replace("\n", "%0A")
            .replace(":", "%3A").replace(",", "%2C"))


def _unescape(text: str) -> str:
    for escaped, plain in (("%0D", "\r"), ("%0A", "\n"), ("%3A", ":"), ("%2C", ","),
                           ("%25", "%")):
        text = text.replace(escaped, plain)
    return text


@pytest.mark.slow
@given(st.text(), st.text())
def test_a_workflow_command_is_one_line_whatever_its_text(name: str, message: str):
    line = github_command("error", [("file", name), ("title", "rapidc fmt")], message)
    assert "\n" not in line and "\r" not in line
    props, rest = line[len("::error "):].split("::", 1)
    file_value, title = props.split(",")
    assert _unescape(file_value[len("file="):]) == name and title == "title=rapidc fmt"
    assert _unescape(rest) == message


# ------------------------------------------------------------------------------------ inputs

@pytest.mark.parametrize("command", [["check"], ["lint"], ["fmt"], ["compile", "-o", "-"]])
@pytest.mark.parametrize("kind, reason", [
    ("fifo", "not a regular file"),
    ("device", "not a regular file"),
    ("too large", "larger than the input limit of 10 MiB (10,485,761 bytes)"),
])
def test_inputs_that_are_not_small_regular_files_exit_2(command, kind, reason, rapidc,
                                                        tmp_path):
    if kind == "device":
        path = Path("/dev/zero")
    else:
        path = tmp_path / "x.rapid"
        if kind == "fifo":
            os.mkfifo(path)
        else:
            with open(path, "wb") as f:
                f.truncate(10 * 1024 * 1024 + 1)
    run = rapidc(command[0], path, *command[1:])
    assert run.code == 2
    assert run.err.startswith(f"rapidc: error: {path}: {reason}\n")
    assert run.out == ""


def test_a_folder_given_as_a_program_exits_2(rapidc, tmp_path):
    run = rapidc("compile", tmp_path, "-o", "-")
    assert run.code == 2 and run.err == f"rapidc: error: {tmp_path}: is a folder\n"


@pytest.fixture
def linked_out(write, tmp_path):
    """programs/ holds ok.rapid and evil.rapid, a symlink to a file outside it."""
    write("outside/passwd.rapid", SECRET + "\n")
    write("programs/ok.rapid", FORMATTED)
    (tmp_path / "programs" / "evil.rapid").symlink_to(tmp_path / "outside" / "passwd.rapid")
    return tmp_path


@pytest.mark.parametrize("command", [["check"], ["lint"], ["fmt", "--check"], ["fmt", "-w"]])
def test_a_folder_may_not_link_out_of_itself(command, rapidc, linked_out):
    folder = linked_out / "programs"
    run = rapidc(*command, folder)
    assert run.code == 2
    assert run.err == (f"rapidc: error: {folder / 'evil.rapid'}: a symbolic link to a file "
                       f"outside {folder} (name the file itself, or allow its folder with "
                       "--allow-path DIR)\n")
    assert SECRET not in run.out + run.err
    allowed = rapidc(*command, "--allow-path", linked_out / "outside", folder)
    assert allowed.code == 1                       # read: it is not a program
    named = rapidc(*command, folder / "evil.rapid")  # named on the command line: taken
    assert named.code == 1


# ---------------------------------------------------------------------------- --allow-path

def test_allow_path_opens_use_paths_for_check_lint_and_compile(rapidc, write, tmp_path):
    write("shared/near.rapid", RELATION)
    program = write("project/main.rapid", 'use "../shared/near.rapid"\n' + CLEAN)
    run = rapidc("check", program)
    assert run.code == 1 and "error[E0216]" in run.out and "--allow-path DIR" in run.out
    for command in (["check"], ["lint"], ["compile", "-o", "-"]):
        run = rapidc(*command, "--allow-path", tmp_path / "shared", program)
        assert run.code == 0, run.out + run.err
    again = rapidc("check", program, "--allow-path", tmp_path / "project",
                   "--allow-path", tmp_path / "shared")
    assert again.code == 0


def test_allow_path_must_be_a_folder(rapidc, write, tmp_path):
    program = write("main.rapid", CLEAN)
    run = rapidc("check", "--allow-path", tmp_path / "nope", program)
    assert run.code == 2
    assert f"--allow-path: `{tmp_path / 'nope'}` is not a folder" in run.err


# ------------------------------------------------------------------------------ bench --json

@pytest.mark.slow
def test_bench_json_refuses_a_symlink(rapidc, write, tmp_path):
    victim = write("victim.txt", "keep me")
    link = tmp_path / "bench.json"
    link.symlink_to(victim)
    run = rapidc("bench", "primitives", "--primitive", "push", "--json", link)
    assert run.code == 2
    assert f"cannot write {link}: is a symbolic link" in run.err
    assert victim.read_text() == "keep me"
    real = tmp_path / "real.json"
    assert rapidc("bench", "primitives", "--primitive", "push", "--json", real).code == 0
    assert real.read_text().startswith("[")


# ------------------------------------------------- files below an output folder, and --html
# Only the folder named on the command line is the user's: the folders rapidc makes below it are
# walked without following a symbolic link, and no output replaces any input.

ROOT = Path(__file__).resolve().parents[2]
PUSH = ROOT / "examples" / "push_box.rapid"
PUSH_SCENE = ROOT / "examples" / "scenes" / "push_box.yaml"
SMALL = ("--samples", "8", "--iterations", "1")


def _tree(folder: Path) -> dict[str, bytes | str]:
    """Every entry under `folder`, no link followed: a file's bytes, a link's target."""
    return {p.relative_to(folder).as_posix(): os.readlink(p) if p.is_symlink()
            else p.read_bytes() if p.is_file() else "folder"
            for p in sorted(folder.rglob("*"))}


@pytest.fixture
def elsewhere(tmp_path):
    """A folder outside every output folder, holding one file, for links to point at."""
    folder = tmp_path / "elsewhere"
    folder.mkdir()
    (folder / "keep.txt").write_text("keep me")
    return folder


def test_variants_will_not_write_meshes_through_a_linked_meshes_folder(rapidc, write, tmp_path,
                                                                       elsewhere):
    """Regression: `variants -o vout` wrote vout/meshes/mesh-*.obj through a `meshes` symlink
    to any folder, then stopped with an internal error (exit 3)."""
    from .test_variants import MESH_SCENE, hex_prism

    write("scene/meshes/hex.obj", hex_prism())
    scene = write("scene/nuts.yaml", MESH_SCENE)
    inputs = _tree(tmp_path / "scene")
    out = tmp_path / "vout"
    out.mkdir()
    (out / "meshes").symlink_to(elsewhere)
    run = rapidc("variants", scene, "-n", 2, "-o", out)
    assert run.code == 2, run.err
    assert run.err.startswith(f"rapidc: error: cannot write {out / 'meshes'}/mesh-")
    assert run.err.endswith(f": {out / 'meshes'}: is a symbolic link; refusing to write "
                            "through it\n")
    assert _tree(elsewhere) == {"keep.txt": b"keep me"}
    assert _tree(out) == {"meshes": str(elsewhere)} and _tree(tmp_path / "scene") == inputs


@pytest.mark.slow
def test_scene_render_will_not_write_masks_through_a_linked_masks_folder(tmp_path, elsewhere):
    """Regression: `scene render -o rend` wrote rend/masks/<object>.png (the name from the
    scene) through a `masks` symlink."""
    from .test_scene_from_rgbd import FLIP, rapidc_process

    out = tmp_path / "rend"
    out.mkdir()
    (out / "masks").symlink_to(elsewhere)
    scene = FLIP.read_bytes()
    run = rapidc_process("scene", "render", FLIP, "-o", out)
    assert run.returncode == 2, run.stderr
    assert run.stderr == (f"{out / 'masks'}: error: is a symbolic link; refusing to write "
                          "through it\n")
    assert _tree(elsewhere) == {"keep.txt": b"keep me"} and FLIP.read_bytes() == scene
    assert "masks" in _tree(out) and not any(name.startswith("masks/") for name in _tree(out))


def test_bench_will_not_write_scenes_through_a_linked_scenes_folder(rapidc, tmp_path,
                                                                   elsewhere):
    """Regression: `bench nonprehensile --out b` wrote b/scenes/t1-000.yaml through a `scenes`
    symlink. Now refused before any scene is drawn or run."""
    out = tmp_path / "b"
    out.mkdir()
    (out / "scenes").symlink_to(elsewhere)
    run = rapidc("bench", "nonprehensile", "--tasks", "T1", "--scenes", 1, "--trials", 1,
                 "--out", out, "--samples", 4, "--iterations", 1)
    assert run.code == 2, run.err
    assert run.err == (f"rapidc: error: --out {out}: {out / 'scenes'}: is a symbolic link; "
                       "refusing to write through it\n")
    assert _tree(elsewhere) == {"keep.txt": b"keep me"}
    assert _tree(out) == {"scenes": str(elsewhere)}


@pytest.mark.parametrize("page", ["ranges.yaml", "lib/near.rapid"])
def test_verify_html_will_not_replace_the_ranges_or_a_used_file(rapidc, write, tmp_path, page):
    """Regression: `verify --html` onto the ranges file or a file the program uses replaced it
    with the page after the whole run. Now refused before anything runs."""
    write("lib/near.rapid", RELATION)
    program = write("main.rapid", 'use "lib/near.rapid"\n' + PUSH.read_text())
    write("ranges.yaml", "{}\n")
    before = _tree(tmp_path)
    run = rapidc("verify", program, "--scene", PUSH_SCENE, "--ranges", tmp_path / "ranges.yaml",
                 "--variants", 1, *SMALL, "--html", tmp_path / page)
    assert run.code == 2, run.err
    assert run.err.startswith(f"rapidc: error: --html {tmp_path / page}: it is one of the "
                              "inputs (")
    assert "verify:" not in run.err            # nothing ran
    assert _tree(tmp_path) == before
