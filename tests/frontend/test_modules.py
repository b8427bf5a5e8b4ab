"""`use`: standard-library names, relative files, cycles, duplicates, and paths in diagnostics."""

from __future__ import annotations

from pathlib import Path

import pytest

from rapid_dsl.frontend.driver import InputError, check_file, check_text

STUBS = Path(__file__).parent.parent / "data" / "stub_stdlib"

TOUCH = """primitive {name} {{
  goal "g"
  roles {{ target: Object, hand: Manipulator }}
  success {{ {success} }}
  cost final = distance(hand, target) / 1cm
  motion {{ keypoint reach = pos(target) }}
}}
"""


def write(folder: Path, files: dict[str, str]) -> None:
    for name, text in files.items():
        path = folder / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)


def codes(path: Path, **kw: object) -> list[str]:
    return [d.code for d in check_file(str(path), stdlib=STUBS, **kw).diagnostics]  # type: ignore[arg-type]


def test_stdlib_names_single_and_braced() -> None:
    assert [d.code for d in check_text("use stdlib.push\nuse stdlib.{flip, grasp}\n", "a.rapid",
                                       stdlib=STUBS).diagnostics] == []


def test_unknown_stdlib_name_lists_what_exists() -> None:
    [d] = check_text("use stdlib.flipp\n", "a.rapid", stdlib=STUBS).diagnostics
    assert d.code == "E0205"
    assert d.help == ("did you mean `flip`? the standard library has: `flip`, `grasp`, `push`")


def test_stdlib_file_must_declare_its_name(tmp_path: Path) -> None:
    write(tmp_path / "lib", {"odd.rapid": "def other() -> Real = 1\n"})
    [d] = check_text("use stdlib.odd\n", "a.rapid", stdlib=tmp_path / "lib").diagnostics
    assert d.code == "E0205" and "does not declare `odd`" in d.message


def test_stdlib_helpers_stay_private(tmp_path: Path) -> None:
    helper = "def reach_of(b: Body) -> Length = height(b)\n"
    write(tmp_path / "lib", {"touch.rapid": helper + TOUCH.format(
        name="touch", success="reach_of(target) > 1cm")})
    lib = tmp_path / "lib"
    assert [d.code for d in check_text("use stdlib.touch\n", "a.rapid", stdlib=lib).diagnostics] \
        == []
    text = "use stdlib.touch\nrelation r(b: Body) = reach_of(b) > 1cm\n"
    assert [d.code for d in check_text(text, "a.rapid", stdlib=lib).diagnostics] == ["E0201"]


def test_file_use_brings_every_declaration_relative_to_the_using_file(tmp_path: Path) -> None:
    write(tmp_path, {
        "main.rapid": 'use "lib/shelf.rapid"\n'
                      + TOUCH.format(name="p", success="near(hand, target)"),
        "lib/shelf.rapid": 'use "more/deep.rapid"\n'
                           "relation near(a: Body, b: Body) = gap(a, b) < 5cm\n",
        "lib/more/deep.rapid": "def gap(a: Body, b: Body) -> Length = distance(a, b)\n",
    })
    result = check_file(str(tmp_path / "main.rapid"), stdlib=STUBS)
    assert result.diagnostics == []
    assert result.program is not None
    assert {f.name for f in result.program.functions} == {"near", "gap"}
    assert result.program.own == ("p",)
    assert set(result.sources) == {str(tmp_path / "main.rapid"),
                                   str(tmp_path / "lib" / "shelf.rapid"),
                                   str(tmp_path / "lib" / "more" / "deep.rapid")}


def test_uses_are_not_passed_on(tmp_path: Path) -> None:
    write(tmp_path, {
        "main.rapid": 'use "lib/shelf.rapid"\nrelation r(a: Body, b: Body) = gap(a, b) < 1cm\n',
        "lib/shelf.rapid": 'use "deep.rapid"\nrelation near(a: Body, b: Body) = gap(a, b) < 5cm\n',
        "lib/deep.rapid": "def gap(a: Body, b: Body) -> Length = distance(a, b)\n",
    })
    assert codes(tmp_path / "main.rapid") == ["E0201"]


def test_diagnostics_of_used_files_keep_their_paths(tmp_path: Path) -> None:
    write(tmp_path, {"main.rapid": 'use "lib.rapid"\n',
                     "lib.rapid": "def bad(a: Body) -> Length = height(a) + 1deg\n"})
    [d] = check_file(str(tmp_path / "main.rapid"), stdlib=STUBS).diagnostics
    assert d.code == "E0301" and d.span.path == str(tmp_path / "lib.rapid")


def test_syntax_errors_of_used_files_are_reported_once(tmp_path: Path) -> None:
    write(tmp_path, {"main.rapid": 'use "a.rapid"\nuse "b.rapid"\n',
                     "a.rapid": 'use "broken.rapid"\n', "b.rapid": 'use "broken.rapid"\n',
                     "broken.rapid": "relation r(a: Body) = \n"})
    assert codes(tmp_path / "main.rapid") == ["E0103"]


