"""Reading untrusted input files and writing output files, the one place both are done.

Inputs (programs, scenes, meshes, tracks) are read only when they are regular files no larger than
`MAX_INPUT_BYTES`: a FIFO would block forever, a device or a huge file would exhaust memory.
Outputs are written atomically (a temporary file in the target's folder, then a rename), never
through a symlink the writer did not create and never over a file the same command reads.
Paths a program or a scene names stay inside an allowed folder tree (`inside`).
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Iterable, Iterator
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
    return decode_text(read_bytes(path, limit=limit))


def decode_text(data: bytes) -> str:
    """UTF-8 `data` as text, a leading BOM dropped. Raises FileProblem."""
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
    if isinstance(data, str):
        try:
            data = data.encode("utf-8")
        except UnicodeEncodeError as exc:   # a lone surrogate: fail before touching any file
            raise FileProblem(f"the text cannot be encoded as UTF-8 ({exc.reason} at "
                              f"character {exc.start})") from None
    target, mode = _prepare(path, inputs, through_links, mode)
    fd, temporary = _temporary(target)
    try:
        with os.fdopen(fd, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        _commit(temporary, target, mode)
    except BaseException as exc:
        _discard(temporary, exc)
        raise
    return target


@contextlib.contextmanager
def replacing(path: str | os.PathLike[str], *, inputs: Iterable[str | os.PathLike[str]] = (),
              through_links: bool = False, mode: int | None = None) -> Iterator[Path]:
    """For writers that need a file name (imageio, ffmpeg): yield an empty temporary file next to
    `path`, with the same extension (writers pick the format by it), which replaces `path` when
    the block ends without an exception and is removed when it raises. Refuses what write_atomic
    refuses; raises FileProblem for OSErrors of its own (those of the block pass through)."""
    target, mode = _prepare(path, inputs, through_links, mode)
    fd, temporary = _temporary(target)
    os.close(fd)
    try:
        yield Path(temporary)
    except BaseException:
        _discard(temporary, None)
        raise
    try:
        fd = os.open(temporary, os.O_RDONLY)
        try:
            os.fsync(fd)
        finally:
            os.close(fd)
        _commit(temporary, target, mode)
    except BaseException as exc:
        _discard(temporary, exc)
        raise


def _prepare(path: str | os.PathLike[str], inputs: Iterable[str | os.PathLike[str]],
             through_links: bool, mode: int | None) -> tuple[Path, int]:
    """The file to replace and the mode to give it, after the refusals of write_atomic."""
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
    if mode is None:
        if existing is not None:
            mode = existing.st_mode & 0o7777
        else:
            umask = os.umask(0)
            os.umask(umask)
            mode = 0o644 & ~umask
    return target, mode


def _temporary(target: Path) -> tuple[int, str]:
    import tempfile  # here: `rapidc check` reads through this module and never writes

    folder = target.parent if str(target.parent) else Path(".")
    try:
        return tempfile.mkstemp(dir=folder, prefix=f".{target.name}.",
                                suffix=f".tmp{target.suffix}")
    except OSError as exc:
        raise FileProblem(exc.strerror or str(exc)) from None


def _commit(temporary: str, target: Path, mode: int) -> None:
    os.chmod(temporary, mode)
    os.replace(temporary, target)   # replaces a symlink put there meanwhile, never writes through


def _discard(temporary: str, exc: BaseException | None) -> None:
    """Remove the temporary file; turn an OSError `exc` into a FileProblem."""
    try:
        os.unlink(temporary)
    except OSError:
        pass
    if isinstance(exc, OSError):
        raise FileProblem(exc.strerror or str(exc)) from None


def _size(n: int) -> str:
    """`10 MiB`, `1 KiB`, else exact bytes: one byte over the limit must not read as the limit."""
    if n and n % (1 << 20) == 0:
        return f"{n >> 20} MiB"
    if n and n % (1 << 10) == 0:
        return f"{n >> 10} KiB"
    return f"{n:,} bytes"
