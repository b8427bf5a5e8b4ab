"""Reading untrusted input files and writing output files, the one place both are done.

Inputs (programs, scenes, meshes, tracks) are read only when they are regular files no larger than
`MAX_INPUT_BYTES`: a FIFO would block forever, a device or a huge file would exhaust memory.
Paths a program or a scene names stay inside an allowed folder tree (`inside`).

Outputs: every file rapidc writes goes through an `OutputFolder`. The folder named on the command
line is the user's choice and is taken as given (made where missing), then held open by a
descriptor; every subfolder and file rapidc names below it (meshes/, masks/<object>.png, scenes/,
key frames) is made and opened one name at a time relative to that descriptor, without following
a symbolic link, so a link anywhere below the folder is refused, never written through (rapidc
makes none). A file is written atomically (a temporary file beside it, then a rename) and never
replaces one of the command's inputs, compared by device and inode.
"""

from __future__ import annotations

import contextlib
import os
import stat
from collections.abc import Callable, Iterable, Iterator
from pathlib import Path

PathLike = str | os.PathLike[str]
MAX_INPUT_BYTES = 10 * 1024 * 1024   # 10 MiB: far above any hand- or agent-written program


class FileProblem(Exception):
    """An input that cannot be read or an output that cannot be written. `reason` says why;
    `path` is set when the problem is not the file itself but a folder on the way to it (a
    symbolic link, a file where a folder is needed), and then str() is `PATH: reason`. Callers
    put the file's path in front, in their own format."""

    def __init__(self, reason: str, path: PathLike | None = None) -> None:
        super().__init__(reason if path is None else f"{path}: {reason}")
        self.reason, self.path = reason, path


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


Identity = tuple[int, int]          # (st_dev, st_ino): the file, whatever name reaches it

_DIRECTORY = os.O_RDONLY | os.O_DIRECTORY | getattr(os, "O_CLOEXEC", 0)
_NEW = os.O_WRONLY | os.O_CREAT | os.O_EXCL | os.O_NOFOLLOW | getattr(os, "O_CLOEXEC", 0)
_LINK = "is a symbolic link; refusing to write through it"
_INPUT = "is an input of this command; refusing to overwrite it"


def identities(paths: Iterable[PathLike]) -> frozenset[Identity]:
    """The files `paths` name now (symlinks followed: a link to an input is that input); a path
    that names nothing is left out."""
    found = set()
    for path in paths:
        try:
            info = os.stat(path)
        except (OSError, ValueError):
            continue
        found.add((info.st_dev, info.st_ino))
    return frozenset(found)


