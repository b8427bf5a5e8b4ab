"""`use "path"` stays inside the root program's folder tree (or an `--allow-path` folder), names
program files only, and never makes a diagnostic quote a file that is not a program."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from rapid_dsl.frontend.driver import check_file, check_text

STUBS = Path(__file__).parent.parent / "data" / "stub_stdlib"
SECRET = "root:x:0:0:root:/root:/bin/bash"

RELATION = "relation near(a: Body, b: Body) = distance(a, b) < 1cm\n"


@pytest.fixture
def tree(tmp_path: Path) -> Path:
    """tmp/project/ (the checked program's folder, with lib/) and tmp/outside/ next to it."""
    (tmp_path / "project" / "lib").mkdir(parents=True)
    (tmp_path / "outside").mkdir()
    (tmp_path / "outside" / "passwd").write_text(SECRET + "\n")
    (tmp_path / "outside" / "shared.rapid").write_text(RELATION)
    return tmp_path


def check(path: Path, **kw: object):
    return check_file(str(path), stdlib=STUBS, **kw)  # type: ignore[arg-type]


def codes(path: Path, **kw: object) -> list[str]:
    return [d.code for d in check(path, **kw).diagnostics]


def everything_said(result) -> str:
    return "\n".join(f"{d.message} {d.help} {d.label}" for d in result.diagnostics) + \
        "\n".join(result.sources.values())


def test_dot_dot_out_of_the_project_is_refused_unread(tree: Path) -> None:
    """Regression: enough `../` read any file (a system account list) and echoed its first line."""
    main = tree / "project" / "main.rapid"
    depth = len(main.parent.parts)
    main.write_text(f'use "{"../" * depth}{tree.relative_to("/")}/outside/passwd"\n')
    result = check(main)
    [d] = result.diagnostics
    assert d.code == "E0216" and "is outside the checked program's folder" in d.message
    assert "--allow-path DIR" in (d.help or "")
    assert SECRET not in everything_said(result)
    assert list(result.sources) == [str(main)]


def test_the_error_is_at_the_path_string(tree: Path) -> None:
    main = tree / "project" / "main.rapid"
    main.write_text('relation r(a: Body) = distance(a, a) < 1cm\nuse   "../outside/shared.rapid"\n')
    [d] = check(main).diagnostics
    assert (d.code, d.span.line, d.span.col, d.span.end_line, d.span.end_col) == \
        ("E0216", 2, 7, 2, 32)
    assert main.read_text()[d.span.start:d.span.end] == '"../outside/shared.rapid"'


def test_yaml_form_is_held_to_the_same_rule_at_its_value(tree: Path) -> None:
    main = tree / "project" / "main.rapid.yaml"
    main.write_text("- use: ../outside/shared.rapid\n")
    [d] = check(main).diagnostics
    assert (d.code, d.span.line, d.span.col, d.span.end_col) == ("E0216", 1, 8, 31)


def test_a_used_file_cannot_reach_out_either(tree: Path) -> None:
    (tree / "project" / "main.rapid").write_text('use "lib/a.rapid"\n')
    (tree / "project" / "lib" / "a.rapid").write_text('use "../../outside/shared.rapid"\n')
    result = check(tree / "project" / "main.rapid")
    [d] = result.diagnostics
    assert d.code == "E0216" and d.span.path.endswith(os.path.join("lib", "a.rapid"))


def test_dot_dot_that_stays_inside_is_fine(tree: Path) -> None:
    (tree / "project" / "main.rapid").write_text('use "lib/a.rapid"\n')
    (tree / "project" / "lib" / "a.rapid").write_text('use "../b.rapid"\n')
    (tree / "project" / "b.rapid").write_text(RELATION)
    assert codes(tree / "project" / "main.rapid") == []


def test_a_symlink_out_of_the_project_counts_as_outside(tree: Path) -> None:
    (tree / "project" / "lib" / "shared.rapid").symlink_to(tree / "outside" / "shared.rapid")
    (tree / "project" / "lib" / "dir").symlink_to(tree / "outside", target_is_directory=True)
    main = tree / "project" / "main.rapid"
    main.write_text('use "lib/shared.rapid"\nuse "lib/dir/shared.rapid"\n')
    assert codes(main) == ["E0216", "E0216"]
    assert codes(main, allowed_dirs=[str(tree / "outside")]) == ["E0203"]  # read: one name twice


def test_allowed_dirs_let_uses_reach_a_chosen_folder(tree: Path) -> None:
    main = tree / "project" / "main.rapid"
    main.write_text('use "../outside/shared.rapid"\n')
    assert codes(main, allowed_dirs=[str(tree / "outside")]) == []
    assert codes(main, allowed_dirs=[str(tree / "project" / "lib")]) == ["E0216"]


def test_a_file_that_is_not_a_program_is_refused_unread(tree: Path) -> None:
    (tree / "project" / "notes.txt").write_text(SECRET + "\n")
    main = tree / "project" / "main.rapid"
    for name in ("notes.txt", "notes", "x.rapid.json", "lib"):
        main.write_text(f'use "{name}"\n')
        result = check(main)
        assert [d.code for d in result.diagnostics] == ["E0217"], name
        assert SECRET not in everything_said(result)
    # Outside and not a program either: allowed there, still not read.
    main.write_text('use "../outside/passwd"\n')
    result = check(main, allowed_dirs=[str(tree / "outside")])
    assert [d.code for d in result.diagnostics] == ["E0217"]
    assert SECRET not in everything_said(result)


def test_a_program_name_that_links_to_another_kind_of_file_is_refused(tree: Path) -> None:
    (tree / "project" / "notes.txt").write_text(SECRET + "\n")
    (tree / "project" / "lib" / "x.rapid").symlink_to(tree / "project" / "notes.txt")
    main = tree / "project" / "main.rapid"
    main.write_text('use "lib/x.rapid"\n')
    result = check(main)
    [d] = result.diagnostics
    assert d.code == "E0217" and d.message == \
        "`lib/x.rapid` links to `notes.txt`, which is not a program file"
    assert SECRET not in everything_said(result)


def test_every_program_suffix_may_be_used(tree: Path) -> None:
    yaml = "- relation: far\n  params: {a: Body, b: Body}\n  body: distance(a, b) > 1cm\n"
    (tree / "project" / "lib" / "a.rapid.yaml").write_text(yaml)
    (tree / "project" / "lib" / "b.rapid.yml").write_text(yaml.replace("far", "apart"))
    (tree / "project" / "lib" / "c.rapid").write_text(RELATION)
    main = tree / "project" / "main.rapid"
    main.write_text('use "lib/a.rapid.yaml"\nuse "lib/b.rapid.yml"\nuse "lib/c.rapid"\n')
    assert codes(main) == []


@pytest.mark.parametrize("kind, reason", [
    ("fifo", "not a regular file"),
    ("too large", "larger than the input limit of 10 MiB"),
    ("folder", "is a folder"),
])
def test_a_used_file_is_read_only_if_regular_and_small(kind: str, reason: str,
                                                      tree: Path) -> None:
    used = tree / "project" / "lib" / "x.rapid"
    if kind == "fifo":
        os.mkfifo(used)
    elif kind == "folder":
        used.mkdir()
    else:
        with open(used, "wb") as f:
            f.truncate(10 * 1024 * 1024 + 1)
    main = tree / "project" / "main.rapid"
    main.write_text('use "lib/x.rapid"\n')
    [d] = check(main).diagnostics
    assert d.code == "E0206" and reason in d.message


def test_a_used_file_with_a_bom_parses(tree: Path) -> None:
    (tree / "project" / "lib" / "x.rapid").write_bytes(b"\xef\xbb\xbf" + RELATION.encode())
    main = tree / "project" / "main.rapid"
    main.write_text('use "lib/x.rapid"\n')
    assert codes(main) == []


def test_the_inputs_are_every_file_read(tree: Path) -> None:
    main = tree / "project" / "main.rapid"
    main.write_text('use "lib/x.rapid"\nuse stdlib.push\n')
    (tree / "project" / "lib" / "x.rapid").write_text(RELATION)
    result = check(main)
    assert result.ok
    assert [Path(p).resolve() for p in result.inputs] == [
        main.resolve(), (tree / "project" / "lib" / "x.rapid").resolve(),
        (STUBS / "push.rapid").resolve()]


def test_a_standard_library_file_stays_in_its_folder(tmp_path: Path) -> None:
    lib = tmp_path / "lib"
    lib.mkdir()
    (tmp_path / "elsewhere.rapid").write_text(RELATION)
    (lib / "odd.rapid").write_text('use "../elsewhere.rapid"\ndef odd() -> Real = 1\n')
    [d] = check_text("use stdlib.odd\n", str(tmp_path / "main.rapid"), stdlib=lib).diagnostics
    assert d.code == "E0216" and "standard library's folder" in d.message
