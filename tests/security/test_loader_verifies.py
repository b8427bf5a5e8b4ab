"""The loader runs a module only if its syntax tree has the compiler's shapes (hand-made attacks).

Each module below is a real generated module with a statement added; the loader must refuse it
with a LoadError naming the line (`+1`: the statement's second line), before any of it runs.
"""

from __future__ import annotations

import linecache
import traceback
from pathlib import Path

import numpy as np
import pytest

from rapid_dsl.compiler import compile_program
from rapid_dsl.frontend.driver import check_file
from rapid_dsl.runtime import api, program, solve
from rapid_dsl.runtime.frames import Frames
from rapid_dsl.runtime.loader import LoadError, load
from rapid_dsl.runtime.program import Context

DATA = Path(__file__).resolve().parents[1] / "data" / "compiled"
GOLDEN = (DATA / "nudge.expected.py").read_text(encoding="utf-8")
SOLVE_GOLDEN = (DATA / "align_then_push.expected.py").read_text(encoding="utf-8")
# The line after `RT.require_abi(1)`: a statement added there runs before anything else.
AFTER_ABI = GOLDEN.splitlines().index("RT.require_abi(1)") + 2


def with_line(text: str, source: str = GOLDEN, at: int = AFTER_ABI) -> str:
    lines = source.splitlines()
    return "\n".join([*lines[: at - 1], *text.splitlines(), *lines[at - 1:]]) + "\n"


def test_the_generated_modules_load():
    assert load(GOLDEN, "nudge").program.primitive("nudge").goal.startswith("Slide")
    assert load(SOLVE_GOLDEN, "align").program.strategy("align_then_push")


ATTACKS = {
    "import os": "`import os` is not one of the runtime's header imports",
    "from os import system as RT": "`from os import system` is not one of",
    "from rapid_dsl.runtime import render as R": "`from rapid_dsl.runtime import render`",
    "from rapid_dsl.runtime.program import np as B": "`from rapid_dsl.runtime.program import np`",
    "from rapid_dsl.runtime import program as RT, solve as SV": "is not one of the runtime's",
    "from .program import NUMERIC as B": "`from .program import NUMERIC`",
    "x = RT.np": "`RT.np`: `np` is not part of the runtime API",
    "x = RT.re": "`RT.re`: `re` is not part of the runtime API",
    "x = B.os": "`B.os`: `os` is not part of the runtime API",
    "x = RT.vec.__globals__": "`.__globals__` is read on an expression",
    "x = RT.__dict__": "`RT.__dict__`: `__dict__` is not part of the runtime API",
    "x = PROGRAM.__class__": "`PROGRAM.__class__`: a compiled program reads only",
    "__class__ = 1": "`__class__`: names starting with `__` are not allowed",
    "__builtins__ = RT": "`__builtins__`: names starting with `__` are not allowed",
    "x = __import__": "`__import__`: names starting with `__` are not allowed",
    "x = getattr(RT, 'np')": "`getattr` is not defined in the module",
    "x = open('/etc/passwd')": "`open` is not defined in the module",
    "x = '{0.__globals__}'.format(RT.vec)": "`.format` is read on an expression",
    "x = (lambda: 0)": "a lambda is not allowed",
    "x = [n for n in ()]": "`ListComp` is not allowed",
    "x = f'{RT}'": "an f-string is not allowed",
    "x = b'bytes'": "a bytes constant is not allowed",
    "x = RT.vec(*())": "a `*` argument is not allowed",
    "x = RT.vec(**{})": "`**` arguments are not allowed",
    "x = {**PROGRAM}": "`**` in a dict is not allowed",
    "x = RT.np if True else 0": "`IfExp` is not allowed",
    "RT.vec = RT.negate": "an assignment must bind exactly one name",
    "RT = B": "`RT` names an imported part of the runtime",
    "x: int = 1": "`AnnAssign` is not allowed",
    "class K: pass": "a class is not allowed",
    "while 1: pass": "`While` is not allowed",
    "try:\n    pass\nexcept Exception:\n    pass": "`Try` is not allowed",
    "def f(F, x=RT):\n    return x": "function `f` is not a plain function",
    "def f(*F):\n    return F": "function `f` is not a plain function",
    "@RT.vec\ndef f(F):\n    return F": "+1 function `f` is not a plain function",
    "def f(F):\n    def g(F):\n        return F\n    return g":
        "+1 a nested function is not allowed",
    "def f(F):\n    import os\n    return os": "+1 an import inside a function is not allowed",
    "def f(__class__):\n    return 0": "`__class__`: names starting with `__`",
    "def f(F):\n    return F.frames.__class__": "+1 `.__class__` is read on an expression",
    "def f(F):\n    return F.f_globals": "+1 `F.f_globals`: a compiled program reads only",
    "async def f(F):\n    return F": "an async function is not allowed",
    # work done at load time, before any check of the program could stop it
    "x = 'a' * 1000000000": "arithmetic on something other than numbers",
    "x = (0,) * 1000000000": "arithmetic on something other than numbers",
    "x = 10 ** 1000000000": "`**` takes an integer constant exponent of at most 1024",
    "x = 2.0 ** PROGRAM": "`**` takes an integer constant exponent of at most 1024",
    "x = 10 ** 1000": "`**` on an integer constant is not allowed",
}