class OutputFolder:
    """A folder open for writing into, by descriptor. Names below it (`write("meshes/a.obj")`)
    are walked one at a time from the descriptor: each folder on the way is made if missing and
    opened without following a symbolic link, so nothing is ever written outside the folder.
    Close it (or use it as a context manager) when done."""

    def __init__(self, fd: int, path: Path, inputs: frozenset[Identity], mode: int) -> None:
        self.fd, self.path, self.inputs, self.mode = fd, path, inputs, mode

    def __enter__(self) -> OutputFolder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def close(self) -> None:
        if self.fd >= 0:
            os.close(self.fd)
            self.fd = -1

    def folder(self, name: PathLike) -> OutputFolder:
        """The subfolder `name` (names joined by `/`), made where missing. Raises FileProblem
        (`PATH: reason`) where a name on the way is a symbolic link or not a folder."""
        current = self
        for part in _parts(name):
            deeper = current._subfolder(part)
            if current is not self:
                current.close()
            current = deeper
        return current

    def write(self, name: PathLike, data: str | bytes, *, mode: int | None = None) -> Path:
        """Write `data` to the file `name` atomically and return its path. An existing file
        keeps its permission bits unless `mode` is given; a new one gets 0o644 less the umask.
        Raises FileProblem; on any failure the old file is left as it was and no partial file
        remains."""
        data = _encoded(data)
        with self._parent(name) as (parent, leaf):
            return parent._replace(leaf, lambda fd: _write_all(fd, data), mode)

    @contextlib.contextmanager
    def replacing(self, name: PathLike, *, mode: int | None = None) -> Iterator[Path]:
        """For writers that need a file name (imageio, ffmpeg): yield an empty file of the same
        extension (writers pick the format by it) in a private temporary folder; when the block
        ends without an exception its content replaces `name` as `write` would, and when it
        raises nothing is written. Refuses what `write` refuses, before the block runs."""
        import tempfile  # here: `rapidc check` reads through this module and never writes

        with self._parent(name) as (parent, leaf):
            parent._existing(leaf)
            with tempfile.TemporaryDirectory(prefix="rapidc-") as private:
                temporary = Path(private) / f"output{Path(leaf).suffix}"
                os.close(os.open(temporary, _NEW, 0o600))
                yield temporary
                try:
                    source = os.open(temporary, os.O_RDONLY | os.O_NOFOLLOW)
                except OSError as exc:
                    raise FileProblem(_reason(exc)) from None
                try:
                    parent._replace(leaf, lambda fd: _copy(source, fd), mode)
                finally:
                    os.close(source)

    def create(self, name: PathLike) -> int:
        """A new empty file at `name`, open for writing: for a journal that is appended to while
        a command runs. It replaces what is there by a rename, as `write` does, so a file
        another name links to is never emptied. Refuses what `write` refuses. Raises
        FileProblem."""
        with self._parent(name) as (parent, leaf):
            parent._existing(leaf)
            fd, temporary = parent._temporary(leaf, 0o644)
            try:
                os.replace(temporary, leaf, src_dir_fd=parent.fd, dst_dir_fd=parent.fd)
            except OSError as exc:
                os.close(fd)
                with contextlib.suppress(OSError):
                    os.unlink(temporary, dir_fd=parent.fd)
                raise FileProblem(_reason(exc)) from None
            return fd

    def append(self, name: PathLike) -> int:
        """The existing file `name`, open for appending (and reading its end): the journal a
        resumed run continues. Refuses what `write` refuses, and a file that is not there.
        Raises FileProblem."""
        with self._parent(name) as (parent, leaf):
            if parent._existing(leaf) is None:
                raise FileProblem("is not there to append to", parent.path / leaf)
            try:
                return os.open(leaf, os.O_RDWR | os.O_APPEND | os.O_NOFOLLOW
                               | getattr(os, "O_CLOEXEC", 0), dir_fd=parent.fd)
            except OSError as exc:
                raise FileProblem(_reason(exc)) from None

    def remove(self, name: PathLike) -> None:
        """Remove the file `name` if it is there (a link is removed, never followed)."""
        with self._parent(name) as (parent, leaf):
            try:
                os.unlink(leaf, dir_fd=parent.fd)
            except FileNotFoundError:
                pass
            except OSError as exc:
                raise FileProblem(_reason(exc)) from None

    def identity(self, name: PathLike) -> Identity | None:
        """The file at `name` (not followed if a link), or None when nothing is there."""
        with self._parent(name) as (parent, leaf):
            try:
                info = os.stat(leaf, dir_fd=parent.fd, follow_symlinks=False)
            except FileNotFoundError:
                return None
            except OSError as exc:
                raise FileProblem(_reason(exc)) from None
            return info.st_dev, info.st_ino

    def _subfolder(self, part: str) -> OutputFolder:
        path = self.path / part
        try:
            os.mkdir(part, self.mode, dir_fd=self.fd)
        except FileExistsError:
            pass   # a folder already, or a link or a file: opening it says which
        except OSError as exc:
            raise FileProblem(f"cannot make the folder: {_reason(exc)}", path) from None
        try:
            fd = os.open(part, _DIRECTORY | os.O_NOFOLLOW, dir_fd=self.fd)
        except OSError as exc:
            raise FileProblem(_folder_reason(exc, self.fd, part), path) from None
        return OutputFolder(fd, path, self.inputs, self.mode)

    @contextlib.contextmanager
    def _parent(self, name: PathLike) -> Iterator[tuple[OutputFolder, str]]:
        """The folder that holds `name` (made where missing) and the last name in it."""
        *folders, leaf = _parts(name)
        if not folders:
            yield self, leaf
            return
        with self.folder("/".join(folders)) as parent:
            yield parent, leaf

    def _existing(self, leaf: str) -> os.stat_result | None:
        """What is at `leaf` now: None, or a regular file that is not an input. Raises
        FileProblem."""
        try:
            info = os.stat(leaf, dir_fd=self.fd, follow_symlinks=False)
        except FileNotFoundError:
            return None
        except OSError as exc:
            raise FileProblem(_reason(exc)) from None
        if stat.S_ISLNK(info.st_mode):
            raise FileProblem(_LINK)
        if stat.S_ISDIR(info.st_mode):
            raise FileProblem("is a folder")
        if not stat.S_ISREG(info.st_mode):
            raise FileProblem("not a regular file")
        if (info.st_dev, info.st_ino) in self.inputs:
            raise FileProblem(_INPUT)
        return info

    def _replace(self, leaf: str, fill: Callable[[int], None], mode: int | None) -> Path:
        """Fill a new temporary file beside `leaf`, then rename it over `leaf`."""
        existing = self._existing(leaf)
        if mode is None and existing is not None:
            mode = stat.S_IMODE(existing.st_mode)
        # a new file without a given mode gets 0o644 less the umask from open() itself
        fd, temporary = self._temporary(leaf, 0o644 if mode is None else 0o600)
        try:
            try:
                fill(fd)
                os.fsync(fd)
                if mode is not None:
                    os.fchmod(fd, mode)
            finally:
                os.close(fd)
            # rename replaces a link put there meanwhile: it never writes through one
            os.replace(temporary, leaf, src_dir_fd=self.fd, dst_dir_fd=self.fd)
        except BaseException as exc:
            with contextlib.suppress(OSError):
                os.unlink(temporary, dir_fd=self.fd)
            if isinstance(exc, OSError):
                raise FileProblem(_reason(exc)) from None
            raise
        return self.path / leaf

    def _temporary(self, leaf: str, mode: int) -> tuple[int, str]:
        """A new file `.LEAF.RANDOM.tmpEXT` in this folder (never an existing name)."""
        import secrets

        for _ in range(100):
            name = f".{leaf[:120]}.{secrets.token_hex(4)}.tmp{Path(leaf).suffix[:16]}"
            try:
                return os.open(name, _NEW, mode, dir_fd=self.fd), name
            except FileExistsError:
                continue
            except OSError as exc:
                raise FileProblem(_reason(exc)) from None
        raise FileProblem("cannot make a temporary file beside it")