def test_each_file_is_parsed_once(tmp_path: Path) -> None:
    from rapid_dsl.frontend.driver import parse_source
    from rapid_dsl.frontend.modules import load_modules
    write(tmp_path, {"main.rapid": 'use "a.rapid"\nuse "b.rapid"\n',
                     "a.rapid": 'use "c.rapid"\ndef fa() -> Real = 1\n',
                     "b.rapid": 'use "c.rapid"\ndef fb() -> Real = 1\n',
                     "c.rapid": "def fc() -> Real = 1\n"})
    parsed: list[str] = []

    def counting(text: str, path: str):  # type: ignore[no-untyped-def]
        parsed.append(Path(path).name)
        return parse_source(text, path)

    main = tmp_path / "main.rapid"
    module, _ = parse_source(main.read_text(), str(main))
    graph = load_modules(main.read_text(), str(main), module, parse=counting, stdlib=STUBS)
    assert sorted(parsed) == ["a.rapid", "b.rapid", "c.rapid"]
    assert len(graph.files) == 4 and graph.diagnostics == []


def test_cycles_are_reported_with_the_chain(tmp_path: Path) -> None:
    write(tmp_path, {"a.rapid": 'use "b.rapid"\ndef fa() -> Real = 1\n',
                     "b.rapid": 'use "c.rapid"\ndef fb() -> Real = 1\n',
                     "c.rapid": 'use "a.rapid"\ndef fc() -> Real = 1\n'})
    [d] = check_file(str(tmp_path / "a.rapid"), stdlib=STUBS).diagnostics
    assert d.code == "E0207"
    a, b, c = (str(tmp_path / n) for n in ("a.rapid", "b.rapid", "c.rapid"))
    assert d.message == f"`use` cycle: {a} -> {b} -> {c} -> {a}"


def test_a_file_using_itself_is_a_cycle(tmp_path: Path) -> None:
    write(tmp_path, {"a.rapid": 'use "a.rapid"\n'})
    assert codes(tmp_path / "a.rapid") == ["E0207"]


def test_missing_file_and_unknown_module(tmp_path: Path) -> None:
    write(tmp_path, {"a.rapid": 'use "nope.rapid"\nuse "sub.rapid"\nuse other.push\n'})
    (tmp_path / "sub.rapid").mkdir()
    assert codes(tmp_path / "a.rapid") == ["E0206", "E0206", "E0208"]


def test_a_name_brought_twice(tmp_path: Path) -> None:
    write(tmp_path, {"a.rapid": 'use stdlib.push\nuse "mine.rapid"\n',
                     "mine.rapid": TOUCH.format(name="push", success="touching(hand, target)")})
    assert codes(tmp_path / "a.rapid") == ["E0203"]
    write(tmp_path, {"b.rapid": "use stdlib.push\nuse stdlib.push\n"})
    assert codes(tmp_path / "b.rapid") == ["E0203"]


def test_use_clashes_with_a_local_declaration(tmp_path: Path) -> None:
    write(tmp_path, {"a.rapid": "use stdlib.grasp\n" + TOUCH.format(
        name="grasp", success="touching(hand, target)")})
    assert codes(tmp_path / "a.rapid") == ["E0204"]


def test_local_duplicates(tmp_path: Path) -> None:
    write(tmp_path, {"a.rapid": "def f() -> Real = 1\nrelation f(a: Body) = touching(a, a)\n"})
    assert codes(tmp_path / "a.rapid") == ["E0202"]


def test_same_helper_name_in_two_files_gets_unique_ir_names(tmp_path: Path) -> None:
    write(tmp_path / "lib", {
        "pa.rapid": "def h() -> Length = 1cm\n" + TOUCH.format(name="pa", success="h() > 0cm"),
        "pb.rapid": "def h() -> Length = 2cm\n" + TOUCH.format(name="pb", success="h() > 0cm"),
    })
    result = check_text("use stdlib.{pa, pb}\n", "main.rapid", stdlib=tmp_path / "lib")
    assert result.program is not None, result.diagnostics
    assert sorted(f.name for f in result.program.functions) == ["h", "h_2"]
    calls = [p.success[0].expr.left.name for p in result.program.primitives]  # type: ignore[union-attr]
    assert sorted(calls) == ["h", "h_2"]


def test_unknown_names_after_a_failed_use_are_not_reported(tmp_path: Path) -> None:
    write(tmp_path, {"a.rapid": "use stdlib.pussh\nstrategy s {\n  goal \"g\"\n"
                                "  roles { box: Object, hand: Manipulator }\n"
                                "  phase go: pussh(target=box, hand=hand)\n}\n"})
    assert codes(tmp_path / "a.rapid") == ["E0205"]


def test_unreadable_root_file_raises_input_error(tmp_path: Path) -> None:
    with pytest.raises(InputError, match="no such file"):
        check_file(str(tmp_path / "missing.rapid"))
    with pytest.raises(InputError, match="folder"):
        check_file(str(tmp_path))
    (tmp_path / "bin.rapid").write_bytes(b"\xff\xfe\x00bad")
    with pytest.raises(InputError, match="UTF-8"):
        check_file(str(tmp_path / "bin.rapid"))


def test_default_stdlib_is_the_package_folder() -> None:
    from rapid_dsl.frontend.modules import Stdlib
    names = Stdlib().names()
    assert {"push", "flip", "grasp"} <= set(names)
