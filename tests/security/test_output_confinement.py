"""rapid_dsl/language/files.py's one write path, against hostile folder trees.

Random trees of folders, files, FIFOs, hard links and symbolic links (into the output folder, out
of it, dangling) are built under an output folder and beside it; then a file or a folder is
written at a random name below the output folder, by each of OutputFolder's ways of writing. The
result must be exactly what a walk of the tree that refuses every symbolic link predicts: the
file written at its physical path (and the folders made on the way), or a refusal that changed
nothing. Nothing outside the output folder is ever created or changed, no link is ever followed
or replaced, no input is replaced, and no temporary file is left.
"""

from __future__ import annotations

import os
import stat
import tempfile
from pathlib import Path

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from rapid_dsl.language.files import FileProblem, output_folder

NAMES = ("a", "b", "meshes")
KINDS = ("folder", "file", "fifo", "link to a folder outside", "link to a file outside",
         "link inside", "dangling link", "hard link to a file outside")
OPS = ("write", "replacing", "create", "folder")
DATA = b"written by the test\n"

relative = st.lists(st.sampled_from(NAMES), min_size=1, max_size=3).map("/".join)
entries = st.lists(st.tuples(relative, st.sampled_from(KINDS), relative), max_size=12)
targets = st.lists(st.sampled_from((*NAMES, "..")), min_size=1, max_size=4).map("/".join)


def _build(base: Path, layout: list[tuple[str, str, str]]) -> None:
    """`outside/` holds a folder and a file; `out/` gets the entries whose folder is a real
    folder (deeper entries under a link or a file are left out)."""
    (base / "outside" / "folder").mkdir(parents=True)
    (base / "outside" / "file").write_bytes(b"outside\n")
    (base / "out").mkdir()
    for name, kind, other in sorted(layout, key=lambda e: e[0].count("/")):
        path = base / "out" / name
        if not _real_folders(base / "out", name.split("/")[:-1]) or os.path.lexists(path):
            continue
        if kind == "folder":
            path.mkdir()
        elif kind == "file":
            path.write_bytes(f"{name}\n".encode())
        elif kind == "fifo":
            os.mkfifo(path)
        elif kind == "link to a folder outside":
            path.symlink_to(base / "outside" / "folder")
        elif kind == "link to a file outside":
            path.symlink_to(base / "outside" / "file")
        elif kind == "link inside":
            path.symlink_to(base / "out" / other)
        elif kind == "dangling link":
            path.symlink_to(base / "outside" / "nothing")
        else:
            os.link(base / "outside" / "file", path)


def _real_folders(root: Path, parts: list[str]) -> bool:
    """Whether every name on the way from `root` is a folder, not a link to one."""
    for depth in range(len(parts)):
        try:
            if not stat.S_ISDIR(os.lstat(root.joinpath(*parts[: depth + 1])).st_mode):
                return False
        except FileNotFoundError:
            return False
    return True


def _snapshot(base: Path) -> dict[str, tuple[object, ...]]:
    """Every entry under `base`, no link followed: its kind, and a file's inode and bytes."""
    found: dict[str, tuple[object, ...]] = {}
    for folder, dirs, files in os.walk(base):
        for name in dirs + files:
            path = Path(folder) / name
            info = os.lstat(path)
            key = path.relative_to(base).as_posix()
            if stat.S_ISLNK(info.st_mode):
                found[key] = ("link", os.readlink(path))
            elif stat.S_ISDIR(info.st_mode):
                found[key] = ("folder",)
            elif stat.S_ISREG(info.st_mode):
                found[key] = ("file", info.st_ino, path.read_bytes())
            else:
                found[key] = ("other",)
    return found


def _expected(out: Path, target: str, op: str, inputs: set[tuple[int, int]]
              ) -> list[str] | None:
    """What a walk that refuses every link predicts: the names made below `out` (the file or
    folder written last), or None for a refusal."""
    parts = target.split("/")
    if ".." in parts:
        return None
    path = out
    for depth, part in enumerate(parts):
        path = path / part
        try:
            info = os.lstat(path)
        except FileNotFoundError:
            return ["/".join(parts[: i + 1]) for i in range(depth, len(parts))]
        if depth == len(parts) - 1 and op != "folder":
            written = stat.S_ISREG(info.st_mode) and (info.st_dev, info.st_ino) not in inputs
            return [target] if written else None
        if not stat.S_ISDIR(info.st_mode):
            return None
    return []


def _write(out: Path, target: str, op: str, inputs: list[Path]) -> None:
    with output_folder(out, inputs=inputs) as folder:
        if op == "write":
            folder.write(target, DATA)
        elif op == "replacing":
            with folder.replacing(target) as temporary:
                temporary.write_bytes(DATA)
        elif op == "create":
            fd = folder.create(target)
            try:
                os.write(fd, DATA)
            finally:
                os.close(fd)
        else:
            folder.folder(target).close()


@pytest.mark.slow    # 400 trees: about 15 s
@settings(max_examples=400, deadline=None, database=None,
          derandomize=not os.environ.get("RAPIDC_HYPOTHESIS_RANDOM"),
          suppress_health_check=[HealthCheck.too_slow])
@given(layout=entries, target=targets, op=st.sampled_from(OPS), data=st.data())
def test_a_write_below_the_output_folder_stays_there_and_follows_no_link(
        layout: list[tuple[str, str, str]], target: str, op: str, data: st.DataObject) -> None:
    with tempfile.TemporaryDirectory() as temporary:
        base = Path(temporary)
        _build(base, layout)
        out = base / "out"
        before = _snapshot(base)
        files = sorted(k for k, v in before.items() if v[0] == "file")
        inputs = [base / k for k in data.draw(st.lists(st.sampled_from(files), unique=True)
                                              if files else st.just([]))]
        identities = {(os.stat(p).st_dev, os.stat(p).st_ino) for p in inputs}
        made = _expected(out, target, op, identities)
        if made is None:
            with pytest.raises(FileProblem):
                _write(out, target, op, inputs)
            assert _snapshot(base) == before
            return
        _write(out, target, op, inputs)
        after = _snapshot(base)
        for name in made:
            key = f"out/{name}"
            if name == target and op != "folder":
                assert after.pop(key)[::2] == ("file", DATA)
            else:
                assert after.pop(key) == ("folder",)
        if op != "folder":
            before.pop(f"out/{target}", None)   # the file replaced (by a new one)
        assert after == before    # nothing else made, changed, replaced or left behind
