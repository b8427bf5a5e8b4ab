"""The parser's tables are built once and kept as JSON in the user's cache folder
(rapid_dsl/parser_tables.py): the cached parser equals a freshly built one, nothing is read from
or written to the shared temporary folder, and a file that is not safely the user's own is never
read. Also: `rapidc check` imports only what checking needs.
"""

from __future__ import annotations

import json
import os
import stat
import subprocess
import sys
import tempfile
from importlib import resources
from pathlib import Path
from typing import Any

import pytest
from lark import Lark

from rapid_dsl import parser_tables
from rapid_dsl.parser import _lark, _Newlines

ROOT = Path(__file__).resolve().parents[2]
GRAMMAR = resources.files("rapid_dsl.grammar").joinpath("rapid.lark").read_text("utf-8")
OPTIONS: dict[str, Any] = {"lexer": "contextual", "start": ["start", "expr_only", "type_only"],
                           "propagate_positions": True, "maybe_placeholders": False}
CORPUS = sorted([*ROOT.glob("stdlib_primitives/*.rapid"), *ROOT.glob("examples/*.rapid"),
                 *ROOT.glob("tests/data/**/*.rapid")])


class Counting(Lark):
    """Lark that counts how often the tables are built (loading does not call __init__)."""

    built = 0

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        type(self).built += 1
        super().__init__(*args, **kwargs)


@pytest.fixture
def cache(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> Path:
    """A fresh cache folder; the shared temporary folder is a folder of its own, to watch."""
    _lark()   # the process's own parser (the post-lexer reads it) is made before any counting
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "cache"))
    shared = tmp_path / "shared-tmp"
    shared.mkdir()
    monkeypatch.setattr(tempfile, "tempdir", str(shared))
    Counting.built = 0
    monkeypatch.setattr(parser_tables, "Lark", Counting)
    return tmp_path / "cache" / "rapid_dsl"


def load() -> Lark:
    return parser_tables.load_lark(GRAMMAR, postlex=_Newlines(), **OPTIONS)


def only_file(folder: Path) -> Path:
    [path] = folder.iterdir()
    return path


def test_the_tables_are_built_once_then_read_from_a_private_file(cache: Path) -> None:
    load()
    assert Counting.built == 1
    path = only_file(cache)
    assert path.name.startswith("parser-") and path.suffix == ".json"
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert stat.S_IMODE(cache.stat().st_mode) == 0o700
    json.loads(path.read_text(encoding="utf-8"))   # plain JSON: reading it runs nothing
    load()
    load()
    assert Counting.built == 1
    assert list(Path(tempfile.gettempdir()).iterdir()) == []


def test_the_cached_parser_parses_exactly_as_a_built_one(cache: Path) -> None:
    load()
    cached, built = load(), Lark(GRAMMAR, parser="lalr", postlex=_Newlines(), **OPTIONS)
    assert Counting.built == 1
    assert len(CORPUS) > 20
    for path in CORPUS:
        text = path.read_text(encoding="utf-8")
        try:
            expected = built.parse(text, start="start")
        except Exception as exc:  # noqa: BLE001 - a golden case with a syntax error
            with pytest.raises(type(exc)):
                cached.parse(text, start="start")
            continue
        assert cached.parse(text, start="start") == expected, path
    for start, text in (("expr_only", "-a.x ^ 2 + f(b, c=3cm) * [1, 2, 3].z"),
                        ("type_only", "Length^2 / Vec[Time]")):
        assert cached.parse(text, start=start) == built.parse(text, start=start)


@pytest.mark.parametrize("spoil", ["group-writable", "world-writable", "symlink", "folder-open",
                                   "garbage", "other-key", "huge"])
