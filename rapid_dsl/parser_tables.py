"""The parser's LALR tables, built once per grammar and kept as JSON in the user's cache folder.

Building the tables of grammar/rapid.lark takes about 0.3 s, loading them under 10 ms: without a
cache every `rapidc check` would pay the build. lark's own `cache=True` keeps a pickle under the
shared temporary folder, with a name anyone can compute, and unpickling a file that someone else
put there first runs their code. Here instead:

- the tables are JSON, so reading them runs nothing; the file name and the file itself carry the
  SHA-256 of the grammar, the parser options and the versions of lark, Python and this format;
- they live in `$XDG_CACHE_HOME/rapid_dsl` (default `~/.cache/rapid_dsl`), a folder made private
  (0700); a file is read only if it and its folder belong to the user, no one else may write
  them and it is a regular file of at most `MAX_BYTES`;
- they are written atomically (`runtime/files.py write_atomic`), mode 0600;
- any problem (no home folder, a read-only disk, a damaged, foreign or older file) means the
  tables are built in memory: the parser is the same either way, only start-up is slower.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
import sys
from pathlib import Path
from typing import Any

import lark
from lark import Lark
from lark.grammar import Rule
from lark.lexer import TerminalDef

FORMAT = 1                      # bump when the layout of the file changes
MAX_BYTES = 4 * 1024 * 1024     # the tables of rapid.lark are about 0.2 MB


def load_lark(grammar: str, *, postlex: Any, **options: Any) -> Lark:
    """An LALR `Lark` for `grammar` with `options` (JSON-able ones) and `postlex`: from the
    cached tables when there are good ones, else built (and cached for the next process)."""
    key = _key(grammar, options)
    path = cache_path(key)
    tables = _read(path, key) if path is not None else None
    if tables is not None:
        try:
            return Lark._load_from_dict(tables["data"], tables["memo"], postlex=postlex)
        except Exception:  # noqa: BLE001 - tables lark cannot load: build them instead
            pass
    parser = Lark(grammar, parser="lalr", postlex=postlex, **options)
    if path is not None:
        _write(path, key, parser)
    return parser


def cache_path(key: str) -> Path | None:
    """Where the tables with this key live, or None without a usable cache folder."""
    base = os.environ.get("XDG_CACHE_HOME") or (
        os.environ.get("LOCALAPPDATA") if sys.platform == "win32" else None)
    if not base:
        home = os.path.expanduser("~")
        if home == "~":
            return None
        base = os.path.join(home, ".cache")
    if not os.path.isabs(base):
        return None   # the XDG rule: a relative $XDG_CACHE_HOME is ignored
    return Path(base, "rapid_dsl", f"parser-{key[:32]}.json")


def _key(grammar: str, options: dict[str, Any]) -> str:
    text = json.dumps([FORMAT, grammar, sorted(options.items()), lark.__version__,
                       list(sys.version_info[:2])], default=str)
    return hashlib.sha256(text.encode("utf-8")).hexdigest()


def _private(info: os.stat_result, kind: int) -> bool:
    """Of the expected kind, the user's own, and writable by no one else."""
    owner = info.st_uid == os.getuid() if hasattr(os, "getuid") else True
    return stat.S_IFMT(info.st_mode) == kind and owner and not info.st_mode & 0o022


def _read(path: Path, key: str) -> dict[str, Any] | None:
    try:
        if not _private(os.lstat(path.parent), stat.S_IFDIR):
            return None
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
        with os.fdopen(fd, "rb") as f:
            info = os.fstat(f.fileno())
            if not _private(info, stat.S_IFREG) or info.st_size > MAX_BYTES:
                return None
            text = f.read(MAX_BYTES + 1)
        tables = json.loads(text, object_hook=_decode)
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(tables, dict) or tables.get("key") != key:
        return None
    return tables


def _write(path: Path, key: str, parser: Lark) -> None:
    from rapid_dsl.runtime.files import FileProblem, write_atomic

    data, memo = parser.memo_serialize([TerminalDef, Rule])
    # the post-lexer is code, given again on loading; every other option is plain data
    data["options"] = {k: v for k, v in data["options"].items() if k != "postlex"}
    try:
        text = json.dumps({"key": key, "data": _encode(data), "memo": _encode(memo)},
                          separators=(",", ":"))
        path.parent.mkdir(mode=0o700, parents=True, exist_ok=True)
        if _private(os.lstat(path.parent), stat.S_IFDIR):
            write_atomic(path, text, mode=0o600)
    except (OSError, FileProblem, TypeError, ValueError):
        pass   # no cache this time: the next start-up builds the tables again


# JSON has no tuples and only string keys; lark's tables have both.
def _encode(value: Any) -> Any:
    if isinstance(value, dict):
        if all(isinstance(k, str) for k in value):
            return {k: _encode(v) for k, v in value.items()}
        return {"__pairs__": [[_encode(k), _encode(v)] for k, v in value.items()]}
    if isinstance(value, tuple):
        return {"__tuple__": [_encode(v) for v in value]}
    if isinstance(value, list):
        return [_encode(v) for v in value]
    return value


def _decode(value: dict[str, Any]) -> Any:
    if len(value) == 1 and "__tuple__" in value:
        return tuple(value["__tuple__"])
    if len(value) == 1 and "__pairs__" in value:
        return {k: v for k, v in value["__pairs__"]}
    return value