@pytest.mark.parametrize("attack", list(ATTACKS), ids=list(ATTACKS))
def test_an_attack_is_refused_at_its_line(attack):
    with pytest.raises(LoadError) as refused:
        load(with_line(attack), "evil")
    message, expected = str(refused.value), ATTACKS[attack]
    below = expected.startswith("+1 ")     # refused on the attack's second line
    line = AFTER_ABI + below
    assert message.startswith(f"cannot load the compiled program evil: line {line}: ")
    assert expected.removeprefix("+1 ") in message


def test_an_attack_deep_in_a_function_names_its_own_line():
    lines = GOLDEN.splitlines()
    at = lines.index("    spun = B.rotation(F, item, B.up)") + 1
    source = "\n".join([*lines[: at - 1], "    spun = C.frames.pos.__class__", *lines[at:]])
    with pytest.raises(LoadError, match=f"line {at}: `.__class__` is read on an expression"):
        load(source, "evil")


def test_syntax_errors_and_deep_nesting_are_load_errors():
    with pytest.raises(LoadError, match=f"line {AFTER_ABI}: "):
        load(with_line("x = ("), "broken")
    with pytest.raises(LoadError, match="cannot load the compiled program deep"):
        load(with_line("x = " + "(" * 5000 + "1" + ")" * 5000), "deep")
    with pytest.raises(LoadError, match="cannot load the compiled program deep"):
        load(with_line("x = -" + "-" * 100_000 + "1"), "deep")


def test_a_module_for_another_abi_is_refused_at_that_line():
    source = GOLDEN.replace("RT.require_abi(1)", "RT.require_abi(2)")
    with pytest.raises(LoadError, match=f"at line {AFTER_ABI - 1}: AbiMismatch"):
        load(source, "old")


def test_the_facades_hold_only_what_the_compiler_targets():
    for header in api.IMPORTS.values():
        assert set(vars(header.facade())) == set(header.names)
    rt, b = api.RT.facade(), api.B.facade()
    assert not hasattr(rt, "np") and not hasattr(rt, "re") and not hasattr(rt, "NUMERIC")
    assert rt.vec is program.vec and b.distance is program.NUMERIC.distance
    assert not any(name.startswith("_") for h in api.IMPORTS.values() for name in h.names)


def test_every_attribute_the_compiler_reads_on_values_exists():
    assert {"frames", "roles", "params", "features", "lets"} <= set(Context.__dataclass_fields__)
    assert callable(Frames.first)
    assert all(callable(getattr(solve.Problem, m)) for m in ("minimize", "subject", "solve"))
    assert api.VALUE_ATTRIBUTES == {"frames", "roles", "params", "features", "lets", "first",
                                    "var", "minimize", "subject", "solve"}


def test_tracebacks_show_generated_lines_and_errors_map_to_rapid_lines():
    loaded = load(GOLDEN, "nudge")
    assert linecache.getline(loaded.filename, AFTER_ABI - 1).strip() == "RT.require_abi(1)"
    features = loaded.program.primitive("nudge").features
    with pytest.raises(AttributeError) as failure:
        features(Context(frames=np.zeros(1), roles={"item": 0}, params={"shift": 0.1,
                                                                        "side": np.zeros(3)}))
    shown = "".join(traceback.format_exception(failure.value))
    assert f'File "{loaded.filename}"' in shown
    assert "F0 = F.first()" in shown
    with pytest.raises(AttributeError) as failure:
        loaded.program.primitive("nudge").requires[0].test(None, 0, 1)
    assert loaded.locate(failure.value) == "nudge.rapid:11"


def test_locate_names_a_hostile_file_name_as_it_is(tmp_path):
    name = 'x"""\n# SOURCES[0]:99.rapid'
    path = tmp_path / name
    path.write_text((DATA / "nudge.rapid").read_text(encoding="utf-8"), encoding="utf-8")
    loaded = load(compile_program(check_file(str(path)).program).source, "nudge")
    with pytest.raises(AttributeError) as failure:
        loaded.program.primitive("nudge").requires[0].test(None, 0, 1)
    assert loaded.locate(failure.value) == f"{name}:11"


def test_rapidc_run_reports_a_refused_module_as_bad_input(monkeypatch, tmp_path):
    """Should the compiler ever emit a module the loader refuses, `run` says so (exit 2)."""
    import rapid_dsl.compiler
    from rapid_dsl.compiler.codegen import GeneratedModule, LineMap

    from .conftest import run_rapidc

    monkeypatch.setattr(rapid_dsl.compiler, "compile_program",
                        lambda program: GeneratedModule(with_line("import os"), LineMap(())))
    scene = Path(__file__).resolve().parents[2] / "examples" / "scenes" / "push_box.yaml"
    done = run_rapidc("run", DATA / "nudge.rapid", "--scene", scene)
    assert done.code == 2
    assert f"line {AFTER_ABI}: `import os` is not one of the runtime's header imports" in done.err