def test_a_file_that_is_not_safely_ours_is_not_read(cache: Path, tmp_path: Path,
                                                    spoil: str) -> None:
    load()
    path = only_file(cache)
    good = path.read_text(encoding="utf-8")
    if spoil == "group-writable":
        path.chmod(0o620)
    elif spoil == "world-writable":
        path.chmod(0o602)
    elif spoil == "symlink":
        elsewhere = tmp_path / "elsewhere.json"
        elsewhere.write_text(good, encoding="utf-8")
        elsewhere.chmod(0o600)
        path.unlink()
        path.symlink_to(elsewhere)
    elif spoil == "folder-open":
        cache.chmod(0o777)
    elif spoil == "garbage":
        path.write_text(good[: len(good) // 2], encoding="utf-8")
    elif spoil == "other-key":
        path.write_text(json.dumps({**json.loads(good), "key": "0" * 64}), encoding="utf-8")
    elif spoil == "huge":
        with path.open("a", encoding="utf-8") as f:
            f.write(" " * parser_tables.MAX_BYTES)
    parser = load()
    assert Counting.built == 2      # built again, not read
    assert parser.parse("relation r(a: Body) = height(a) > 1cm\n", start="start")


@pytest.mark.skipif(not hasattr(os, "getuid") or os.getuid() != 0, reason="needs root to chown")
def test_a_file_of_another_user_is_not_read(cache: Path) -> None:
    load()
    os.chown(only_file(cache), 12345, 12345)
    load()
    assert Counting.built == 2


def test_without_a_usable_cache_folder_the_tables_are_built_in_memory(
        tmp_path: Path, monkeypatch: pytest.MonkeyPatch, cache: Path) -> None:
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/cache")   # ignored, as XDG says
    home = tmp_path / "home-is-a-file"
    home.write_text("", encoding="utf-8")
    monkeypatch.setenv("HOME", str(home))                   # so ~/.cache cannot be made
    for _ in range(2):
        parser = load()
        assert parser.parse("def d() -> Length = 1cm\n", start="start")
    assert Counting.built == 2
    assert not (tmp_path / "relative").exists() and not cache.exists()


def test_the_parser_is_the_cached_one() -> None:
    assert isinstance(_lark(), Lark)
    path = parser_tables.cache_path(parser_tables._key(GRAMMAR, OPTIONS))
    assert path is None or path.name.startswith("parser-")


def test_rapidc_check_imports_only_what_checking_needs(tmp_path: Path) -> None:
    program = tmp_path / "p.rapid"
    program.write_text("relation near(a: Body, b: Body) = distance(a, b) < 5cm\n",
                       encoding="utf-8")
    code = ("import sys\nfrom rapid_dsl.cli import main\n"
            f"status = main(['check', '--quiet', {str(program)!r}])\n"
            "print(status, ' '.join(sorted(sys.modules)))\n")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True, cwd=tmp_path).stdout.split()
    assert out[0] == "0"
    modules = set(out[1:])
    for heavy in ("numpy", "mujoco", "pydantic", "jinja2", "rich", "ruamel", "casadi"):
        assert heavy not in modules, heavy
    commands = {m for m in modules if m.startswith("rapid_dsl.commands.")}
    assert commands == {"rapid_dsl.commands.check", "rapid_dsl.commands.common"}
    assert "rapid_dsl.compiler" not in modules and "rapid_dsl.lint" not in modules


@pytest.mark.parametrize("argv", [["--format", "json", "check"], ["--format=json", "-q", "check"],
                                  ["--color", "never", "--strict", "check"]])
def test_options_before_the_command_still_apply(tmp_path: Path, argv: list[str],
                                                capsys: pytest.CaptureFixture[str]) -> None:
    from rapid_dsl.cli import main

    program = tmp_path / "p.rapid"
    program.write_text("relation far(a: Body, b: Body) = distance(a, b) > 5\n", encoding="utf-8")
    assert main([*argv, str(program)]) == 1
    out = capsys.readouterr().out
    if "json" in " ".join(argv):
        assert json.loads(out)[0]["code"] == "E0302"
    else:
        assert "error[E0302]" in out


def test_help_and_unknown_commands_still_list_every_command(
        capsys: pytest.CaptureFixture[str]) -> None:
    from rapid_dsl.cli import COMMANDS, main

    assert main(["--help"]) == 0
    help_text = capsys.readouterr().out
    assert main(["chek", "x.rapid"]) == 2
    error = capsys.readouterr().err
    for command in COMMANDS:
        assert command in help_text and f"'{command}'" in error
