"""The parser's LALR tables: built by lark once per grammar, kept as JSON in the user's cache
folder, and run by rapid_dsl/frontend/lalr.py (which imports nothing of lark).

Building the tables of grammar/rapid.lark takes about 0.3 s and importing lark about as long as
checking a 200-line file; reading the cached tables takes a few milliseconds. lark's own
`cache=True` keeps a pickle under the shared temporary folder, with a name anyone can compute,
and unpickling a file that someone else put there first runs their code. Here instead:

- the tables are JSON, so reading them runs nothing; the file holds the grammar and the start
  symbols it was built for, and the format version, and is used only if all three are the same;
- they live in `$XDG_CACHE_HOME/rapid_dsl` (default `~/.cache/rapid_dsl`), a folder made private
  (0700); a file is read only if it and its folder belong to the user, no one else may write
  them and it is a regular file of at most `MAX_BYTES`;
- they are written atomically (`rapid_dsl/language/files.py`), mode 0600;
- any problem (no home folder, a read-only disk, a damaged, foreign or older file) means the
  tables are built in memory: the parser is the same either way, only start-up is slower.
"""

from __future__ import annotations

import json
import os
import stat
import sys
import zlib
from pathlib import Path
from typing import Any

from rapid_dsl.frontend.lalr import FORMAT, Parser

MAX_BYTES = 4 * 1024 * 1024     # the tables of rapid.lark are about 0.1 MB


def load_parser(grammar: str, start: list[str], always_accept: tuple[str, ...] = ()) -> Parser:
    """The parser of `grammar` for the `start` symbols: from cached tables when there are good
    ones, else built with lark (and cached for the next process)."""
    path = cache_path(grammar)
    tables = _read(path, grammar, start) if path is not None else None
    if tables is not None:
        try:
            return Parser(tables, always_accept)
        except ValueError:
            pass    # damaged: build them again
    tables = build_tables(grammar, start)
    if path is not None:
        _write(path, tables)
    return Parser(tables, always_accept)


def cache_path(grammar: str) -> Path | None:
    """Where the tables of this grammar live, or None without a usable cache folder."""
    base = os.environ.get("XDG_CACHE_HOME") or (
        os.environ.get("LOCALAPPDATA") if sys.platform == "win32" else None)
    if not base:
        home = os.path.expanduser("~")
        if home == "~":
            return None
        base = os.path.join(home, ".cache")
    if not os.path.isabs(base):
        return None   # the XDG rule: a relative $XDG_CACHE_HOME is ignored
    # the name tells grammars apart; the grammar inside the file decides
    return Path(base, "rapid_dsl", f"parser-{FORMAT}-{zlib.crc32(grammar.encode()):08x}.json")


def build_tables(grammar: str, start: list[str]) -> dict[str, Any]:
    """lark's LALR tables of `grammar`, in the plain form lalr.py reads."""
    from lark import Lark
    from lark.parsers.lalr_analysis import Shift

    built = Lark(grammar, parser="lalr", lexer="contextual", start=start,
                 maybe_placeholders=False)
    table = built.parser.parser.parser.parse_table
    rules: list[dict[str, Any]] = []
    index: dict[int, int] = {}

    def rule_id(rule: Any) -> int:
        if id(rule) not in index:
            index[id(rule)] = len(rules)
            rules.append(_rule(rule))
        return index[id(rule)]

    states = [{symbol: [0, arg] if action is Shift else [1, rule_id(arg)]
               for symbol, (action, arg) in table.states[s].items()}
              for s in range(len(table.states))]
    terminals = []
    for t in built.terminals:
        if t.pattern.flags or t.pattern.min_width == 0:
            raise ValueError(f"terminal {t.name}: lalr.py reads no regexp flags or empty tokens")
        # the literals a pattern also matches whole (keywords a name would match), for lark's
        # `unless`: worked out here once, not by every lexer state of every process
        keywords = [s.name for s in built.terminals if t.pattern.type == "re"
                    and s.pattern.type == "str" and s.priority == t.priority
                    and _matches_whole(t.pattern.value, s.pattern.value)]
        terminals.append({"name": t.name, "kind": t.pattern.type, "pattern": t.pattern.value,
                          "priority": t.priority, "width": t.pattern.max_width,
                          "keywords": keywords})
    return {"format": FORMAT, "grammar": grammar, "start": list(start), "terminals": terminals,
            "ignore": list(built.lexer_conf.ignore), "rules": rules, "states": states,
            "start_states": dict(table.start_states), "end_states": dict(table.end_states)}


def _matches_whole(pattern: str, text: str) -> bool:
    import re

    match = re.match(pattern, text)
    return match is not None and match.group(0) == text


def _rule(rule: Any) -> dict[str, Any]:
    """lark's ParseTreeBuilder for one rule (no placeholders): which children stay, which are
    `_rules` to splice, and whether a `?rule` passes a single child up."""
    keep_all = rule.options.keep_all_tokens
    keep = [[i, not sym.is_term and sym.name.startswith("_")]
            for i, sym in enumerate(rule.expansion)
            if keep_all or not (sym.is_term and sym.filter_out)]
    plain = len(keep) == len(rule.expansion) and not any(splice for _, splice in keep)
    splice = rule.origin.name.startswith("_")
    if splice and (rule.alias or rule.options.expand1):
        raise ValueError(f"rule {rule.origin.name}: an inlined rule with an alias or `?`")
    return {"name": rule.alias or rule.options.template_source or rule.origin.name,
            "origin": rule.origin.name, "size": len(rule.expansion), "splice": splice,
            "expand1": bool(rule.options.expand1 and not rule.alias),
            "keep": None if plain else keep}


def _private(info: os.stat_result, kind: int) -> bool:
    """Of the expected kind, the user's own, and writable by no one else."""
    owner = info.st_uid == os.getuid() if hasattr(os, "getuid") else True
    return stat.S_IFMT(info.st_mode) == kind and owner and not info.st_mode & 0o022


def _read(path: Path, grammar: str, start: list[str]) -> dict[str, Any] | None:
    try:
        if not _private(os.lstat(path.parent), stat.S_IFDIR):
            return None
        fd = os.open(path, os.O_RDONLY | getattr(os, "O_NOFOLLOW", 0))
        with os.fdopen(fd, "rb") as f:
            info = os.fstat(f.fileno())
            if not _private(info, stat.S_IFREG) or info.st_size > MAX_BYTES:
                return None
            tables = json.loads(f.read(MAX_BYTES + 1))
    except (OSError, ValueError, RecursionError):
        return None
    if not isinstance(tables, dict) or tables.get("format") != FORMAT or \
            tables.get("grammar") != grammar or tables.get("start") != start:
        return None
    return tables


def _write(path: Path, tables: dict[str, Any]) -> None:
    from rapid_dsl.language.files import FileProblem, output_folder

    try:
        with output_folder(path.parent, mode=0o700) as folder:
            if _private(os.lstat(path.parent), stat.S_IFDIR):
                folder.write(path.name, json.dumps(tables, separators=(",", ":")), mode=0o600)
    except (OSError, FileProblem):
        pass   # no cache this time: the next start-up builds the tables again
