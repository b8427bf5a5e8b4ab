"""language/files.py: bounded reading of regular files, atomic writes, folder-tree containment."""

from __future__ import annotations

import os
import stat
from pathlib import Path

import pytest

from rapid_dsl.language.files import (
    MAX_INPUT_BYTES,
    FileProblem,
    inside,
    read_bytes,
    read_text,
    replacing,
    write_atomic,
)


def _listing(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


# ----------------------------------------------------------------------------------- reading

def test_reads_a_regular_file_and_drops_a_bom(tmp_path: Path) -> None:
    path = tmp_path / "a.rapid"
    path.write_bytes(b"\xef\xbb\xbfuse stdlib.push\n")
    assert read_text(path) == "use stdlib.push\n"
    assert read_bytes(path) == b"\xef\xbb\xbfuse stdlib.push\n"


@pytest.mark.parametrize("kind, reason", [
    ("missing", "no such file"),
    ("folder", "is a folder"),
    ("fifo", "not a regular file"),
    ("device", "not a regular file"),
    ("too large", "larger than the input limit of 10 MiB (10,485,761 bytes)"),
    ("not utf-8", "not UTF-8 text"),
])
def test_refuses_what_is_not_a_small_regular_text_file(kind: str, reason: str,
                                                       tmp_path: Path) -> None:
    path = tmp_path / "x.rapid"
    if kind == "folder":
        path.mkdir()
    elif kind == "fifo":
        os.mkfifo(path)          # reading it would block forever: it must not be opened blocking
    elif kind == "device":
        path = Path("/dev/zero")  # endless: reading it would exhaust memory
    elif kind == "too large":
        with open(path, "wb") as f:
            f.truncate(MAX_INPUT_BYTES + 1)
    elif kind == "not utf-8":
        path.write_bytes(b"\xff\xfe")
    with pytest.raises(FileProblem) as caught:
        read_text(path)
    assert str(caught.value) == reason


def test_a_limit_of_its_own(tmp_path: Path) -> None:
    path = tmp_path / "x.yaml"
    path.write_text("x" * 2000)
    with pytest.raises(FileProblem, match=r"larger than the input limit of 1 KiB \(2,000 bytes\)"):
        read_text(path, limit=1024)


# ------------------------------------------------------------------------------- containment

def test_inside_resolves_symlinks_and_dot_dot(tmp_path: Path) -> None:
    project, other = tmp_path / "project", tmp_path / "other"
    (project / "lib").mkdir(parents=True)
    other.mkdir()
    (other / "secret.rapid").write_text("")
    (project / "lib" / "out.rapid").symlink_to(other / "secret.rapid")
    assert inside(project / "lib" / "a.rapid", [project])
    assert inside(project, [project])
    assert not inside(project / ".." / "other" / "secret.rapid", [project])
    assert not inside(project / "lib" / "out.rapid", [project])
    assert inside(project / "lib" / "out.rapid", [project, other])
    assert not inside(tmp_path / "project2" / "a.rapid", [project])   # a prefix is not a folder


# ----------------------------------------------------------------------------------- writing

def test_writes_a_new_file_with_the_umask_and_no_temporary_left(tmp_path: Path) -> None:
    target = tmp_path / "out.py"
    assert write_atomic(target, "x = 1\n") == target
    assert target.read_text() == "x = 1\n"
    umask = os.umask(0)
    os.umask(umask)
    assert stat.S_IMODE(target.stat().st_mode) == 0o644 & ~umask
    assert _listing(tmp_path) == ["out.py"]


def test_replacing_keeps_the_mode(tmp_path: Path) -> None:
    target = tmp_path / "out.py"
    target.write_text("old")
    target.chmod(0o600)
    write_atomic(target, "new")
    assert target.read_text() == "new" and stat.S_IMODE(target.stat().st_mode) == 0o600


def test_a_symlink_is_refused_and_its_target_untouched(tmp_path: Path) -> None:
    victim = tmp_path / "victim"
    victim.write_text("keep")
    link = tmp_path / "out.py"
    link.symlink_to(victim)
    with pytest.raises(FileProblem, match="is a symbolic link; refusing to write through it"):
        write_atomic(link, "x")
    assert victim.read_text() == "keep" and link.is_symlink()
    assert _listing(tmp_path) == ["out.py", "victim"]


def test_through_links_writes_the_target_and_keeps_the_link(tmp_path: Path) -> None:
    (tmp_path / "real").mkdir()
    real = tmp_path / "real" / "p.rapid"
    real.write_text("old")
    real.chmod(0o640)
    link = tmp_path / "p.rapid"
    link.symlink_to(Path("real") / "p.rapid")
    assert write_atomic(link, "new", through_links=True) == real
    assert link.is_symlink() and real.read_text() == "new"
    assert stat.S_IMODE(real.stat().st_mode) == 0o640


def test_an_input_is_never_overwritten_by_any_name(tmp_path: Path) -> None:
    program = tmp_path / "x.py"
    program.write_text("the program")
    hard = tmp_path / "hard.py"
    os.link(program, hard)
    for target in (program, hard):
        with pytest.raises(FileProblem, match="is an input of this command"):
            write_atomic(target, "generated", inputs=[str(program)])
    assert program.read_text() == "the program"
    write_atomic(tmp_path / "other.py", "ok", inputs=[str(program), str(tmp_path / "missing")])


@pytest.mark.parametrize("kind", ["folder", "fifo"])
def test_only_a_regular_file_is_replaced(kind: str, tmp_path: Path) -> None:
    target = tmp_path / "out"
    target.mkdir() if kind == "folder" else os.mkfifo(target)
    with pytest.raises(FileProblem, match="is a folder" if kind == "folder"
                       else "not a regular file"):
        write_atomic(target, "x")


def test_text_that_cannot_be_encoded_leaves_no_file(tmp_path: Path) -> None:
    """Regression: `compile -o` left a 0-byte file when encoding failed half way."""
    target = tmp_path / "out.py"
    with pytest.raises(FileProblem, match="cannot be encoded as UTF-8"):
        write_atomic(target, "goal = '\ud800'\n")
    assert _listing(tmp_path) == []
    target.write_text("old")
    with pytest.raises(FileProblem):
        write_atomic(target, "\udfff")
    assert target.read_text() == "old"


def test_a_failed_rename_leaves_the_old_file_and_no_temporary(tmp_path: Path,
                                                              monkeypatch) -> None:
    target = tmp_path / "out.json"
    target.write_text("old")

    def refuse(*args: object, **kwargs: object) -> None:
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr("rapid_dsl.language.files.os.replace", refuse)
    with pytest.raises(FileProblem, match="Permission denied"):
        write_atomic(target, "new")
    assert target.read_text() == "old" and _listing(tmp_path) == ["out.json"]


def test_a_missing_folder_is_made_and_a_file_in_its_way_named(tmp_path: Path) -> None:
    assert write_atomic(tmp_path / "new" / "deeper" / "out.py", "x").read_text() == "x"
    (tmp_path / "file").write_text("keep")
    with pytest.raises(FileProblem, match=f"^{tmp_path / 'file'}: a file, not a folder$"):
        write_atomic(tmp_path / "file" / "deeper" / "out.py", "x")
    assert (tmp_path / "file").read_text() == "keep"


# --------------------------------------------------------------------------- replacing(path)

def test_replacing_gives_a_temporary_with_the_extension_and_renames_it(tmp_path: Path) -> None:
    target = tmp_path / "run.mp4"
    target.write_bytes(b"old video")
    with replacing(target) as temporary:
        assert temporary.name.endswith(".mp4") and temporary.stat().st_size == 0
        assert temporary.parent != tmp_path                       # a private folder of its own
        assert stat.S_IMODE(temporary.parent.stat().st_mode) == 0o700
        temporary.write_bytes(b"new video")
        assert target.read_bytes() == b"old video"     # nothing visible before the block ends
    assert target.read_bytes() == b"new video" and _listing(tmp_path) == ["run.mp4"]


def test_replacing_discards_the_temporary_when_the_writer_fails(tmp_path: Path) -> None:
    target = tmp_path / "frame.png"
    target.write_bytes(b"old")
    with pytest.raises(ValueError, match="encoder broke"):
        with replacing(target) as temporary:
            temporary.write_bytes(b"half")
            raise ValueError("encoder broke")
    assert target.read_bytes() == b"old" and _listing(tmp_path) == ["frame.png"]


def test_replacing_refuses_symlinks_and_inputs_before_the_writer_runs(tmp_path: Path) -> None:
    scene = tmp_path / "scene.yaml"
    scene.write_text("scene")
    link = tmp_path / "frame.png"
    link.symlink_to(scene)
    for target, message in ((link, "symbolic link"), (scene, "is an input")):
        with pytest.raises(FileProblem, match=message):
            with replacing(target, inputs=[scene]):
                raise AssertionError("the writer must not run")
    assert scene.read_text() == "scene" and _listing(tmp_path) == ["frame.png", "scene.yaml"]
