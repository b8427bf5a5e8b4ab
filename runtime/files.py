"""Reading untrusted input files and writing output files, the one place both are done.

Inputs (programs, scenes, meshes, tracks) are read only when they are regular files no larger than
`MAX_INPUT_BYTES`: a FIFO would block forever, a device or a huge file would exhaust memory.
Outputs are written atomically (a temporary file in the target's folder, then a rename), never
through a symlink the writer did not create and never over a file the same command reads.
Paths a program or a scene names stay inside an allowed folder tree (`inside`).
"""

from __future__ import annotations

import os
import stat
import tempfile
from collections.abc import Iterable
from pathlib import Path

MAX_INPUT_BYTES = 10 * 1024 * 1024   # 10 MiB: far above any hand- or agent-written program


class FileProblem(Exception):
    """An input that cannot be read or an output that cannot be written; the message says why
    without the path (callers put the path in front, in their own format)."""


def read_bytes(path: str | os.PathLike[str], *, limit: int = MAX_INPUT_BYTES) -> bytes:
    """The content of a regular file of at most `limit` bytes. Raises FileProblem."""
    try:
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0) | getattr(os, "O_NOCTTY", 0))
    except FileNotFoundError:
        raise FileProblem("no such file") from None
    except IsADirectoryError:
        raise FileProblem("is a folder") from None
    except OSError as exc:
        raise FileProblem(exc.strerror or str(exc)) from None
    try:
        info = os.fstat(fd)
        if stat.S_ISDIR(info.st_mode):
            raise FileProblem("is a folder")
        if not stat.S_ISREG(info.st_mode):
            raise FileProblem("not a regular file")
        if info.st_size > limit:
            raise FileProblem(f"larger than the input limit of {_size(limit)} "
                              f"({_size(info.st_size)})")
        chunks = []
        total = 0
        while chunk := os.read(fd, 1 << 20):
            total += len(chunk)
            if total > limit:   # the file grew while it was read
                raise FileProblem(f"larger than the input limit of {_size(limit)}")
            chunks.append(chunk)
        return b"".join(chunks)
    except OSError as exc:
        raise FileProblem(exc.strerror or str(exc)) from None
    finally:
        os.close(fd)


def read_text(path: str | os.PathLike[str], *, limit: int = MAX_INPUT_BYTES) -> str:
    """A regular UTF-8 text file of at most `limit` bytes (a leading BOM is dropped).
    Raises FileProblem."""
    data = read_bytes(path, limit=limit)
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise FileProblem("not UTF-8 text") from None
    return text.removeprefix("\ufeff")


def inside(path: str | os.PathLike[str], roots: Iterable[str | os.PathLike[str]]) -> bool:
    """Whether `path`, with every symlink resolved, lies in one of the folder trees `roots`."""
    resolved = Path(os.path.realpath(path))
    for root in roots:
        base = Path(os.path.realpath(root))
        if resolved == base or base in resolved.parents:
            return True
    return False


def write_atomic(path: str | os.PathLike[str], data: str | bytes, *,
                 inputs: Iterable[str | os.PathLike[str]] = (),
                 through_links: bool = False, mode: int | None = None) -> Path:
    """Write `data` to `path` atomically and return the path actually written.

    An existing symlink at `path` is refused, unless `through_links` (then its final target is
    written, as `fmt -w` does for a program it read through the link). Writing over one of
    `inputs` (compared by identity, so hard links and links count) is refused. An existing
    file's permission bits are kept unless `mode` is given; a new file gets 0o644 less the umask.
    Raises FileProblem; on any failure the old file is left as it was and no partial file remains.
    """
    target = Path(path)
    if target.is_symlink():
        if not through_links:
            raise FileProblem("is a symbolic link; refusing to write through it")
        target = Path(os.path.realpath(target))
    existing: os.stat_result | None
    try:
        existing = os.stat(target, follow_symlinks=False)
    except FileNotFoundError:
        existing = None
    except OSError as exc:
        raise FileProblem(exc.strerror or str(exc)) from None
    if existing is not None:
        if stat.S_ISDIR(existing.st_mode):
            raise FileProblem("is a folder")
        if not stat.S_ISREG(existing.st_mode):
            raise FileProblem("not a regular file")
        for source in inputs:
            try:
                other = os.stat(source)
            except OSError:
                continue
            if (other.st_dev, other.st_ino) == (existing.st_dev, existing.st_ino):
                raise FileProblem("is an input of this command; refusing to overwrite it")
    payload = data.encode("utf-8") if isinstance(data, str) else data
    if mode is None:
        if existing is not None:
            mode = existing.st_mode & 0o7777
        else:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o644 & ~umask
    folder = target.parent if str(target.parent) else Path(".")
    try:
        fd, temporary = tempfile.mkstemp(dir=folder, prefix=f".{target.name}.", suffix=".tmp")
    except OSError as exc:
        raise FileProblem(exc.strerror or str(exc)) from None
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(payload)
            f.flush()
            os.fsync(f.fileno())
        os.chmod(temporary, mode)
        os.replace(temporary, target)
    except BaseException as exc:
        try:
            os.unlink(temporary)
        except OSError:
            pass
        if isinstance(exc, OSError):
            raise FileProblem(exc.strerror or str(exc)) from None
        raise
    return target


def _size(n: int) -> str:
    if n >= 1 << 20:
        return f"{n / (1 << 20):.1f} MiB"
    if n >= 1 << 10:
        return f"{n / (1 << 10):.1f} KiB"
    return f"{n} bytes"
