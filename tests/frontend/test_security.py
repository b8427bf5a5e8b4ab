"""A program can name nothing outside the builtin registry and its own declarations."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from rapid_dsl.frontend.driver import check_text
from rapid_dsl.language.registry import BUILTINS

STUBS = Path(__file__).parent.parent / "data" / "stub_stdlib"

PRIMITIVE = """primitive p {{
  goal "g"
  roles {{ target: Object, hand: Manipulator }}
  success {{ {clause} }}
  cost final = distance(hand, target) / 1cm
  motion {{ keypoint reach = pos(target) }}
}}
"""

PYTHON_NAMES = ["__import__", "open", "os", "eval", "exec", "compile", "getattr", "globals",
                "locals", "vars", "__builtins__", "sys", "subprocess", "print", "input", "type",
                "object", "breakpoint", "exit", "np", "mujoco", "rt", "self", "_"]


def codes(clause: str) -> list[str]:
    result = check_text(PRIMITIVE.format(clause=clause), "p.rapid", stdlib=STUBS)
    assert result.program is None or not result.diagnostics
    return [d.code for d in result.diagnostics]


@pytest.mark.parametrize("name", PYTHON_NAMES)
def test_python_names_are_unknown_names(name: str) -> None:
    assert codes(f"{name} > 1") == ["E0201"]


@pytest.mark.parametrize("name", PYTHON_NAMES)
def test_python_names_are_unknown_functions(name: str) -> None:
    assert codes(f"{name}(target) > 1") == ["E0201"]


@pytest.mark.parametrize("attribute", ["__class__", "__dict__", "__globals__", "mro", "path",
                                       "system", "xx", "w"])
def test_attributes_other_than_components_are_errors(attribute: str) -> None:
    assert codes(f"pos(target).{attribute} > 1cm") == ["E0306"]
    assert codes(f"target.{attribute} > 1cm") == ["E0306"]


def test_chained_attributes_cannot_reach_anything() -> None:
    assert codes("pos(target).x.x > 1cm") == ["E0312"]
    assert "E0201" in codes("os.path.x > 1")


def test_strings_are_not_expressions() -> None:
    # A string is only a goal or a `use` path; the grammar has no string expression.
    result = check_text(PRIMITIVE.format(clause='eval("1") > 0'), "p.rapid", stdlib=STUBS)
    assert [d.code for d in result.diagnostics] == ["E0101"]


def test_use_cannot_name_python_modules() -> None:
    for text in ("use os.path\n", "use sys.modules\n"):
        assert [d.code for d in check_text(text, "p.rapid", stdlib=STUBS).diagnostics] == ["E0208"]
    assert [d.code for d in check_text("use stdlib.os\n", "p.rapid", stdlib=STUBS).diagnostics] \
        == ["E0205"]


def test_use_of_a_non_rapid_file_is_refused_unread(tmp_path: Path) -> None:
    (tmp_path / "evil.py").write_text("import os\nos.system('touch pwned')\n")
    result = check_text('use "evil.py"\n', str(tmp_path / "main.rapid"), stdlib=STUBS)
    assert [d.code for d in result.diagnostics] == ["E0217"]
    assert list(result.sources) == [str(tmp_path / "main.rapid")]
    assert not (tmp_path / "pwned").exists()


def test_every_callable_name_comes_from_the_registry_or_the_program() -> None:
    """Walk the IR of a program using many builtins: every call is a registry entry."""
    from rapid_dsl.frontend import ir
    from rapid_dsl.frontend.tree import walk
    clause = ("norm(pos(target) - pos(hand)) < 1cm and abs(yaw(target)) < 1deg and "
              "max(height(target), top(hand)) > 0cm and touching(hand, target)")
    result = check_text(PRIMITIVE.format(clause=clause), "p.rapid", stdlib=STUBS)
    assert result.program is not None
    p = result.program.primitive("p")
    calls = [n for c in p.success for n in walk(c.expr) if isinstance(n, ir.BuiltinCall)]
    assert calls and all(c.name in BUILTINS for c in calls)


def test_checking_does_not_import_heavy_or_dangerous_modules() -> None:
    code = ("import sys\nfrom rapid_dsl.frontend.driver import check_file\n"
            "r = check_file('examples/flip_box.rapid', lint=True)\n"
            "assert r.ok, r.diagnostics\n"
            "bad = [m for m in ('numpy', 'mujoco', 'jinja2', 'pydantic', 'casadi', 'subprocess')"
            " if m in sys.modules]\nassert not bad, bad\n")
    root = Path(__file__).parent.parent.parent
    subprocess.run([sys.executable, "-c", code], cwd=root, check=True)