def output_folder(path: PathLike, *, inputs: Iterable[PathLike] = (),
                  mode: int = 0o777) -> OutputFolder:
    """The folder `path`, named on the command line, open for writing into: made (with its
    parents, `mode` less the umask) where missing, and taken as it is named (a symlink in it is
    the user's own). Files written under it never replace one of `inputs`. Raises FileProblem
    (`PATH: reason`)."""
    folder = Path(path)
    try:
        os.makedirs(folder, mode=mode, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        pass   # said below, by opening it
    except OSError as exc:
        raise FileProblem(f"cannot make the folder: {_reason(exc)}", folder) from None
    try:
        fd = os.open(folder, _DIRECTORY)
    except (NotADirectoryError, FileExistsError):
        raise FileProblem("a file, not a folder", _blocker(folder)) from None
    except OSError as exc:
        raise FileProblem(_reason(exc), folder) from None
    return OutputFolder(fd, folder, identities(inputs), mode)


def write_atomic(path: PathLike, data: str | bytes, *, inputs: Iterable[PathLike] = (),
                 through_links: bool = False, mode: int | None = None) -> Path:
    """Write `data` to the file `path` named on the command line (its folder made if missing),
    as OutputFolder.write does, and return the path written. An existing symlink at `path` is
    refused, unless `through_links` (then its final target is written, as `fmt -w` does for a
    program it read through the link). Raises FileProblem."""
    data = _encoded(data)   # before touching any file
    target = _target(path, through_links)
    with output_folder(target.parent, inputs=inputs) as folder:
        folder.write(target.name, data, mode=mode)
    return target


@contextlib.contextmanager
def replacing(path: PathLike, *, inputs: Iterable[PathLike] = (),
              mode: int | None = None) -> Iterator[Path]:
    """OutputFolder.replacing for the file `path` named on the command line."""
    target = _target(path, False)
    with output_folder(target.parent, inputs=inputs) as folder, \
            folder.replacing(target.name, mode=mode) as temporary:
        yield temporary


def _target(path: PathLike, through_links: bool) -> Path:
    target = Path(path)
    if through_links and target.is_symlink():
        target = Path(os.path.realpath(target))
    if target.name in ("", ".", ".."):
        raise FileProblem("is a folder")
    return target


def _parts(name: PathLike) -> list[str]:
    """The names of a relative path below an output folder; FileProblem for anything that could
    leave it (an absolute path, `..`) or name no file."""
    text = os.fspath(name)
    parts = [p for p in text.split("/") if p not in ("", ".")]
    if not parts or text.startswith("/") or ".." in parts or "\0" in text:
        raise FileProblem(f"`{text}` is not a file name below the output folder")
    return parts


def _encoded(data: str | bytes) -> bytes:
    if isinstance(data, bytes):
        return data
    try:
        return data.encode("utf-8")
    except UnicodeEncodeError as exc:   # a lone surrogate: fail before touching any file
        raise FileProblem(f"the text cannot be encoded as UTF-8 ({exc.reason} at "
                          f"character {exc.start})") from None


def _write_all(fd: int, data: bytes) -> None:
    view = memoryview(data)
    while view:
        view = view[os.write(fd, view):]


def _copy(source: int, fd: int) -> None:
    while chunk := os.read(source, 1 << 20):
        _write_all(fd, chunk)


def _folder_reason(exc: OSError, fd: int, part: str) -> str:
    """Why the name `part` could not be opened as a folder."""
    try:
        info = os.stat(part, dir_fd=fd, follow_symlinks=False)
    except OSError:
        return _reason(exc)
    if stat.S_ISLNK(info.st_mode):
        return _LINK
    if stat.S_ISREG(info.st_mode):
        return "a file, not a folder"
    if not stat.S_ISDIR(info.st_mode):
        return "not a folder"
    return _reason(exc)


def _blocker(folder: Path) -> Path:
    """The first name on the way to `folder` that is there but is not a folder."""
    for candidate in reversed([folder, *folder.parents]):
        if candidate.exists() and not candidate.is_dir():
            return candidate
    return folder


def _reason(exc: OSError) -> str:
    return exc.strerror or str(exc)


def _size(n: int) -> str:
    """`10 MiB`, `1 KiB`, else exact bytes: one byte over the limit must not read as the limit."""
    if n and n % (1 << 20) == 0:
        return f"{n >> 20} MiB"
    if n and n % (1 << 10) == 0:
        return f"{n >> 10} KiB"
    return f"{n:,} bytes"
